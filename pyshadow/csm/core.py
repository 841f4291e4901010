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
from .._validate import flag
from ..views import ViewSet

__all__ = ["CoherentShadowMap", "CSMFormatError", "DEPTH_Q", "MISS16", "SEARCH_BLOCK",
           "FRONT_MARGIN_TEXELS", "DEFAULT_BIAS_TEXELS", "DEFAULT_BIAS_TAN", "VOTE_BIAS_TEXELS",
           "PLANE_BIAS_TEXELS",
           "front_margin", "SLOPE_SLACK_QUANTA", "slope_slack", "BOX_PAD", "lookup_box"]

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
# ... but a point whose normal m is known (the surface rule's rays) is
# compared at each tap with its own surface, the plane through it with normal
# m, at the tap's texel centre: bias max(quantum, quantum + (PLANE_BIAS_TEXELS
# + DEFAULT_BIAS_TAN tan a - rise) / R), where the plane lies `rise` texels of
# depth behind the point at the centre, rise = (m.u dx + m.v dy) / (m.d) for a
# centre (dx, dy) texels from the point (u, v, d the map's rows; m.d clamped
# to at least 1e-3). Derived, not tuned: every stored depth lies at or behind
# the centre's first surface, which for a plane is the plane itself; the
# quarter texel covers a surface curving towards the map with a radius of one
# texel (benchmarks/README.md, "Inside corners: the receiver's plane")
PLANE_BIAS_TEXELS = 0.25


# the lookup's box (lookup_box) lies this far (normalised units) outside the
# mesh's box: beyond the float32 rounding of a point in the normalised frame
BOX_PAD = 1e-4


class CSMFormatError(ValueError):
    """A .csm file is truncated, corrupted, foreign or inconsistent."""


def front_margin(resolution) -> np.float32:
    """The margin in normalised depth: ``FRONT_MARGIN_TEXELS / R`` as float32."""
    return np.float32(FRONT_MARGIN_TEXELS / int(resolution))


def slope_slack() -> np.float32:
    """The slack after z2's slope term in normalised depth: ``SLOPE_SLACK_QUANTA / DEPTH_Q`` as float32."""
    return np.float32(SLOPE_SLACK_QUANTA / DEPTH_Q)



def lookup_box(csm) -> tuple[np.ndarray, np.ndarray]:
    """The box the lookup cuts each ray's chord to, normalised frame: ``(lo, hi)``, float32 (3,) each.

    The mesh's box (``csm.box``) padded by :data:`BOX_PAD`; for a CSM without
    one (a file from before boxes) the cube of side 4, which holds the
    bounding sphere, so that the sphere alone cuts the chord as it did.
    """
    box = getattr(csm, "box", None)
    if box is None:
        return np.full(3, -2.0, np.float32), np.full(3, 2.0, np.float32)
    return (np.asarray(box[0], np.float64) - BOX_PAD).astype(np.float32), \
        (np.asarray(box[1], np.float64) + BOX_PAD).astype(np.float32)


def _depth_dtype(bits):
    return np.dtype(np.uint16) if bits == 16 else np.dtype(np.float32)


def _iend_dtype(maps):
    return np.dtype(np.uint16) if maps <= 65536 else np.dtype(np.uint32)


def _offsets_dtype(segments):
    return np.dtype(np.uint32) if segments < 2**32 else np.dtype(np.uint64)


def _whole_numbers(name, a, what):
    """``a`` (any shape) checked to hold integers (or floats that are whole numbers): TypeError or
    ValueError naming ``name``; ``what`` names the values in messages."""
    if isinstance(a, np.ndarray) and a.dtype.kind in "iu":
        return a
    if a is None or isinstance(a, (bool, np.bool_, str, bytes)):
        raise TypeError(f"{name} must be integers, got {a!r}")
    try:
        arr = np.asarray(a)
    except (ValueError, TypeError) as e:
        raise TypeError(f"{name} must be an array of integers ({e})") from None
    kind = arr.dtype.kind
    if kind == "O":             # Python ints beyond int64 (2**64) arrive as objects
        vals = arr.reshape(-1).tolist()
        if not all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) for v in vals):
            raise TypeError(f"{name} must be integers, got {a!r}")
        vals = [int(v) for v in vals]
        if any(not -2**63 <= v < 2**63 for v in vals):
            raise ValueError(f"{what}: {name} holds {max(vals, key=abs)}")
        arr = arr.astype(np.int64)
    if kind not in "iuf":
        raise TypeError(f"{name} must be integers, got {arr.dtype} values")
    if kind == "f" and arr.size:
        whole = np.isfinite(arr) & (arr == np.floor(arr))
        if not whole.all():
            raise ValueError(f"{what}: {name} holds {arr[~whole].reshape(-1)[0]!r}, not a whole number")
    return arr


