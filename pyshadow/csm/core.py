"""The CSM itself: its arrays, sizes and decoding; the other jobs live beside it.

:mod:`.build` renders and compresses (the streaming builder), :mod:`.device`
lays the segment lists out for the search kernels, :mod:`.fileformat` saves,
loads and validates ``.csm`` files, :mod:`.reference` holds the NumPy mirrors
of the kernels. The encoding is described in :mod:`pyshadow.csm`.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .._compat import keyword_only
from ..views import ViewSet

__all__ = ["CoherentShadowMap", "CSMFormatError", "DEPTH_Q", "MISS16", "SEARCH_BLOCK",
           "FRONT_MARGIN_TEXELS", "DEFAULT_BIAS_TEXELS", "DEFAULT_BIAS_TAN", "VOTE_BIAS_TEXELS",
           "front_margin", "SLOPE_SLACK_QUANTA", "slope_slack"]

DEPTH_Q = 65534          # 16-bit depth k means k / DEPTH_Q
SEARCH_BLOCK = 16        # segments per block of the device search summary
MISS16 = 65535           # 16-bit stored value of a miss (+inf)
# a run's depth stays this many texels (of depth, 1/R each) in front of a
# surface behind the first one that is asked with a self-bias (z2 where it
# faces the light or the mesh is open, z3 of layers=3), on top of z2's slope
# term: twice the visibility kernel's default self-bias, so points on that
# surface stay in shadow under the bias (module docstring)
FRONT_MARGIN_TEXELS = 3.0
# ... and every z2 keeps its slope term plus this many 16-bit depth quanta:
# more than the bias of a point off the object (one quantum plus 1e-7), so
# points on z2 (the ground under a closed body) stay in shadow
SLOPE_SLACK_QUANTA = 2
_LAYOUTS = ("zigzag", "hilbert")
# the self-bias of a lookup from a point on the caster itself: quantum +
# (texels + DEFAULT_BIAS_TAN * tan a) / R, a the angle between the direction
# and the map's axis (pyshadow.visibility; tuned in benchmarks/accuracy.py)
DEFAULT_BIAS_TEXELS = 1.5
DEFAULT_BIAS_TAN = 0.5
VOTE_BIAS_TEXELS = 1.0      # the same for the vote lookup


class CSMFormatError(ValueError):
    """A .csm file is truncated, corrupted, foreign or inconsistent."""


def front_margin(resolution) -> np.float32:
    """The margin in normalised depth: ``FRONT_MARGIN_TEXELS / R`` as float32."""
    return np.float32(FRONT_MARGIN_TEXELS / int(resolution))


def slope_slack() -> np.float32:
    """The slack after z2's slope term in normalised depth: ``SLOPE_SLACK_QUANTA / DEPTH_Q`` as float32."""
    return np.float32(SLOPE_SLACK_QUANTA / DEPTH_Q)



def _depth_dtype(bits):
    return np.dtype(np.uint16) if bits == 16 else np.dtype(np.float32)


def _iend_dtype(maps):
    return np.dtype(np.uint16) if maps <= 65536 else np.dtype(np.uint32)


def _offsets_dtype(segments):
    return np.dtype(np.uint32) if segments < 2**32 else np.dtype(np.uint64)



