"""Numerical stability at the extremes: the geometry rows, measured against Embree.

Imported by ``benchmarks/extremes.py`` (:data:`ROWS`); runs on its own too.
Every row builds its CSMs, asks pyshadow (``"csm"``) and Embree identical
(point, direction) pairs and reports a figure, its bound and pass/fail.
Groups: ``size`` (mesh vertices at 1e-3, 1, 1e4: agreement and the rendered
AO image against size 1), ``position`` (mesh vertices, and the bundled
scene by its transforms, 1e5 and 1e7 from the origin, camera too; the pair
beside a copy of itself 1e7 and 1e12 away),
``thin-plate`` (3 mm on 1 m; grazing rays are extremes.py's), ``small-large``
(4 cm beside 4 m), ``contact`` (touching, resting, interpenetrating),
``ground-contact`` (on the ground, 1e-6 above), ``on-surface`` (points on
faces, edges, vertices), ``invariants`` (AO in [0, 1], closed box, open
plane, rigid motion, determinism); the broken meshes are
``extremes_meshes.py``'s.

Bounds: a disagreement with Embree on AO rays is held to 0.5 %, the CSM's on
the bunny (99.52 % agreement at 64x128 maps of 128^2, benchmarks/README.md);
size and position to 0.1 points of agreement and 0.005 mean absolute AO of
the rendered image (the issue's bounds); a special case with an ordinary
counterpart on the same construction (a mesh defect against the clean box,
an edge or vertex against a face) to the counterpart's figure plus 0.1
point. Rows marked "(documented)" report a behaviour outside the CSM's
contract and baselines are informational (bound None).

    python benchmarks/extremes_geometry.py [--rows size,mesh,...] [--maps 64x128] [--resolution 128] [--json]
"""
from __future__ import annotations

import sys

import numpy as np
import trimesh

import pyshadow
from pyshadow import embree

#: disagreement with Embree on AO rays: the CSM's on the bunny (0.5 %, benchmarks/README.md)
DISAGREE_BOUND = 0.005
AGREEMENT_POINTS = 0.1          # size and position invariance: points of agreement (issue's bound)
AO_MEAN_ABS = 0.005             # ... and mean absolute AO of a rendered image
SAMPLES = 16                    # AO rays per point
#: a special case against its ordinary counterpart on the same construction
#: (a defect against the clean mesh, an edge against a face): 0.1 point,
#: about three binomial standard deviations of a 0.5 % rate on the 32,000 to
#: 64,000 rays of a row
SAME_POINTS = 0.001


def _row(name, figure, bound, ok, **extra):
    """One row; ``bound`` and ``ok`` None for an informational row (a baseline, or documented behaviour)."""
    return {"row": name, "figure": figure, "bound": bound, "pass": None if ok is None else bool(ok), **extra}


# --- shared helpers ---
def _build(mesh, views, resolution):
    return pyshadow.CoherentShadowMap.build(mesh, views, resolution=resolution, progress=False)


def scene_of(parts, views, resolution, ground=0.0):
    """A scene of ``[(mesh, transform)]`` casters (one CSM per distinct mesh object)."""
    scene = pyshadow.Scene(ground=ground)
    built = {}
    for mesh, T in parts:
        if id(mesh) not in built:
            built[id(mesh)] = _build(mesh, views, resolution)
        scene.add(built[id(mesh)], np.eye(4) if T is None else T, mesh=mesh)
    return scene


def surface_samples(mesh, T, n, seed):
    """``n`` points uniformly on ``mesh``'s faces under transform ``T`` (None: identity), face normals."""
    local, face = trimesh.sample.sample_surface(mesh, n, seed=seed)
    T = np.eye(4) if T is None else T
    R = T[:3, :3] / np.cbrt(np.linalg.det(T[:3, :3]))
    return local @ T[:3, :3].T + T[:3, 3], mesh.face_normals[face] @ R.T


