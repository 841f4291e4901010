"""pyshadow-bench: ambient occlusion on a bundled scene, timed and measured against Embree.

The main job of pyshadow, end to end, on the bundled default scene (Stanford
bunny and a torus on a ground plane, two walls) or on the user's own meshes:

1. build the casters' Coherent Shadow Maps, or load them from the on-disk
   cache (``platformdirs.user_cache_dir("pyshadow")``, ``$PYSHADOW_CACHE`` or
   ``--cache-dir``; keyed by the mesh hash, every build parameter and the
   compression code; a corrupt cache file is rebuilt);
2. render AO (:meth:`pyshadow.Scene.render`, 36 cosine-weighted Hammersley
   samples per pixel by default) and time it;
3. trace the *identical* rays -- the same G-buffer points, the same sample
   directions -- with Embree (embreex, one thread per core) and time them;
   per-ray agreement of the two isolates the CSM's discretisation error
   (DESIGN.md, "Measuring");
4. trace a converged Embree reference (1024 samples per pixel by default,
   cached like the CSMs) and measure the AO error against both references;
5. print one table and write ``ao.png``, ``reference.png``,
   ``difference.png``, ``ao.exr``, ``reference.exr``, ``converged.exr`` and
   ``results.json`` into ``--out``.

``--sweep`` runs the speed/accuracy trade study instead (maps, resolution,
samples, filter, depth bits) and writes ``sweep.json``, ``sweep.md`` and
``pareto.png``; ``--max-error E`` names the fastest configuration of a sweep
whose AO RMSE (against the converged reference) is at most ``E``.

Every figure of ``results.json`` is an object ``{"value": ..., "unit": ...,
"label": ...}``; see ``benchmarks/README.md`` for the schema and the
commands that reproduce every published figure.

Usage::

    pyshadow-bench                       # default scene, 640x480, 36 samples (< 3 min)
    pyshadow-bench --quick               # smaller settings (< 1 min)
    pyshadow-bench --sweep --max-error 0.02
    pyshadow-bench --mesh a.obj --mesh b.ply --json
    python -m pyshadow.bench ...         # the same
"""
from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import math
import os
import platform
import statistics
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from ._files import write_bytes_atomic

__all__ = ["main", "PRESETS", "SWEEP_GRIDS", "Config", "CSMCache", "EmbreeTracer", "mesh_scene",
           "pareto_front"]

SCHEMA = "pyshadow-bench/1"
#: The single benchmark times pyshadow and Embree on at most this many samples
#: (all covered pixels at the presets; the first pixels of bigger custom runs).
TIMED_SAMPLES = 1 << 25
SWEEP_SCHEMA = "pyshadow-bench-sweep/1"


# ---------------------------------------------------------------------------
# configurations
# ---------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Config:
    """One configuration of the AO pipeline (what a sweep row varies)."""

    maps: tuple            # zigzag (theta, phi)
    resolution: int        # texels per CSM side
    depth_bits: int        # 16 or 32
    samples: int           # AO samples per pixel
    filter: str | None = None     # None or a Scene.render filter
    filtered_lookup: bool = False     # Scene.visible(..., filtered=True) and its AO

    @property
    def label(self) -> str:
        s = f"{self.maps[0]}x{self.maps[1]} r{self.resolution} {self.depth_bits}b s{self.samples}"
        return s + (f" {self.filter}" if self.filter else "") + (" filtered-lookup" if self.filtered_lookup else "")

    def as_dict(self) -> dict:
        return {"maps": f"{self.maps[0]}x{self.maps[1]}", "layout": "zigzag",
                "views": self.maps[0] * self.maps[1], "resolution": self.resolution,
                "depth_bits": self.depth_bits, "samples": self.samples, "filter": self.filter,
                "filtered_lookup": self.filtered_lookup}


#: Settings of the two standard runs. ``reference_samples``: converged reference.
PRESETS = {
    "default": dict(maps=(64, 128), resolution=128, depth_bits=16, size=(640, 480), samples=36,
                    reference_samples=1024, repeats=5),
    "quick": dict(maps=(32, 64), resolution=128, depth_bits=16, size=(320, 240), samples=36,
                  reference_samples=512, repeats=3),
}

#: Sweep grids: rows as overrides of the base configuration (the run's settings).
#: One knob at a time, then a few combinations. Cost on the 2-core development
#: machine (cold cache, CPU through PoCL): 'full' about 8 minutes, half of it
#: building the 128x256 and 256^2 maps (up to twice that on a busy machine);
#: 'quick' about 2 minutes; 'tiny' (for tests) seconds.
SWEEP_GRIDS = {
    "full": [
        {},
        {"maps": (16, 32)}, {"maps": (32, 64)}, {"maps": (128, 256)},
        {"resolution": 64}, {"resolution": 256},
        {"depth_bits": 32},
        {"samples": 4}, {"samples": 16}, {"samples": 64}, {"samples": 144}, {"samples": 256},
        {"filter": "bilateral"},
        {"samples": 16, "filter": "bilateral"},
        {"maps": (32, 64), "samples": 16, "filter": "bilateral"},
        {"maps": (32, 64), "resolution": 64, "samples": 16, "filter": "bilateral"},
        {"maps": (16, 32), "resolution": 64, "samples": 4, "filter": "bilateral"},
        {"samples": 144, "filter": "bilateral"},
        {"resolution": 256, "samples": 144},
        {"filtered_lookup": True},
        {"samples": 144, "filtered_lookup": True},
    ],
    "quick": [
        {},
        {"maps": (16, 32)}, {"maps": (64, 128)},
        {"resolution": 64}, {"resolution": 256},
        {"depth_bits": 32},
        {"samples": 4}, {"samples": 16}, {"samples": 64}, {"samples": 144},
        {"filter": "bilateral"},
        {"samples": 16, "filter": "bilateral"},
        {"maps": (16, 32), "resolution": 64, "samples": 4, "filter": "bilateral"},
        {"filtered_lookup": True},
    ],
    "tiny": [
        {}, {"samples": 4}, {"filter": "bilateral"}, {"maps": (4, 8)}, {"depth_bits": 32}, {"filtered_lookup": True},
    ],
}

_VARIES = ("maps", "resolution", "depth_bits", "samples", "filter")


# ---------------------------------------------------------------------------
# small helpers
# ---------------------------------------------------------------------------
class _Log:
    """Progress and information on stderr (stdout carries only the result)."""

    def __init__(self, quiet: bool = False):
        self.quiet = quiet

    def __call__(self, msg: str):
        if not self.quiet:
            print(msg, file=sys.stderr, flush=True)


_PROGRESS = {"on": True}      # --quiet turns progress bars off


def _bar(total, desc, unit="it"):
    """A tqdm bar on stderr, shown only on a terminal (and not with --quiet)."""
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit=unit, file=sys.stderr,
                disable=None if _PROGRESS["on"] else True, leave=False)


def _fig(value, unit: str, label: str) -> dict:
    if isinstance(value, (np.floating, np.integer)):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        value = None
    return {"value": value, "unit": unit, "label": label}


def environment(threads: int) -> dict:
    """Device and software the figures were measured on."""
    import pyshadow

    info = pyshadow.device_info()
    try:
        from importlib.metadata import version

        embreex_version = version("embreex")
    except Exception:                          # not installed as a distribution
        embreex_version = None
    return {"device": info["name"], "platform": info["platform"], "device_type": info["type"],
            "compute_units": info["compute_units"], "cpu_count": os.cpu_count(),
            "embree_threads": threads, "embreex": embreex_version,
            "python": sys.version.split()[0], "machine": platform.machine(),
            "pyshadow": pyshadow.__version__}


# ---------------------------------------------------------------------------
# the on-disk cache
# ---------------------------------------------------------------------------
def default_cache_dir() -> Path:
    """``$PYSHADOW_CACHE`` if set, else ``platformdirs.user_cache_dir("pyshadow")``."""
    env = os.environ.get("PYSHADOW_CACHE", "").strip()
    if env:
        return Path(env).expanduser()
    import platformdirs

    return Path(platformdirs.user_cache_dir("pyshadow"))


def _code_digest() -> str:
    """Hash of the code a CSM depends on: pyshadow's version and the build kernels."""
    import pyshadow
    from pyshadow import _cl

    from pyshadow.csm import FRONT_MARGIN_TEXELS

    h = hashlib.sha256(pyshadow.__version__.encode())
    h.update(repr(FRONT_MARGIN_TEXELS).encode())
    for name in ("csm.cl", "raster.cl"):
        try:
            h.update(_cl.kernel_source(name).encode())
        except (OSError, FileNotFoundError):
            h.update(b"?" + name.encode())
    return h.hexdigest()


