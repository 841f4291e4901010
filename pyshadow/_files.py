"""Atomic file writes: a temporary file beside the target, then a rename."""
from __future__ import annotations

import errno
import os
import secrets
import stat
import tempfile
from contextlib import contextmanager
from pathlib import Path

__all__ = ["atomic_path", "write_bytes_atomic", "writable_folder"]


def link_target(path: Path) -> Path:
    """The file the symbolic link ``path`` leads to (which need not exist); OSError ELOOP naming ``path`` where
    its links lead back to themselves (Python before 3.13 raised RuntimeError there, 3.13 returns a link)."""
    try:
        target = path.resolve()
    except RuntimeError:
        target = path
    if target.is_symlink():
        raise OSError(errno.ELOOP, "too many levels of symbolic links", str(path))
    return target


@contextmanager
def atomic_path(path):
    """Yield a temporary path in ``path``'s folder; flush it to disk and rename it over ``path`` on success.

    The temporary name keeps ``path``'s extension as given (so format-guessing
    writers such as OpenImageIO pick the format asked for, also where ``path``
    is a symbolic link to a file of another or no extension). On any exception
    the temporary file is removed and the existing ``path`` is left untouched; an OSError
    about the temporary file names ``path`` instead. A missing folder is a
    FileNotFoundError naming it, before anything is written. A symbolic link
    is written through (the file it names is replaced); a path that exists
    but is no regular file (a folder, a device, a FIFO) is a FileExistsError.
    A file this process may not write (a read-only file, mode 0444 for a user) is a
    PermissionError before anything is written, as opening it for writing would be, and is
    left as it was. A file replaced keeps its permission bits.
    """
    path = Path(os.fspath(path))
    suffix = path.suffix                # the format asked for, whatever the name a link leads to
    if path.is_symlink():               # write through the link: the file it names is replaced, not the link
        path = link_target(path)
    if path.exists() and not path.is_file():
        raise FileExistsError(errno.EEXIST, "not a regular file, which a write would replace", str(path))
    if path.exists() and not os.access(path, os.W_OK):     # the rename would replace it all the same
        raise PermissionError(errno.EACCES, "no permission to write this file (read-only); left as it was",
                              str(path))
    if not path.parent.is_dir():
        raise FileNotFoundError(errno.ENOENT, f"no folder {str(path.parent)!r} to write into", str(path))
    tmp = path.parent / _temporary_name(path, suffix)
    try:
        yield tmp
        _sync(tmp)
        if path.exists():               # the file replaced keeps its permissions (a private 0600 stays so)
            os.chmod(tmp, stat.S_IMODE(path.stat().st_mode))
        os.replace(tmp, path)
    except BaseException as e:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(e, OSError) and e.filename in (str(tmp), tmp):    # name the file asked for
            e.filename = str(path)
            if isinstance(e.strerror, str):
                e.strerror = e.strerror.replace(str(tmp), str(path))
        raise


def _sync(tmp: Path) -> None:
    """Flush ``tmp``'s data to disk before the rename, which may otherwise reach the disk first (ext4's
    delayed allocation: a crash soon after left an empty file in place of the old one). A file system that
    cannot sync (EINVAL, ENOTSUP: some network and FUSE mounts) is passed over."""
    fd = os.open(tmp, os.O_RDWR if os.name == "nt" else os.O_RDONLY)     # Windows' _commit needs write access
    try:
        os.fsync(fd)
    except OSError as e:
        if e.errno not in (errno.EINVAL, errno.ENOTSUP, errno.EOPNOTSUPP):
            if e.filename is None:      # fsync's error names no file: name it (atomic_path names the target)
                e.filename = str(tmp)
            raise
    finally:
        os.close(fd)


def _temporary_name(path: Path, suffix: str) -> str:
    """``.<stem>.<12 hex>.tmp<suffix>``, the stem shortened where the name would exceed the folder's
    limit on a file name's length (a target name near the limit is still writable)."""
    try:
        limit = os.pathconf(path.parent, "PC_NAME_MAX")
    except (OSError, ValueError, AttributeError):
        limit = 255
    stem, tail = path.stem, f".{secrets.token_hex(6)}.tmp{suffix}"
    while 0 < limit < len(os.fsencode(f".{stem}{tail}")) and len(stem) > 1:
        stem = stem[:-1]
    return f".{stem}{tail}"


def write_bytes_atomic(path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (flushed to disk before the rename, by :func:`atomic_path`)."""
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f:
            f.write(data)


def writable_folder(path, probe_prefix: str = ".pyshadow-") -> None:
    """Create the folder ``path`` (and its parents) and probe that a file can be written there.

    Raises ValueError with the reason ("exists and is not a directory",
    "cannot write there (...)"), for a command line to report as a usage
    error before any work starts; the probe file is removed.
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise ValueError("exists and is not a directory")
    try:
        path.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=path, prefix=probe_prefix, suffix=".probe"):
            pass
    except OSError as e:
        raise ValueError(f"cannot write there ({e.strerror or e})") from None