def query_indices(csm, map_index, rows, cols):
    """The map indices, rows and columns of a texel query checked: ``(m, r, c)`` int64 (N,) and the
    broadcast shape; ValueError or TypeError naming the argument (a fraction, NaN, a bool, an index
    outside ``0 .. D-1`` or ``0 .. R-1``) where a cast would truncate, wrap or read out of bounds."""
    D, R = csm.maps, csm.resolution
    checked = []
    for name, a, n, what in (("map_index", map_index, D, f"map index outside 0..{D - 1}"),
                             ("rows", rows, R, f"row/column outside 0..{R - 1}"),
                             ("cols", cols, R, f"row/column outside 0..{R - 1}")):
        a = _whole_numbers(name, a, what)
        if a.size and (a.min() < 0 or a.max() >= n):
            bad = a.reshape(-1)[np.flatnonzero((a.reshape(-1) < 0) | (a.reshape(-1) >= n))[0]]
            raise ValueError(f"{what}: {name} holds {bad}")
        checked.append(a)
    try:
        m, r, c = np.broadcast_arrays(*checked)
    except ValueError:
        raise ValueError("map_index, rows and cols cannot be broadcast together: shapes "
                         f"{', '.join(str(np.shape(a)) for a in checked)}") from None
    return (*(a.astype(np.int64).reshape(-1) for a in (m, r, c)), m.shape)