def ground_grid(centre, half, n, level=0.0, seed=0):
    """``n`` random points on the ground ``y = level`` in a square of half side ``half``, normals up."""
    rng = np.random.default_rng(seed)
    p = np.column_stack([centre[0] + rng.uniform(-half, half, n), np.full(n, float(level)),
                         centre[2] + rng.uniform(-half, half, n)])
    return p, np.tile([0.0, 1.0, 0.0], (n, 1))


def ao_rays(points, normals, samples=SAMPLES, seed=0):
    """The AO rays the kernel traces from each point: (N*S, 3) origins and directions (float64)."""
    d = pyshadow.sample_directions(np.asarray(normals, np.float64), sampling=pyshadow.Sampling(samples, seed=seed))
    return np.repeat(np.asarray(points, np.float64), samples, axis=0), d.reshape(-1, 3).astype(np.float64)


def agreement(scene, points, normals, surface_ids, samples=SAMPLES, backend="csm", seed=0):
    """pyshadow vs Embree on the identical AO rays of ``points``.

    Returns a dict: ``disagree`` (fraction of rays), ``false_shadow``
    (pyshadow occluded, Embree open), ``false_light``, ``rays``, and the
    per-ray answers ``vis`` and ``truth``.
    """
    P, D = ao_rays(points, normals, samples, seed)
    sid = np.repeat(np.broadcast_to(np.asarray(surface_ids), (len(points),)), samples).astype(np.int32)
    # with the points' normals, as the AO kernel asks them (the surface rule)
    N = np.repeat(np.asarray(normals, np.float64), samples, axis=0)
    vis = scene.visible(P, D, surface_ids=sid, backend=None if backend == "csm" else backend, normals=N)
    truth = embree.visible(scene, P, D)
    return {"disagree": float(np.mean(vis != truth)), "false_shadow": float(np.mean(truth & ~vis)),
            "false_light": float(np.mean(vis & ~truth)), "rays": int(len(P)), "vis": vis, "truth": truth}


def _agree_row(name, a, bound=DISAGREE_BOUND, **extra):
    return _row(name, a["disagree"], bound, a["disagree"] <= bound, unit="fraction of AO rays disagreeing with Embree",
                false_shadow=a["false_shadow"], false_light=a["false_light"], rays=a["rays"], **extra)


def _box_at(size, centre):
    return trimesh.creation.box(size, trimesh.transformations.translation_matrix(centre))


# --- object size and position: the meshes themselves, and render-level AO ---
def _pair_parts(scale, offset):
    """A box and a leaning torus on the ground y = offset[1], mesh vertices scaled then shifted."""
    box = _box_at((0.8, 0.8, 0.8), (0.0, 0.4, 0.0))
    tor = trimesh.creation.torus(major_radius=0.55, minor_radius=0.22, major_sections=48, minor_sections=16)
    tor.apply_transform(trimesh.transformations.rotation_matrix(np.radians(55), [1, 0, 0.2]))
    tor.apply_translation([1.05, -tor.bounds[0, 1], 0.3])
    return [trimesh.Trimesh(np.asarray(m.vertices) * scale + offset, m.faces, process=False) for m in (box, tor)]


def _pair_views(scale, offset):
    """The surface points, the ground points and a camera for :func:`_pair_parts`."""
    eye = np.array([2.2, 1.9, 3.6]) * scale + offset
    target = np.array([0.5, 0.3, 0.0]) * scale + offset
    return pyshadow.Camera(eye, target, fov_y=45.0, width=96, height=72)


def _render_pair(parts, camera, ground, views, resolution):
    scene = scene_of([(m, None) for m in parts], views, resolution, ground=ground)
    return scene, scene.render(camera, sampling=_sampling(SAMPLES))


def _sampling(samples, seed=0):
    return pyshadow.Sampling(samples, seed=seed)


