"""The error model: how often a CSM will disagree with a ray tracer, predicted before it is built.

A CSM answers a ray by asking, in the map(s) its lookup picks, whether a
surface lies between the point and the light along the *centre ray of the
point's texel*, beyond the bias (:func:`pyshadow.csm.reference.shadow_taps`).
Every error it makes comes from that substitution: the map's axis instead of
the ray's direction (map spacing, the lookup), the texel's centre instead of
the point (resolution), the bias and the depth quantum (depth bits), the
surface rule's raised directions. A ray tracer can ask exactly the same
question of the mesh without rendering a single map: trace, from the texel
centre at the point's depth, the ray along the map's axis, starting past the
bias. This model does so for a sample of rays (by default the object's own
AO rays: area-uniform points, cosine-weighted directions about the face
normal) and counts where the lookup's vote differs from the ray's own
answer. The object's geometry enters through the rays it stops -- its
feature size, thin parts, silhouettes and openness are what make the
substituted ray differ -- so nothing is fitted to a mesh; the cost is one
Embree pass per tap, independent of map count and resolution.

Where the traced ray meets the mesh, the model keeps what the compression
stores there: a depth in the first solid layer the centre ray crosses (its
middle, as one map's interval would give), against which a point on that
layer's own surface is never behind. What it leaves out: how runs of maps
narrow that interval, the rasteriser's coverage rule at triangle edges
against Embree's, and the footprint option. How far its predictions
lie from measured CSMs on the shared meshes is measured by
``benchmarks/error_model.py`` and stated as :data:`MODEL_RATIO` (the range of
measured / predicted); the sampling uncertainty of each prediction is the
Wilson interval of its count, counted as the independent rays its rays per point are worth.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._validate import check_int, uniform_scale
from ..mesh import check_mesh, referenced_mesh
from ..views import ViewSet
from .build import check_depth_bits, check_float32_frame
from .core import DEPTH_Q, front_margin
from .reference import shadow_taps

__all__ = ["Layout", "Body", "MODEL_RATIO", "CANDIDATES", "LARGE_WORK", "traced_vote", "truth_visible", "model_visible",
           "ao_rays", "near_rays", "rays_for", "predict", "wilson"]

#: measured / predicted disagreement on the shared meshes (benchmarks/error_model.py: 0.78-1.11 over
#: 27 rows, 0.67-1.23 before open meshes' insides were drawn): the range a prediction is stated with; an
#: unverified choice aims at ``target / MODEL_RATIO[1]``
MODEL_RATIO = (0.65, 1.3)

#: build work (maps x texels) above which a candidate is a last resort: 64x128 maps @ 512^2
LARGE_WORK = 64 * 128 * 512 ** 2

#: the candidates a choice considers, by build work (maps x texels): (theta, phi, resolution); the
#: last, 128x256 @ 512^2 (twice :data:`LARGE_WORK`: 462 MB and 4.5 min for the cow), is tried only
#: once every smaller one has missed with every lookup (:func:`pyshadow.csm.choose.choose_csm`)
CANDIDATES = tuple(sorted(((t, 2 * t, r) for t in (16, 32, 64, 128) for r in (64, 128, 256, 512)
                           if t * r <= 128 * 512), key=lambda c: (c[0] * c[1] * c[2] ** 2, c[2])))


@dataclasses.dataclass(frozen=True)
class Layout:
    """What a CSM's lookup depends on, without its tables: views, resolution, depth bits, frame.

    Parameters
    ----------
    views : ViewSet
    resolution : int
        Texels per map side.
    depth_bits : {16, 32}
    centre : ndarray, shape (3,)
        The frame's centre, object units (the bounding sphere's by default).
    radius : float
        The frame's radius, object units.
    box : ndarray, shape (2, 3), optional
        The mesh's box in the normalised frame (:attr:`CoherentShadowMap.box`);
        None: the sphere alone cuts a ray's chord.
    """
    views: ViewSet
    resolution: int
    depth_bits: int
    centre: np.ndarray
    radius: float
    box: np.ndarray | None = None

    @classmethod
    def for_mesh(cls, mesh, maps=(64, 128), resolution: int = 128, depth_bits: int = 16) -> "Layout":
        """The layout :meth:`CoherentShadowMap.build` would give ``mesh`` (zigzag maps, bounding sphere)."""
        from ..mesh import bounding_sphere, normalised_bounds

        try:            # (a third entry was zigzag's row_offset: another grid than the one built)
            theta, phi = maps
        except (TypeError, ValueError):
            raise ValueError(f"maps must be a pair (theta, phi), got {maps!r}") from None
        check_mesh(mesh, "Layout.for_mesh")     # as build: a face past the vertices was numpy's IndexError
        c, r = bounding_sphere(mesh)
        c = np.asarray(c, np.float64)
        check_float32_frame(c, r)           # as build: no CSM of this mesh exists to predict
        return cls(ViewSet.zigzag(theta, phi), int(resolution), int(depth_bits), c, float(r),
                   normalised_bounds(mesh, c, float(r)))

    @property
    def label(self) -> str:
        p = self.views.params
        return f"{p.get('theta', '?')}x{p.get('phi', '?')} r{self.resolution} {self.depth_bits}b"


@dataclasses.dataclass
class Body:
    """A rigid body of a modelled scene: its mesh, object-to-world transform and layout (or None: receiver)."""
    mesh: object
    transform: np.ndarray
    layout: Layout | None

    @property
    def scale(self) -> float:
        return float(uniform_scale(self.transform[:3, :3]))

    def world_triangles(self, anchor) -> np.ndarray:
        T = self.transform
        v = np.asarray(self.mesh.vertices, np.float64) @ T[:3, :3].T + T[:3, 3] - anchor
        return v[np.asarray(self.mesh.faces)]

    def world_sphere(self):
        T = self.transform
        return T[:3, :3] @ self.layout.centre + T[:3, 3], self.layout.radius * self.scale


def traced_vote(tracer):
    """A ``vote`` for :func:`pyshadow.visibility.mirror.caster_occludes` that traces each tap.

    Parameters
    ----------
    tracer : pyshadow.embree.EmbreeScene
        The body's triangles in its layout's normalised frame.

    Returns
    -------
    callable
        ``vote(layout, pn, wn, maps, map_weights, **taps)``: the summed
        weights of the taps whose texel-centre ray, from the point's depth
        plus the bias towards the light along the map's axis, meets the mesh
        where the depth the compression keeps (:func:`_stored_depth`) lies
        before the point's, less the bias.
    """
    def vote(layout, pn, wn, maps, map_weights, **kw):
        R = layout.resolution
        out = np.zeros(len(pn))
        for k, _, col, row, depth, b, inside, weight in shadow_taps(layout.views, R, pn, wn, maps, map_weights, **kw):
            B = layout.views.bases[k]
            start = 1.0 - 2.0 * (depth - b)                      # along the axis: depth z is at 1 - 2z
            o = (B[:, 0] * ((2.0 * (col + 0.5) / R - 1.0))[:, None] + B[:, 1] * ((2.0 * (row + 0.5) / R - 1.0))[:, None]
                 + B[:, 2] * start[:, None])
            ask = np.flatnonzero(inside & (start < 1.0))
            hit = np.zeros(len(pn), bool)
            if len(ask):
                hit[ask] = tracer.occluded(o[ask], B[ask, 2])
            met = np.flatnonzero(hit)
            if len(met):        # the compression's depth: the middle of the first solid layer
                hit[met] = _stored_depth(tracer, o[met] + B[met, 2] * (1.0 - start[met])[:, None], B[met, 2],
                                         front_margin(R)) < depth[met] - (b[met] if np.ndim(b) else b)
            out += weight * hit
        return out
    return vote


def _stored_depth(tracer, front, axis, margin):
    """The depth a CSM keeps where the centre ray from ``front`` (depth 0) along ``-axis`` meets the mesh:
    the middle of its first solid layer ``[z1, z2)``, the layer's far end drawn in by the front margin
    (``margin``, normalised depth; the most z2's slope term takes) and at least ``z1``; ``z1`` where the ray
    meets one surface only (:func:`pyshadow.csm.reference.compress_reference`: one map's interval, the
    middle of its keys)."""
    t1 = tracer.intersect(front, -axis)[0]
    # a ray grazing an edge or a corner can meet it one way and miss it the other (float32): the caller's
    # ray from the point met the mesh, this one from the map's plane does not, so the texel keeps a miss
    # (depth inf), as the compression's ray through its centre would; nothing is traced on from inf
    met = np.flatnonzero(np.isfinite(t1))
    t2 = np.full_like(t1, np.inf)
    step = t1[met] + 1e-5
    t2[met] = step + tracer.intersect(front[met] - axis[met] * step[:, None], -axis[met])[0]
    z1 = 0.5 * t1
    z2 = np.maximum(0.5 * t2 - margin, z1)                  # inf - margin: inf
    return np.where(np.isfinite(z2), 0.5 * (z1 + z2), z1)


def _frame(bodies):
    """(casters, anchor, scale) of modelled bodies: the casters, their mean sphere centre, largest radius."""
    casters = [b for b in bodies if b.layout is not None]
    anchor = np.mean([b.world_sphere()[0] for b in casters], axis=0) if casters else np.zeros(3)
    return casters, anchor, max([b.world_sphere()[1] for b in casters] or [1.0])


def _ground(p, w, ground, scale):
    """The analytic ground plane's answer, by the kernels' rule (:func:`pyshadow.visibility.finite.ground_blocks`)."""
    from ..contact import plane_tolerance
    from ..visibility.finite import ground_blocks

    if ground is None:
        return np.zeros(len(p), bool)
    return ground_blocks(p[:, 1] - ground, w[:, 1], None, plane_tolerance(scale, ground))


def _rays(points, directions):
    p = np.asarray(points, np.float64).reshape(-1, 3)
    w = np.asarray(directions, np.float64).reshape(-1, 3)
    return p, w / np.linalg.norm(w, axis=1, keepdims=True)


def truth_visible(bodies, points, directions, *, ground: float | None = None) -> np.ndarray:
    """Embree's answers for world rays among the casters of ``bodies`` (as :func:`pyshadow.embree.visible`).

    Returns
    -------
    ndarray of bool, shape (N,)
        True where the ray reaches the sky.
    """
    from .._embree_lift import off_own_surface, sphere_size
    from ..anchor_reach import caster_buckets
    from ..embree import EmbreeScene, ray_epsilon
    from ..mesh import float32_unit
    from ..scene_arrays import ANCHOR_REACH_RADII, cube_groups

    p, w = _rays(points, directions)
    casters, anchor, scale = _frame(bodies)
    occ = _ground(p, w, ground, scale)
    if not casters:
        return ~occ
    centres, radii = (np.array(x) for x in zip(*(b.world_sphere() for b in casters)))
    # each ray lifted by its own body's size (pyshadow.embree's rule, _embree_lift.body_size): by the
    # largest, a small body's rays stepped over it
    size = np.full(len(p), scale) if radii.min() == radii.max() else sphere_size(p, centres, radii)
    # traced at unit size, scaled by a power of two (1 near it: exact): ray_epsilon is at least float32's
    # smallest normal number, which lifted the rays off a body below 1e-38 units past every surface
    unit = float32_unit(scale)
    # points beyond their reach from the anchor (pyshadow.anchor_reach: near a caster tiny beside their distance
    # from it, bodies far apart) relative to anchors of their own, as pyshadow.embree's
    for rows, a in cube_groups(p, anchor, ANCHOR_REACH_RADII * radii.min(),
                               None, lambda: caster_buckets(centres, radii)):
        rows = np.arange(len(p)) if rows is None else rows
        todo = rows[~occ[rows]]
        rel = (p[todo] - a) * unit
        lift = size[todo] * unit
        eps = np.maximum(2e-5 * lift, ray_epsilon(np.maximum(np.abs(rel).max(axis=1), lift)))
        world = EmbreeScene(np.concatenate([b.world_triangles(a) * unit for b in casters]))
        # a ray grazing the surface its point lies on traced again off that surface, as embree.visible's
        hit = world.occluded(rel + eps[:, None] * w[todo], w[todo])
        occ[todo] = off_own_surface(world, rel, w[todo], eps, None, hit)
    return ~occ


def model_visible(bodies, points, directions, normals=None, owner=None, *, lookup: str = "nearest",
                  ground: float | None = None) -> np.ndarray:
    """The answers the bodies' CSMs would give, without building them (traced taps).

    Parameters
    ----------
    bodies : sequence of Body
        Casters (``layout`` set) and receivers (``layout`` None) in world space.
    points, directions : ndarray, shape (N, 3), float64
        World ray origins and directions.
    normals : ndarray, shape (N, 3), optional
        Unit surface normals at the points (the surface rule; AO rays have them).
    owner : ndarray of int, shape (N,), optional
        Index into ``bodies`` of the body each point lies on (-1 unknown).
    lookup : {'nearest', 'vote'}
    ground : float, optional
        Height of the ground plane y = ground (analytic, exact in both).

    Returns
    -------
    ndarray of bool, shape (N,)
        True where the modelled lookup lets the ray reach the sky.
    """
    from ..embree import EmbreeScene
    from ..visibility.mirror import caster_occludes

    if lookup not in ("nearest", "vote"):
        raise ValueError(f"lookup must be 'nearest' or 'vote', got {lookup!r}")
    p, w = _rays(points, directions)
    casters, _, scale = _frame(bodies)
    owner = np.full(len(p), -1) if owner is None else np.broadcast_to(np.asarray(owner), (len(p),))
    occ = _ground(p, w, ground, scale)
    bits = 16 if all(b.layout.depth_bits == 16 for b in casters) else 32
    quantum = (1.0 / DEPTH_Q if bits == 16 else 0.0) + 1e-7
    m = None if normals is None else np.asarray(normals, np.float64).reshape(-1, 3)
    for i, b in enumerate(bodies):
        if b.layout is None:
            continue
        L = b.layout
        tracer = EmbreeScene((np.asarray(b.mesh.vertices, np.float64)[np.asarray(b.mesh.faces)] - L.centre) / L.radius)
        s = b.scale
        occ |= caster_occludes(L, b.world_sphere(), b.transform[:3, :3] / s, s, b.transform[:3, 3], p, w, m,
                               (owner == -1) | (owner == i), ~occ, lookup=lookup, bias=None, quantum=quantum,
                               vote=traced_vote(tracer))
    return ~occ


#: the last mesh's :func:`_open_backs` (its hash: the faces)
_BACKS: dict = {}


def _open_backs(mesh):
    """The faces of an open mesh whose back side a ray from outside reaches (the build's ``two_sided='auto'``
    faces, :func:`pyshadow.csm.exposure.exposed_back_faces` in the bounding sphere's frame), or None: a
    watertight mesh (its backs lie inside the solid) or none found."""
    from ..mesh import bounding_sphere, mesh_hash
    from .exposure import exposed_back_faces

    if mesh.is_watertight or not len(mesh.faces):
        return None
    key = mesh_hash(mesh)
    if key not in _BACKS:           # the model's rays and the check's are drawn on the same mesh: traced once
        _BACKS.clear()
        _BACKS[key] = exposed_back_faces(mesh, bounding_sphere(mesh))
    backs = _BACKS[key]
    return backs.copy() if backs.any() else None


def ao_rays(mesh, points: int = 2000, samples: int = 16, seed: int = 7, *, backs: bool = False):
    """A body's own AO rays: ``points`` area-uniform surface points, ``samples`` cosine-weighted directions each.

    The surface is every face's front; with ``backs`` (as :func:`rays_for`
    draws them), on an open mesh also the back of each face a ray from
    outside reaches (:func:`_open_backs`: the inside of a shell, a box
    without a lid), the points there with the reversed normal: AO is asked
    there too, and the CSM keeps a margin for those faces.
    ``points`` and ``seed`` are ints, ``points >= 1``; the mesh must have some area (ValueError).

    Returns
    -------
    p, d, n : ndarray, shape (points * samples, 3), float64
        Origins (object frame), unit directions, unit face normals.
    """
    import trimesh

    from ..mesh import float32_unit
    from ..sampling import Sampling, sample_directions

    check_mesh(mesh, "ao_rays")      # a NaN vertex read 'no surface area', a face past the vertices IndexError
    mesh = referenced_mesh(mesh)     # the same faces: a far vertex no face used fell outside the backs' frame
    check_int(points, "points", 1)
    check_int(seed, "seed", 0)
    # drawn at unit size, scaled by a power of two (1 near it: exact): the face areas that weigh the draw
    # underflow (tiny meshes) or overflow (huge ones) in the mesh's own units
    verts = np.asarray(mesh.vertices, np.float64)
    unit = float32_unit(np.ptp(verts, axis=0).max()) if len(verts) else 1.0
    fit = mesh if unit == 1.0 else trimesh.Trimesh(verts * unit, np.asarray(mesh.faces), process=False)
    if not fit.area > 0:
        raise ValueError(f"ao_rays: the mesh has no surface area (its {len(mesh.faces)} faces are all degenerate): "
                         "there are no AO rays to draw on it")
    backs = _open_backs(mesh) if backs else None
    if backs is not None:       # the surface a ray from outside reaches: the backs the build keeps a margin for too
        faces = np.asarray(mesh.faces)
        fit = trimesh.Trimesh(fit.vertices, np.concatenate([faces, faces[backs][:, ::-1]]), process=False)
    local, face = trimesh.sample.sample_surface(fit, points, seed=seed)
    local = local / unit
    nrm = np.asarray(fit.face_normals, np.float64)[face]
    zero = np.flatnonzero(~np.abs(nrm).any(axis=1))
    if len(zero):           # trimesh zeroes the normals of small faces (a mesh in micrometres): scale-free here
        tri = np.asarray(fit.vertices, np.float64)[np.asarray(fit.faces)[face[zero]]]
        e = tri[:, 1:] - tri[:, :1]
        e /= np.maximum(np.abs(e).max(axis=(1, 2)), np.finfo(np.float64).tiny)[:, None, None]
        c = np.cross(e[:, 0], e[:, 1])
        nrm[zero] = c / np.linalg.norm(c, axis=1, keepdims=True)
    d = sample_directions(nrm, sampling=Sampling(samples, seed=seed)).reshape(-1, 3).astype(np.float64)
    return np.repeat(local, samples, axis=0), d, np.repeat(nrm, samples, axis=0)


def near_rays(mesh, count: int = 16000, seed: int = 7):
    """Rays of other bodies near a body: the shadows it casts.

    Origins uniform in volume in the shell between one and two bounding
    radii around the body's bounding sphere (outside it, so never inside
    the body); directions uniform over the sphere of directions, drawn
    only from the cone of those that meet the bounding sphere (the others
    can be answered wrongly by no CSM), each ray weighted by that cone's
    share of the sphere.

    Returns
    -------
    p, d : ndarray, shape (count, 3), float64
        Origins (object frame) and unit directions.
    w : ndarray, shape (count,), float64
        The weights: ``(1 - cos a) / 2`` of the cone's half-angle ``a``.
    """
    from ..mesh import bounding_sphere

    check_mesh(mesh, "near_rays")
    check_int(count, "count", 0)
    c, r = bounding_sphere(mesh)
    rng = np.random.default_rng(seed)
    u = rng.normal(size=(count, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    dist = r * np.cbrt(1.0 + 7.0 * rng.random(count))            # uniform in volume, r .. 2r
    cos_max = np.sqrt(1.0 - (r / dist) ** 2)                    # the cone that meets the sphere
    ct = 1.0 - rng.random(count) * (1.0 - cos_max)
    st = np.sqrt(np.maximum(0.0, 1.0 - ct * ct))
    ph = 2.0 * np.pi * rng.random(count)
    a = -u                                                       # the cone's axis: towards the centre
    t1 = np.cross(a, np.where(np.abs(a[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]]))
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = np.cross(a, t1)
    d = a * ct[:, None] + t1 * (st * np.cos(ph))[:, None] + t2 * (st * np.sin(ph))[:, None]
    return np.asarray(c, np.float64) + u * dist[:, None], d, 0.5 * (1.0 - cos_max)


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """The Wilson score interval of a proportion ``k / n`` (95 % by default)."""
    if n == 0:
        return 0.0, 1.0
    ph = k / n
    den = 1 + z * z / n
    mid = (ph + z * z / (2 * n)) / den
    half = z * math.sqrt(ph * (1 - ph) / n + z * z / (4 * n * n)) / den
    return max(0.0, mid - half), min(1.0, mid + half)


def rays_for(mesh, *, points: int = 2000, samples: int = 16, near: int = 16000, seed: int = 7) -> dict:
    """The rays a body's CSM is judged on, with Embree's answers: ``{"own": ..., "near": ...}``.

    ``own``: its AO rays (:func:`ao_rays`, ``points * samples``, the backs
    of an open mesh's faces that a ray from outside reaches included); ``near``:
    :func:`near_rays` (``near``; none when 0). Each a dict ``p, d, n``
    (normals or None), ``truth`` (bool), ``w`` (weights, or None), in the
    object's frame, no ground; ``own`` also ``group`` (its rays per point: ``samples``).
    """
    check_mesh(mesh, "rays_for")     # a face index of -1 (numpy wraps it) was drawn on, and judged
    check_int(near, "near", 0)
    body = [Body(mesh, np.eye(4), Layout.for_mesh(mesh))]
    p, d, nrm = ao_rays(mesh, points, samples, seed, backs=True)
    out = {"own": {"p": p, "d": d, "n": nrm, "truth": truth_visible(body, p, d), "w": None, "group": samples}}
    if near:
        q, e, w = near_rays(mesh, near, seed)
        out["near"] = {"p": q, "d": e, "n": None, "truth": truth_visible(body, q, e), "w": w}
    return out


def _effective_rays(flip, group) -> float:
    """How many independent rays ``flip`` (bool, (N,)) is worth when it comes in runs of ``group`` rays from one
    point: N over the design effect, from the spread of the points' shares (a point's rays agree or not
    together: AO rays about one normal), within [N / group, N]; N where ``group`` is 1 or does not divide N."""
    n = len(flip)
    if group <= 1 or n % group or n // group < 2:
        return float(n)
    share = flip.reshape(-1, group).mean(axis=1)
    p, var = float(share.mean()), float(share.var(ddof=1)) / len(share)
    if not 0.0 < p < 1.0 or var <= 0.0:
        return float(n)
    return min(float(n), max(n / group, p * (1.0 - p) / var))


def _count(truth, answer, weights=None, group: int = 1) -> dict:
    """Disagreement of ``answer`` with ``truth``: the share (or weighted mean) and its 95 % interval, the
    Wilson interval of the rays' worth as independent ones (``group``: rays per point, :func:`_effective_rays`)."""
    flip = truth != answer
    n = len(flip)
    if weights is None:
        k = int(np.count_nonzero(flip))
        m = _effective_rays(flip, group)
        return {"disagreement": k / max(n, 1), "interval": wilson(k * m / max(n, 1), m), "rays": n}
    x = np.asarray(weights, np.float64) * flip
    e = float(x.mean()) if n else 0.0
    half = 1.96 * float(x.std()) / math.sqrt(max(n, 1))
    return {"disagreement": e, "interval": (max(0.0, e - half), e + half), "rays": n}