def decode_depth(stored, depth_bits) -> np.ndarray:
    """:meth:`CoherentShadowMap.stored_to_depth`: stored values to float64 normalised depth (+inf for a miss).

    16-bit values must be whole numbers 0 .. 65535 (any integer or float dtype; uint16 is not checked);
    anything else is a ValueError or TypeError, never a depth between two keys, below 0 or beyond the far
    plane.
    """
    s = np.asarray(stored)
    if depth_bits == 16:
        if s.dtype != np.uint16:
            s = _whole_numbers("stored", s, "stored 16-bit depth outside 0..65535")
            if s.size and (s.min() < 0 or s.max() > MISS16):
                raise ValueError(f"stored 16-bit depth outside 0..65535: got {s.min()} .. {s.max()}")
        return np.where(s == MISS16, np.inf, s.astype(np.float64) / DEPTH_Q)
    return s.astype(np.float64)



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
        2: runs intersect ``[z1, z2)``; 3: up to ``z3`` (closed meshes); both keep a
        margin in front of surfaces that face the light (module docstring).
    centre : ndarray, shape (3,), float64
    radius : float
    mesh_hash : str
        SHA-256 of the mesh the maps were rendered from.
    offsets : ndarray, shape (R*R + 1,), uint32 or uint64
        Texel ``t = row*R + col`` owns segments ``offsets[t]:offsets[t+1]``.
    iend : ndarray, shape (S,), uint16 (D <= 65536) or uint32
        Last map index of each segment, strictly rising within a list, the last ``D - 1``.
    depth : ndarray, shape (S,), uint16 or float32
        Stored depth (see module docstring for the encoding).
    front_margin_texels : float
        How far (texels of depth, ``1/R``) a stored depth stays in front of a surface behind
        the first one that faces the light; 0 in files from before the margin.
    footprint : bool
        Built with ``footprint=True`` (texel corners); False in files from before the option.
    box : ndarray, shape (2, 3), float64, or None
        The mesh's bounding box ``(lo, hi)``, normalised frame: the lookup cuts each ray's
        chord to it (:func:`lookup_box`); None in files from before boxes (the sphere alone).
    two_sided : {'auto', True, False} or None
        The build's ``two_sided``; ``both_sided_faces``: how many faces it kept the margin before
        from either side (``True``: all). Both None in files from before the record.
    stats : dict
        See :attr:`stats`.
    """

    def __init__(self, *, views, resolution, depth_bits, layer_rule, centre, radius, mesh_hash,
                 offsets, iend, depth, build_seconds=float("nan"), peak_bytes=0, front_margin_texels=0.0,
                 footprint=False, box=None, two_sided=None, both_sided_faces=None):
        self.views = views
        self.resolution = int(resolution)
        self.depth_bits = int(depth_bits)
        self.layer_rule = int(layer_rule)
        self.front_margin_texels = float(front_margin_texels)
        self.footprint = bool(footprint)
        self.box = None if box is None else np.array(box, dtype=np.float64).reshape(2, 3)
        self.two_sided, self.both_sided_faces = two_sided, both_sided_faces
        self.centre = np.asarray(centre, dtype=np.float64)
        self.radius = float(radius)
        self.mesh_hash = str(mesh_hash)
        self.offsets, self.iend, self.depth = offsets, iend, depth
        self._build_seconds = float(build_seconds)
        self._peak_bytes = int(peak_bytes)
        self._device = None
        self.choice = None           # set by build(max_error=...)

    # ------------------------------------------------------------------
    # build
    # ------------------------------------------------------------------
    @classmethod
    @keyword_only("CoherentShadowMap.build")
    def build(cls, mesh, views: ViewSet | None = None, *, resolution: int | None = None, depth_bits: int = 16,
              layers="auto", block: int | None = None, progress: bool = True,
              frame=None, footprint: bool = False, two_sided="auto",
              max_error: float | None = None, max_bytes: int | None = None, lookup: str = "nearest",
              verify: bool = True) -> "CoherentShadowMap":
        """Render and compress the depth maps of ``mesh`` for ``views``, or for the accuracy asked.

        Parameters
        ----------
        mesh : trimesh.Trimesh or path
            Anything :func:`pyshadow.load_mesh` accepts.
        views : ViewSet
            A ``zigzag`` or ``hilbert`` view set (their nearest-map lookup is
            what the query kernels implement). Leave out with ``max_error``.
        resolution : int, optional
            Texels per side, 1 .. 4096; default 128. Leave out with ``max_error``.
        depth_bits : {16, 32}, optional
            Stored depth precision.
        layers : {'auto', 2, 3}, optional
            Which surfaces bound a map's interval of valid depths (the
            guarantees of each: :mod:`pyshadow.csm`, "Layer rules"). ``2``:
            ``[z1, z2)``, exact for points anywhere around a closed mesh;
            ``3``: up to the re-entry ``z3`` less a margin where the ray leaves
            and re-enters, closed meshes only, fewer segments; ``'auto'``: 3
            for watertight meshes, else 2.
        block : int, optional
            Maps rendered and folded per step; default keeps the device
            working set near 96 MiB. Peak memory depends on ``block`` and
            ``resolution``, not on ``len(views)``.
        progress : bool, optional
            Bars on a terminal: the maps, naming the steps before them, and a ``max_error`` choice's steps.
        frame : (centre, radius), optional
            The sphere the maps frame, in the mesh's units: centre shape (3,),
            radius > 0; it must hold every vertex a face uses. Default: the minimal
            bounding sphere (:func:`pyshadow.bounding_sphere`), which puts the
            most texels on the object. A wider sphere leaves empty texels
            around it, which cost one segment each: the ratio rises and the
            detail per texel falls (benchmarks/README.md, ``compression.py``).
        footprint : bool, optional
            Take each map's interval over the texel's whole footprint, not
            only its centre ray: the surfaces' depths at the texel's four
            corners (a second rendering at ``R + 1`` texels,
            :func:`footprint_interval`) narrow the centre's interval, so every
            guarantee above holds and a point anywhere in the texel on the
            surface nearest the light stays lit without a larger self-bias.
            More segments, twice the rasterisation (benchmarks/README.md,
            ``accuracy.py`` section 7). ``R <= 4095``.
        two_sided : {'auto', True, False}, optional
            ``m`` also before a ``z2`` facing away: ``'auto'`` on backs open to the outside (an open box's
            inside; :func:`pyshadow.csm.exposed_back_faces`; where the mesh is mostly open, free space before them:
            :func:`pyshadow.csm.open_sheet`), ``True`` on every one (``layers=2``), ``False`` none.
        max_error : float, optional
            Choose views and resolution instead: the smallest CSM whose
            disagreement with Embree, predicted by the error model and checked
            (:mod:`pyshadow.csm.choose`), is at most this fraction of rays.
            How it chose is in ``stats["choice"]``.
        max_bytes : int, optional
            The most accurate CSM within this many bytes; with ``max_error``, the cheapest meeting it within them.
        lookup : {'nearest', 'vote', 'auto'}, optional
            With ``max_error`` or ``max_bytes``: the lookup the CSM will be queried with (``'auto'``: with
            ``max_error``, one-texel where it can meet it, else the vote; ``max_bytes`` alone: the more accurate).
        verify : bool, optional
            With ``max_error``: measure the built CSM against Embree on independent rays, and go on to the
            next candidate where it misses; with ``max_bytes``: measure it (reported).

        Returns
        -------
        CoherentShadowMap
        """
        progress = flag(progress, "progress")
        if max_error is not None or max_bytes is not None:
            from .choose import build_chosen
            return build_chosen(mesh, views, resolution, frame, footprint, two_sided, max_error=max_error,
                                max_bytes=max_bytes, lookup=lookup, depth_bits=depth_bits, layers=layers,
                                verify=verify, progress=progress)
        if views is None:
            raise TypeError("CoherentShadowMap.build needs views (or max_error)")
        from .build import build_csm
        return build_csm(cls, mesh, views, 128 if resolution is None else resolution, depth_bits, layers, block,
                         progress, frame, footprint, two_sided)

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
            ``footprint``, ``layout``, ``two_sided``, ``both_sided_faces``,
            ``choice`` (how ``build(max_error=...)`` chose the parameters, with
            the error model's prediction and the check; None otherwise).
        """
        nbytes = int(self.depth.nbytes + self.iend.nbytes + self.offsets.nbytes)
        unc = self.maps * self.resolution**2 * self.depth_bits // 8
        return {"maps": self.maps, "resolution": self.resolution, "segments": self.segments, "bytes": nbytes,
                "uncompressed_bytes": unc, "ratio": unc / nbytes, "build_seconds": self._build_seconds,
                "peak_bytes": self._peak_bytes, "depth_bits": self.depth_bits, "layer_rule": self.layer_rule,
                "front_margin_texels": self.front_margin_texels, "footprint": self.footprint,
                "layout": self.views.layout, "two_sided": self.two_sided,
                "both_sided_faces": self.both_sided_faces, "choice": self.choice}

    def texel_segment_counts(self) -> np.ndarray:
        """Segments per texel, (R, R) int64, indexed ``[row, col]``."""
        return np.diff(self.offsets.astype(np.int64)).reshape(self.resolution, self.resolution)

    def stored_to_depth(self, stored) -> np.ndarray:
        """Decode stored depth values to float64 normalised depth (+inf for a miss): :func:`decode_depth`."""
        return decode_depth(stored, self.depth_bits)

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

    def search_arrays(self, wide: bool | None = None, padded: bool = False, segment: bool = True) -> dict:
        """The device layout the search kernels read (:func:`pyshadow.csm.device.search_arrays`), the arrays
        checked first: :func:`pyshadow.csm.file_checks.checked_search_arrays`."""
        from .file_checks import checked_search_arrays

        return checked_search_arrays(self, wide, padded, segment)

    def device_buffers(self):
        """(offsets, soff, summary, pairs) on the device, kept while its arrays stay (:mod:`.device`)."""
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
        The file holds the view set as its layout and parameters: a CSM built with other bases on
        that grid (``ViewSet(d, bases, "zigzag", params)``) is a ValueError, before anything is written;
        so are arrays and header values (a NaN centre, ...) that :meth:`load` would refuse (CSMFormatError).
        """
        from .fileformat import save

        return save(self, path, reproducible=reproducible)

    @classmethod
    def load(cls, path, mmap: bool = False) -> "CoherentShadowMap":
        """Read and validate a .csm file written by :meth:`save`.

        Parameters
        ----------
        path : str or os.PathLike
        mmap : bool, optional
            Map the arrays from the file instead of reading them into memory (the file must then not
            change while mapped: :meth:`save` replaces files whole, which keeps a mapped one, but a copy
            written over it in place is read from then on, and one cut shorter in place (``truncate``) ends
            the process with SIGBUS; a device upload checks the arrays again).

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