def _pair_agreement(scene, scale, offset, n=1500, seed=5, instances=None):
    """Agreement on points of the first ``instances`` (default all) bodies' meshes, untransformed, and the ground."""
    parts = [inst.mesh for inst in scene.instances[:instances]]
    P, N, S = [], [], []
    for i, m in enumerate(parts):
        p, nn = surface_samples(m, None, n, seed + i)
        P.append(p), N.append(nn), S.append(np.full(n, i))
    g, gn = ground_grid(np.array([0.5, 0, 0]) * scale + offset, 1.5 * scale, n, level=offset[1], seed=seed)
    P.append(g), N.append(gn), S.append(np.full(n, -2))
    return agreement(scene, np.concatenate(P), np.concatenate(N), np.concatenate(S))


def _image_rows(label, frame, ref, scale_note):
    same = np.array_equal(frame.object_id, ref.object_id)
    both = (frame.object_id != -1) & (ref.object_id != -1)
    mad = float(np.abs(frame.ao[both] - ref.ao[both]).mean())
    cover = float(np.mean(frame.object_id != ref.object_id))
    return _row(f"{label}: rendered AO", mad, AO_MEAN_ABS, mad <= AO_MEAN_ABS and cover <= 0.01,
                unit=f"mean absolute AO difference of the rendered image from {scale_note}",
                same_pixels=same, pixels_differing_object=cover)


def size_rows(views, resolution) -> list[dict]:
    """Mesh vertices at size 1e-3, 1 and 1e4: agreement with Embree and the rendered AO image."""
    res = {}
    for s in (1.0, 1e-3, 1e4):
        off = np.zeros(3)
        parts = _pair_parts(s, off)
        scene, frame = _render_pair(parts, _pair_views(s, off), 0.0, views, resolution)
        res[s] = (_pair_agreement(scene, s, off), frame)
    ref_a, ref_f = res[1.0]
    rows = [_row("size 1: agreement (the baseline of the size rows)", ref_a["disagree"], None, None,
                 unit="fraction of AO rays disagreeing with Embree")]
    for s in (1e-3, 1e4):
        a, f = res[s]
        d = 100.0 * abs(a["disagree"] - ref_a["disagree"])
        rows.append(_row(f"size {s:g}: agreement", d, AGREEMENT_POINTS, d <= AGREEMENT_POINTS,
                         unit="points of agreement from size 1", disagree=a["disagree"],
                         identical_answers=float(np.mean(a["vis"] == ref_a["vis"]))))
        rows.append(_image_rows(f"size {s:g}", f, ref_f, "size 1"))
    return rows


