"""The CSM backends: the visibility kernels (``kernels/visibility.cl``) over a scene's casters.

Stage "visibility kernel" of the pipeline (README.md, the table of stages;
thesis 000, 5.3, 5.3.1-5.3.3). ``"csm"`` asks one texel of each
caster's nearest map; ``"csm-vote"`` asks the four maps of
:meth:`pyshadow.ViewSet.filter_window` times the four texels around the
point and lets the weighted vote decide. The kernels are specialised to the
scene through compile-time macros (number of CSM types, ground plane or
not, layouts present, sample count, bent normals or not, lookup) and cached
per configuration by :mod:`pyshadow._cl`. The scene's CSMs are packed into
one device atlas, rebuilt only when the set of caster types changes; moving
an instance rewrites one small table.

Bias (normalised depth, 1 = the diameter of a CSM's bounding sphere): by
default, against the caster a point lies on (``surface_ids``), ``quantum +
(b0 + b1 tan a) / R`` with ``a`` the angle between the direction and the
map's axis, ``R`` the CSM resolution, ``b0 = DEFAULT_BIAS_TEXELS`` (1.5;
``VOTE_BIAS_TEXELS`` = 1 for the vote) and ``b1 = DEFAULT_BIAS_TAN`` (0.5);
against every other caster only the depth quantum (1/65534 for 16-bit
depth). A given ``bias`` applies to every caster instead.

Rays that leave a caster's own surface at a known normal (AO always;
``visible(..., normals=...)``) follow the surface rule of
:mod:`pyshadow.csm.surface_rule`: grazing rays over a flat face are not
shadowed by that face, and with the default bias each tap's tolerance is
that of the plane through the point at the tap's texel centre
(``PLANE_BIAS``; the receiver's plane).

Unused features cost nothing: a scene without casters compiles with
``NTYPES=0`` (no sphere test, instance tree or grid, or CSM lookup in the kernel), one
without a ground plane with ``GROUND=0`` (no ground test). With neither, no
kernel is launched where the answer is known: ``visible`` is all True and
AO all 1; only bent normals and the SH transfer still launch the AO kernel,
which then merely sums its sample directions (bent normals bit-identical to
those of a scene with occluders that block nothing).
:meth:`CSMVisibility.query_defines` tells what a query compiles with.
"""
from __future__ import annotations

import weakref

import numpy as np
import pyopencl as cl

from .. import _cl
from .._cl import launch
from .._cl.launch import lane_table
from .._cl.tables import BVH_NODE, GRID, GRID_PACKET, INSTANCE
from .._validate import (FLOAT32_MAX, check_both, check_float32_instances, check_float32_points, check_indices,
                         flag, kernel_rows, rows3, unit_normals)
from ..contact import close_contacts, ground_tolerance, occlude_contacts
from ..csm import SEARCH_BLOCK
from ..csm.choose import warn_unchosen_lookup
from ..csm.core import DEFAULT_BIAS_TAN, DEFAULT_BIAS_TEXELS, PLANE_BIAS_TEXELS, VOTE_BIAS_TEXELS
from ..csm.device import empty_table, scene_atlas
from ..csm.surface_rule import SURFACE_LIFT_TEXELS, surface_horizon
from ..sampling import ao_from_samples, direction_table, pattern_indices
from ..scene_arrays import anchor_groups, points_bound, scene_arrays
from ..views import FILTER_ANGLE_EPS
from . import order
from .base import check_bias, check_sampling, register
from .finite import (answer_finite, ao_nodes, check_ao_options, check_max_distance, check_straddle, rays_ao,
                     shell_clear, unit_directions)
from .bvh import BVH_MIN_INSTANCES, STACK as BVH_STACK, box_pad, instance_bvh
from .grid import grid_margin, grid_packets, instance_grid, isolated_casters
from .grouped import ao_grouped, visible_grouped
from .held import check_tables, held_at, kept as _kept, on_device as _on_device
from .sampled_sky import _SampledSky

__all__ = ["CSMVisibility", "lane_table", "instance_accel"]

#: Whether scenes of at least BVH_MIN_INSTANCES casters may take the grid (pyshadow.visibility.grid)
#: where it is balanced; False: always the tree (tests and benchmarks compare the two).
USE_GRID = True
#: Whether rays asked with their surface normals and the default bias take the receiver's plane's bias at each tap
#: (pyshadow.csm.core.PLANE_BIAS_TEXELS) and no lift; False: the constant self-bias and the surface rule's lift
#: alone, the code before the plane's bias (benchmarks/surface_rule.py measures both).
PLANE_BIAS = True


