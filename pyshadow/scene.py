"""Scenes of rigid bodies: visibility queries, ambient occlusion, AO images.

Stage "visibility kernel" of the pipeline (DESIGN.md "Visibility query",
"Sampling"; thesis 000, 5.3, 5.3.1-5.3.3). A scene holds instances of
Coherent Shadow Maps (casters) and of plain meshes (receivers), each with a
rigid 4x4 transform (rotation, translation, uniform scale), and optionally an
analytic ground plane ``y = ground``. Moving an instance changes one small
buffer; no CSM is rebuilt.

Kernels are specialised to the scene through compile-time macros (number of
CSM types, ground plane or not, layouts present, sample count, bent normals
or not) and cached per configuration by :mod:`pyshadow._cl`.
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np
import pyopencl as cl
import trimesh

from . import _cl
from . import csm as csm_module
from ._cl import launch
from ._cl.tables import CSM_TYPE, INSTANCE
from .csm import DEPTH_Q, CoherentShadowMap
from .gbuffer import check_transform
from .mesh import bounding_sphere, load_mesh, mesh_hash
from .sampling import check_sampling, direction_table, pattern_indices
from .views import FILTER_ANGLE_EPS, ViewSet

__all__ = ["Scene", "Instance", "GROUND_ID", "DEFAULT_BIAS_TEXELS", "DEFAULT_BIAS_TAN",
           "FILTERED_BIAS_TEXELS", "visible_reference", "shadow_vote"]

GROUND_ID = -2           # object id of the ground plane in rendered images
DEFAULT_BIAS_TEXELS = 1.5
DEFAULT_BIAS_TAN = 0.5
FILTERED_BIAS_TEXELS = 1.0   # self-bias of filtered lookups, chosen on the bunny (benchmarks/README.md)
_LAYOUT_CODE = {"zigzag": 0, "hilbert": 1}


@dataclass
class Instance:
    """One placed object of a :class:`Scene`."""

    transform: np.ndarray
    casts: bool
    csm: CoherentShadowMap | None = None
    mesh: trimesh.Trimesh | None = None
    # mesh data derived once (object frame)
    _normals: np.ndarray | None = field(default=None, repr=False)

    @property
    def scale(self) -> float:
        return float(np.cbrt(np.linalg.det(self.transform[:3, :3])))

    @property
    def rotation(self) -> np.ndarray:
        return self.transform[:3, :3] / self.scale

    def object_sphere(self):
        if self.csm is not None:
            return self.csm.centre, self.csm.radius
        return bounding_sphere(self.mesh)

    def world_sphere(self):
        c, r = self.object_sphere()
        T = self.transform
        return T[:3, :3] @ c + T[:3, 3], r * self.scale


def _rows3(a, name, n=None, dtype=np.float64):
    """Validate an (N, 3) numeric array of finite values; return it as ``dtype``."""
    a = np.asarray(_check_rows(a, name, n), dtype=dtype)
    _check_values(a, name)
    return a


def _check_values(a, name, nonzero=False):
    """Raise ValueError for rows of an (N, 3) array that are not finite (or,
    with ``nonzero``, are zero vectors).

    Cheap for valid input (query batches hold millions of rows): the sum of
    all entries is finite unless an entry is not (or finite entries overflow
    it: then the rows are checked exactly), and a zero row is three zero
    entries in a row of the flat array, found among the (usually few) zero
    entries. No BLAS call: its worker threads would keep spinning on the cores
    the kernel is about to use.
    """
    if len(a) == 0:
        return
    if not np.issubdtype(a.dtype, np.integer):
        with np.errstate(all="ignore"):
            total = np.add.reduce(a, axis=None)
        if not np.isfinite(total):
            bad = int((~np.isfinite(a).all(axis=1)).sum())
            if bad:
                raise ValueError(f"{name}: {bad} rows are not finite")
    if nonzero:
        z = np.flatnonzero(a.reshape(-1) == 0)
        if len(z) >= 3:
            head = z[:-2]
            zero = int(((z[2:] - head == 2) & (head % 3 == 0)).sum())
            if zero:
                raise ValueError(f"{name}: {zero} rows are zero vectors")


_checker = None


def _check_both(p, p_name, w, w_name):
    """_check_values of points and of (non-zero) directions, side by side on
    two threads for large batches (NumPy releases the GIL); the first error in
    argument order is raised."""
    global _checker
    if len(p) < 100_000:
        _check_values(p, p_name)
        _check_values(w, w_name, nonzero=True)
        return
    if _checker is None:
        _checker = ThreadPoolExecutor(1, thread_name_prefix="pyshadow-check")
    future = _checker.submit(_check_values, p, p_name)
    try:
        _check_values(w, w_name, nonzero=True)
    except ValueError:
        future.result()                 # points first, as in the sequential order
        raise
    future.result()


def _kernel_rows(a, name, n=None):
    """An (N, 3) array as the visibility kernel reads it: C-contiguous float32
    or float64 (other dtypes are converted to float64; no copy otherwise)."""
    a = _check_rows(a, name, n)
    if a.dtype not in (np.float32, np.float64):
        a = a.astype(np.float64)
    return np.ascontiguousarray(a)


def _lane_table(table):
    """(M, S, 3) local directions -> (M, 3, S padded to the lane width) for the lane kernels.

    Padding directions are (0, 1, 0) (along the normal); the kernel masks them out.
    """
    M, S, _ = table.shape
    lanes = launch.shape().lanes
    spad = -(-S // lanes) * lanes
    out = np.zeros((M, 3, spad), np.float32)
    out[:, 1, :] = 1.0
    out[:, :, :S] = table.transpose(0, 2, 1)
    return out


def _check_rows(a, name, n=None):
    """Shape and dtype checks of an (N, 3) array, no copy (values are checked later)."""
    a = np.asarray(a)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3), got {a.shape}")
    if n is not None and len(a) != n:
        raise ValueError(f"{name} has {len(a)} rows but points has {n} (shapes must match)")
    if not (np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)):
        raise TypeError(f"{name} must be numeric, got {a.dtype}")
    return a


def _nonzero(a, name):
    _check_values(a, name, nonzero=True)
    return a


class Scene:
    """Rigid bodies with CSMs, receivers and an optional ground plane.

    Parameters
    ----------
    ground : float, optional
        Height ``h`` of an infinite ground plane ``y = h`` (analytic, no CSM):
        a ray from a point above it that points downwards is occluded.
    views : ViewSet, optional
        Map directions for CSMs built by :meth:`add` from meshes; default
        ``ViewSet.zigzag(64, 128)`` (the thesis's 8192 maps).
    resolution, depth_bits, layers, footprint :
        Passed to :meth:`CoherentShadowMap.build` for meshes added as casters.
    progress : bool, optional
        Progress bars while building CSMs.

    Examples
    --------
    >>> import trimesh
    >>> scene = Scene(ground=0.0, views=ViewSet.zigzag(8, 16), resolution=32)
    >>> box = trimesh.creation.box((1, 1, 1))
    >>> i = scene.add(box, trimesh.transformations.translation_matrix([0, 0.5, 0]))
    >>> float(scene.ambient_occlusion([[3.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]], samples=64)[0]) > 0.8
    True
    """

    def __init__(self, ground: float | None = None, *, views: ViewSet | None = None,
                 resolution: int = 128, depth_bits: int = 16, layers="auto", footprint: bool = False,
                 progress: bool = False):
        if ground is not None:
            ground = float(ground)
            if not np.isfinite(ground):
                raise ValueError(f"ground must be a finite height, got {ground}")
        if not isinstance(footprint, (bool, np.bool_)):
            raise TypeError(f"footprint must be True or False, got {footprint!r}")
        self.ground = ground
        self.csm_options = dict(views=views if views is not None else ViewSet.zigzag(64, 128),
                                resolution=resolution, depth_bits=depth_bits, layers=layers,
                                footprint=bool(footprint))
        self.progress = progress
        self.instances: list[Instance] = []
        self._built: dict = {}           # id(mesh) -> CSM built by add()
        self._atlas = None
        self._atlas_key = None

    # ------------------------------------------------------------------
    # building the scene
    # ------------------------------------------------------------------
    def add(self, obj, transform=None, casts: bool = True, *, mesh=None) -> int:
        """Place an object; returns its instance id.

        Parameters
        ----------
        obj : CoherentShadowMap, trimesh.Trimesh or path
            A CSM (a caster; several instances share one CSM and its device
            buffers), or a mesh. A mesh with ``casts=True`` gets a CSM built
            with the scene's options (once per mesh object); with
            ``casts=False`` it only receives (walls, floors).
        transform : array_like, shape (4, 4), optional
            Object-to-world transform: rotation, translation and uniform
            positive scale only. Default identity.
        casts : bool, optional
        mesh : trimesh.Trimesh, optional
            The mesh of a CSM given as ``obj``, needed to draw it
            (:meth:`render`) and for :meth:`vertex_ao` and the Embree
            reference; it must be the mesh the CSM was built from.

        Raises
        ------
        ValueError
            Non-rigid transform, a CSM added with ``casts=False``, or a mesh
            that does not match the CSM.
        """
        T = check_transform(np.eye(4) if transform is None else transform, rigid=True,
                            name="transform")
        if isinstance(obj, CoherentShadowMap):
            if not casts:
                raise ValueError("a CoherentShadowMap always casts; add its mesh with casts=False instead")
            if mesh is not None:
                if not isinstance(mesh, trimesh.Trimesh):
                    mesh = load_mesh(mesh)
                if mesh_hash(mesh) != obj.mesh_hash:
                    raise ValueError("mesh does not match the CSM (different mesh hash)")
            inst = Instance(T, True, csm=obj, mesh=mesh)
        else:
            if mesh is not None:
                raise ValueError("mesh= is only for CSMs; pass the mesh as obj")
            if not isinstance(obj, trimesh.Trimesh):
                obj = load_mesh(obj)
            csm = None
            if casts:
                csm = self._built.get(id(obj))
                if csm is None:
                    o = self.csm_options
                    csm = CoherentShadowMap.build(obj, o["views"], o["resolution"], o["depth_bits"],
                                                  o["layers"], progress=self.progress, footprint=o["footprint"])
                    self._built[id(obj)] = csm
            inst = Instance(T, bool(casts), csm=csm, mesh=obj)
        self.instances.append(inst)
        return len(self.instances) - 1

    def _instance(self, instance_id) -> Instance:
        if isinstance(instance_id, bool) or not isinstance(instance_id, (int, np.integer)) \
                or not 0 <= instance_id < len(self.instances):
            raise IndexError(f"no instance {instance_id!r} (the scene has {len(self.instances)})")
        return self.instances[int(instance_id)]

    def set_transform(self, instance_id: int, transform) -> None:
        """Move an instance (rigid transform, as in :meth:`add`). Nothing is rebuilt."""
        inst = self._instance(instance_id)
        inst.transform = check_transform(transform, rigid=True, name="transform")

    def transform(self, instance_id: int) -> np.ndarray:
        """The current 4x4 transform of an instance (a copy)."""
        return self._instance(instance_id).transform.copy()

    @property
    def casters(self) -> list[int]:
        return [i for i, inst in enumerate(self.instances) if inst.casts]

    # ------------------------------------------------------------------
    # device data
    # ------------------------------------------------------------------
    def _types(self):
        seen, types = {}, []
        for inst in self.instances:
            if inst.casts and id(inst.csm) not in seen:
                seen[id(inst.csm)] = len(types)
                types.append(inst.csm)
        return types, seen

    def _device_atlas(self):
        """Concatenated CSM data of every caster type (rebuilt only when types change)."""
        types, index = self._types()
        key = (id(_cl.context()), tuple(id(c) for c in types))
        if self._atlas is not None and self._atlas_key == key:
            return self._atlas, index
        bits = 16 if all(c.depth_bits == 16 for c in types) else 32
        wide_iend = any(c.iend.dtype != np.uint16 for c in types)
        wide = bits == 32 or wide_iend
        di = np.uint32 if wide_iend else np.uint16
        trow = np.zeros(max(1, len(types)), CSM_TYPE)
        offs, soffs, summ, pairs, bases, cells = [], [], [], [], [], []
        seg = blk = view = cell = tex = 0
        for ti, c in enumerate(types):
            R, D = c.resolution, c.maps
            a = c.search_arrays(wide=wide, padded=True)
            if len(a["pairs"]) + seg >= 2**32:
                raise ValueError("the scene's CSMs hold 2^32 or more segments together")
            layout = _LAYOUT_CODE[c.views.layout]
            p = c.views.params
            if c.views.layout == "zigzag":
                p1, p2 = p["theta"], p["phi"]
            else:
                p1, p2 = p["level"], 0
                if p.get("hemispheres"):
                    layout = 2
                cells.append(c.views._hilbert_cells().reshape(-1).astype(np.int32))
            # zigzag grid steps' cos and sin: the kernel's angle addition
            steps = ([np.cos(np.pi / p1), np.sin(np.pi / p1), np.cos(2 * np.pi / p2),
                      np.sin(2 * np.pi / p2)] if c.views.layout == "zigzag" else [0.0] * 4)
            trow[ti] = (R, D, layout, p1, p2, tex, view, cell, np.array(steps, np.float32))
            offs.append(a["offsets"][:-1].astype(np.int64) + seg)
            soffs.append(a["soff"][:-1].astype(np.int64) + blk)
            summ.append(a["summary"].astype(di))
            pr = a["pairs"]
            if bits == 32 and c.depth_bits == 16:     # a 32-bit atlas stores float depths
                pr[:, 1] = c.stored_to_depth(c.depth[a["segment"]]).astype(np.float32).view(np.uint32)
            pairs.append(pr)
            bases.append(c.views.bases.reshape(-1, 9).astype(np.float32))
            seg += len(a["pairs"])
            blk += len(a["summary"])
            view += D
            tex += R * R
            cell += len(cells[-1]) if c.views.layout == "hilbert" else 0
        # every type's tables end where the next type's begin; the last entries
        # close the final type (offsets[tex_base + R*R], soff[...] as the search needs)
        offs.append(np.array([seg], dtype=np.int64))
        soffs.append(np.array([blk], dtype=np.int64))

        def cat(parts, dtype, empty):
            return np.concatenate(parts).astype(dtype) if parts else np.asarray(empty, dtype)

        atlas = {
            "bits": bits,
            "iend_t": "uint" if wide_iend else "ushort",
            "pair_wide": int(wide),
            "ntypes": len(types),
            "layouts": {c.views.layout for c in types},
            "quantum": 1.0 / DEPTH_Q if bits == 16 else 0.0,
            "buffers": [
                _cl.to_device(trow),
                _cl.to_device(cat(offs, np.uint32, [0])),
                _cl.to_device(cat(soffs, np.uint32, [0])),
                _cl.to_device(cat(summ, di, [0])),
                _cl.to_device(cat(pairs, np.uint32, [0, 0] if wide else [0])),
                _cl.to_device(cat(bases, np.float32, np.zeros(9))),
                _cl.to_device(cat(cells, np.int32, [0])),
            ],
        }
        self._atlas, self._atlas_key = atlas, key
        return atlas, index

    def _anchor(self, points=None) -> np.ndarray:
        """A world point near the scene; device coordinates are relative to it."""
        if self.instances:
            return np.mean([inst.world_sphere()[0] for inst in self.instances], axis=0)
        if points is not None and len(points):
            return points.mean(axis=0)
        return np.zeros(3)

    def scale(self) -> float:
        """Largest world bounding-sphere radius of the instances (1 for an empty scene)."""
        if not self.instances:
            return 1.0
        return max(inst.world_sphere()[1] for inst in self.instances)

    def _instance_data(self, anchor, index):
        """The casters' INSTANCE records (anchor-relative) and CSM type indices."""
        casters = [inst for inst in self.instances if inst.casts]
        rows = np.zeros(max(1, len(casters)), INSTANCE)
        itype = np.zeros(max(1, len(casters)), np.int32)
        for k, inst in enumerate(casters):
            s = inst.scale
            Rm = inst.rotation
            c, r = inst.csm.centre, inst.csm.radius
            t = inst.transform[:3, 3]
            wc, wr = inst.world_sphere()
            rows[k] = (
                (Rm.T / (s * r)).reshape(-1),               # to_object A
                Rm.T @ (anchor - t) / (s * r) - c / r,      # offset c
                Rm.T.reshape(-1),                           # rotation Rw
                wc - anchor,                                # centre
                wr * (1 + 1e-6),                            # radius
            )
            itype[k] = index[id(inst.csm)]
        return _cl.to_device(rows), _cl.to_device(itype), len(casters)

    def _bias(self, bias, atlas, filtered=False):
        q = atlas["quantum"] + 1e-7
        if bias is None:
            return q, FILTERED_BIAS_TEXELS if filtered else DEFAULT_BIAS_TEXELS, DEFAULT_BIAS_TAN, q
        bias = float(bias)
        if not np.isfinite(bias):
            raise ValueError(f"bias must be finite, got {bias}")
        return bias, 0.0, 0.0, bias

    def _owners(self, surface_ids, n):
        """Caster slot of each point's surface for the kernels (-1 unknown, -2 none)."""
        if surface_ids is None:
            return np.full(n, -1, np.int32)
        ids = np.asarray(surface_ids)
        if not np.issubdtype(ids.dtype, np.integer):
            raise TypeError(f"surface_ids must be integers, got {ids.dtype}")
        if (ids.dtype == np.int32 and ids.shape == (n,) and ids.flags.c_contiguous and n
                and self.casters == list(range(len(self.instances)))
                and ids.min() >= GROUND_ID and ids.max() < len(self.instances)):
            return ids          # every instance casts: ids are the slots (-1, -2 included)
        ids = np.broadcast_to(ids, (n,)).astype(np.int64)
        ok = (ids == -1) | (ids == GROUND_ID) | ((ids >= 0) & (ids < len(self.instances)))
        if not ok.all():
            raise ValueError(f"surface_ids must be instance ids, -1 (unknown) or {GROUND_ID} (ground); "
                             f"got {int(ids[~ok][0])}")
        slot = np.full(len(self.instances) + 2, -2, np.int32)     # receivers: -2
        for k, i in enumerate(self.casters):
            slot[i] = k
        slot[-1] = -1                                            # index -1: unknown
        slot[-2] = -2                                            # index -2: ground
        return slot[ids]

    def _defines(self, atlas, **extra):
        d = {"DEPTH_BITS": atlas["bits"], "IEND_T": atlas["iend_t"], "PAIR_WIDE": atlas["pair_wide"],
             "SEARCH_BLOCK": csm_module.SEARCH_BLOCK,
             "NTYPES": atlas["ntypes"],
             "GROUND": int(self.ground is not None),
             "LAYOUT_ZIGZAG": int("zigzag" in atlas["layouts"]),
             "LAYOUT_HILBERT": int("hilbert" in atlas["layouts"]),
             "BATCH": launch.shape().query_batch,
             "FILTERED": 0, "FILTER_ANGLE_EPS": f"{FILTER_ANGLE_EPS!r}f"}
        d.update(extra)
        return d

    def _scene_args(self, anchor, bias, filtered=False):
        atlas, index = self._device_atlas()
        inst, itype, ninst = self._instance_data(anchor, index)
        b_abs, b_tex, b_tan, b_other = self._bias(bias, atlas, filtered)
        gy = (self.ground - anchor[1]) if self.ground is not None else 0.0
        g_eps = 1e-5 * self.scale()
        args = [*atlas["buffers"], inst, itype, np.int32(ninst), np.float32(gy), np.float32(g_eps),
                np.float32(b_abs), np.float32(b_tex), np.float32(b_tan),
                np.float32(b_other)]
        return atlas, args

    # ------------------------------------------------------------------
    # queries
    # ------------------------------------------------------------------
    def visible(self, points, directions, *, bias: float | None = None, surface_ids=None,
                filtered: bool = False) -> np.ndarray:
        """Is each ray unoccluded by the scene's casters and ground plane?

        Parameters
        ----------
        points : array_like, shape (N, 3)
            World positions (a point on a caster's surface is not occluded
            by that surface itself: see ``bias``). float64 or float32
            C-contiguous arrays are read in place by the kernel (no copy);
            other dtypes are converted to float64 first.
        directions : array_like, shape (N, 3)
            World directions, float64 or float32 as for ``points``;
            normalised here, so any non-zero length works (lengths far outside
            float32's range are first scaled by an exact power of two).
        bias : float, optional
            Depth tolerance in normalised depth units (1 = the diameter of a
            CSM's bounding sphere), against every caster. Default: against
            the caster a point lies on (see ``surface_ids``),
            ``quantum + (b0 + b1 tan a) / R`` with ``a`` the angle between the
            direction and the map's axis, ``R`` the CSM resolution and
            ``b0, b1 = DEFAULT_BIAS_TEXELS, DEFAULT_BIAS_TAN`` (1.5 and 0.5,
            tuned on the Stanford bunny against Embree: see
            benchmarks/accuracy.py); against every other caster only the
            depth quantum (1/65534 for 16-bit depth).
        surface_ids : int or array_like of int, optional
            Instance id of the surface each point lies on; ``-1`` (default)
            means unknown (the default bias then applies against every
            caster), ``GROUND_ID`` (-2) the ground plane. Points on receivers
            and the ground need no self-bias, so contact shadows stay sharp.
        filtered : bool, optional
            Ask each caster with a filtered lookup instead of one texel of
            its nearest map: the four maps of
            :meth:`ViewSet.filter_window` (weights by inverse angle to the
            direction), in each the four texels around the point (bilinear
            weights of the texel centres, border texels repeated), each
            saying shadowed or not with the bias above measured to its own
            map's axis (default self-bias ``FILTERED_BIAS_TEXELS`` = 1 texel
            in place of ``b0``); the caster shadows the ray when the weights
            of the shadowing votes sum to more than one half. Up to 16
            segment searches per query instead of one (a query stops asking
            once its vote is decided): more agreement with exact ray casting
            (Stanford bunny, 64x128 maps at 128^2: 98.67 -> 99.06 % on
            uniform hemisphere rays, 99.52 -> 99.73 % on AO rays) at about
            a quarter of the speed (benchmarks/accuracy.py section 8,
            benchmarks/visibility.py).

        Returns
        -------
        ndarray, shape (N,), bool
            True where the ray reaches the sky.
        """
        p = _kernel_rows(points, "points")
        w = _kernel_rows(directions, "directions", len(p))
        _check_both(p, "points", w, "directions")
        n = len(p)
        own = self._owners(surface_ids, n)
        out = np.empty(n, np.bool_)
        if n == 0:
            return out
        anchor = self._anchor(p)
        fp64 = _cl.has_fp64()
        if not fp64:
            # float-only device: the host does what the kernel does in double
            # elsewhere, with the same roundings: points relative to the
            # anchor, rounded once to float32; float64 directions scaled by a
            # power of two (exact) so their largest component lies in
            # [0.5, 1) before they are rounded to float32
            p = (p - anchor).astype(np.float32)
            if w.dtype == np.float64:
                w = np.ldexp(w, -np.frexp(np.abs(w).max(axis=1, keepdims=True))[1]).astype(np.float32)
        atlas, args = self._scene_args(anchor, bias, filtered)
        k = _cl.kernel("visibility.cl", "scene_visible",
                       self._defines(atlas, HAVE_FP64=int(fp64), POINTS_F64=int(p.dtype == np.float64),
                                     DIRS_F64=int(w.dtype == np.float64), FILTERED=int(bool(filtered))))
        # what the kernel subtracts from the points (the host already did on float-only devices)
        a = [np.float64(x) for x in anchor] if fp64 else [np.float32(0.0)] * 3
        q = _cl.queue()
        res = out.view(np.uint8)
        shape = launch.shape()
        batch = shape.query_batch
        for s in range(0, n, shape.query_chunk):
            e = min(n, s + shape.query_chunk)
            buf = _cl.host_buffer(res[s:e], writable=True)
            k(q, *launch.grid(-(-(e - s) // batch), shape.query_group), *args, np.int32(e - s), _cl.host_buffer(p[s:e]),
              _cl.host_buffer(w[s:e]), *a, _cl.host_buffer(own[s:e]), buf)
            _cl.sync_host_buffer(buf, res[s:e])
        return out

    def ambient_occlusion(self, points, normals, samples: int = 36, strategy: str = "hammersley",
                          patterns: int = 256, seed: int = 0, bent_normals: bool = False, *,
                          bias: float | None = None, indices=None, surface_ids=None,
                          filtered: bool = False):
        """Ambient occlusion of surface points (DESIGN.md convention: 1 = open).

        Parameters
        ----------
        points : array_like, shape (N, 3)
            World positions.
        normals : array_like, shape (N, 3)
            Surface normals (normalised here; zero normals are an error).
        samples : int, optional
            Cosine-weighted directions per point, 1 .. 4096 (thesis: 36).
        strategy : str, optional
            'random', 'stratified', 'latin_hypercube', 'halton' or
            'hammersley' (see :mod:`pyshadow.sampling`).
        patterns : int, optional
            Precomputed patterns; point ``i`` uses pattern
            ``pattern_indices(indices[i], patterns, seed)``.
        seed : int, optional
        bent_normals : bool, optional
            Also return the normalised sum of the unoccluded directions (the
            normal itself where every direction is occluded).
        bias, surface_ids, filtered : optional
            As in :meth:`visible`.
        indices : array_like of int, optional
            Sample-pattern index of each point; default ``arange(N)``.
            :func:`pyshadow.sample_directions` returns the directions used
            for ``indices = arange(N)``.

        Returns
        -------
        ao : ndarray, shape (N,), float32
            Unoccluded cosine-weighted fraction in [0, 1].
        bent : ndarray, shape (N, 3), float32
            Only with ``bent_normals=True``.
        """
        check_sampling(samples, strategy, patterns)
        p = _rows3(points, "points")
        n = _nonzero(_rows3(normals, "normals", len(p)), "normals")
        n = n / np.linalg.norm(n, axis=1, keepdims=True)
        N, S = len(p), int(samples)
        idx = np.arange(N) if indices is None else np.asarray(indices, dtype=np.int64)
        if idx.shape != (N,):
            raise ValueError(f"indices must have shape ({N},), got {idx.shape}")
        own = self._owners(surface_ids, N)
        ao = np.empty(N, np.float32)
        bent = np.empty((N, 3), np.float32)
        if N:
            anchor = self._anchor(p)
            atlas, args = self._scene_args(anchor, bias, filtered)
            k = _cl.kernel("visibility.cl", "scene_ao",
                           self._defines(atlas, SAMPLES=S, BENT_NORMALS=int(bool(bent_normals)),
                                         FILTERED=int(bool(filtered))))
            table = _cl.to_device(_lane_table(direction_table(S, strategy, patterns, seed)))
            pidx = pattern_indices(idx, patterns, seed)
            q = _cl.queue()
            shape = launch.shape()
            chunk = max(1, shape.ao_chunk_samples // S)
            for s in range(0, N, chunk):
                e = min(N, s + chunk)
                ao_buf = _cl.empty(4 * (e - s))
                bent_buf = _cl.empty(12 * (e - s) if bent_normals else 4)
                k(q, *launch.grid(e - s, shape.query_group), *args, np.int32(e - s),
                  _cl.to_device(p[s:e] - anchor, np.float32), _cl.to_device(n[s:e], np.float32),
                  _cl.to_device(pidx[s:e], np.int32), _cl.to_device(own[s:e]), table, ao_buf, bent_buf)
                cl.enqueue_copy(q, ao[s:e], ao_buf)
                if bent_normals:
                    cl.enqueue_copy(q, bent[s:e], bent_buf)
        return (ao, bent) if bent_normals else ao

    # ------------------------------------------------------------------
    # meshes, vertices, images
    # ------------------------------------------------------------------
    def vertex_points(self, instance_id: int):
        """World vertex positions (V, 3) and unit vertex normals (V, 3) of an instance, float64."""
        inst = self._instance(instance_id)
        if inst.mesh is None:
            raise ValueError(f"instance {instance_id} was added as a CSM without its mesh (pass mesh=)")
        if inst._normals is None:
            inst._normals = np.asarray(inst.mesh.vertex_normals, dtype=np.float64)
        T = inst.transform
        pts = np.asarray(inst.mesh.vertices) @ T[:3, :3].T + T[:3, 3]
        nrm = inst._normals @ inst.rotation.T
        return pts, nrm

    def vertex_ao(self, instance_id: int, samples: int = 64, strategy: str = "hammersley",
                  patterns: int = 256, seed: int = 0, bent_normals: bool = False, *,
                  bias: float | None = None, filtered: bool = False):
        """Per-vertex AO of an instance's mesh (for display), as :meth:`ambient_occlusion`.

        Points are the mesh's vertices in world space, normals its
        area-weighted vertex normals. Returns ``(V,)`` float32 (and
        ``(V, 3)`` bent normals).
        """
        pts, nrm = self.vertex_points(instance_id)
        ok = np.linalg.norm(nrm, axis=1) > 0
        if not ok.all():       # isolated vertices: give them any normal
            nrm = nrm.copy()
            nrm[~ok] = [0.0, 1.0, 0.0]
        return self.ambient_occlusion(pts, nrm, samples, strategy, patterns, seed, bent_normals,
                                      bias=bias, surface_ids=int(instance_id), filtered=filtered)

    def ground_quad(self, size: float | None = None) -> trimesh.Trimesh:
        """A finite square of the ground plane for drawing, centred under the scene.

        ``size`` is the side length; default 8 times the diameter of the
        region the instances occupy (at least 8 times the largest radius).
        """
        if self.ground is None:
            raise ValueError("the scene has no ground plane")
        anchor = self._anchor()
        if size is None:
            reach = max([np.linalg.norm(c - anchor) + r for c, r in
                         (inst.world_sphere() for inst in self.instances)] or [1.0])
            size = 16.0 * reach
        h = 0.5 * float(size)
        cx, cz = anchor[0], anchor[2]
        v = np.array([[cx - h, self.ground, cz - h], [cx + h, self.ground, cz - h],
                      [cx + h, self.ground, cz + h], [cx - h, self.ground, cz + h]])
        return trimesh.Trimesh(v, [[0, 2, 1], [0, 3, 2]], process=False)

    def draw_items(self, ground_size: float | None = None):
        """(mesh, transform) items to draw and the object id of each."""
        items, ids = [], []
        for i, inst in enumerate(self.instances):
            if inst.mesh is not None:
                items.append((inst.mesh, inst.transform))
                ids.append(i)
        if self.ground is not None:
            items.append((self.ground_quad(ground_size), np.eye(4)))
            ids.append(GROUND_ID)
        return items, np.array(ids, dtype=np.int32)

    def render(self, camera, samples: int = 36, strategy: str = "hammersley", seed: int = 0,
               patterns: int = 256, *, filter: str | None = None, ao_scale: int = 1,
               ground_size: float | None = None, bias: float | None = None,
               filtered: bool = False) -> dict:
        """Render AO and the G-buffer of the scene from ``camera``.

        Parameters
        ----------
        camera : Camera
        samples, strategy, seed, patterns :
            As in :meth:`ambient_occlusion`; pixel ``(r, c)`` uses pattern
            index ``r * W + c``.
        filter : {None, 'bilateral', 'separable', 'box'}, optional
            Edge-aware filtering of the AO image (:mod:`pyshadow.filters`).
        ao_scale : {1, 2, 4}, optional
            Compute AO at 1/ao_scale resolution and upsample it with the
            full-resolution G-buffer (joint bilateral upsampling).
        ground_size : float, optional
            Side of the drawn ground quad (:meth:`ground_quad`).
        bias, filtered : optional
            As in :meth:`visible`.

        Returns
        -------
        dict of ndarray
            ``'ao'`` float32 (H, W) in [0, 1], 1 on the background;
            ``'bent_normal'`` float32 (H, W, 3), 0 on the background;
            ``'depth'`` float32 (H, W), distance along the eye ray, inf on the
            background; ``'normal'`` float32 (H, W, 3) world normals facing
            the camera; ``'object_id'`` int32 (H, W): instance id,
            ``GROUND_ID`` (-2) for the ground, -1 for the background;
            ``'position'`` float32 (H, W, 3) world positions (NaN on the
            background).
        """
        from .gbuffer import render_gbuffer

        if filter not in (None, "bilateral", "separable", "box"):
            raise ValueError(f"filter must be None, 'bilateral', 'separable' or 'box', got {filter!r}")
        if ao_scale not in (1, 2, 4) or isinstance(ao_scale, bool):
            raise ValueError(f"ao_scale must be 1, 2 or 4, got {ao_scale!r}")
        check_sampling(samples, strategy, patterns)
        items, ids = self.draw_items(ground_size)
        g = render_gbuffer(items, camera)
        H, W = camera.height, camera.width
        hit = g["object_id"] >= 0
        obj = np.where(hit, ids[np.maximum(g["object_id"], 0)] if len(ids) else -1, -1).astype(np.int32)
        dirs = camera.ray_directions()
        pos = camera.eye + np.where(hit, g["depth"], 0.0)[..., None].astype(np.float64) * dirs
        ao = np.ones((H, W), np.float32)
        bent = np.zeros((H, W, 3), np.float32)
        if ao_scale == 1:
            sel = np.flatnonzero(hit.reshape(-1))
        else:
            sub = np.zeros((H, W), bool)
            sub[::ao_scale, ::ao_scale] = True
            sel = np.flatnonzero((hit & sub).reshape(-1))
        if len(sel):
            a, b = self.ambient_occlusion(pos.reshape(-1, 3)[sel], g["normal"].reshape(-1, 3)[sel],
                                          samples, strategy, patterns, seed, True, bias=bias,
                                          indices=sel, surface_ids=obj.reshape(-1)[sel], filtered=filtered)
            ao.reshape(-1)[sel] = a
            bent.reshape(-1, 3)[sel] = b
        out = {"ao": ao, "bent_normal": bent, "depth": g["depth"], "normal": g["normal"],
               "object_id": obj, "position": g["position"]}
        if ao_scale != 1 or filter is not None:
            from . import filters

            if ao_scale != 1:
                low = ao[::ao_scale, ::ao_scale]
                out["ao"] = filters.upsample(low, g["depth"], g["normal"], scale=ao_scale)
            if filter == "bilateral":
                out["ao"] = filters.bilateral(out["ao"], g["depth"], g["normal"])
            elif filter == "separable":
                out["ao"] = filters.bilateral(out["ao"], g["depth"], g["normal"], separable=True)
            elif filter == "box":
                out["ao"] = filters.edge_aware_box(out["ao"], g["depth"], g["normal"])
        return out


# ---------------------------------------------------------------------------
# NumPy reference of the visibility kernel (float64, small inputs)
# ---------------------------------------------------------------------------
def visible_reference(scene: Scene, points, directions, *, bias: float | None = None,
                      surface_ids=None, filtered: bool = False) -> np.ndarray:
    """NumPy version of :meth:`Scene.visible` (the same rules in float64).

    For each caster: bounding-sphere cull, the point and direction in the
    instance's normalised frame, the nearest map (:meth:`ViewSet.nearest`),
    the texel, the stored depth of that (map, texel) found with
    ``searchsorted`` on the segment lists, and the comparison with the bias;
    then the analytic ground plane. With ``filtered``, the weighted vote of
    the four maps of :meth:`ViewSet.filter_window` times the four texels
    around the point. Differences to the kernel come only from float32
    rounding (e.g. a direction almost exactly between two maps, a vote of
    almost exactly one half).
    """
    p = _rows3(points, "points")
    w = _nonzero(_rows3(directions, "directions", len(p)), "directions")
    w = w / np.linalg.norm(w, axis=1, keepdims=True)
    own = scene._owners(surface_ids, len(p))
    occ = np.zeros(len(p), bool)
    if scene.ground is not None:
        h = p[:, 1] - scene.ground
        eps = 1e-5 * scene.scale()
        occ |= ((h >= -eps) & (w[:, 1] < 0)) | ((h < -eps) & (w[:, 1] > 0))
    types, _ = scene._types()
    bits = 16 if all(c.depth_bits == 16 for c in types) else 32
    quantum = (1.0 / DEPTH_Q if bits == 16 else 0.0) + 1e-7
    b_texels = FILTERED_BIAS_TEXELS if filtered else DEFAULT_BIAS_TEXELS
    for slot, i in enumerate(scene.casters):
        inst = scene.instances[i]
        csm = inst.csm
        wc, wr = inst.world_sphere()
        oc = wc - p
        tca = np.einsum("ij,ij->i", oc, w)
        oc2 = np.einsum("ij,ij->i", oc, oc)
        r2 = (wr * (1 + 1e-6)) ** 2
        act = ~occ & ~((oc2 > r2) & ((tca < 0) | (oc2 - tca * tca > r2)))
        if not act.any():
            continue
        Rm, s = inst.rotation, inst.scale
        t = inst.transform[:3, 3]
        pn = ((p[act] - t) @ Rm) / (s * csm.radius) - csm.centre / csm.radius
        wn = w[act] @ Rm
        if filtered:
            maps, map_w = csm.views.filter_window(wn)
        else:
            maps, map_w = csm.views.nearest(wn)[:, None].astype(np.int64), np.ones((len(wn), 1))
        vote = shadow_vote(csm, pn, wn, maps, map_w, quantum=quantum, texels=4 if filtered else 1,
                           self_=(own[act] == -1) | (own[act] == slot), bias=bias, bias_texels=b_texels)
        idx = np.flatnonzero(act)
        occ[idx[vote > 0.5]] = True
    return ~occ


def shadow_vote(csm: CoherentShadowMap, pn, wn, maps, map_weights, *, quantum: float, texels: int = 1,
                self_=True, bias: float | None = None, bias_texels: float = DEFAULT_BIAS_TEXELS) -> np.ndarray:
    """Weighted shadowing vote of a CSM's taps for points and directions in its frame (NumPy).

    The rule of the visibility kernel (``instance16``) for one caster, in
    float64: each point is asked in the maps ``maps[:, m]`` with weights
    ``map_weights[:, m]``, at the texel holding it (``texels=1``) or at the
    four texels around it with bilinear weights of the texel centres, border
    texels repeated (``texels=4``); a tap votes "shadowed" when the point's
    depth exceeds the stored depth plus the bias.

    Parameters
    ----------
    csm : CoherentShadowMap
    pn, wn : ndarray, shape (N, 3)
        Points in the CSM's normalised frame (its bounding sphere centred at
        the origin with radius 1) and unit directions in its frame.
    maps, map_weights : ndarray, shape (N, M)
        Map indices (int) and their weights.
    quantum : float
        Depth quantum plus rounding slack, normalised depth units.
    texels : {1, 4}
    self_ : bool or ndarray of bool, shape (N,)
        Where the point may lie on this caster, the self-bias
        ``quantum + (bias_texels + DEFAULT_BIAS_TAN * tan a) / R`` applies
        (``a`` the angle between direction and map axis); elsewhere ``quantum``.
    bias : float, optional
        One fixed bias for every tap instead.
    bias_texels : float, optional

    Returns
    -------
    ndarray, shape (N,), float64
        The summed weights of the shadowing taps; the caster shadows a ray
        where this exceeds one half.
    """
    R, D = csm.resolution, csm.maps
    # global keys texel * D + i_end are sorted: one searchsorted finds every segment
    keys = (np.repeat(np.arange(R * R), np.diff(np.asarray(csm.offsets, dtype=np.int64))) * D
            + np.asarray(csm.iend, dtype=np.int64))
    depths = np.asarray(csm.depth)
    if texels == 4:      # texel offsets and their bilinear weights (tx, ty)
        taps = [(0, 0, lambda tx, ty: (1 - tx) * (1 - ty)), (0, 1, lambda tx, ty: tx * (1 - ty)),
                (1, 0, lambda tx, ty: (1 - tx) * ty), (1, 1, lambda tx, ty: tx * ty)]
    elif texels == 1:
        taps = [(0, 0, lambda tx, ty: 1.0)]
    else:
        raise ValueError(f"texels must be 1 or 4, got {texels!r}")
    vote = np.zeros(len(pn))
    for m in range(maps.shape[1]):
        k = maps[:, m]
        B = csm.views.bases[k]
        depth = (1.0 - np.einsum("ij,ij->i", pn, B[:, 2])) * 0.5
        fx = (np.einsum("ij,ij->i", pn, B[:, 0]) + 1.0) * 0.5 * R
        fy = (np.einsum("ij,ij->i", pn, B[:, 1]) + 1.0) * 0.5 * R
        inside = (depth > 0) & (fx >= 0) & (fx < R) & (fy >= 0) & (fy < R)
        if bias is None:
            ca = np.clip(np.einsum("ij,ij->i", wn, B[:, 2]), 1e-3, 1.0)
            tan_a = np.sqrt(np.maximum(1.0 - ca * ca, 0.0)) / ca
            b = np.where(self_, quantum + (bias_texels + DEFAULT_BIAS_TAN * tan_a) / R, quantum)
        else:
            b = float(bias)
        gx, gy = (fx - 0.5, fy - 0.5) if texels == 4 else (fx, fy)
        x0, y0 = np.floor(gx), np.floor(gy)
        tx, ty = gx - x0, gy - y0
        for dy, dx, weight in taps:
            tex = np.clip(y0.astype(np.int64) + dy, 0, R - 1) * R + np.clip(x0.astype(np.int64) + dx, 0, R - 1)
            seg = np.searchsorted(keys, np.where(inside, tex, 0) * D + k)
            z = csm.stored_to_depth(depths[np.minimum(seg, len(keys) - 1)])
            vote += map_weights[:, m] * weight(tx, ty) * (inside & (depth > z + b))
    return vote