def position_rows(views, resolution) -> list[dict]:
    """Mesh vertices 1e5 and 1e7 from the origin, the bundled scene moved there (render level), and the pair
    beside a copy of itself 1e7 and 1e12 away (the anchor halfway)."""
    from pyshadow.data import default_scene

    rows = []
    res = {}
    for off in (0.0, 1e5, 1e7):
        shift = np.array([off, 0.5 * off, -off])
        parts = _pair_parts(1.0, shift)
        scene, frame = _render_pair(parts, _pair_views(1.0, shift), shift[1], views, resolution)
        res[off] = (_pair_agreement(scene, 1.0, shift), frame)
    ref_a, ref_f = res[0.0]
    for off in (1e5, 1e7):
        a, f = res[off]
        d = 100.0 * abs(a["disagree"] - ref_a["disagree"])
        rows.append(_row(f"mesh vertices at {off:g}: agreement", d, AGREEMENT_POINTS, d <= AGREEMENT_POINTS,
                         unit="points of agreement from the origin", disagree=a["disagree"]))
        rows.append(_image_rows(f"mesh vertices at {off:g}", f, ref_f, "the origin"))
    # the bundled scene placed far away by its transforms, camera too
    base, camera = default_scene(views=views, resolution=resolution, width=96, height=72)
    ref = base.render(camera, sampling=_sampling(SAMPLES))
    for off in (1e5, 1e7):
        shift = np.array([off, 0.5 * off, -off])
        moved = pyshadow.Scene(ground=base.ground + shift[1])
        for inst in base.instances:
            T = inst.transform.copy()
            T[:3, 3] += shift
            if inst.casts:
                moved.add(inst.csm, T, mesh=inst.mesh)
            else:
                moved.add(inst.mesh, T, casts=False)
        cam = pyshadow.Camera(camera.eye + shift, camera.target + shift, fov_y=camera.fov_y,
                              width=camera.width, height=camera.height)
        rows.append(_image_rows(f"bundled scene at {off:g}", moved.render(cam, sampling=_sampling(SAMPLES)),
                                ref, "the origin"))
    # a copy of the pair far away: the scene's anchor lies halfway, the points near the first pair
    parts = _pair_parts(1.0, np.zeros(3))
    cam = _pair_views(1.0, np.zeros(3))
    alone = scene_of([(m, None) for m in parts], views, resolution)
    ref_a = _pair_agreement(alone, 1.0, np.zeros(3))
    for far in (1e7, 1e12):
        T = np.eye(4)
        T[0, 3] = far
        spread = scene_of([(m, None) for m in parts] + [(m, T) for m in parts], views, resolution)
        a = _pair_agreement(spread, 1.0, np.zeros(3), instances=len(parts))
        d = 100.0 * abs(a["disagree"] - ref_a["disagree"])
        rows.append(_row(f"a copy of the scene {far:g} away: agreement", d, AGREEMENT_POINTS, d <= AGREEMENT_POINTS,
                         unit="points of agreement from the scene alone", disagree=a["disagree"]))
        try:        # documented behaviour: the drawn ground spans both copies, the near plane would cut the first
            spread.render(cam, sampling=_sampling(SAMPLES))
            rows.append(_row(f"a copy of the scene {far:g} away: render", 0.0, None, None, unit="rendered"))
        except ValueError as exc:
            rows.append(_row(f"a copy of the scene {far:g} away: render", float("nan"), None, None, unit="refused",
                             error=str(exc)))
    return rows


# --- thin, small, touching, on the ground ---
def thin_plate_rows(views, resolution, n=3000, seed=11) -> list[dict]:
    """A 1 m x 3 mm x 1 m plate raised 0.3 m over the ground: points on it and on the ground under it."""
    plate = _box_at((1.0, 0.003, 1.0), (0.0, 0.3, 0.0))
    scene = scene_of([(plate, None)], views, resolution, ground=0.0)
    p, nn = surface_samples(plate, None, n, seed)
    top = nn[:, 1] > 0.5
    bottom = nn[:, 1] < -0.5
    side = ~top & ~bottom
    rows = []
    a_all = agreement(scene, p, nn, 0)
    per_point = (a_all["vis"] != a_all["truth"]).reshape(len(p), SAMPLES)
    for name, sel in (("top face", top), ("bottom face", bottom), ("3 mm sides", side)):
        if sel.any():
            d = float(per_point[sel].mean())
            rows.append(_row(f"thin plate: {name}", d, DISAGREE_BOUND, d <= DISAGREE_BOUND,
                             unit="fraction of AO rays disagreeing with Embree", points=int(sel.sum())))
    g, gn = ground_grid(np.zeros(3), 0.8, n, seed=seed)
    rows.append(_agree_row("thin plate: ground under and around it", agreement(scene, g, gn, -2)))
    # just above the top face and just below the bottom one (1e-4 of the part)
    q = np.column_stack([np.random.default_rng(seed).uniform(-0.45, 0.45, (n, 2))])
    for name, y, ny in (("1e-4 above the top", 0.3015 + 1e-4, 1.0), ("1e-4 below the bottom", 0.2985 - 1e-4, -1.0)):
        pts = np.column_stack([q[:, 0], np.full(n, y), q[:, 1]])
        nrm = np.tile([0.0, ny, 0.0], (n, 1))
        rows.append(_agree_row(f"thin plate: points {name}", agreement(scene, pts, nrm, -1)))
    return rows