def instance_accel(scene) -> str:
    """How the kernels find the casters of ``scene`` a ray can meet.

    Returns
    -------
    {'none', 'all', 'tree', 'grid'}
        'none': no caster. 'all': every caster's sphere is tested (fewer than
        ``BVH_MIN_INSTANCES``). 'grid': the uniform grid over the casters'
        spheres (:mod:`pyshadow.visibility.grid`), where it is balanced;
        'tree' otherwise (:mod:`pyshadow.visibility.bvh`).
    """
    held = scene_arrays(scene)
    ninst = int(held["casts"].sum())
    if ninst == 0:
        return "none"
    if ninst < BVH_MIN_INSTANCES:
        return "all"
    if not USE_GRID:
        return "tree"
    if "instance_accel" not in held:           # the grid of queries near the scene decides (and is kept)
        anchor = scene.anchor()
        rows = _instance_data(scene, anchor, "nearest")[0]
        margin = _grid_margin(rows, 0.0)
        g = instance_grid(rows["centre"], rows["radius"], margin)
        if g is not None:
            held[_grid_key(anchor, margin)] = (g[0], grid_packets(g[0]["dims"][0], g[1], g[2]))
        held["instance_accel"] = "tree" if g is None else "grid"
    return held["instance_accel"]


def _spheres_extent(rows) -> float:
    """The largest |coordinate| of the casters' spheres in the grid's cells (anchor-relative INSTANCE rows; those
    set apart, :func:`.grid.isolated_casters`, are asked by every ray, through no cell)."""
    c, r = rows["centre"], rows["radius"]
    inside = np.ones(len(r), bool)
    inside[isolated_casters(c.astype(np.float64), r.astype(np.float64))] = False
    return float(np.abs(c[inside]).max() + r[inside].max())


def _grid_margin(rows, points_extent, spheres=None):
    """The grid's margin for queries within ``points_extent`` of the anchor: at least that of
    queries within the spheres' own extent (``spheres``: :func:`_spheres_extent` of ``rows``
    when not given), so that queries near the scene share one grid."""
    if spheres is None:
        spheres = _spheres_extent(rows)
    return grid_margin(max(points_extent, spheres), spheres)


def _grid_key(anchor, margin):
    return ("instance_grid", np.asarray(anchor, np.float64).tobytes(), margin)


# scene -> (key, atlas): the packed CSMs of its caster types on the current context
_ATLAS = weakref.WeakKeyDictionary()


def _device_atlas(scene):
    """Concatenated CSM data of every caster type of ``scene`` (rebuilt only when types change)."""
    types, index = scene.caster_types()
    key = (id(_cl.context()), tuple(id(c) for c in types))
    held = _ATLAS.get(scene)
    if held is not None and held[0] == key:
        return held[1], index
    atlas = scene_atlas(types)
    _ATLAS[scene] = (key, atlas)
    return atlas, index


def _instance_data(scene, anchor, lookup="nearest"):
    """The casters' INSTANCE records (anchor-relative), CSM type indices, and their count.

    Computed for all casters at once from :func:`pyshadow.scene_arrays.scene_arrays`, with
    the operations of :meth:`pyshadow.scene.Instance.world_sphere` (bit-identical to
    computing them instance by instance), and kept with those arrays per anchor and
    lookup until the scene changes (read-only; :func:`.held.held_at`).
    """
    held = held_at(scene, anchor)       # first: a move landing before the arrays keeps no rows of the old poses
    arr = scene_arrays(scene)
    if not arr["casts"].any():              # an empty scene's anchor follows its points: nothing kept
        return _instance_rows(arr, np.asarray(anchor, np.float64), lookup)
    key = ("instance_data", np.asarray(anchor, np.float64).tobytes(), lookup)
    return _kept(held, key, lambda: _instance_rows(arr, np.asarray(anchor, np.float64), lookup))