class CoherentShadowMap:
    """Compressed visibility of one rigid object from every map direction.

    Build with :meth:`build` or read with :meth:`load`. All geometry lives in
    the object's normalised frame (``centre``, ``radius``).

    Attributes
    ----------
    views : ViewSet
        The ``D`` map directions in compression order.
    resolution : int
        Texels per map side ``R``.
    depth_bits : {16, 32}
    layer_rule : {2, 3}
        2: runs intersect ``[z1, z2)``; 3: up to ``z3`` (closed meshes); both
        keep a margin in front of surfaces that face the light (module
        docstring).
    centre : ndarray, shape (3,), float64
    radius : float
    mesh_hash : str
        SHA-256 of the mesh the maps were rendered from.
    offsets : ndarray, shape (R*R + 1,), uint32 or uint64
        Texel ``t = row*R + col`` owns segments ``offsets[t]:offsets[t+1]``.
    iend : ndarray, shape (S,), uint16 (D <= 65536) or uint32
        Last map index of each segment, strictly increasing within a list,
        the last of every list ``D - 1``.
    depth : ndarray, shape (S,), uint16 or float32
        Stored depth (see module docstring for the encoding).
    front_margin_texels : float
        How far (in texels of depth, ``1/R`` each) a stored depth stays in
        front of a surface behind the first one that faces the light; 0 for
        files written before the margin existed.
    footprint : bool
        Built with ``footprint=True`` (intervals over each texel's corners);
        False for files written before the option existed.
    stats : dict
        See :attr:`stats`.
    """

    def __init__(self, *, views, resolution, depth_bits, layer_rule, centre, radius, mesh_hash,
                 offsets, iend, depth, build_seconds=float("nan"), peak_bytes=0, front_margin_texels=0.0,
                 footprint=False):
        self.views = views
        self.resolution = int(resolution)
        self.depth_bits = int(depth_bits)
        self.layer_rule = int(layer_rule)
        self.front_margin_texels = float(front_margin_texels)
        self.footprint = bool(footprint)
        self.centre = np.asarray(centre, dtype=np.float64)
        self.radius = float(radius)
        self.mesh_hash = str(mesh_hash)
        self.offsets, self.iend, self.depth = offsets, iend, depth
        self._build_seconds = float(build_seconds)
        self._peak_bytes = int(peak_bytes)
        self._device = None

    # ------------------------------------------------------------------
    # build
    # ------------------------------------------------------------------
    @classmethod
    @keyword_only("CoherentShadowMap.build")
    def build(cls, mesh, views: ViewSet, *, resolution: int = 128, depth_bits: int = 16,
              layers="auto", block: int | None = None, progress: bool = True,
              frame=None, footprint: bool = False, two_sided: bool = False) -> "CoherentShadowMap":
        """Render and compress the depth maps of ``mesh`` for ``views``.

        Parameters
        ----------
        mesh : trimesh.Trimesh or path
            Anything :func:`pyshadow.load_mesh` accepts.
        views : ViewSet
            A ``zigzag`` or ``hilbert`` view set (their nearest-map lookup is
            what the query kernels implement).
        resolution : int, optional
            Texels per side, 1 .. 4096.
        depth_bits : {16, 32}, optional
            Stored depth precision.
        layers : {'auto', 2, 3}, optional
            Which surfaces bound a map's interval of valid depths.
            ``2``: ``[z1, z2)`` -- every shadow query along a texel's ray is
            exact (up to the depth quantum and the map discretisation), for
            points anywhere: on this object, on other objects, on the ground
            -- on a closed mesh. On an open one, a point in the air between
            two sheets (inside an open box, say) may be reported lit; points
            on the second sheet where it faces the light (every ``z2`` with
            ``two_sided``) stay in shadow: the interval ends ``m`` (below) more
            before it, or is ``z1``. All end z2's slope term before it (:mod:`pyshadow.csm`).
            ``3``: ``[z1, z3 - m)`` with ``m = FRONT_MARGIN_TEXELS / R`` (3
            texels of depth) where the texel's ray leaves the object at
            ``z2`` and re-enters it at ``z3`` and ``z3 - m > z2``, ``[z1,
            z2)`` elsewhere; closed meshes only (the freedom of Ritschel et al.;
            thesis 4.2.1, footnote 2). Fewer segments. Exact for points on
            this object's own surface whose normal faces the light, tested
            with a self-bias up to ``m`` (the back face at ``z2`` is never
            asked: its hemisphere excludes the light; the default self-bias
            of :meth:`pyshadow.Scene.visible` is 1.5 texels plus an angle
            term), and for every other point except those inside a
            concavity of the object along the ray, between its exit ``z2``
            and re-entry ``z3``: such a point (on another body, say, tucked
            under an arch of this one) may be reported lit where it is in
            shadow. The margin keeps a stored depth out of the self-bias of
            ``z3``, so the re-entry surface stays in shadow. The stored depth
            is taken inside ``[z1, z2)`` of every map of the run whenever that
            is possible. What the margin and the rule cost and buy is measured
            in benchmarks/README.md.
            ``'auto'``: 3 for watertight meshes, else 2.
        block : int, optional
            Maps rendered and folded per step; default keeps the device
            working set near 96 MiB. Peak memory depends on ``block`` and
            ``resolution``, not on ``len(views)``.
        progress : bool, optional
            Progress bar over the blocks (shown only on a terminal).
        frame : (centre, radius), optional
            The sphere the maps frame, in the mesh's units: centre shape (3,),
            radius > 0; it must hold every vertex. Default: the minimal
            bounding sphere (:func:`pyshadow.bounding_sphere`), which puts the
            most texels on the object. A wider sphere leaves empty texels
            around it, which cost one segment each: the ratio rises and the
            detail per texel falls (benchmarks/README.md, ``compression.py``).
        footprint : bool, optional
            Take each map's interval over the texel's whole footprint, not
            only along its centre ray: where the centre ray meets two
            surfaces, the first surface's depth at the texel's four corners
            raises the lower end (a point anywhere in the texel on the
            surface nearest the light then stays lit without a larger
            self-bias) and the second surface's depth at the corners lowers
            the upper end. Corner depths come from a second rendering at
            ``R + 1`` texels (:func:`footprint_interval`); the result always
            lies inside the centre's interval, so every guarantee above
            holds, and where the corners leave no depth the centre's
            interval stands. Narrower intervals mean more segments, and the
            second rendering doubles the rasterisation (measured in
            benchmarks/README.md, ``accuracy.py`` section 7). ``R <= 4095``.
        two_sided : bool, optional
            ``m`` before every ``z2``: open sheets seen from both sides (an open box). ``layers=2`` only.

        Returns
        -------
        CoherentShadowMap
        """
        from .build import build_csm
        return build_csm(cls, mesh, views, resolution, depth_bits, layers, block, progress, frame, footprint, two_sided)

    # ------------------------------------------------------------------
    # sizes and statistics
    # ------------------------------------------------------------------
    @property
    def maps(self) -> int:
        return len(self.views)

    @property
    def segments(self) -> int:
        return int(len(self.depth))

    @property
    def stats(self) -> dict:
        """Sizes and build figures.

        Returns
        -------
        dict
            ``maps`` (D), ``resolution`` (R), ``segments`` (S), ``bytes``
            (segments plus offset table, as stored), ``uncompressed_bytes``
            (``D * R^2 * depth_bits / 8``), ``ratio`` (uncompressed / bytes),
            ``build_seconds``, ``peak_bytes`` (device and host working set of
            the build), ``depth_bits``, ``layer_rule``, ``front_margin_texels``,
            ``footprint``, ``layout``.
        """
        nbytes = int(self.depth.nbytes + self.iend.nbytes + self.offsets.nbytes)
        unc = self.maps * self.resolution**2 * self.depth_bits // 8
        return {
            "maps": self.maps,
            "resolution": self.resolution,
            "segments": self.segments,
            "bytes": nbytes,
            "uncompressed_bytes": unc,
            "ratio": unc / nbytes,
            "build_seconds": self._build_seconds,
            "peak_bytes": self._peak_bytes,
            "depth_bits": self.depth_bits,
            "layer_rule": self.layer_rule,
            "front_margin_texels": self.front_margin_texels,
            "footprint": self.footprint,
            "layout": self.views.layout,
        }

    def texel_segment_counts(self) -> np.ndarray:
        """Segments per texel, (R, R) int64, indexed ``[row, col]``."""
        return np.diff(self.offsets.astype(np.int64)).reshape(self.resolution, self.resolution)

    def stored_to_depth(self, stored) -> np.ndarray:
        """Decode stored depth values to float64 normalised depth (+inf for a miss)."""
        s = np.asarray(stored)
        if self.depth_bits == 16:
            return np.where(s == MISS16, np.inf, s.astype(np.float64) / DEPTH_Q)
        return s.astype(np.float64)

    # ------------------------------------------------------------------
    # device side
    # ------------------------------------------------------------------
    @property
    def pair_wide(self) -> bool:
        """Whether the device pairs need 32-bit fields (32-bit depth or i_end)."""
        return self.depth_bits == 32 or self.iend.dtype != np.uint16

    @property
    def defines(self) -> dict:
        """Compile-time macros that describe this CSM's storage to a kernel."""
        return {"RES": self.resolution, "DEPTH_BITS": self.depth_bits,
                "IEND_T": "ushort" if self.iend.dtype == np.uint16 else "uint",
                "PAIR_WIDE": int(self.pair_wide), "SEARCH_BLOCK": SEARCH_BLOCK}

    def search_arrays(self, wide: bool | None = None, padded: bool = False) -> dict:
        """The device layout the search kernels read: see :func:`pyshadow.csm.device.search_arrays`."""
        from .device import search_arrays

        return search_arrays(self, wide, padded)

    def device_buffers(self):
        """(offsets, soff, summary, pairs) as device buffers, uploaded once per context and kept."""
        from .device import device_buffers

        return device_buffers(self)

    def segment_index(self, map_index, rows, cols) -> np.ndarray:
        """Index of the segment holding (map, texel), by the kernels' search (csm_find)."""
        from .device import segment_index

        return segment_index(self, map_index, rows, cols)

    def depth_for(self, map_index, rows, cols) -> np.ndarray:
        """Stored depth of texels ``(rows, cols)`` of map ``map_index``.

        Parameters
        ----------
        map_index : int or array_like of int
            Map index in view-set order, 0 .. D-1.
        rows, cols : array_like of int
            Texel coordinates, 0 .. R-1; broadcast against ``map_index``.

        Returns
        -------
        ndarray, float64
            Normalised depth the shadow test compares against (``+inf`` where
            the texel's ray misses the object), found by the counting search of
            kernels/csm_search.h (block summary, then block), which lands on
            the same segment as the visibility kernel's search (tested).
        """
        return self.stored_to_depth(self.depth[self.segment_index(map_index, rows, cols)])

    def segment_index_reference(self, map_index, rows, cols) -> np.ndarray:
        """NumPy version of :meth:`segment_index` (searchsorted per texel)."""
        from .reference import segment_index_reference

        return segment_index_reference(self, map_index, rows, cols)

    # ------------------------------------------------------------------
    # files
    # ------------------------------------------------------------------
    def save(self, path, *, reproducible: bool = False) -> Path:
        """Write the CSM to ``path`` atomically (temporary file, then rename); never pickled.

        Layout in :mod:`pyshadow.csm.fileformat`: 16-bit depth ``k`` means ``k / 65534``,
        ``65535`` a miss; float32 ``+inf`` a miss. ``reproducible=True`` leaves the measured
        build time out (``null``), so equal CSMs give equal bytes (:mod:`pyshadow.bake`).
        """
        from .fileformat import save

        return save(self, path, reproducible=reproducible)

    @classmethod
    def load(cls, path, mmap: bool = True) -> "CoherentShadowMap":
        """Read and validate a .csm file written by :meth:`save`.

        Parameters
        ----------
        path : str or os.PathLike
        mmap : bool, optional
            Map the arrays from the file instead of reading them into memory.

        Raises
        ------
        FileNotFoundError
            If the file does not exist.
        CSMFormatError
            If the file is truncated, its checksum does not match, its header
            is not a pyshadow CSM of a known version, or its arrays break a
            rule the kernels rely on (offsets monotone and in bounds, every
            list non-empty with strictly increasing i_end ending at D - 1,
            depths finite or the miss value).
        """
        from .fileformat import load

        return load(cls, path, mmap)

    def __repr__(self) -> str:
        s = self.stats
        return (f"<CoherentShadowMap {s['layout']} {s['maps']} maps {s['resolution']}^2, "
                f"{s['segments']} segments, {s['bytes'] / 1e6:.2f} MB, {s['ratio']:.1f}:1>")