def small_large_rows(views, resolution, n=3000, seed=12) -> list[dict]:
    """A 4 cm cube on the ground 5 cm beside a 4 m one."""
    big = _box_at((4.0, 4.0, 4.0), (0.0, 2.0, 0.0))
    small = _box_at((0.04, 0.04, 0.04), (2.07, 0.02, 0.0))
    scene = scene_of([(big, None), (small, None)], views, resolution, ground=0.0)
    rows = []
    p, nn = surface_samples(small, None, n, seed)
    rows.append(_agree_row("4 cm beside 4 m: on the small part", agreement(scene, p, nn, 1)))
    p, nn = surface_samples(big, None, n, seed)
    near = np.abs(p[:, 0] - 2.0) < 1e-9
    rows.append(_agree_row("4 cm beside 4 m: big part's face toward it",
                           agreement(scene, p[near], nn[near], 0)))
    g, gn = ground_grid(np.array([2.07, 0.0, 0.0]), 0.06, n, seed=seed)
    keep = ~((np.abs(g[:, 0] - 2.07) < 0.02) & (np.abs(g[:, 2]) < 0.02)) & (g[:, 0] > 2.0)
    rows.append(_agree_row("4 cm beside 4 m: ground around the small part",
                           agreement(scene, g[keep], gn[keep], -2)))
    return rows


#: (size, centre) of the two boxes of each contact case
CONTACT_CASES = {"touching side by side": (((1, 1, 1), (0, 0.5, 0)), ((1, 1, 1), (1.0, 0.5, 0.3))),
                 "resting on top": (((1, 1, 1), (0, 0.5, 0)), ((0.6, 0.6, 0.6), (0.1, 1.3, 0.1))),
                 "interpenetrating": (((1, 1, 1), (0, 0.5, 0)), ((0.8, 0.8, 0.8), (0.7, 0.6, 0.2)))}


def contact_points(a, b, n, seed):
    """Points on both boxes (surface ids 0, 1), and which of them lie strictly inside the other box."""
    pn = [surface_samples(m, None, n, seed + i) for i, m in enumerate((a, b))]
    P, N = np.concatenate([x[0] for x in pn]), np.concatenate([x[1] for x in pn])
    S = np.repeat([0, 1], n)
    inside = np.zeros(len(P), bool)
    for i, other in enumerate((b, a)):
        lo, hi = other.bounds
        inside |= (S == i) & np.all((P > lo + 1e-9) & (P < hi - 1e-9), axis=1)
    return P, N, S, inside


def contact_rows(views, resolution, n=3000, seed=13) -> list[dict]:
    """Two boxes touching side by side, one resting on the other, and interpenetrating."""
    rows = []
    for label, boxes in CONTACT_CASES.items():
        a, b = (_box_at(*x) for x in boxes)
        scene = scene_of([(a, None), (b, None)], views, resolution, ground=0.0)
        P, N, S, inside = contact_points(a, b, n, seed)
        res = agreement(scene, P, N, S)
        per_point = (res["vis"] != res["truth"]).reshape(len(P), SAMPLES)
        d_out = float(per_point[~inside].mean())
        rows.append(_row(f"{label}: surfaces outside the other", d_out, DISAGREE_BOUND, d_out <= DISAGREE_BOUND,
                         unit="fraction of AO rays disagreeing with Embree", points=int((~inside).sum())))
        if inside.any():
            # documented behaviour: a surface inside another solid is not a point the CSM answers for
            # (it lies inside the interval [z1, z2) of which the CSM stores any depth); Embree: occluded
            vis_in = res["vis"].reshape(len(P), SAMPLES)[inside]
            truth_in = res["truth"].reshape(len(P), SAMPLES)[inside]
            lit = float(vis_in.mean())
            rows.append(_row(f"{label}: surface inside the other (documented)", lit, None, None,
                             unit="fraction of AO rays reported open (Embree: %.4f)" % float(truth_in.mean()),
                             points=int(inside.sum())))
    return rows