def _instance_rows(arr, anchor, lookup):
    sel = np.flatnonzero(arr["casts"])
    n = len(sel)
    rows = np.zeros(max(1, n), INSTANCE)
    itype = np.zeros(max(1, n), np.int32)
    if n:
        T = arr["transform"][sel]
        s = arr["scale"][sel]
        RT = (T[:, :3, :3] / s[:, None, None]).transpose(0, 2, 1)        # rotation^T
        c, r = arr["object_centre"][sel], arr["object_radius"][sel]
        sr = (s * r)[:, None]
        fields = {"to_object": (RT / sr[:, :, None]).reshape(n, 9),                         # A
                  "offset": np.matmul(RT, (anchor - T[:, :3, 3])[:, :, None])[:, :, 0] / sr - c / r[:, None],
                  "centre": arr["world_centre"][sel] - anchor, "radius": arr["world_radius"][sel] * (1 + 1e-6)}
        for name, value in fields.items():
            check_float32_instances(name, value, sel, arr["world_radius"][sel], fields["centre"])
            rows[name] = value
        rows["rotation"] = RT.reshape(n, 9)                             # Rw
        itype[:] = arr["itype"][sel]          # the type order of scene.caster_types(), as the atlas
        horizon = np.array([surface_horizon(csm, lookup) for csm in arr["types"]], np.float64)
        rows["horizon"] = horizon[itype]
    rows.flags.writeable = False
    itype.flags.writeable = False
    return rows, itype, n


def _read_only(a):
    a.flags.writeable = False
    return a


# the one-record tables of the structure a scene does not use
_NO_NODES, _NO_ORDER = _read_only(np.zeros(1, BVH_NODE)), _read_only(np.zeros(1, np.int32))
_NO_GRID, _NO_PACKETS = _read_only(np.zeros(1, GRID)), _read_only(np.zeros(1, GRID_PACKET))


def _accel_tables(scene, rows, anchor, points_extent, held):
    """The kernels' tables of :func:`instance_accel`: the tree (nodes, order, box margin) and the
    grid (header, packets); one-record placeholders for the one not used. Both are kept in ``held``
    (:func:`.held.held_at` of the anchor, taken before ``rows``; the grid per margin) until the scene changes."""
    accel = instance_accel(scene)
    nodes, order, pad, grid, packets = _NO_NODES, _NO_ORDER, 0.0, _NO_GRID, _NO_PACKETS
    at = np.asarray(anchor, np.float64).tobytes()
    if accel == "tree":
        nodes, order, _ = _kept(held, ("instance_bvh", at), lambda: instance_bvh(rows["centre"], rows["radius"]))
        pad = box_pad(points_extent, _kept(held, ("bvh_extent", at),
                                           lambda: np.abs(np.concatenate([nodes["lo"], nodes["hi"]])).max()))
    elif accel == "grid":
        margin = _grid_margin(rows, points_extent, _kept(held, ("spheres_extent", at), lambda: _spheres_extent(rows)))

        def packed():
            g = instance_grid(rows["centre"], rows["radius"], margin, balanced_only=False)
            return g[0], grid_packets(g[0]["dims"][0], g[1], g[2])
        grid, packets = _kept(held, _grid_key(anchor, margin), packed)
    return nodes, order, pad, grid, packets


def _ao_points(samples, batch) -> int:
    """``launch.ao_points``, checked: ``scene_ao``'s arrays hold ``batch`` queries, its points' samples
    (rounded up to the lanes, at most ``batch`` a point) must fit."""
    points, per = launch.ao_points(samples), min(launch.padded_samples(samples), batch)
    if points * per > batch:
        raise ValueError(f"AO_POINTS {points} x {per} samples exceeds the batch of {batch} queries")
    return points


def _open_sky(scene) -> bool:
    """Whether nothing in ``scene`` can occlude a ray: no caster and no ground plane."""
    return scene.ground is None and not scene_arrays(scene)["casts"].any()


def _extent(p, anchor, bound=None) -> float:
    """A bound on the largest |coordinate| of the points relative to the anchor (``bound``: ``points_bound(p)``
    if known); beyond float32's range the points beyond it are refused, named."""
    bound = (points_bound(p) if bound is None else bound) + float(np.abs(anchor).max())
    return bound if bound <= FLOAT32_MAX else check_float32_points(p, anchor)


