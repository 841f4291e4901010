"""What a baked output depends on: the parameters of a bake and the code that runs it."""
from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import numbers

import numpy as np

__all__ = ["AssetParams", "code_digest", "asset_key"]

MESH_FORMATS = ("ply", "glb")
LOOKUPS = ("nearest", "vote")


@dataclasses.dataclass(frozen=True)
class AssetParams:
    """Parameters of one asset bake: the CSM, the per-vertex AO and the output mesh.

    Parameters
    ----------
    theta, phi : int
        Maps of the ``ViewSet.zigzag(theta, phi)`` view set of the CSM
        (rows of polar angle, maps per row): each 2 .. 65536, ``theta * phi``
        at most 2**21.
    resolution : int
        Texels per map side, 1 .. 4096.
    depth_bits : {16, 32}
        Depth precision of the CSM.
    samples : int
        AO samples per vertex (cosine-weighted Hammersley patterns,
        :class:`pyshadow.Sampling`).
    lookup : {'nearest', 'vote'}
        CSM lookup of the AO rays (:func:`pyshadow.visibility.visible`).
    ground : bool
        Bake with a ground plane at the mesh's lowest vertex (``y`` up), as
        an asset standing on a floor; default: the mesh alone.
    fill_holes : bool
        Close the mesh's holes before building the CSM
        (:func:`pyshadow.load_mesh`); the output mesh is then the closed one.
    mesh_format : {'ply', 'glb'}
        Format of the output mesh.
    max_error : float or None
        When set, the CSM's maps and resolution are not ``theta``, ``phi``,
        ``resolution`` but the smallest CSM whose visibility disagreement
        with Embree (on the asset's own AO rays and on rays of bodies
        around it) is at most ``max_error`` (a fraction, e.g. 0.01):
        predicted by the error model, then checked per asset
        (:func:`pyshadow.csm.choose.choose_csm`).
    """

    theta: int = 64
    phi: int = 128
    resolution: int = 128
    depth_bits: int = 16
    samples: int = 64
    lookup: str = "nearest"
    ground: bool = False
    fill_holes: bool = False
    mesh_format: str = "ply"
    max_error: float | None = None

    def __post_init__(self):
        for f in ("theta", "phi", "resolution", "samples"):
            v = getattr(self, f)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ValueError(f"AssetParams.{f} must be a positive int, got {v!r}")
        from ..sampling import MAX_SAMPLES

        if self.samples > MAX_SAMPLES:          # else every asset failed, after its CSM was built
            raise ValueError(f"AssetParams.samples must be at most {MAX_SAMPLES} (the AO kernels' limit), got "
                             f"{self.samples}")
        if self.theta < 2 or self.phi < 2:
            raise ValueError(f"AssetParams: at least 2x2 maps, got {self.theta}x{self.phi}")
        from ..raster import MAX_RESOLUTION
        from ..views import MAX_GRID, MAX_MAPS

        # the CSM's own limits: beyond them every asset was loaded, then failed
        if max(self.theta, self.phi) > MAX_GRID or self.theta * self.phi > MAX_MAPS:
            raise ValueError(f"AssetParams: theta and phi must be at most {MAX_GRID} and theta * phi at most "
                             f"{MAX_MAPS} (ViewSet.zigzag's limits), got {self.theta}x{self.phi}")
        if self.resolution > MAX_RESOLUTION:
            raise ValueError(f"AssetParams.resolution must be at most {MAX_RESOLUTION} (the CSM builder's limit), "
                             f"got {self.resolution}")
        d = self.depth_bits         # 16.0 == 16: a bake alike under another key (and np.int64 no JSON)
        if isinstance(d, bool) or not isinstance(d, int) or d not in (16, 32):
            raise ValueError(f"AssetParams.depth_bits must be 16 or 32, got {self.depth_bits!r}")
        if not isinstance(self.lookup, str) or self.lookup not in LOOKUPS:
            raise ValueError(f"AssetParams.lookup must be one of {LOOKUPS}, got {self.lookup!r}")
        if not isinstance(self.mesh_format, str) or self.mesh_format not in MESH_FORMATS:    # np.array("ply")
            raise ValueError(f"AssetParams.mesh_format must be one of {MESH_FORMATS}, got {self.mesh_format!r}")
        for f in ("ground", "fill_holes"):      # a string such as "false" is truthy: a bake of other settings
            v = getattr(self, f)
            if not isinstance(v, (bool, np.bool_)):
                raise TypeError(f"AssetParams.{f} must be a bool, got {v!r}")
            object.__setattr__(self, f, bool(v))
        if self.max_error is not None:
            v = self.max_error
            if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real):
                raise TypeError(f"AssetParams.max_error must be a float or None, got {v!r}")
            if not (0.0 < float(v) < 1.0):
                raise ValueError(f"AssetParams.max_error must lie in (0, 1), got {v!r}")
            object.__setattr__(self, "max_error", float(v))     # JSON-ready: the key and the manifest

    def to_dict(self) -> dict:
        """The parameters as a JSON-ready dict (the manifest's ``params``)."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "AssetParams":
        """Inverse of :meth:`to_dict`; unknown keys are an error."""
        if not isinstance(d, dict):
            raise TypeError(f"AssetParams.from_dict needs a dict, got {type(d).__name__}")
        names = {f.name for f in dataclasses.fields(cls)}
        extra = set(d) - names
        if extra:
            raise ValueError(f"unknown bake parameters: {', '.join(sorted(map(repr, extra)))}")
        return cls(**d)


@functools.lru_cache(maxsize=1)
def code_digest() -> str:
    """SHA-256 (hex) of pyshadow's version, every module of the package and every kernel source.

    A baked output depends on the CSM builder, the AO kernels and the host
    code around them; hashing all of it (:func:`pyshadow.cache.source_digest`)
    makes a code change produce new keys, so a rerun redoes the assets
    instead of keeping stale ones. Read once per process: the code it
    loaded (files changed on disk during a bake, an editable install being
    edited, made every later asset fail as a worker's "other code", the
    serial bake's too).
    """
    from ..cache import source_digest

    return source_digest()


def asset_key(source_sha256: str, params: AssetParams, code: str) -> str:
    """The key a baked asset is stored under: SHA-256 of its source, parameters and code."""
    spec = {"source": source_sha256, "params": params.to_dict(), "code": code}
    return hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()