def ground_contact_rows(views, resolution, n=3000, seed=14) -> list[dict]:
    """A unit box lying on the ground plane, and one 1e-6 above it."""
    rows = []
    for label, gap in (("on the ground", 0.0), ("1e-6 above the ground", 1e-6)):
        box = _box_at((1, 1, 1), (0, 0.5 + gap, 0))
        scene = scene_of([(box, None)], views, resolution, ground=0.0)
        p, nn = surface_samples(box, None, n, seed)
        down = nn[:, 1] < -0.5
        rows.append(_agree_row(f"box {label}: its faces", agreement(scene, p[~down], nn[~down], 0)))
        g, gn = ground_grid(np.zeros(3), 0.6, n, seed=seed)
        out = np.abs(g[:, [0, 2]]).max(axis=1) > 0.5
        rows.append(_agree_row(f"box {label}: ground around it", agreement(scene, g[out], gn[out], -2)))
        # the ground under it and the box's bottom face: closed in (AO 0)
        ao_under = scene.ambient_occlusion(g[~out], gn[~out], sampling=_sampling(SAMPLES), surface_ids=-2)
        ao_bottom = scene.ambient_occlusion(p[down], nn[down], sampling=_sampling(SAMPLES), surface_ids=0)
        worst = float(max(ao_under.max(), ao_bottom.max()))
        rows.append(_row(f"box {label}: ground under it and bottom face, AO", worst, 0.0, worst == 0.0,
                         unit="largest AO (a closed contact has AO 0)"))
    return rows


# --- points exactly on faces, edges and vertices ---
def edge_points(mesh, n, seed):
    """Points on ``n`` random unique edges (uniform along them), normals the mean of the adjacent faces'."""
    rng = np.random.default_rng(seed)
    ea = mesh.face_adjacency_edges
    fa = mesh.face_adjacency
    k = rng.integers(0, len(ea), n)
    t = rng.uniform(0.0, 1.0, n)[:, None]
    v = np.asarray(mesh.vertices)
    p = v[ea[k, 0]] * (1 - t) + v[ea[k, 1]] * t
    nn = mesh.face_normals[fa[k, 0]] + mesh.face_normals[fa[k, 1]]
    good = np.linalg.norm(nn, axis=1) > 1e-6
    return p[good], nn[good] / np.linalg.norm(nn[good], axis=1, keepdims=True)


def on_surface_rows(views, resolution, n=3000, seed=15) -> list[dict]:
    """Points exactly on faces, edges and vertices of a box and of the bunny on the ground."""
    rows = []
    bunny = pyshadow.data.bunny()
    Tb = pyshadow.mesh.stand_on_ground(bunny, radius=1.0)
    bunny_w = bunny.copy()
    bunny_w.apply_transform(Tb)
    box = _box_at((1, 1, 1), (2.2, 0.5, 0.0))
    scene = scene_of([(bunny_w, None), (box, None)], views, resolution, ground=0.0)
    for i, (name, m) in enumerate((("bunny", bunny_w), ("box", box))):
        p, nn = surface_samples(m, None, n, seed)
        faces = agreement(scene, p, nn, i)
        rows.append(_row(f"{name}: points on faces (the baseline of its edges and vertices)", faces["disagree"],
                         None, None, unit="fraction of AO rays disagreeing with Embree"))
        # a point exactly on an edge or a vertex may be no worse than one inside a face
        bound = faces["disagree"] + SAME_POINTS
        p, nn = edge_points(m, n, seed)
        rows.append(_agree_row(f"{name}: points on edges", agreement(scene, p, nn, i), bound=bound))
        v = np.asarray(m.vertices)
        vn = np.asarray(m.vertex_normals)
        sel = np.random.default_rng(seed).choice(len(v), min(n, len(v)), replace=False)
        rows.append(_agree_row(f"{name}: points on vertices", agreement(scene, v[sel], vn[sel], i), bound=bound))
    return rows