class CSMCache:
    """CSMs (and converged references) on disk, keyed by everything they depend on.

    A CSM file ``csm/<mesh hash[:12]>-<key[:24]>.csm`` is written with
    :meth:`pyshadow.CoherentShadowMap.save` (atomic, checksummed); a sidecar
    ``.json`` keeps its original build time. The key hashes the mesh hash,
    the view set (layout and parameters), resolution, depth bits, layer rule,
    the CSM file format version, pyshadow's version and the build kernels'
    source. A file that fails to load (checksum, truncation, format) or does
    not match its key is rebuilt and replaced; a cache directory that cannot
    be written only disables caching.

    Parameters
    ----------
    root : path or None
        Cache directory; ``None`` disables the cache.
    """

    def __init__(self, root, log=None):
        self.root = Path(root) if root is not None else None
        self.log = log or _Log(True)
        self._code = None
        self._warned = False

    @property
    def enabled(self) -> bool:
        return self.root is not None

    def _dir(self, sub: str) -> Path | None:
        if self.root is None:
            return None
        d = self.root / sub
        try:
            d.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            if not self._warned:
                self.log(f"warning: cache directory {d} cannot be created ({e}); not caching")
                self._warned = True
            return None
        return d

    def csm_key(self, mesh_hash: str, views, resolution: int, depth_bits: int, layers) -> str:
        from pyshadow.csm import FORMAT_VERSION

        if self._code is None:
            self._code = _code_digest()
        spec = {"mesh": mesh_hash, "layout": views.layout,
                "params": {k: views.params[k] for k in sorted(views.params)}, "maps": len(views),
                "resolution": int(resolution), "depth_bits": int(depth_bits), "layers": str(layers),
                "format": FORMAT_VERSION, "code": self._code}
        return hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()

    def csm(self, name: str, mesh, views, resolution: int, depth_bits: int, layers="auto",
            progress: bool = False):
        """The CSM of ``mesh`` for these parameters: from the cache, or built (and stored).

        Returns
        -------
        csm : CoherentShadowMap
        info : dict
            ``name``, ``source`` ('cached', 'built' or 'rebuilt' after a bad
            cache file), ``seconds`` (time spent now), ``build_seconds`` (of
            the original build; None if unknown), ``file``, ``stats``.
        """
        from pyshadow import CoherentShadowMap
        from pyshadow.mesh import mesh_hash as _mesh_hash

        mh = _mesh_hash(mesh)
        key = self.csm_key(mh, views, resolution, depth_bits, layers)
        d = self._dir("csm")
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
                if csm.views.layout != views.layout or csm.views.params != views.params:
                    bad.append("views")
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
                build = None
                try:
                    meta = json.loads(side.read_text())
                    if meta.get("key") == key:
                        build = float(meta["build_seconds"])
                except (OSError, ValueError, KeyError, TypeError):
                    pass
                return csm, {"name": name, "source": "cached", "seconds": time.perf_counter() - t0,
                             "build_seconds": build, "file": str(path), "stats": csm.stats}
        self.log(f"building the CSM of {name}: {len(views)} maps of {resolution}^2 texels, "
                 f"{depth_bits}-bit depth")
        csm = CoherentShadowMap.build(mesh, views, resolution, depth_bits, layers, progress=progress)
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
        """A cached float32 array (None when absent or damaged: the entry is removed)."""
        d = self._dir("reference")
        if d is None:
            return None
        path = d / f"{key[:40]}.npz"
        if not path.exists():
            return None
        try:
            with np.load(path, allow_pickle=False) as z:
                a = np.array(z["data"], dtype=np.float32)
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
        d = self._dir("reference")
        if d is None:
            return
        a = np.ascontiguousarray(a, dtype=np.float32)
        path = d / f"{key[:40]}.npz"
        import io

        buf = io.BytesIO()
        np.savez_compressed(buf, data=a, sha256=np.frombuffer(hashlib.sha256(a.tobytes()).digest(),
                                                              np.uint8))
        try:
            write_bytes_atomic(path, buf.getvalue())
        except OSError as e:
            self.log(f"warning: cannot write the cache file {path} ({e})")


# ---------------------------------------------------------------------------
# scenes
# ---------------------------------------------------------------------------
def mesh_scene(meshes, *, views, resolution: int = 128, depth_bits: int = 16, layers="auto",
               width: int = 640, height: int = 480, csm_for=None, fov_y: float = 40.0,
               gap: float = 0.5):
    """User meshes standing side by side on a ground plane, and a camera framing them.

    Parameters
    ----------
    meshes : list of (name, trimesh.Trimesh)
        Each is scaled to bounding radius 1, centred on its bounding sphere,
        lifted so its lowest vertex touches the ground ``y = 0`` and placed
        along x, ``2 + gap`` apart (the row centred on x = 0).
    views, resolution, depth_bits, layers :
        CSM options (:meth:`pyshadow.CoherentShadowMap.build`).
    csm_for : callable, optional
        ``csm_for(name, mesh) -> CoherentShadowMap``; default builds.
    fov_y : float
        Vertical field of view of the camera, degrees.

    Returns
    -------
    scene : pyshadow.Scene
        One caster instance per mesh (ids in the given order), ground ``y = 0``.
    camera : pyshadow.Camera
        Looking at the row from the front (+z), above and to the right, at a
        distance where the bounding sphere of all bodies fits the image.
    """
    from pyshadow import Camera, CoherentShadowMap, Scene
    from pyshadow.mesh import stand_on_ground

    scene = Scene(ground=0.0, views=views, resolution=resolution, depth_bits=depth_bits,
                  layers=layers)
    n = len(meshes)
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for i, (name, mesh) in enumerate(meshes):
        T = stand_on_ground(mesh, position=((i - (n - 1) / 2.0) * (2.0 + gap), 0.0))
        w = np.asarray(mesh.vertices) @ T[:3, :3].T + T[:3, 3]
        lo, hi = np.minimum(lo, w.min(axis=0)), np.maximum(hi, w.max(axis=0))
        csm = csm_for(name, mesh) if csm_for is not None else None
        if csm is None:
            csm = CoherentShadowMap.build(mesh, views, resolution, depth_bits, layers, progress=False)
        scene.add(csm, T, mesh=mesh)
    target = 0.5 * (lo + hi)
    radius = 0.5 * float(np.linalg.norm(hi - lo))
    half = math.radians(fov_y) / 2.0
    half = min(half, math.atan(math.tan(half) * width / height))
    dist = 1.08 * radius / math.sin(half)
    view = np.array([0.35, 0.55, 1.0])
    camera = Camera(target + dist * view / np.linalg.norm(view), target, fov_y=fov_y,
                    width=width, height=height)
    return scene, camera


def _load_meshes(paths):
    """[(name, mesh)] of the --mesh files; raises ValueError with the path on failure."""
    import warnings

    from pyshadow import load_mesh

    out = []
    for p in paths:
        path = Path(p).expanduser()
        if not path.exists():
            raise ValueError(f"--mesh {p}: no such file")
        if not path.is_file():
            raise ValueError(f"--mesh {p}: not a file")
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")        # cleanup notes are not errors here
                mesh = load_mesh(path)
        except Exception as e:
            raise ValueError(f"--mesh {p}: cannot load it as a mesh ({e})") from None
        if len(mesh.faces) == 0:
            raise ValueError(f"--mesh {p}: the mesh has no faces")
        out.append((path.stem, mesh))
    return out


