"""The scenes of a benchmark: the bundled default scene or the user's meshes, CSMs from the cache."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..cache import CSMCache
from .config import Config


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
            csm = CoherentShadowMap.build(mesh, views, resolution=resolution, depth_bits=depth_bits,
                                          layers=layers, progress=False)
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
        try:
            found, is_file = path.exists(), path.is_file()
        except OSError as e:            # a name too long for the file system (ENAMETOOLONG), say
            raise ValueError(f"--mesh {p}: cannot look it up ({e.strerror or e})") from None
        if not found:
            raise ValueError(f"--mesh {p}: no such file")
        if not is_file:
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
    """Scenes of one geometry (default bodies or user meshes) for any :class:`Config`.

    Calling the factory with a :class:`Config` returns ``(scene, camera,
    infos)``: the scene built with that configuration's CSMs (from
    ``cache``; one CSM per distinct mesh), the camera of the geometry, and
    the :meth:`pyshadow.cache.CSMCache.csm` info of every CSM obtained.

    Parameters
    ----------
    meshes : list of (name, trimesh.Trimesh) or None
        The user's meshes (:func:`mesh_scene`); None: the bundled default
        scene (:func:`pyshadow.data.default_scene`).
    size : tuple of int
        Image ``(width, height)`` in pixels.
    cache : pyshadow.cache.CSMCache
    progress : bool
        Show the CSM builder's progress bars.
    """

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
        """One line naming the geometry (the ``scene`` field of the outputs)."""
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
    """Totals over the CSM infos of one scene: bytes, ratio, build and load seconds, source.

    ``build_seconds`` is None unless every CSM's original build time is
    known; ``source`` is 'cached', 'built' (none cached) or 'partly cached'.
    """
    nbytes = sum(i["stats"]["bytes"] for i in infos)
    unc = sum(i["stats"]["uncompressed_bytes"] for i in infos)
    builds = [i["build_seconds"] for i in infos]
    sources = {i["source"] for i in infos}
    source = "cached" if sources == {"cached"} else ("built" if "cached" not in sources else "partly cached")
    return {"bytes": nbytes, "uncompressed_bytes": unc, "ratio": unc / nbytes if nbytes else float("nan"),
            "build_seconds": sum(builds) if all(b is not None for b in builds) else None,
            "seconds": sum(i["seconds"] for i in infos), "source": source,
            "segments": sum(i["stats"]["segments"] for i in infos)}
