"""An on-disk cache of Coherent Shadow Maps, keyed by everything a CSM depends on.

Building a CSM is the slow step of pyshadow; its result depends only on the
mesh, the build parameters and the code that builds it. :class:`CSMCache`
stores each built CSM under a key that hashes all of these, so a CSM is
built once per mesh and setting and loaded afterwards::

    from pyshadow.cache import CSMCache, default_cache_dir

    cache = CSMCache(default_cache_dir())
    csm, info = cache.csm("bunny", mesh, pyshadow.ViewSet.zigzag(64, 128), 128, 16)
    info["source"]          # 'built' the first time, 'cached' afterwards

The same directory also holds float32 arrays under keys of the caller's
choosing (:meth:`CSMCache.array`, :meth:`CSMCache.put_array`); the
``pyshadow-bench`` command keeps its converged Embree references there.

Every file is written atomically (a temporary file in the same folder,
flushed, then renamed over the target), so a crash or a concurrent writer
never leaves a partial file under a final name, and a damaged file is
detected by its checksum and replaced.
"""
from __future__ import annotations

import errno
import hashlib
import io
import json
import math
import os
import re
import time
from pathlib import Path

import numpy as np

from ._files import write_bytes_atomic

__all__ = ["CSMCache", "default_cache_dir"]


def default_cache_dir() -> Path:
    """The default cache directory.

    Returns
    -------
    pathlib.Path
        ``$PYSHADOW_CACHE`` (``~`` expanded) when that variable is set and
        not blank, else ``platformdirs.user_cache_dir("pyshadow")`` (e.g.
        ``~/.cache/pyshadow`` on Linux). The directory is not created here.
    """
    env = os.environ.get("PYSHADOW_CACHE", "").strip()
    if env:
        return Path(env).expanduser()
    import platformdirs

    return Path(platformdirs.user_cache_dir("pyshadow"))


#: the package's modules whose code decides a built CSM's bytes (the functions a build runs, found by
#: tests/test_cache.py; besides them only the device and launch choice of ``_cl``, whose answers are
#: the same bit for bit at every width, and the argument checks of ``_compat`` and ``_validate`` run)
BUILD_SOURCES = ("_embree_checks.py", "_embree_lift.py", "_views_checks.py", "csm/build.py", "csm/core.py",
                 "csm/exposure.py", "csm/fileformat.py", "csm/surface_rule.py", "embree.py", "mesh.py", "mesh_kept.py",
                 "mesh_sphere.py", "raster.py", "views.py")


def source_digest(paths=None, kernels=None) -> str:
    """SHA-256 (hex) of pyshadow's version, the text of its modules ``paths`` and of ``kernels``.

    Parameters
    ----------
    paths : iterable of str, optional
        Module files relative to the package folder (``"csm/build.py"``);
        default: every ``.py`` file of the package.
    kernels : iterable of str, optional
        Kernel files (``"csm.cl"``), hashed with their includes inlined;
        default: every ``.cl`` and ``.h`` file of the kernels.

    Returns
    -------
    str
        A change of pyshadow's version or of one of those files changes it
        (a file that cannot be read contributes its name only).
    """
    from . import _cl
    from ._version import __version__

    pkg = Path(__file__).resolve().parent
    # every module but the kernels' package (an installed pyshadow has one, a source checkout has the
    # kernels beside the package): the same digest from either, whichever a subprocess imports
    texts = [(p, lambda p=p: (pkg / p).read_bytes()) for p in paths] if paths is not None else [
        (str(f.relative_to(pkg)), f.read_bytes) for f in sorted(pkg.rglob("*.py"))
        if f.relative_to(pkg).parts[0] != "kernels"]
    texts += [(k, lambda k=k: _cl.kernel_source(k).encode()) for k in kernels] if kernels is not None else [
        (f.name, f.read_bytes) for f in sorted(_cl.kernel_dir().glob("*")) if f.suffix in (".cl", ".h")]
    h = hashlib.sha256(__version__.encode())
    for name, read in texts:
        h.update(name.encode() + b"\0")
        try:
            h.update(read())
        except OSError:
            h.update(b"?")
    return h.hexdigest()