class SceneFactory:
    """Scenes of one geometry (default bodies or user meshes) for any :class:`Config`."""

    def __init__(self, meshes, size, cache: CSMCache, progress: bool):
        self.meshes = meshes               # None: the default scene
        self.size = size
        self.cache = cache
        self.progress = progress

    @property
    def names(self) -> dict:
        """Instance id -> name of every body of the scene (GROUND_ID: 'ground')."""
        from pyshadow.scene import GROUND_ID

        if self.meshes is None:
            from pyshadow.data import DEFAULT_PARTS

            names = dict(enumerate(DEFAULT_PARTS))
        else:
            names = {i: name for i, (name, _) in enumerate(self.meshes)}
        names[GROUND_ID] = "ground"
        return names

    @property
    def description(self) -> str:
        if self.meshes is None:
            from pyshadow.data import DEFAULT_PARTS

            cast = [k for k, v in DEFAULT_PARTS.items() if v[1]]
            recv = [k for k, v in DEFAULT_PARTS.items() if not v[1]]
            return f"default scene ({', '.join(cast)}; receivers {', '.join(recv)}; ground plane)"
        return "meshes " + ", ".join(name for name, _ in self.meshes) + " on a ground plane"

    def __call__(self, cfg: Config):
        """(scene, camera, [csm info per caster type])."""
        from pyshadow import ViewSet

        views = ViewSet.zigzag(*cfg.maps)
        infos, seen = [], {}

        def csm_for(name, mesh):
            from pyshadow.mesh import mesh_hash

            h = mesh_hash(mesh)
            if h not in seen:                  # the same mesh twice: one CSM
                seen[h], info = self.cache.csm(name, mesh, views, cfg.resolution, cfg.depth_bits,
                                               progress=self.progress)
                infos.append(info)
            return seen[h]

        W, H = self.size
        if self.meshes is None:
            from pyshadow.data import default_scene

            scene, camera = default_scene(views=views, resolution=cfg.resolution,
                                          depth_bits=cfg.depth_bits, csm_for=csm_for,
                                          width=W, height=H)
        else:
            scene, camera = mesh_scene(self.meshes, views=views, resolution=cfg.resolution,
                                       depth_bits=cfg.depth_bits, width=W, height=H,
                                       csm_for=csm_for)
        return scene, camera, infos


def _csm_summary(infos) -> dict:
    nbytes = sum(i["stats"]["bytes"] for i in infos)
    unc = sum(i["stats"]["uncompressed_bytes"] for i in infos)
    builds = [i["build_seconds"] for i in infos]
    sources = {i["source"] for i in infos}
    source = "cached" if sources == {"cached"} else ("built" if "cached" not in sources else "partly cached")
    return {"bytes": nbytes, "uncompressed_bytes": unc, "ratio": unc / nbytes if nbytes else float("nan"),
            "build_seconds": sum(builds) if all(b is not None for b in builds) else None,
            "seconds": sum(i["seconds"] for i in infos), "source": source,
            "segments": sum(i["stats"]["segments"] for i in infos)}


# ---------------------------------------------------------------------------
# G-buffer points and rays
# ---------------------------------------------------------------------------
@dataclasses.dataclass
class GBuffer:
    """The covered pixels of a render, exactly as :meth:`Scene.render` queries them."""

    height: int
    width: int
    sel: np.ndarray          # (N,) int64 flat pixel indices (also the pattern indices)
    points: np.ndarray       # (N, 3) float64 world positions
    normals: np.ndarray      # (N, 3) float64 unit normals
    ids: np.ndarray          # (N,) int32 surface ids (instance id, GROUND_ID)
    object_id: np.ndarray    # (H, W) int32

    @classmethod
    def from_render(cls, out, camera):
        oid = out["object_id"]
        hit = oid != -1
        sel = np.flatnonzero(hit.reshape(-1)).astype(np.int64)
        dirs = camera.ray_directions().reshape(-1, 3)[sel]
        depth = out["depth"].reshape(-1)[sel].astype(np.float64)
        pts = camera.eye + depth[:, None] * dirs           # as Scene.render computes them
        n = np.asarray(out["normal"], np.float64).reshape(-1, 3)[sel]
        n = n / np.linalg.norm(n, axis=1, keepdims=True)
        return cls(camera.height, camera.width, sel, pts, n, oid.reshape(-1)[sel].astype(np.int32), oid)

    @property
    def n(self) -> int:
        return len(self.sel)

    def image(self, values, background=1.0) -> np.ndarray:
        img = np.full(self.height * self.width, background, np.float32)
        img[self.sel] = values
        return img.reshape(self.height, self.width)

    def digest(self) -> str:
        h = hashlib.sha256()
        for a in (self.sel, self.points, self.normals, self.ids):
            h.update(np.ascontiguousarray(a).tobytes())
        return h.hexdigest()


