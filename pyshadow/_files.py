"""Atomic file writes: a temporary file beside the target, then a rename."""
from __future__ import annotations

import os
import secrets
from contextlib import contextmanager
from pathlib import Path

__all__ = ["atomic_path", "write_bytes_atomic"]


@contextmanager
def atomic_path(path):
    """Yield a temporary path in ``path``'s folder; rename it over ``path`` on success.

    The temporary name keeps ``path``'s extension (so format-guessing writers
    such as OpenImageIO pick the right one). On any exception the temporary
    file is removed and the existing ``path`` is left untouched.
    """
    path = Path(os.fspath(path))
    tmp = path.parent / f".{path.stem}.{secrets.token_hex(6)}.tmp{path.suffix}"
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise


def write_bytes_atomic(path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (flushed to disk before the rename)."""
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