def _code_digest() -> str:
    """Hash of the code a CSM depends on: :func:`source_digest` of :data:`BUILD_SOURCES` and the build
    kernels ``csm.cl`` and ``raster.cl``."""
    return source_digest(BUILD_SOURCES, ("csm.cl", "raster.cl"))


def _sidecar_seconds(side: Path, key: str):
    """The build seconds a CSM's sidecar records for ``key``: a finite number >= 0, else None (no file,
    not JSON, not an object, another key, a missing or non-numeric value, an integer beyond float64)."""
    try:
        meta = json.loads(side.read_text())
    except (OSError, ValueError, RecursionError):       # RecursionError: arrays nested thousands deep
        return None
    s = meta.get("build_seconds") if isinstance(meta, dict) and meta.get("key") == key else None
    if not isinstance(s, (int, float)) or isinstance(s, bool):
        return None
    try:
        s = float(s)
    except OverflowError:                               # an integer beyond float64 (10**400)
        return None
    return s if math.isfinite(s) and s >= 0 else None


def _array_name(key) -> str:
    """The file name of the array under ``key``: its first 40 characters, which must be letters,
    digits, '-' or '_' (a hex digest), so that the file lies in the cache's reference folder."""
    if not isinstance(key, str):
        raise TypeError(f"the array's key must be a str, got {type(key).__name__}")
    if not re.fullmatch(r"[0-9A-Za-z_-]+", key[:40]):
        raise ValueError(f"the array's key must start with letters, digits, '-' or '_' (a hex digest), got {key!r}")
    return f"{key[:40]}.npz"


def _quiet(msg: str) -> None:
    """The default ``log``: discard the message."""