# --- invariants ---
def invariant_rows(views, resolution, n=2000, seed=17) -> list[dict]:
    """AO range, closed box, open plane, rigid motion of the whole scene, determinism."""
    rows = []
    bunny = pyshadow.data.bunny()
    bunny.apply_transform(pyshadow.mesh.stand_on_ground(bunny, radius=1.0))
    box = _box_at((1, 1, 1), (2.2, 0.5, 0.0))
    floating = _box_at((0.6, 0.6, 0.6), (-2.0, 1.0, 0.0))
    quad = trimesh.Trimesh([[-1.0, 0.0, 3.0], [1.0, 0.0, 3.0], [1.0, 0.0, 5.0], [-1.0, 0.0, 5.0]],
                           [[0, 2, 1], [0, 3, 2]], process=False)
    quad.apply_translation([0.0, 0.5, 0.0])       # an open plane caster, 0.5 over the ground
    parts = [(bunny, None), (box, None), (floating, None), (quad, None)]
    scene = scene_of(parts, views, resolution, ground=0.0)
    S = _sampling(64, seed=3)
    # AO in [0, 1] over surface points of every part and the ground, both lookups
    P, N, I = [], [], []
    for i, (m, _) in enumerate(parts):
        p, nn = surface_samples(m, None, n, seed + i)
        P.append(p), N.append(nn), I.append(np.full(n, i))
    g, gn = ground_grid(np.zeros(3), 3.0, n, seed=seed)
    P, N, I = np.concatenate(P + [g]), np.concatenate(N + [gn]), np.concatenate(I + [np.full(n, -2)])
    lo, hi, finite = 1.0, 0.0, True
    for lookup in ("nearest", "vote"):
        ao = scene.ambient_occlusion(P, N, sampling=S, surface_ids=I, lookup=lookup)
        lo, hi = min(lo, float(ao.min())), max(hi, float(ao.max()))
        finite = finite and bool(np.isfinite(ao).all())
    out = max(0.0 - lo, hi - 1.0, 0.0)
    rows.append(_row("AO in [0, 1]", out, 0.0, out == 0.0 and finite, unit="largest excursion outside [0, 1]",
                     ao_min=lo, ao_max=hi))
    # closed box: the ground under the box on the ground, and points inside the floating box
    rng = np.random.default_rng(seed)
    under = np.column_stack([rng.uniform(1.75, 2.65, n), np.zeros(n), rng.uniform(-0.45, 0.45, n)])
    inside = rng.uniform(-0.28, 0.28, (n, 3)) + [-2.0, 1.0, 0.0]
    dirs = rng.normal(size=(n, 3))
    for lookup in ("nearest", "vote"):
        a1 = scene.ambient_occlusion(under, np.tile([0, 1.0, 0], (n, 1)), sampling=S, surface_ids=-2, lookup=lookup)
        rows.append(_row(f"closed box on the ground, {lookup}: AO of the ground under it", float(a1.max()), 0.0,
                         float(a1.max()) == 0.0, unit="largest AO", mean=float(a1.mean()),
                         points_above_0=float(np.mean(a1 > 0))))
        a2 = scene.ambient_occlusion(inside, dirs, sampling=S, surface_ids=-1, lookup=lookup)
        # documented: a point strictly inside a solid lies inside the interval [z1, z2) the CSM may store
        # any depth of (the middle of the run's interval): it is not a point the CSM answers for
        rows.append(_row(f"closed box, {lookup}: mean AO of points inside it (documented)", float(a2.mean()),
                         None, None, unit="mean AO (undefined inside a solid; Embree: 0)",
                         max=float(a2.max())))
    # open plane: the ground far from everything, and the top of the quad caster
    far = np.column_stack([rng.uniform(200, 300, n), np.zeros(n), rng.uniform(200, 300, n)])
    on_quad = np.column_stack([rng.uniform(-0.95, 0.95, n), np.full(n, 0.5), rng.uniform(3.05, 4.95, n)])
    up = np.tile([0, 1.0, 0], (n, 1))
    a_far = scene.ambient_occlusion(far, up, sampling=S, surface_ids=-2)
    rows.append(_row("open plane (ground, nothing above): AO", 1.0 - float(a_far.min()), 0.0,
                     float(a_far.min()) == 1.0, unit="1 - smallest AO"))
    for lookup in ("nearest", "vote"):
        a_q = scene.ambient_occlusion(on_quad, up, sampling=S, surface_ids=3, lookup=lookup)
        rows.append(_row(f"open plane (top of a caster quad), {lookup}: AO", 1.0 - float(a_q.mean()), DISAGREE_BOUND,
                         1.0 - float(a_q.mean()) <= DISAGREE_BOUND, unit="1 - mean AO (grazing rays: extremes.py)",
                         points_below_1=float(np.mean(a_q < 1.0)), ao_min=float(a_q.min())))
    # rigid motion of the whole scene: rotation about the vertical, translation (ground moves with it)
    R = trimesh.transformations.rotation_matrix(0.7, [0, 1, 0])
    R[:3, 3] = [31.0, 2.5, -17.0]
    moved = pyshadow.Scene(ground=2.5)
    for inst in scene.instances:
        moved.add(inst.csm, R @ inst.transform, mesh=inst.mesh)
    Pm = P @ R[:3, :3].T + R[:3, 3]
    Nm = N @ R[:3, :3].T
    Pr, Dr = ao_rays(P, N, 16)
    Prm, Drm = Pr @ R[:3, :3].T + R[:3, 3], Dr @ R[:3, :3].T
    sid = np.repeat(I, 16).astype(np.int32)
    v0 = scene.visible(Pr, Dr, surface_ids=sid)
    v1 = moved.visible(Prm, Drm, surface_ids=sid)
    d = float(np.mean(v0 != v1))
    rows.append(_row("rigid motion: visibility of the identical moved rays", d, 1e-3, d <= 1e-3,
                     unit="fraction of rays whose answer changes"))
    a0 = scene.ambient_occlusion(P, N, sampling=S, surface_ids=I)
    a1 = moved.ambient_occlusion(Pm, Nm, sampling=S, surface_ids=I)
    mad = float(np.abs(a0 - a1).mean())
    rows.append(_row("rigid motion: AO (sample frame turns with the normal)", mad, 0.02, mad <= 0.02,
                     unit="mean absolute AO difference (64 samples)"))
    # determinism: the same seed twice, a rebuilt CSM
    b = scene.ambient_occlusion(P, N, sampling=S, surface_ids=I)
    other = scene.ambient_occlusion(P, N, sampling=_sampling(64, seed=4), surface_ids=I)
    again = _build(box, views, resolution)
    same_csm = all(np.array_equal(getattr(again, k), getattr(scene.instances[1].csm, k))
                   for k in ("offsets", "iend", "depth"))
    diff = float(np.abs(a0 - b).max())
    rows.append(_row("deterministic: same seed, rebuilt CSM", diff, 0.0, diff == 0.0 and same_csm,
                     unit="largest AO difference between two runs", csm_identical=same_csm,
                     other_seed_differs=float(np.abs(a0 - other).mean())))
    return rows


_GROUPS = (("size", size_rows), ("position", position_rows), ("thin-plate", thin_plate_rows),
           ("small-large", small_large_rows), ("contact", contact_rows), ("ground-contact", ground_contact_rows),
           ("on-surface", on_surface_rows), ("invariants", invariant_rows))
#: row group -> callable(args) -> list of rows (args: ``.views``, ``.resolution``)
ROWS = {name: (lambda f: lambda a: f(a.views, a.resolution))(f) for name, f in _GROUPS}


def main(argv=None) -> int:
    import extremes

    return extremes.main(argv, groups=ROWS, benchmark="extremes_geometry")


if __name__ == "__main__":
    sys.exit(main())