def _ray_chunks(gb: GBuffer, samples, strategy, seed, patterns, max_rays=1 << 22):
    """Yield (start, end, dirs float32 (n*S, 3)): the kernels' sample directions of pixel runs."""
    from pyshadow.sampling import sample_directions

    step = max(1, max_rays // samples)
    for s in range(0, gb.n, step):
        e = min(gb.n, s + step)
        d = sample_directions(gb.normals[s:e], samples, strategy, patterns, seed, indices=gb.sel[s:e])
        yield s, e, np.ascontiguousarray(d.reshape(-1, 3), dtype=np.float32)


class EmbreeTracer:
    """Embree occlusion rays of a scene's casters, split over a thread pool.

    The rays are built exactly as :func:`pyshadow.reference.ambient_occlusion`
    builds them (origin lifted along the normal by
    :func:`pyshadow.reference.surface_epsilon`, the ground plane tested
    analytically at the point itself); embreex releases the GIL while it
    traces, so ``threads`` workers use that many cores.
    """

    def __init__(self, scene, threads: int):
        from pyshadow import reference

        self.scene = scene
        self.rays, self.anchor = reference.caster_scene(scene)
        self.eps = reference.surface_epsilon(scene)
        self.threads = int(threads)
        self.pool = ThreadPoolExecutor(self.threads)
        # first call commits Embree's BVH: keep it out of every timing
        self.rays.occluded(np.zeros((1, 3), np.float32), np.array([[0.0, 1.0, 0.0]], np.float32))

    def close(self):
        self.pool.shutdown()

    def occluded(self, o32, d32):
        """Embree occlusion of float32 rays, split over the thread pool; bool (n,)."""
        n = len(o32)
        out = np.empty(n, bool)
        if n == 0:
            return out
        step = max(4096, -(-n // (4 * self.threads)))

        def work(s):
            out[s:s + step] = self.rays.occluded(o32[s:s + step], d32[s:s + step])

        list(self.pool.map(work, range(0, n, step)))
        return out

    def prepare(self, points, normals, dirs32, samples: int):
        """The rays of ``samples`` directions per point, as the reference builds them.

        Parameters
        ----------
        points, normals : ndarray, shape (n, 3), float64
            World points, unit normals.
        dirs32 : ndarray, shape (n * samples, 3), float32

        Returns
        -------
        ground : ndarray, shape (n * samples,), bool
            Rays the ground plane occludes (decided analytically, not traced).
        todo : ndarray of int
            Indices of the rays to trace.
        origins, dirs : ndarray, shape (len(todo), 3), float32
            The rays handed to Embree.
        """
        from pyshadow import reference

        S = int(samples)
        rel = points - self.anchor
        ground = reference.ground_occludes(self.scene, np.repeat(rel, S, axis=0), dirs32, self.anchor)
        origins = np.repeat((rel + self.eps * normals).astype(np.float32), S, axis=0)
        todo = np.flatnonzero(~ground)
        return ground, todo, origins[todo], dirs32[todo]

    def time_rays(self, rays) -> float:
        """Seconds to trace the stored ``[(origins, dirs), ...]`` once."""
        t0 = time.perf_counter()
        for o32, d32 in rays:
            self.occluded(o32, d32)
        return time.perf_counter() - t0


def embree_pass(tracer: EmbreeTracer, gb: GBuffer, samples, strategy, seed, patterns, *,
                keep: bool = True, keep_rays: int = 0, desc: str | None = None):
    """Embree AO on the G-buffer points along the kernels' directions.

    Parameters
    ----------
    keep : bool
        Return every ray's occlusion (``occluded``).
    keep_rays : int
        Also keep the prepared rays of the first pixel chunks, up to about
        this many samples, for timing (``rays``; ``rays_pixels`` of them).

    Returns
    -------
    dict
        ``ao`` (N,) float32, ``occluded`` (N*S,) bool or None, ``seconds``
        (time of this pass's Embree calls), ``traced`` (rays given to
        Embree), ``rays`` and ``rays_pixels`` (see ``keep_rays``),
        ``rays_traced`` (traced rays among them).
    """
    S = int(samples)
    ao = np.empty(gb.n, np.float32)
    occ_all = np.empty(gb.n * S, bool) if keep else None
    seconds, traced = 0.0, 0
    rays, rays_pixels, rays_traced = [], 0, 0
    bar = _bar(gb.n, desc or f"Embree {S} spp", "px")
    try:
        for s, e, d32 in _ray_chunks(gb, S, strategy, seed, patterns):
            occ, todo, o32, dd = tracer.prepare(gb.points[s:e], gb.normals[s:e], d32, S)
            t0 = time.perf_counter()
            occ[todo] = tracer.occluded(o32, dd)
            seconds += time.perf_counter() - t0
            ao[s:e] = (~occ.reshape(e - s, S)).mean(axis=1)
            if keep:
                occ_all[s * S:e * S] = occ
            if rays_pixels * S < keep_rays and rays_pixels == s:
                rays.append((o32, dd))
                rays_pixels, rays_traced = e, rays_traced + len(todo)
            traced += len(todo)
            bar.update(e - s)
    finally:
        bar.close()
    return {"ao": ao, "occluded": occ_all, "seconds": seconds, "traced": traced, "samples": gb.n * S,
            "rays": rays, "rays_pixels": rays_pixels, "rays_traced": rays_traced}


def visibility_pass(scene, gb: GBuffer, samples, strategy, seed, patterns, embree_occluded,
                    filtered=False):
    """pyshadow's :meth:`Scene.visible` on the identical rays, compared with Embree's.

    Returns the fraction of rays on which both agree, and the fractions
    pyshadow calls visible where Embree hits (``false_visible``) and
    occluded where Embree sees the sky (``false_occluded``), and the AO the
    per-ray results give (for a consistency check against ``scene_ao``) and
    the number of disagreeing rays of every pixel (``disagree``, (N,) int).
    """
    S = int(samples)
    agree = fv = fo = 0
    ao = np.empty(gb.n, np.float32)
    disagree = np.empty(gb.n, np.int32)
    for s, e, d32 in _ray_chunks(gb, S, strategy, seed, patterns):
        vis = scene.visible(np.repeat(gb.points[s:e], S, axis=0), d32,
                            surface_ids=np.repeat(gb.ids[s:e], S), filtered=filtered)
        ref = ~embree_occluded[s * S:e * S]
        agree += int(np.count_nonzero(vis == ref))
        fv += int(np.count_nonzero(vis & ~ref))
        fo += int(np.count_nonzero(~vis & ref))
        ao[s:e] = vis.reshape(e - s, S).mean(axis=1)
        disagree[s:e] = (vis != ref).reshape(e - s, S).sum(axis=1)
    total = max(1, gb.n * S)
    return {"agreement": agree / total, "false_visible": fv / total, "false_occluded": fo / total,
            "ao": ao, "disagree": disagree}


def by_surface(gb: GBuffer, names: dict, samples: int, disagree, ao, ref_ao, conv_ao) -> list:
    """Per surface (instance or ground): pixels, ray agreement, AO bias and errors."""
    from pyshadow.scene import GROUND_ID

    rows = []
    for sid in np.unique(gb.ids):
        m = gb.ids == sid
        d = ao[m].astype(np.float64) - ref_ao[m]
        rows.append({
            "surface": names.get(int(sid), "ground" if sid == GROUND_ID else f"instance {int(sid)}"),
            "id": int(sid),
            "pixels": _fig(int(m.sum()), "px", "covered pixels of this surface"),
            "visibility_agreement": _fig(1.0 - disagree[m].sum() / (m.sum() * samples), "fraction",
                                         "rays on which pyshadow and Embree agree"),
            "ao_bias_identical": _fig(float(d.mean()), "AO", "mean pyshadow - Embree, identical rays"),
            "ao_rmse_identical": _fig(_errors(ao[m], ref_ao[m])[0], "AO", "AO RMSE, identical rays"),
            "ao_rmse_converged": _fig(_errors(ao[m], conv_ao[m])[0], "AO",
                                      "unfiltered AO RMSE vs converged"),
        })
    return rows


def _errors(a, b):
    d = np.asarray(a, np.float64) - np.asarray(b, np.float64)
    if d.size == 0:
        return float("nan"), float("nan")
    return float(np.sqrt(np.mean(d * d))), float(np.mean(np.abs(d)))


def _reference_key(scene, gb: GBuffer, samples, strategy, seed, patterns) -> str:
    """Everything a converged reference depends on."""
    import pyshadow
    from pyshadow.reference import surface_epsilon

    h = hashlib.sha256(b"pyshadow-bench converged reference v1")
    h.update(gb.digest().encode())
    h.update(json.dumps([int(samples), strategy, int(seed), int(patterns), scene.ground,
                         surface_epsilon(scene), pyshadow.__version__]).encode())
    for inst in scene.instances:
        if inst.casts:
            from pyshadow.mesh import mesh_hash

            h.update(mesh_hash(inst.mesh).encode())
            h.update(np.ascontiguousarray(inst.transform, "<f8").tobytes())
    return h.hexdigest()


def converged_reference(cache: CSMCache, tracer, scene, gb, samples, strategy, seed, patterns, log):
    """(ao (N,) float32, seconds or None when cached, source)."""
    key = _reference_key(scene, gb, samples, strategy, seed, patterns)
    ao = cache.array(key)
    if ao is not None and ao.shape == (gb.n,):
        return ao, None, "cached"
    log(f"tracing the converged Embree reference: {samples} samples x {gb.n} pixels "
        f"({gb.n * samples / 1e6:.0f} M rays, {tracer.threads} threads)")
    t0 = time.perf_counter()
    r = embree_pass(tracer, gb, samples, strategy, seed, patterns, keep=False,
                    desc=f"reference {samples} spp")
    seconds = time.perf_counter() - t0
    cache.put_array(key, r["ao"])
    return r["ao"], seconds, "computed"


# ---------------------------------------------------------------------------
# images
# ---------------------------------------------------------------------------
def difference_rgb(diff, covered, vmax=None):
    """Diverging colour image of ``diff`` (RdBu centred at 0, symmetric range), uint8 RGB.

    Red: pyshadow darker (more occluded) than the reference; blue: lighter.
    The range is ``vmax`` or the 99.5th percentile of ``|diff|`` over the
    covered pixels (at least 0.01). Returns ``(rgb, vmax)``.
    """
    import matplotlib

    d = np.asarray(diff, np.float64)
    if vmax is None:
        a = np.abs(d[covered])
        vmax = max(0.01, float(np.percentile(a, 99.5)) if a.size else 0.0)
    cmap = matplotlib.colormaps["RdBu"]
    rgb = cmap(np.clip(0.5 + 0.5 * d / vmax, 0.0, 1.0), bytes=True)[..., :3]
    return np.ascontiguousarray(rgb, dtype=np.uint8), vmax


# ---------------------------------------------------------------------------
# the main run
# ---------------------------------------------------------------------------
def run_main(args, cfg: Config, factory: SceneFactory, cache: CSMCache, log) -> dict:
    import pyshadow

    t_start = time.perf_counter()
    out_dir = Path(args.out)
    S, strat, seed, pat = cfg.samples, args.strategy, args.seed, args.patterns
    scene, camera, infos = factory(cfg)
    csm = _csm_summary(infos)

    log(f"rendering {camera.width}x{camera.height}, {S} samples ({strat})")

    def render():
        return scene.render(camera, S, strat, seed, pat, filter=cfg.filter, filtered=cfg.filtered_lookup)

    out = render()                       # also the warm-up: kernel builds
    gb = GBuffer.from_render(out, camera)
    N = gb.n
    if N == 0:
        raise RuntimeError("the camera sees no surface: nothing to measure")

    def ao_call(sl=slice(None)):         # what Scene.render asks of the AO kernel
        return scene.ambient_occlusion(gb.points[sl], gb.normals[sl], S, strat, pat, seed, True,
                                       indices=gb.sel[sl], surface_ids=gb.ids[sl], filtered=cfg.filtered_lookup)[0]

    raw = ao_call()
    ao_img = out["ao"]
    tracer = EmbreeTracer(scene, args.threads)
    try:
        log(f"tracing the identical {N * S / 1e6:.1f} M rays with Embree ({tracer.threads} threads)")
        ident = embree_pass(tracer, gb, S, strat, seed, pat, keep_rays=TIMED_SAMPLES,
                            desc=f"Embree {S} spp")
        # timed pixels: all of them unless that is more than TIMED_SAMPLES samples
        K = ident["rays_pixels"]
        sub = slice(0, K)
        log(f"timing: {args.repeats} interleaved rounds of render, pyshadow AO and Embree"
            + ("" if K == N else f" (AO and Embree on the first {K} pixels)"))
        times = {"frame": [], "ao": [], "embree": []}
        bar = _bar(args.repeats, "timing", "round")
        try:
            for _ in range(args.repeats):   # interleaved, so machine noise hits all three alike
                t0 = time.perf_counter()
                render()
                times["frame"].append(time.perf_counter() - t0)
                t0 = time.perf_counter()
                ao_call(sub)
                times["ao"].append(time.perf_counter() - t0)
                times["embree"].append(tracer.time_rays(ident["rays"]))
                bar.update(1)
        finally:
            bar.close()
        ident["rays"] = None
        frame_time, ao_time, embree_time = (statistics.median(times[k]) for k in ("frame", "ao", "embree"))
        vis = visibility_pass(scene, gb, S, strat, seed, pat, ident["occluded"], cfg.filtered_lookup)
        conv, conv_s, conv_src = converged_reference(cache, tracer, scene, gb, args.reference_samples,
                                                     strat, seed, pat, log)
    finally:
        tracer.close()

    # primary rays: does the rasterised G-buffer see what Embree's primary rays see?
    from pyshadow import reference

    items, item_ids = scene.draw_items()
    eg = reference.gbuffer(items, camera)["object_id"]
    eg = np.where(eg >= 0, item_ids[np.maximum(eg, 0)] if len(item_ids) else -1, -1)
    prim_agree = float(np.mean(eg == out["object_id"]))

    final = ao_img.reshape(-1)[gb.sel]                 # the image as rendered (filtered if asked)
    rmse_i, mae_i = _errors(raw, ident["ao"])
    rmse_c, mae_c = _errors(final, conv)
    noise_rmse, noise_mae = _errors(ident["ao"], conv)
    consistency = float(np.max(np.abs(vis["ao"] - raw))) if N else 0.0

    # images
    ref_img = gb.image(ident["ao"])
    conv_img = gb.image(conv)
    diff = gb.image(raw - ident["ao"], 0.0)
    rgb, vmax = difference_rgb(diff, gb.object_id != -1)
    files = {}
    for name, img in (("ao.png", ao_img), ("reference.png", ref_img), ("difference.png", rgb),
                      ("ao.exr", ao_img.astype(np.float32)), ("reference.exr", ref_img),
                      ("converged.exr", conv_img)):
        pyshadow.write_image(out_dir / name, img)
        files[name] = str(out_dir / name)

    nS = N * S
    figures = {
        "csm_build_time": _fig(csm["build_seconds"], "s", "CSM build (all casters)"),
        "csm_time": _fig(csm["seconds"], "s", "time to obtain the CSMs in this run (build or cache load)"),
        "csm_size": _fig(csm["bytes"] / 1e6, "MB", "CSM size (all casters, 10^6 bytes)"),
        "csm_bytes": _fig(csm["bytes"], "B", "CSM size (all casters)"),
        "csm_ratio": _fig(csm["ratio"], "1", "compression ratio (D*R^2*depth bytes / stored bytes)"),
        "covered_pixels": _fig(N, "px", "pixels covered by a surface"),
        "ao_samples": _fig(nS, "samples", "AO samples per frame (samples x covered pixels)"),
        "frame_time": _fig(frame_time, "s", "Scene.render frame time (median)"),
        "timed_pixels": _fig(K, "px", "pixels whose AO is timed (pyshadow and Embree alike)"),
        "ao_time": _fig(ao_time, "s", "Scene.ambient_occlusion on the timed pixels (median)"),
        "ao_throughput": _fig(K * S / ao_time / 1e6, "Msamples/s", "pyshadow AO samples per second"),
        "frame_throughput": _fig(nS / frame_time / 1e6, "Msamples/s",
                                 "AO samples per second of whole frames"),
        "embree_time": _fig(embree_time, "s", "Embree on the identical rays of the timed pixels "
                                              "(median)"),
        "embree_throughput": _fig(K * S / embree_time / 1e6 if embree_time else None,
                                  "Msamples/s", "Embree AO samples per second (same samples)"),
        "embree_ray_rate": _fig(ident["rays_traced"] / embree_time / 1e6 if embree_time else None,
                                "Mrays/s", "Embree occlusion rays traced per second"),
        "embree_rays": _fig(ident["traced"], "rays", "rays traced by Embree per frame (the others "
                                                     "the ground plane decides analytically)"),
        "embree_threads": _fig(tracer.threads, "threads", "Embree worker threads"),
        "speedup": _fig(embree_time / ao_time if ao_time else None, "x",
                        "pyshadow / Embree throughput on the same samples"),
        "visibility_agreement": _fig(vis["agreement"], "fraction",
                                     "rays on which pyshadow and Embree agree"),
        "false_visible": _fig(vis["false_visible"], "fraction",
                              "rays pyshadow calls unoccluded that Embree finds occluded"),
        "false_occluded": _fig(vis["false_occluded"], "fraction",
                               "rays pyshadow calls occluded that Embree finds unoccluded"),
        "ao_rmse_identical": _fig(rmse_i, "AO", f"AO RMSE vs Embree, identical {S} directions"),
        "ao_mae_identical": _fig(mae_i, "AO", f"AO MAE vs Embree, identical {S} directions"),
        "ao_rmse_converged": _fig(rmse_c, "AO",
                                  f"AO RMSE vs converged Embree ({args.reference_samples} spp)"),
        "ao_mae_converged": _fig(mae_c, "AO", f"AO MAE vs converged Embree ({args.reference_samples} spp)"),
        "reference_noise_rmse": _fig(noise_rmse, "AO", f"Embree {S} spp vs converged: RMSE "
                                                        "(sampling noise alone)"),
        "converged_time": _fig(conv_s, "s", "time of the converged reference (null when cached)"),
        "primary_agreement": _fig(prim_agree, "fraction",
                                  "pixels where raster and Embree primary rays see the same object"),
        "difference_range": _fig(vmax, "AO", "difference.png colour range (+-)"),
    }
    figures["total_time"] = _fig(time.perf_counter() - t_start, "s", "wall time of this run")
    return {
        "schema": SCHEMA,
        "mode": args.mode,
        "environment": environment(args.threads),
        "scene": factory.description,
        "config": {**cfg.as_dict(), "width": camera.width, "height": camera.height,
                   "strategy": strat, "seed": seed, "patterns": pat,
                   "reference_samples": args.reference_samples, "repeats": args.repeats},
        "csm": {"source": csm["source"], "casters": [
            {"name": i["name"], "source": i["source"], "file": i["file"],
             "seconds": _fig(i["seconds"], "s", "time in this run"),
             "build_time": _fig(i["build_seconds"], "s", "original build time"),
             "bytes": _fig(i["stats"]["bytes"], "B", "stored size"),
             "ratio": _fig(i["stats"]["ratio"], "1", "compression ratio"),
             "segments": i["stats"]["segments"], "layer_rule": i["stats"]["layer_rule"]}
            for i in infos]},
        "converged_source": conv_src,
        "figures": figures,
        "surfaces": by_surface(gb, factory.names, S, vis["disagree"], raw, ident["ao"], conv),
        "checks": {"ao_equals_render": bool(cfg.filter is not None or np.array_equal(raw, final)),
                   "ao_vs_visible_max_abs": consistency},
        "files": files,
    }


def format_table(r: dict) -> str:
    f = {k: v["value"] for k, v in r["figures"].items()}
    c, env = r["config"], r["environment"]

    def num(x, fmt):
        return "n/a" if x is None else format(x, fmt)

    if r["csm"]["source"] == "cached":
        build = "cached (loaded in %.2f s%s)" % (
            f["csm_time"], "" if f["csm_build_time"] is None else f"; built in {f['csm_build_time']:.1f} s")
    else:
        build = f"{f['csm_time']:.1f} s ({r['csm']['source']})"
    rs = c["reference_samples"]
    conv_t = "cached" if r["converged_source"] == "cached" else f"{f['converged_time']:.1f} s"
    rows = [
        ("device", f"{env['device']} ({env['platform']}, {env['device_type']}, "
                   f"{env['compute_units']} compute units)"),
        ("CSM build", build),
        ("CSM size, ratio", f"{f['csm_size']:.2f} MB, {f['csm_ratio']:.1f}:1"),
        ("AO", f"{num(f['ao_throughput'], '.2f')} Msamples/s; frame {f['frame_time'] * 1e3:.0f} ms "
               f"(AO {f['ao_time'] * 1e3:.0f} ms; {f['covered_pixels']} px)"),
        (f"Embree, same rays ({env['embree_threads']} thr)",
         f"{num(f['embree_ray_rate'], '.2f')} Mrays/s ({num(f['embree_throughput'], '.2f')} Msamples/s)"),
        ("pyshadow / Embree", f"{num(f['speedup'], '.2f')}x"),
        ("visibility agreement", f"{100 * f['visibility_agreement']:.3f} % "
                                 f"({100 * f['false_visible']:.3f} % too open, "
                                 f"{100 * f['false_occluded']:.3f} % too shadowed)"),
        (f"AO vs Embree, same {c['samples']} dirs", f"RMSE {f['ao_rmse_identical']:.4f}  "
                                                    f"MAE {f['ao_mae_identical']:.4f}"),
        (f"AO vs Embree {rs} spp", f"RMSE {f['ao_rmse_converged']:.4f}  MAE {f['ao_mae_converged']:.4f}"
                                   f"  (Embree {c['samples']} spp itself: RMSE "
                                   f"{f['reference_noise_rmse']:.4f})"),
        ("converged reference", conv_t),
        ("total", f"{f['total_time']:.1f} s"),
        ("by surface", "pixels, ray agreement, AO bias and RMSE (pyshadow - Embree)"),
    ]
    for srf in r.get("surfaces", []):
        g = {k: v["value"] for k, v in srf.items() if isinstance(v, dict)}
        rows.append((f"  {srf['surface']}", f"{g['pixels']:>7} px  agreement "
                     f"{100 * g['visibility_agreement']:7.3f} %  bias {g['ao_bias_identical']:+.4f}  "
                     f"RMSE {g['ao_rmse_identical']:.4f} (same dirs) {g['ao_rmse_converged']:.4f} "
                     f"(converged)"))
    w = max(len(k) for k, _ in rows)
    head = (f"pyshadow-bench ({r['mode']}): {r['scene']}\n"
            f"  {c['width']}x{c['height']}, {c['samples']} samples ({c['strategy']}), maps zigzag "
            f"{c['maps']} at {c['resolution']}^2, {c['depth_bits']}-bit depth"
            + (f", filter {c['filter']}" if c["filter"] else "")
            + (", filtered lookups" if c.get("filtered_lookup") else ""))
    return head + "\n" + "\n".join(f"  {k:<{w}}  {v}" for k, v in rows)


# ---------------------------------------------------------------------------
# the sweep
# ---------------------------------------------------------------------------
def pareto_front(points) -> list[int]:
    """Indices of the non-dominated (time, error) pairs (both minimised), by time.

    A point is dominated when another is no worse in both and better in one.
    Points with a missing value are never on the front.
    """
    pts = [(i, t, e) for i, (t, e) in enumerate(points)
           if t is not None and e is not None and math.isfinite(t) and math.isfinite(e)]
    front = []
    for i, t, e in pts:
        if not any((t2 <= t and e2 <= e) and (t2 < t or e2 < e) for j, t2, e2 in pts if j != i):
            front.append(i)
    return sorted(front, key=lambda i: points[i][0])


def sweep_configs(base: Config, grid: str) -> list[tuple[Config, str]]:
    """(config, what it varies) rows of a grid, duplicates dropped."""
    rows, seen = [], set()
    for over in SWEEP_GRIDS[grid]:
        cfg = dataclasses.replace(base, **over)
        if cfg in seen:
            continue
        seen.add(cfg)
        varies = "base" if not over else (next(iter(over)) if len(over) == 1 else "combination")
        rows.append((cfg, varies))
    return rows


def run_sweep(args, base: Config, factory: SceneFactory, cache: CSMCache, log) -> dict:
    t_start = time.perf_counter()
    configs = sweep_configs(base, args.sweep_grid)
    strat, seed, pat = args.strategy, args.seed, args.patterns
    log(f"sweep '{args.sweep_grid}': {len(configs)} configurations around {base.label}, "
        f"{factory.size[0]}x{factory.size[1]}, {args.repeats} timed runs each")
    # the G-buffer does not depend on the CSMs: one G-buffer, one converged reference
    scene0, camera, _ = factory(base)
    gb = GBuffer.from_render(scene0.render(camera, 1, strat, seed, pat), camera)
    if gb.n == 0:
        raise RuntimeError("the camera sees no surface: nothing to measure")
    tracer = EmbreeTracer(scene0, args.threads)
    embree = {}
    rows = []
    try:
        conv, conv_s, conv_src = converged_reference(cache, tracer, scene0, gb, args.reference_samples,
                                                     strat, seed, pat, log)
        # pass 1: build (or load) every configuration, warm its kernels up, measure its accuracy
        entries = []
        bar = _bar(len(configs), "sweep: accuracy", "config")
        try:
            for cfg, varies in configs:
                log(f"  {cfg.label}")
                scene, camera, infos = factory(cfg)
                csm = _csm_summary(infos)
                out = scene.render(camera, cfg.samples, strat, seed, pat, filter=cfg.filter,
                                   filtered=cfg.filtered_lookup)
                if not np.array_equal(out["object_id"], gb.object_id):
                    raise RuntimeError(f"{cfg.label}: the G-buffer differs from the base render")
                raw = scene.ambient_occlusion(gb.points, gb.normals, cfg.samples, strat, pat, seed,
                                              True, indices=gb.sel, surface_ids=gb.ids,
                                              filtered=cfg.filtered_lookup)[0]
                if cfg.samples not in embree:
                    embree[cfg.samples] = embree_pass(tracer, gb, cfg.samples, strat, seed, pat,
                                                      desc=f"Embree {cfg.samples} spp")
                ident = embree[cfg.samples]
                vis = visibility_pass(scene, gb, cfg.samples, strat, seed, pat, ident["occluded"],
                                      cfg.filtered_lookup)
                rmse_c, mae_c = _errors(out["ao"].reshape(-1)[gb.sel], conv)
                rmse_i, _ = _errors(raw, ident["ao"])
                entries.append({"cfg": cfg, "varies": varies, "scene": scene, "camera": camera,
                                "csm": csm, "vis": vis, "rmse_c": rmse_c, "mae_c": mae_c,
                                "rmse_i": rmse_i, "frame": [], "ao": []})
                bar.update(1)
        finally:
            bar.close()
        embree.clear()
        # pass 2: timing, in interleaved rounds over all configurations, so that a slow
        # stretch of a shared machine slows every configuration alike
        log(f"timing: {args.repeats} interleaved rounds over {len(entries)} configurations")
        bar = _bar(args.repeats * len(entries), "sweep: timing", "run")
        try:
            for _ in range(args.repeats):
                for ent in entries:
                    cfg, scene = ent["cfg"], ent["scene"]
                    t0 = time.perf_counter()
                    scene.render(ent["camera"], cfg.samples, strat, seed, pat, filter=cfg.filter,
                                 filtered=cfg.filtered_lookup)
                    ent["frame"].append(time.perf_counter() - t0)
                    t0 = time.perf_counter()
                    scene.ambient_occlusion(gb.points, gb.normals, cfg.samples, strat, pat, seed, True,
                                            indices=gb.sel, surface_ids=gb.ids, filtered=cfg.filtered_lookup)
                    ent["ao"].append(time.perf_counter() - t0)
                    bar.update(1)
        finally:
            bar.close()
    finally:
        tracer.close()
    for ent in entries:
        cfg, csm, vis = ent["cfg"], ent["csm"], ent["vis"]
        frame_time, ao_time = statistics.median(ent["frame"]), statistics.median(ent["ao"])
        nS = gb.n * cfg.samples
        rows.append({
            "label": cfg.label, "varies": ent["varies"], "config": cfg.as_dict(),
            "csm_source": csm["source"],
            "figures": {
                "build_time": _fig(csm["build_seconds"], "s", "CSM build (all casters)"),
                "csm_bytes": _fig(csm["bytes"], "B", "CSM size (all casters)"),
                "csm_ratio": _fig(csm["ratio"], "1", "compression ratio"),
                "frame_time": _fig(frame_time, "s", "Scene.render frame time (median)"),
                "ao_time": _fig(ao_time, "s", "Scene.ambient_occlusion time (median)"),
                "ao_throughput": _fig(nS / ao_time / 1e6, "Msamples/s", "AO samples per second"),
                "visibility_agreement": _fig(vis["agreement"], "fraction",
                                             "per-ray agreement with Embree"),
                "ao_rmse_converged": _fig(ent["rmse_c"], "AO", "AO RMSE vs converged Embree"),
                "ao_mae_converged": _fig(ent["mae_c"], "AO", "AO MAE vs converged Embree"),
                "ao_rmse_identical": _fig(ent["rmse_i"], "AO", "unfiltered AO RMSE vs Embree on "
                                                               "identical rays"),
            }})
    front = pareto_front([(r["figures"]["frame_time"]["value"], r["figures"]["ao_rmse_converged"]["value"])
                          for r in rows])
    for i, r in enumerate(rows):
        r["pareto"] = i in front
    return {
        "schema": SWEEP_SCHEMA,
        "environment": environment(args.threads),
        "scene": factory.description,
        "grid": args.sweep_grid,
        "base": base.as_dict(),
        "image": {"width": factory.size[0], "height": factory.size[1]},
        "strategy": strat, "seed": seed, "patterns": pat, "repeats": args.repeats,
        "reference_samples": args.reference_samples,
        "converged_source": conv_src,
        "converged_time": _fig(conv_s, "s", "converged reference (null when cached)"),
        "rows": rows,
        "pareto": [rows[i]["label"] for i in front],
        "runtime": _fig(time.perf_counter() - t_start, "s", "wall time of the sweep"),
    }


def best_under(sweep: dict, max_error: float):
    """The fastest row (frame time) with AO RMSE vs the converged reference <= max_error."""
    ok = [r for r in sweep["rows"]
          if r["figures"]["ao_rmse_converged"]["value"] is not None
          and r["figures"]["ao_rmse_converged"]["value"] <= max_error]
    return min(ok, key=lambda r: r["figures"]["frame_time"]["value"]) if ok else None


def _answer(sweep: dict, max_error: float) -> dict:
    row = best_under(sweep, max_error)
    return {"threshold": _fig(max_error, "AO", "largest AO RMSE vs the converged reference allowed"),
            "label": row["label"] if row else None, "row": row}


def _answer_text(ans: dict) -> str:
    e = ans["threshold"]["value"]
    row = ans["row"]
    if row is None:
        return f"no configuration of the sweep reaches AO RMSE <= {e:g}"
    f = {k: v["value"] for k, v in row["figures"].items()}
    return (f"fastest configuration with AO RMSE <= {e:g}: {row['label']} -- "
            f"{f['frame_time'] * 1e3:.0f} ms/frame, RMSE {f['ao_rmse_converged']:.4f}, "
            f"{f['csm_bytes'] / 1e6:.2f} MB of CSMs, agreement {100 * f['visibility_agreement']:.2f} %")


def _config_of(d: dict) -> Config:
    """The :class:`Config` of a ``Config.as_dict()`` record."""
    return Config(tuple(int(x) for x in d["maps"].split("x")), d["resolution"], d["depth_bits"],
                  d["samples"], d["filter"], bool(d.get("filtered_lookup", False)))


def sweep_markdown(sw: dict) -> str:
    env = sw["environment"]
    lines = [
        f"# pyshadow-bench sweep ({sw['grid']} grid)", "",
        f"- scene: {sw['scene']}; {sw['image']['width']}x{sw['image']['height']} pixels",
        f"- device: {env['device']} ({env['platform']}); pyshadow {env['pyshadow']}",
        f"- base: {_config_of(sw['base']).label}"
        f"; strategy {sw['strategy']}; converged reference {sw['reference_samples']} spp (Embree)",
        f"- runtime: {sw['runtime']['value']:.0f} s; frame and AO times are medians of "
        f"{sw['repeats']} runs after a warm-up, taken in rounds interleaved over all rows", "",
        "| configuration | varies | build s | CSM MB | ratio | frame ms | AO Msamples/s "
        "| agreement % | RMSE | MAE | RMSE same rays | Pareto |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|:---:|",
    ]
    for r in sw["rows"]:
        f = {k: v["value"] for k, v in r["figures"].items()}
        b = "n/a" if f["build_time"] is None else f"{f['build_time']:.1f}"
        lines.append(
            f"| {r['label']} | {r['varies']} | {b} | {f['csm_bytes'] / 1e6:.2f} | {f['csm_ratio']:.1f} "
            f"| {f['frame_time'] * 1e3:.0f} | {f['ao_throughput']:.2f} | "
            f"{100 * f['visibility_agreement']:.3f} | {f['ao_rmse_converged']:.4f} | "
            f"{f['ao_mae_converged']:.4f} | {f['ao_rmse_identical']:.4f} | "
            f"{'**yes**' if r['pareto'] else ''} |")
    lines += ["", "RMSE/MAE: AO against the converged reference over covered pixels (filtered "
              "rows: the filtered image). RMSE same rays: unfiltered AO against Embree on the "
              "identical rays (discretisation only). Build s: the original build time of the "
              "CSMs (also for cached ones).", ""]
    if sw.get("max_error"):
        lines += [_answer_text(sw["max_error"]), ""]
    return "\n".join(lines)


def _place_labels(fig, ax, items):
    """Annotate points without overlapping labels: try a few offsets per label.

    ``items``: (text, x, y, style dict, required) in priority order; a label
    that is not required is left out when no offset is free.
    """
    renderer = fig.canvas.get_renderer()
    frame = ax.get_window_extent(renderer)
    placed = []
    offsets = [(6, 4), (6, -11), (-6, 4), (-6, -11), (6, 15), (6, -22), (-6, 15), (-6, -22),
               (6, 26), (6, -33)]
    for text, x, y, style, required in items:
        # required labels may move further away; the others stay next to their point
        for k, (dx, dy) in enumerate(offsets + [offsets[0]] if required else offsets[:4]):
            ann = ax.annotate(text, (x, y), textcoords="offset points", xytext=(dx, dy),
                              ha="left" if dx > 0 else "right", **style)
            bb = ann.get_window_extent(renderer)
            last = required and k == len(offsets)
            inside = (bb.x0 >= frame.x0 and bb.x1 <= frame.x1 and bb.y0 >= frame.y0
                      and bb.y1 <= frame.y1)
            if last or (inside and not any(bb.overlaps(o) for o in placed)):
                placed.append(bb)
                break
            ann.remove()


def pareto_plot(sw: dict, path: Path, max_error: float | None = None):
    """AO RMSE against frame time (log-log); the non-dominated configurations marked and labelled.

    Every Pareto configuration is labelled; dominated ones are labelled where
    there is room.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FormatStrFormatter, LogLocator

    rows = sw["rows"]
    t = np.array([r["figures"]["frame_time"]["value"] * 1e3 for r in rows])
    e = np.array([r["figures"]["ao_rmse_converged"]["value"] for r in rows], float)
    on = np.array([r["pareto"] for r in rows])
    fig, ax = plt.subplots(figsize=(10, 6.5), dpi=110)
    ax.scatter(t[~on], e[~on], c="0.6", s=28, label="dominated")
    order = np.argsort(t[on])
    ax.step(t[on][order], e[on][order], where="post", c="C3", lw=1, alpha=0.6)
    ax.scatter(t[on], e[on], c="C3", s=46, marker="D", label="Pareto front", zorder=3)
    if max_error is not None:
        ax.axhline(max_error, c="C0", ls="--", lw=1, label=f"RMSE = {max_error:g}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    for axis in (ax.xaxis, ax.yaxis):          # after set_*scale, which resets them
        axis.set_major_formatter(FormatStrFormatter("%g"))
        axis.set_minor_locator(LogLocator(subs=(2.0, 5.0)))
        axis.set_minor_formatter(FormatStrFormatter("%g"))
    ax.tick_params(which="minor", labelsize=7)
    ax.margins(x=0.12, y=0.08)
    ax.set_xlabel("frame time (ms, Scene.render, median)")
    ax.set_ylabel("AO RMSE vs converged Embree reference")
    ax.set_title(f"pyshadow speed/accuracy: {sw['scene']}\n"
                 f"{sw['image']['width']}x{sw['image']['height']}, {sw['environment']['device']}",
                 fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    fig.canvas.draw()
    front = sorted(np.flatnonzero(on), key=lambda i: t[i])
    rest = sorted(np.flatnonzero(~on), key=lambda i: t[i])
    _place_labels(fig, ax, [(rows[i]["label"], t[i], e[i], {"fontsize": 7.5, "color": "C3"}, True)
                            for i in front]
                  + [(rows[i]["label"], t[i], e[i], {"fontsize": 6.5, "color": "0.45"}, False)
                     for i in rest])
    from pyshadow._files import atomic_path

    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp)
    finally:
        plt.close(fig)


# ---------------------------------------------------------------------------
# command line
# ---------------------------------------------------------------------------
def _pair(text: str, what: str, lo: int, hi: int):
    parts = text.lower().split("x")
    try:
        a, b = (int(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {what} as AxB (e.g. 64x128), got {text!r}") from None
    if not (lo <= a <= hi and lo <= b <= hi):
        raise argparse.ArgumentTypeError(f"{what} must be between {lo} and {hi} each, got {text!r}")
    return a, b


def _maps(text):
    return _pair(text, "maps (zigzag theta x phi)", 1, 4096)


def _size(text):
    return _pair(text, "image size WIDTHxHEIGHT", 1, 16384)


def _int_range(lo, hi, what):
    def parse(text):
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{what} must be an integer, got {text!r}") from None
        if not lo <= v <= hi:
            raise argparse.ArgumentTypeError(f"{what} must be in {lo}..{hi}, got {v}")
        return v
    return parse


def _positive_float(text):
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"must be a positive finite number, got {text!r}")
    return v


def build_parser() -> argparse.ArgumentParser:
    from pyshadow import STRATEGIES

    ap = argparse.ArgumentParser(
        prog="pyshadow-bench",
        description="Ambient occlusion from Coherent Shadow Maps on a bundled scene (or your "
                    "meshes), timed and measured against the Embree ray tracer on the identical "
                    "rays and against a converged Embree reference.",
        epilog="Defaults: zigzag 64x128 maps of 128^2 texels, 16-bit depth, 640x480, 36 samples, "
               "1024-sample reference (< 3 min on 2 CPU cores, most of it the first CSM build and "
               "the reference). --quick: 32x64 maps, 320x240, 512-sample reference (< 1 min). "
               "The sweep's full grid takes about 8 minutes cold on 2 CPU cores. "
               "See benchmarks/README.md.")
    mode = ap.add_argument_group("what to run")
    mode.add_argument("--quick", action="store_true",
                      help="smaller settings: 32x64 maps, 320x240, 512-sample reference")
    mode.add_argument("--sweep", action="store_true",
                      help="run the speed/accuracy trade study instead of the single benchmark; "
                           "writes sweep.json, sweep.md, pareto.png")
    mode.add_argument("--sweep-grid", choices=sorted(SWEEP_GRIDS), default=None,
                      help="rows of the sweep (default: 'quick' with --quick, else 'full'; "
                           "'tiny' is for tests)")
    mode.add_argument("--max-error", type=_positive_float, metavar="E",
                      help="print the fastest sweep configuration with AO RMSE <= E (vs the "
                           "converged reference); with --sweep from the new sweep, else from "
                           "OUT/sweep.json of an earlier sweep (no benchmark is run)")
    mode.add_argument("--mesh", action="append", metavar="PATH",
                      help="use this mesh instead of the default bodies (repeatable); each is "
                           "scaled to bounding radius 1 and stood on the ground, side by side")
    io = ap.add_argument_group("output")
    io.add_argument("--out", default="pyshadow-bench-out", metavar="DIR",
                    help="output directory (default ./pyshadow-bench-out)")
    io.add_argument("--json", action="store_true",
                    help="print results.json (sweep.json with --sweep) on stdout and nothing else; "
                         "the table goes to stderr")
    io.add_argument("--quiet", action="store_true", help="no progress messages on stderr")
    io.add_argument("--cache-dir", metavar="DIR",
                    help="CSM and reference cache (default $PYSHADOW_CACHE, else "
                         "the user cache directory of 'pyshadow')")
    io.add_argument("--no-cache", action="store_true", help="neither read nor write the cache")
    knobs = ap.add_argument_group("settings (override the preset; for tests and power users)")
    knobs.add_argument("--maps", type=_maps, metavar="TxP", help="zigzag map grid theta x phi")
    knobs.add_argument("--resolution", type=_int_range(2, 4096, "--resolution"), metavar="R",
                       help="CSM texels per side")
    knobs.add_argument("--depth-bits", type=int, choices=(16, 32), help="stored depth precision")
    knobs.add_argument("--size", type=_size, metavar="WxH", help="image size")
    knobs.add_argument("--samples", type=_int_range(1, 4096, "--samples"), metavar="N",
                       help="AO samples per pixel")
    knobs.add_argument("--reference-samples", type=_int_range(1, 65536, "--reference-samples"),
                       metavar="N", help="samples per pixel of the converged Embree reference")
    knobs.add_argument("--filter", choices=("none", "bilateral", "separable", "box"), default="none",
                       help="AO filter of the single benchmark (default none)")
    knobs.add_argument("--filtered-lookup", action="store_true",
                       help="filtered CSM lookups: 4 maps x 4 texels a ray (Scene.visible(..., filtered=True))")
    knobs.add_argument("--strategy", choices=STRATEGIES, default="hammersley",
                       help="sampling strategy (default hammersley)")
    knobs.add_argument("--seed", type=_int_range(0, 2**31 - 1, "--seed"), default=0)
    knobs.add_argument("--patterns", type=_int_range(1, 65536, "--patterns"), default=256,
                       help="precomputed sample patterns (default 256)")
    knobs.add_argument("--repeats", type=_int_range(1, 100, "--repeats"), metavar="N",
                       help="timed runs (median) after a warm-up")
    knobs.add_argument("--threads", type=_int_range(1, 1024, "--threads"), default=os.cpu_count() or 1,
                       metavar="N", help="Embree threads (default: all cores)")
    return ap


def _check_out(ap, out: Path):
    if out.exists() and not out.is_dir():
        ap.error(f"--out {out}: exists and is not a directory")
    try:
        out.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=out, prefix=".pyshadow-bench-", suffix=".probe"):
            pass
    except OSError as e:
        ap.error(f"--out {out}: cannot write there ({e.strerror or e})")


def _emit(obj, path: Path | None, as_json: bool):
    text = json.dumps(obj, indent=2, allow_nan=False)
    if path is not None:
        write_bytes_atomic(path, (text + "\n").encode())
    if as_json:
        sys.stdout.write(text + "\n")
        sys.stdout.flush()


def main(argv=None) -> int:
    ap = build_parser()
    args = ap.parse_args(argv)
    log = _Log(args.quiet)
    out = Path(args.out).expanduser()
    args.out = str(out)

    # --max-error alone: answer from an earlier sweep
    if args.max_error is not None and not args.sweep:
        path = out / "sweep.json"
        try:
            sw = json.loads(path.read_text())
            if sw.get("schema") != SWEEP_SCHEMA:
                raise ValueError(f"not a pyshadow-bench sweep (schema {sw.get('schema')!r})")
        except FileNotFoundError:
            ap.error(f"--max-error without --sweep reads {path}, which does not exist; "
                     "run with --sweep (or point --out at an earlier sweep)")
        except (OSError, ValueError) as e:
            ap.error(f"--max-error: cannot read {path} ({e})")
        ans = _answer(sw, args.max_error)
        if args.json:
            _emit({"max_error": ans}, None, True)
        else:
            print(_answer_text(ans))
        return 0

    if args.sweep_grid is not None and not args.sweep:
        ap.error("--sweep-grid needs --sweep")
    meshes = None
    if args.mesh:
        try:
            meshes = _load_meshes(args.mesh)
        except ValueError as e:
            ap.error(str(e))
    _check_out(ap, out)

    preset = PRESETS["quick" if args.quick else "default"]
    explicit = [k for k in ("maps", "resolution", "depth_bits", "size", "samples",
                            "reference_samples", "repeats") if getattr(args, k) is not None]
    for k, v in preset.items():
        if getattr(args, k) is None:
            setattr(args, k, v)
    # 'custom' when a setting differs from the preset
    args.mode = ("quick" if args.quick else "default") \
        if not explicit and args.filter == "none" and not args.filtered_lookup else "custom"
    if args.sweep:
        args.mode = "sweep"
        if args.sweep_grid is None:
            args.sweep_grid = "quick" if args.quick else "full"
        if "repeats" not in explicit:
            args.repeats = 3
    cfg = Config(tuple(args.maps), args.resolution, args.depth_bits, args.samples,
                 None if args.filter == "none" else args.filter, bool(args.filtered_lookup))

    if args.no_cache:
        cache_root = None
    elif args.cache_dir:
        cache_root = Path(args.cache_dir).expanduser()
    else:
        cache_root = default_cache_dir()
    cache = CSMCache(cache_root, log)
    progress = _PROGRESS["on"] = not args.quiet
    factory = SceneFactory(meshes, tuple(args.size), cache, progress)
    log(f"pyshadow-bench: {factory.description}; cache "
        f"{cache_root if cache_root is not None else 'off'}; output {out}")

    if args.sweep:
        sw = run_sweep(args, cfg, factory, cache, log)
        if args.max_error is not None:
            sw["max_error"] = _answer(sw, args.max_error)
        pareto_plot(sw, out / "pareto.png", args.max_error)
        write_bytes_atomic(out / "sweep.md", sweep_markdown(sw).encode())
        _emit(sw, out / "sweep.json", args.json)
        print(sweep_markdown(sw), file=sys.stderr if args.json else sys.stdout)
        return 0

    result = run_main(args, cfg, factory, cache, log)
    result["files"]["results.json"] = str(out / "results.json")
    _emit(result, out / "results.json", args.json)
    print(format_table(result), file=sys.stderr if args.json else sys.stdout)
    return 0


if __name__ == "__main__":
    sys.exit(main())