class CSMCache:
    """CSMs (and float32 arrays) on disk, keyed by everything they depend on.

    What is cached, and where (below ``root``):

    - ``csm/<mesh hash[:12]>-<key[:24]>.csm``: a CSM, written with
      :meth:`pyshadow.CoherentShadowMap.save` (atomic, checksummed), and a
      sidecar ``.json`` beside it with the full key, the CSM's name and the
      seconds of its original build;
    - ``reference/<key[:40]>.npz``: a float32 array (:meth:`put_array`),
      stored with the SHA-256 of its bytes.

    The key of a CSM (:meth:`csm_key`) hashes the mesh hash
    (:func:`pyshadow.mesh.mesh_hash`), the view set (layout, parameters and
    number of maps), resolution, depth bits, layer rule, the CSM file
    format version and :func:`_code_digest` (pyshadow's version, the modules
    that build a CSM and the kernels): a change of any of them makes a new
    entry, never a stale hit.

    Every file is written atomically (temporary file, flush, rename). A file
    that fails to load (checksum, truncation, format) or holds a CSM that
    does not match its key (mesh, views, resolution, depth bits, layer
    rule, the build's defaults; a centre, radius or box that is not its
    mesh's, which the mesh hash does not cover) is removed and rebuilt; a
    cache directory that cannot be created, searched (a 0700 folder of
    another user in a shared cache) or written only disables caching (one
    warning through ``log``), it never fails a call.

    Parameters
    ----------
    root : str or path-like or None
        Cache directory (created on first use; ``~`` is expanded; a relative
        path is taken from the working directory of the moment the cache is
        made; an empty string is a ValueError); ``None`` disables the cache:
        every :meth:`csm` call builds, :meth:`array` returns None and
        :meth:`put_array` does nothing.
    log : callable, optional
        ``log(message: str)`` receives progress notes ("building the CSM
        of ...") and warnings (unusable files, unwritable directories);
        default: discard them.
    """

    def __init__(self, root, log=None):
        if isinstance(root, str) and not root.strip():
            raise ValueError("CSMCache: root is an empty path; pass None to disable the cache")
        # absolute now: a later change of the working directory does not move the cache
        self.root = Path(root).expanduser().absolute() if root is not None else None
        self.log = log if log is not None else _quiet
        self._code = None
        self._warned = False

    @property
    def enabled(self) -> bool:
        """True when a cache directory is set (it may still turn out unwritable)."""
        return self.root is not None

    def _dir(self, sub: str) -> Path | None:
        if self.root is None:
            return None
        d = self.root / sub
        try:
            d.mkdir(parents=True, exist_ok=True)
            # a folder of another user (0700 in a shared cache): looking up its files raised PermissionError
            if not os.access(d, os.X_OK):
                raise PermissionError(errno.EACCES, "no permission to look up its files", str(d))
        except OSError as e:
            if not self._warned:
                self.log(f"warning: cache directory {d} cannot be created or used ({e}); not caching")
                self._warned = True
            return None
        return d

    def csm_key(self, mesh_hash: str, views, resolution: int, depth_bits: int, layers) -> str:
        """The cache key of a CSM.

        Parameters
        ----------
        mesh_hash : str
            :func:`pyshadow.mesh.mesh_hash` of the mesh.
        views : pyshadow.ViewSet
        resolution : int
            Texels per map side.
        depth_bits : int
            16 or 32.
        layers : int or str
            The layer rule given to :meth:`pyshadow.CoherentShadowMap.build`.

        Returns
        -------
        str
            SHA-256 hex digest (64 characters) of these parameters, the CSM
            file format version and :func:`_code_digest`.
        """
        from .csm import FORMAT_VERSION
        from .csm.build import check_arguments
        from .csm.fileformat import file_params

        # build's checks first: a key of int(8.7) would find the CSM of resolution 8
        check_arguments(views, resolution, depth_bits, layers)
        if self._code is None:
            self._code = _code_digest()
        spec = {"mesh": mesh_hash, "layout": views.layout,
                "params": file_params(views), "maps": len(views),         # JSON numbers, as a file holds them
                "resolution": int(resolution), "depth_bits": int(depth_bits),
                "layers": layers if isinstance(layers, str) else str(int(layers)),
                "format": FORMAT_VERSION, "code": self._code}
        return hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()

    def csm(self, name: str, mesh, views, resolution: int, depth_bits: int, layers="auto",
            progress: bool = False):
        """The CSM of ``mesh`` for these parameters: from the cache, or built (and stored).

        Parameters
        ----------
        name : str
            A name for messages and the sidecar file (not part of the key).
        mesh : trimesh.Trimesh
        views, resolution, depth_bits, layers :
            As :meth:`pyshadow.CoherentShadowMap.build`.
        progress : bool
            Show the builder's progress bar.

        Returns
        -------
        csm : CoherentShadowMap
            Loaded fully into memory (no memory map) or freshly built.
        info : dict
            ``name``; ``source``: 'cached', 'built', or 'rebuilt' after an
            unusable cache file; ``seconds``: time spent in this call;
            ``build_seconds``: time of the original build (None when a
            cached CSM's sidecar is missing or stale); ``file``: the CSM's
            path as str (None when not cached: also where ``views`` has
            other bases than its layout's, which a file cannot hold);
            ``stats``: ``csm.stats``.
        """
        from . import CoherentShadowMap
        from .csm.build import layer_rule
        from .csm.core import FRONT_MARGIN_TEXELS
        from .csm.fileformat import check_layout_bases, file_params
        from .mesh import mesh_hash as _mesh_hash
        from .scene import _check_csm_frame

        mh = _mesh_hash(mesh)
        key = self.csm_key(mh, views, resolution, depth_bits, layers)
        try:        # the file keeps the layout alone: a CSM of other bases would load with the layout's
            check_layout_bases(views)
            d = self._dir("csm")
        except ValueError as e:
            self.log(f"cache: not caching the CSM of {name} ({e})")
            d = None
        path = d / f"{mh[:12]}-{key[:24]}.csm" if d is not None else None
        side = path.with_suffix(".json") if path is not None else None
        source = "built"
        t0 = time.perf_counter()
        if path is not None and path.exists():
            try:
                csm = CoherentShadowMap.load(path, mmap=False)
                bad = [f for f, want in (("mesh_hash", mh), ("maps", len(views)),
                                         ("resolution", int(resolution)),
                                         ("depth_bits", int(depth_bits)))
                       if getattr(csm, f) != want]
                if csm.views.layout != views.layout or csm.views.params != file_params(views):
                    bad.append("views")
                if csm.layer_rule != layer_rule(layers, mesh):
                    bad.append("layer_rule")
                if csm.footprint or csm.two_sided != "auto":        # what build's defaults give
                    bad.append("footprint or two_sided")
                if csm.front_margin_texels != FRONT_MARGIN_TEXELS:
                    bad.append("front_margin_texels")
                try:        # the mesh hash does not cover the frame: the sphere holds the mesh, the box is its box
                    _check_csm_frame(csm, mesh, mh)
                except ValueError:
                    bad.append("centre, radius or box")
                if bad:
                    raise ValueError(f"holds different {', '.join(bad)}")
            except (ValueError, OSError) as e:       # CSMFormatError is a ValueError
                self.log(f"cache: {path} is unusable ({e}); rebuilding it")
                source = "rebuilt"
                for p in (path, side):
                    try:
                        p.unlink()
                    except OSError:
                        pass
            else:
                build = _sidecar_seconds(side, key)
                return csm, {"name": name, "source": "cached", "seconds": time.perf_counter() - t0,
                             "build_seconds": build, "file": str(path), "stats": csm.stats}
        self.log(f"building the CSM of {name}: {len(views)} maps of {resolution}^2 texels, "
                 f"{depth_bits}-bit depth")
        csm = CoherentShadowMap.build(mesh, views, resolution=resolution, depth_bits=depth_bits,
                                      layers=layers, progress=progress)
        seconds = time.perf_counter() - t0
        if path is not None:
            try:
                csm.save(path)
                write_bytes_atomic(side, json.dumps({"key": key, "build_seconds": seconds, "name": name},
                                                    indent=1).encode())
            except OSError as e:
                self.log(f"warning: cannot write the cache file {path} ({e})")
                path = None
        return csm, {"name": name, "source": source, "seconds": seconds, "build_seconds": seconds,
                     "file": str(path) if path is not None else None, "stats": csm.stats}

    def array(self, key: str):
        """A cached float32 array.

        Parameters
        ----------
        key : str
            The caller's key (a hex digest of everything the array depends
            on); its first 40 characters name the file: letters, digits, '-'
            or '_' (else ValueError; not a str: TypeError).

        Returns
        -------
        ndarray, float32, or None
            The array as stored by :meth:`put_array` (any shape); None when
            absent, or when the file is damaged (zip, format or checksum
            error, data not float32): such a file is removed.
        """
        name = _array_name(key)
        d = self._dir("reference")
        if d is None:
            return None
        path = d / name
        if not path.exists():
            return None
        try:
            # numpy leaves its own file open when the zip is damaged: open and close it here
            with open(path, "rb") as f, np.load(f, allow_pickle=False) as z:
                a = z["data"]
                if a.dtype != np.float32:
                    raise ValueError(f"holds {a.dtype} data, not float32")
                digest = bytes(z["sha256"])
            if hashlib.sha256(a.tobytes()).digest() != digest:
                raise ValueError("checksum mismatch")
            return a
        except Exception as e:                  # zip/CRC/format errors of a damaged file
            self.log(f"cache: {path} is unusable ({e}); recomputing it")
            try:
                path.unlink()
            except OSError:
                pass
            return None

    def put_array(self, key: str, a) -> None:
        """Store ``a`` (converted to contiguous float32) under ``key``.

        The file ``reference/<key[:40]>.npz`` (compressed, with the SHA-256
        of the array's bytes) is written atomically and replaces an earlier
        one; a write error is logged, not raised. ``key`` as in :meth:`array`;
        an array of non-real values is a TypeError, finite values beyond
        float32's range a ValueError (NaN and infinities are stored).
        """
        name = _array_name(key)
        a = np.asarray(a)
        if a.dtype.kind not in "biuf":
            raise TypeError(f"put_array: the array must hold real numbers, got {a.dtype}")
        with np.errstate(over="ignore"):        # (ascontiguousarray made a 0-d array one of shape (1,))
            a32 = np.ascontiguousarray(a, dtype=np.float32).reshape(a.shape)
        if a.dtype.kind == "f" and (np.isinf(a32) & np.isfinite(a)).any():
            raise ValueError("put_array: the array holds finite values beyond float32's range")
        a = a32
        d = self._dir("reference")
        if d is None:
            return
        path = d / name
        buf = io.BytesIO()
        np.savez_compressed(buf, data=a, sha256=np.frombuffer(hashlib.sha256(a.tobytes()).digest(),
                                                              np.uint8))
        try:
            write_bytes_atomic(path, buf.getvalue())
        except OSError as e:
            self.log(f"warning: cannot write the cache file {path} ({e})")