def predict(mesh, maps=(64, 128), resolution: int = 128, depth_bits: int = 16, lookup: str = "nearest", *,
            rays: dict | None = None, **draw) -> dict:
    """Predicted disagreement with Embree of the CSM ``build`` would give ``mesh``.

    Parameters
    ----------
    mesh : trimesh.Trimesh
    maps : (theta, phi)
        Zigzag view set.
    resolution : int
    depth_bits : {16, 32}
    lookup : {'nearest', 'vote'}
        The lookup the CSM will be queried with.
    rays : dict, optional
        :func:`rays_for` of ``mesh``, to share between predictions;
        otherwise drawn with the keyword arguments ``draw``.

    Returns
    -------
    dict
        Per ray set (``own``: the body's AO rays; ``near``: rays of
        bodies around it, :func:`near_rays`), ``disagreement`` (fraction),
        ``interval``
        (Wilson 95 %, of the rays' worth as independent ones), ``rays``; and at the top ``disagreement`` (the larger
        of the two), ``range`` (times :data:`MODEL_RATIO`: where the
        measured value is expected), ``layout`` (label), ``lookup``,
        ``seconds`` (the model's own cost, without drawing the rays).
    """
    import time

    from ..raster import MAX_RESOLUTION

    check_mesh(mesh, "predict")
    check_depth_bits(depth_bits)
    check_int(resolution, "resolution", 1, MAX_RESOLUTION)
    if lookup not in ("nearest", "vote"):
        raise ValueError(f"lookup must be 'nearest' or 'vote', got {lookup!r}")
    L = Layout.for_mesh(mesh, maps, resolution, depth_bits)
    body = [Body(mesh, np.eye(4), L)]
    rays = rays_for(mesh, **draw) if rays is None else rays
    t0 = time.perf_counter()
    out = {"layout": L.label, "maps": [int(maps[0]), int(maps[1])], "resolution": int(resolution),
           "depth_bits": int(depth_bits), "lookup": lookup}
    for name, r in rays.items():
        owner = np.zeros(len(r["p"]), np.int64) if r["n"] is not None else np.full(len(r["p"]), -2)
        out[name] = _count(r["truth"], model_visible(body, r["p"], r["d"], r["n"], owner, lookup=lookup), r["w"],
                           r.get("group", 1))
    e = max(out[name]["disagreement"] for name in rays)
    out.update(disagreement=e, range=[e * MODEL_RATIO[0], e * MODEL_RATIO[1]], seconds=time.perf_counter() - t0)
    return out