def _float32_lengths(tmax):
    """float64 ray lengths -> float32 for the kernel (those beyond float32's range: +inf; positive ones
    below its smallest normal number: that number, not 0, which ends a ray before a surface at its point)."""
    t = np.where(tmax > np.finfo(np.float32).max, np.inf, tmax).astype(np.float32)
    tiny = np.finfo(np.float32).tiny        # (a subnormal length: 0 on a device that flushes them)
    return np.where((t < tiny) & (tmax > 0), tiny, t)


class CSMVisibility(_SampledSky):
    """Visibility from the scene's Coherent Shadow Maps, by the OpenCL kernels.

    Parameters
    ----------
    lookup : {'nearest', 'vote'}
        One texel of the nearest map, or the weighted vote of four maps times
        four texels (up to 16 segment searches a query; a query stops asking
        once its vote is decided).
    """

    def __init__(self, lookup: str = "nearest"):
        if lookup not in ("nearest", "vote"):
            raise ValueError(f"lookup must be 'nearest' or 'vote', got {lookup!r}")
        self.lookup = lookup
        self.name = "csm" if lookup == "nearest" else "csm-vote"

    def __repr__(self) -> str:
        return f"<CSMVisibility {self.name!r}>"

    @property
    def _vote(self) -> bool:
        return self.lookup == "vote"

    def _bias(self, bias, atlas):
        q = atlas["quantum"] + 1e-7
        if bias is None:
            return q, VOTE_BIAS_TEXELS if self._vote else DEFAULT_BIAS_TEXELS, DEFAULT_BIAS_TAN, q
        bias = float(check_bias(bias))      # one real number within float32 (the kernels' argument)
        return bias, 0.0, 0.0, bias

    def _defines(self, scene, atlas, **extra):
        accel = instance_accel(scene)
        d = {"DEPTH_BITS": atlas["bits"], "IEND_T": atlas["iend_t"], "PAIR_WIDE": atlas["pair_wide"],
             "SEARCH_BLOCK": SEARCH_BLOCK, "EMPTY_RUNS": int(accel in ("tree", "grid") and not self._vote),
             "NTYPES": min(atlas["ntypes"], 2),     # the kernels ask only 0, 1 or more: one program for 2..n types
             "GROUND": int(scene.ground is not None),
             "LAYOUT_ZIGZAG": int("zigzag" in atlas["layouts"]),
             "LAYOUT_HILBERT": int("hilbert" in atlas["layouts"]),
             "BATCH": launch.shape().query_batch,
             "FILTERED": int(self._vote), "FILTER_ANGLE_EPS": f"{FILTER_ANGLE_EPS!r}f",
             "TRANSFER": 0, "SURFACE_NORMALS": 0, "FINITE_RAYS": 0, "SURFACE_LIFT_TEXELS": f"{float(SURFACE_LIFT_TEXELS)!r}f",
             "PLANE_BIAS": int(PLANE_BIAS), "PLANE_BIAS_TEXELS": f"{float(PLANE_BIAS_TEXELS)!r}f",
             "INSTANCE_BVH": int(accel == "tree"), "INSTANCE_GRID": int(accel == "grid"), "BVH_STACK": BVH_STACK}
        d.update(extra)
        if "SAMPLES" in extra:                  # scene_ao: points per work-item
            d.setdefault("AO_POINTS", _ao_points(int(extra["SAMPLES"]), d["BATCH"]))
        return d

    def query_defines(self, scene, kernel: str = "scene_visible", **extra) -> dict | None:
        """The compile-time defines of a query kernel for ``scene``, or None where no kernel is launched.

        Parameters
        ----------
        scene : pyshadow.Scene
        kernel : {'scene_visible', 'scene_ao'}
            The kernel of :meth:`visible`, or that of :meth:`ambient_occlusion`
            and :meth:`sh_transfer`.
        **extra
            The query's own defines (e.g. ``BENT_NORMALS=1``, ``TRANSFER=1``,
            ``SAMPLES``), which override the scene's.

        Returns
        -------
        dict or None
            The ``-D`` defines (without ``LANES``, which :func:`pyshadow._cl.kernel`
            adds): ``NTYPES`` 0 for a scene without casters (no CSM lookup is
            compiled), ``GROUND`` 0 for one without a ground plane (no ground
            test). None when the scene has neither and the answer needs no
            kernel: ``visible``, and AO without bent normals or transfer.
        """
        if kernel not in ("scene_visible", "scene_ao"):
            raise ValueError(f"kernel must be 'scene_visible' or 'scene_ao', got {kernel!r}")
        sums = kernel == "scene_ao" and (extra.get("BENT_NORMALS") or extra.get("TRANSFER"))
        if _open_sky(scene) and not sums:
            return None
        atlas, _ = _device_atlas(scene)
        return self._defines(scene, atlas, **extra)

    def _scene_args(self, scene, anchor, bias, points_extent=0.0, defines=None):
        """Kernel arguments of the scene tables; ``points_extent``: largest |coordinate| of the
        queries' anchor-relative points (it sizes the margins of the instance tree's boxes and of the
        grid's spheres)."""
        atlas, _ = _device_atlas(scene)
        # the tables are kept with the scene's arrays when it has casters (an empty scene's follow its points); taken
        # before the rows: a move landing between them (another thread's) keeps no tables of the old poses
        held = held_at(scene, anchor)
        rows, itype, ninst = _instance_data(scene, anchor, self.lookup)
        check_tables(defines, atlas, itype, ninst)      # (the program compiled for the tables it is given)
        b_abs, b_tex, b_tan, b_other = self._bias(bias, atlas)
        gy = (scene.ground - anchor[1]) if scene.ground is not None else 0.0
        g_eps = ground_tolerance(scene)
        nodes, order, pad, grid, packets = _accel_tables(scene, rows, anchor, points_extent, held)
        _kept(held, ("lookup checked", self.lookup), lambda: warn_unchosen_lookup(scene, self.lookup))
        dev = (lambda a: _on_device(held, a)) if ninst else _cl.to_device
        args = [*atlas["buffers"], empty_table(atlas, defines is None or defines.get("EMPTY_RUNS", 1)), dev(rows),
                dev(itype), np.int32(ninst), np.float32(gy), np.float32(g_eps), np.float32(b_abs), np.float32(b_tex),
                np.float32(b_tan), np.float32(b_other), dev(nodes), dev(order), np.float32(pad), dev(grid),
                dev(packets)]
        return atlas, args

    def visible(self, scene, points, directions, *, bias=None, surface_ids=None, normals=None,
                max_distance=None, straddle="error") -> np.ndarray:
        """:meth:`pyshadow.Scene.visible` by the kernel (float32 or float64 rows read in place).

        ``max_distance`` and ``straddle``: :mod:`pyshadow.visibility.finite`
        (the kernel compiled with ``FINITE_RAYS=1`` only when given).
        """
        p = kernel_rows(points, "points")
        w = kernel_rows(directions, "directions", len(p))
        pb = check_both(p, "points", w, "directions")
        n = len(p)
        own = scene.caster_slots(surface_ids, n, p)
        m = None if normals is None else unit_normals(normals, n).astype(np.float32)
        tmax = check_max_distance(max_distance, n)
        check_bias(bias)                # also where no kernel runs (an empty scene), and unused straddle:
        check_straddle(straddle)        # a bad value is an error, as on the other backends
        if tmax is not None and n:
            return answer_finite(scene, np.asarray(p, np.float64), unit_directions(w), tmax, straddle,
                                 lambda: self._visible(scene, p, w, own, m, bias, _float32_lengths(tmax), pb=pb))
        return self._visible(scene, p, w, own, m, bias, None, pb=pb)

    def _visible(self, scene, p, w, own, m, bias, tmax, ground=True, pb=None):
        """:meth:`_visible_kernel`, then the footprints of bodies resting on the ground (:mod:`pyshadow.contact`)."""
        return occlude_contacts(scene, p, w, self._visible_kernel(scene, p, w, own, m, bias, tmax, ground=ground,
                                                                  pb=pb))

    def _visible_kernel(self, scene, p, w, own, m, bias, tmax, coherent=True, anchor=None, ground=True, pb=None):
        """The kernel's answers for validated rows (``tmax``: float32 (N,) lengths, or None; order: :mod:`.order`;
        ``anchor``: the rows' anchor, or None: :func:`~pyshadow.scene_arrays.anchor_groups`'s; ``ground``
        False: the casters alone, the kernel compiled with ``GROUND=0``; ``pb``: ``points_bound(p)``, or None)."""
        n = len(p)
        out = np.empty(n, np.bool_)
        if n == 0:
            return out
        if coherent and order.enabled(n) and self.query_defines(scene, "scene_visible") is not None:
            return order.reordered(lambda *r: self._visible_kernel(scene, *r[:4], bias, r[4], False, ground=ground),
                                   p, w, own, m, tmax)
        fp64 = _cl.has_fp64()
        # float64 inputs are read as such where the device has doubles (else the host rounds them below)
        defines = self.query_defines(scene, "scene_visible", HAVE_FP64=int(fp64),
                                     POINTS_F64=int(fp64 and p.dtype == np.float64),
                                     DIRS_F64=int(fp64 and w.dtype == np.float64),
                                     SURFACE_NORMALS=int(m is not None), FINITE_RAYS=int(tmax is not None),
                                     **({} if ground else {"GROUND": 0}))
        if defines is None:             # nothing occludes: no kernel
            out[:] = True
            return out
        if not fp64 and w.dtype == np.float64:
            # float-only device: the host does what the kernel does in double
            # elsewhere, with the same roundings: float64 directions scaled by
            # a power of two (exact) so their largest component lies in
            # [0.5, 1) before they are rounded to float32 (row by row, for
            # every anchor group alike); points relative to their anchor below
            w = np.ldexp(w, -np.frexp(np.abs(w).max(axis=1, keepdims=True))[1]).astype(np.float32)
        if anchor is None:
            pb = points_bound(p) if pb is None else pb
            groups = anchor_groups(scene, p, pb)
            if len(groups) > 1:             # points far apart: each group relative to an anchor of its own
                k = _cl.kernel("visibility.cl", "scene_visible", defines)
                visible_grouped(self, scene, k, defines, groups, p, w, own, m, tmax, bias, fp64, out, _extent)
                return out
            anchor = groups[0][1]
        if not fp64:
            p = (p - anchor).astype(np.float32)     # relative to the anchor, rounded once to float32
        _, args = self._scene_args(scene, anchor, bias, _extent(p, anchor, pb if fp64 else None), defines)
        k = _cl.kernel("visibility.cl", "scene_visible", defines)
        # what the kernel subtracts from the points (the host already did on float-only devices)
        a = [np.float64(x) for x in anchor] if fp64 else [np.float32(0.0)] * 3
        q = _cl.queue()
        res = out.view(np.uint8)
        shape = launch.shape()
        batch = shape.query_batch
        for s in range(0, n, shape.query_chunk):
            e = min(n, s + shape.query_chunk)
            buf = _cl.host_buffer(res[s:e], writable=True)
            k(q, *launch.grid(-(-(e - s) // batch), shape.query_group, k), *args, np.int32(e - s),
              _cl.host_buffer(p[s:e]), _cl.host_buffer(w[s:e]), *a, _cl.host_buffer(own[s:e]),
              *([] if m is None else [_cl.host_buffer(m[s:e])]),
              *([] if tmax is None else [_cl.host_buffer(tmax[s:e])]), buf)
            _cl.sync_host_buffer(buf, res[s:e])
        return out

    def ambient_occlusion(self, scene, points, normals, *, sampling, return_bent_normals=False,
                          bias=None, indices=None, surface_ids=None, max_distance=None, obscurance=None,
                          quadrature=16, straddle="error"):
        """:meth:`pyshadow.Scene.ambient_occlusion` by the kernel.

        ``max_distance``, ``obscurance``, ``quadrature``, ``straddle``: distance
        AO (:func:`pyshadow.visibility.ambient_occlusion`); without the first
        two, the kernel of before (compiled with ``FINITE_RAYS=0``).
        """
        bent_normals = flag(return_bent_normals, "return_bent_normals")     # "False" returned (ao, bent)
        check_sampling(sampling)                # (8: AttributeError "'int' object has no attribute 'samples'")
        check_bias(bias)                        # also where no kernel runs; the options also where unused
        options = check_ao_options(obscurance, quadrature, straddle)
        if max_distance is not None or obscurance is not None:
            return _distance_ao(self, scene, points, normals, sampling, bent_normals, bias, indices,
                                surface_ids, max_distance, *options)
        ao, bent, _ = self._ao(scene, points, normals, sampling, bent_normals, False, bias, indices, surface_ids)
        return (ao, bent) if bent_normals else ao

    def sh_transfer(self, scene, points, normals, *, sampling, bias=None, indices=None, surface_ids=None):
        """AO, bent normals and the shadowed SH transfer of each point, from one pass of the AO kernel.

        ``T_k = pi / S * sum over the unoccluded directions w_s of Y_k(w_s)``
        (:mod:`pyshadow.lighting.transfer`): float32 (N,), (N, 3), (N, 9).
        """
        return self._ao(scene, points, normals, check_sampling(sampling), True, True, check_bias(bias), indices,
                        surface_ids)

    def _ao(self, scene, points, normals, sampling, bent_normals, transfer, bias, indices, surface_ids, tmax=None,
            sky_env=None):
        """The AO kernel (``tmax``: float32 (N,) lengths, compiled with ``FINITE_RAYS=1``, or None; ``sky_env``:
        the map's arguments (:meth:`sampled_sky`), ``SKY_SAMPLED=1``: (sky, ao, bent), not (ao, bent, transfer))."""
        p = rows3(points, "points")
        n = unit_normals(normals, len(p), dtype=np.float32)     # what the kernel reads
        N, S = len(p), int(sampling.samples)
        idx = check_indices(indices, N)
        own = scene.caster_slots(surface_ids, N, p)
        ao = np.empty(N, np.float32)
        bent = np.empty((N, 3), np.float32)
        tr = np.empty((N, 9), np.float32) if transfer else None
        sky = None
        finite_def = {} if tmax is None else {"FINITE_RAYS": 1}
        if sky_env is not None:       # bent normals asked too: the kernel runs even where nothing occludes
            finite_def["SKY_SAMPLED"], sky = 1, np.zeros((N, 3), np.float32)
        defines = self.query_defines(scene, "scene_ao", SAMPLES=S, BENT_NORMALS=int(bent_normals),
                                     TRANSFER=int(transfer), SURFACE_NORMALS=1, **finite_def) if N else None
        if N and defines is None:       # nothing occludes and only AO is asked: every sample is open
            ao[:] = 1.0
        elif N:
            k = _cl.kernel("visibility.cl", "scene_ao", defines)
            table = _cl.to_device(lane_table(direction_table(S, sampling.strategy, sampling.patterns,
                                                             sampling.seed)))
            pidx = pattern_indices(idx, sampling.patterns, sampling.seed)
            pb = points_bound(p)
            groups = anchor_groups(scene, p, pb)
            if len(groups) == 1 and groups[0][0] is None:      # every point at the scene's anchor
                self._ao_launch(scene, k, defines, table, groups[0][1], bias, p, n, pidx, own, tmax, sky_env,
                                (ao, bent, tr, sky), bent_normals, transfer, pb)
            else:       # points far apart: each group relative to an anchor of its own, uploaded together
                ao_grouped(self, scene, k, defines, table, groups, bias, p, n, pidx, own, tmax, sky_env,
                           (ao, bent, tr, sky), bent_normals, transfer, _extent)
        close_contacts(scene, p, n, ao, bent, tr, sky)
        return (sky, ao, bent) if sky_env is not None else (ao, bent, tr)


    def _ao_launch(self, scene, k, defines, table, anchor, bias, p, n, pidx, own, tmax, sky_env, outs, bent_normals,
                   transfer, pb):
        """The AO kernel over points ``p`` (``points_bound``: ``pb`` or None) relative to ``anchor``, in chunks, into
        ``outs`` (ao, bent, tr, sky)."""
        ao, bent, tr, sky = outs
        N, S = len(p), int(defines["SAMPLES"])
        _, args = self._scene_args(scene, anchor, bias, _extent(p, anchor, pb), defines)
        rel = np.empty(p.shape, np.float32)
        np.subtract(p, anchor, out=rel)     # anchor-relative in float64, rounded once
        q = _cl.queue()
        shape = launch.shape()
        chunk = max(1, shape.ao_chunk_samples // S)
        for s in range(0, N, chunk):
            e = min(N, s + chunk)
            ao_buf = _cl.empty(4 * (e - s))
            bent_buf = _cl.empty(12 * (e - s) if bent_normals else 4)
            tr_buf = _cl.empty(36 * (e - s) if transfer else 4)
            k(q, *launch.grid(-(-(e - s) // defines["AO_POINTS"]), shape.query_group, k), *args, np.int32(e - s),
              _cl.to_device(rel[s:e]), _cl.to_device(n[s:e]),
              _cl.to_device(pidx[s:e], np.int32), _cl.to_device(own[s:e]),
              *([] if tmax is None else [_cl.to_device(tmax[s:e], np.float32)]), table, ao_buf, bent_buf, tr_buf,
              *([] if sky_env is None else [*sky_env, sky_buf := _cl.empty(12 * (e - s))]))
            cl.enqueue_copy(q, ao[s:e], ao_buf)
            if sky_env is not None:
                cl.enqueue_copy(q, sky[s:e], sky_buf)
            if bent_normals:
                cl.enqueue_copy(q, bent[s:e], bent_buf)
            if transfer:
                cl.enqueue_copy(q, tr[s:e], tr_buf)


def _distance_ao(backend, scene, points, normals, sampling, bent, bias, indices, surface_ids, max_distance, tau,
                 Q, straddle):
    """Distance-limited (one node) or -weighted (Q nodes) AO of ``backend`` (a :class:`CSMVisibility`;
    :mod:`pyshadow.visibility.finite`).

    Per distinct node length: the points whose rays cannot end inside a
    caster's bounding sphere (:func:`finite.shell_clear`) run the AO
    kernel with ``FINITE_RAYS=1``; the others go ray by ray through the
    visibility kernel (``sample_directions``' directions) and the
    straddle rule of :func:`finite.answer_finite_ao`. Bent normals of
    weighted AO take the ray-by-ray path for every point and node.
    """
    p = rows3(points, "points")
    n = unit_normals(normals, len(p))
    N = len(p)
    idx = check_indices(indices, N)
    own = scene.caster_slots(surface_ids, N, p)
    tmax = check_max_distance(np.inf if max_distance is None else max_distance, N)
    sid = None if surface_ids is None else np.broadcast_to(np.asarray(surface_ids), (N,))
    nodes = ao_nodes(tmax, tau, Q)
    out_bent = np.zeros((N, 3), np.float32)
    S = int(sampling.samples)

    def by_rays(rows, cols):
        """AO (and bent normals) of points ``rows`` at node lengths ``cols`` (K, q), ray by ray."""
        res_ao, res_bent = np.empty(len(rows)), np.empty((len(rows), 3), np.float32)
        step = max(1, (1 << 20) // (S * cols.shape[1]))
        for s in range(0, len(rows), step):
            sel = rows[s:s + step]
            dirs = sampling.directions(n[sel], indices=idx[sel])
            P, W = np.repeat(p[sel], S, axis=0), dirs.reshape(-1, 3)
            own_r, m_r = np.repeat(own[sel], S), np.repeat(n[sel].astype(np.float32), S, axis=0)

            def answer(k, t, P=P, W=W, own_r=own_r, m_r=m_r, ground=True):
                return backend._visible(scene, P[k], W[k], own_r[k], m_r[k], bias, _float32_lengths(t), ground)

            weights = rays_ao(scene, p[sel], n[sel], dirs, cols[s:s + step], straddle, answer, sel,
                              lambda k, a=answer: a(k, np.full(len(k), np.inf), ground=False))
            res = ao_from_samples(dirs.astype(np.float64), weights, n[sel], True)
            res_ao[s:s + step], res_bent[s:s + step] = res
        return res_ao, res_bent

    if bent and nodes.shape[1] > 1:
        ao, out_bent = by_rays(np.arange(N), nodes)
        return ao.astype(np.float32), out_bent
    acc = np.zeros(N)
    last = held = None
    for j in range(nodes.shape[1]):
        t = nodes[:, j]
        if last is not None and np.array_equal(t, last):     # the same lengths: the same answers
            acc += held
            continue
        held, last = np.zeros(N), t
        clear = shell_clear(scene, p, t)
        c, r = np.flatnonzero(clear), np.flatnonzero(~clear)
        if len(c):
            a, b, _ = backend._ao(scene, p[c], n[c], sampling, bent, False, bias, idx[c],
                                  None if sid is None else sid[c], tmax=_float32_lengths(t[c]))
            held[c] = a
            out_bent[c] = b
        if len(r):
            held[r], out_bent[r] = by_rays(r, t[r, None])
        acc += held
    ao = (acc / nodes.shape[1]).astype(np.float32)
    return (ao, out_bent) if bent else ao


register("csm", CSMVisibility("nearest"))
register("csm-vote", CSMVisibility("vote"))
