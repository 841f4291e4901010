"""Numerical stability at the extremes: the parameter and direction rows, against Embree.

The rows of issue "Numerical stability at the extremes" that vary a parameter
(sample count, map count, resolution, depth bits, instance count, what a
scene holds) or ask a direction the map grid treats specially. Every row asks
pyshadow and Embree the identical rays; ``benchmarks/extremes.py`` imports
:data:`ROWS` (same row dicts: ``row``, ``figure``, ``bound``, ``pass``,
``unit`` and extras).

Row groups and what each row is held to:

- ``directions``: a direction exactly at each pole of the map frame (+y, -y;
  also reached through a turned instance), exactly on the phi seam (z = +0,
  -0 and -1e-9, the last just below 2 pi), exactly between two maps (in phi,
  in theta) and between four; both lookups. Rays along it from points of the
  bunny's surface facing it (beyond 10 deg of grazing) and from a disk behind
  the bunny (its shadow). Figure: the fraction that disagrees with Embree;
  bound: the worst of 8 generic directions on the same construction (a
  special direction may be no worse than an ordinary one); beside it,
  informational (``near_ordinary``), 4 ordinary directions 1.5 map steps
  around the special one, which see the body as it does. One more row per
  lookup: the kernel against its float64 NumPy mirror over all the special
  directions (bound 2e-3; the mirror is asked at the direction moved by 0
  and +-2e-4 rad in theta and phi, as float32 angles may stand for any of
  them at ties and on grid lines; at a pole, towards every map of its row).
- ``samples``: AO with 1 and 4096 samples on the bundled scene's covered
  pixels against Embree AO on the identical directions. Figure: mean
  absolute AO difference; bound 0.005, the CSM's visibility disagreement on
  the AO rays of this scene (benchmarks/README.md): the mean AO difference
  of a pixel is at most the fraction of its rays that disagree. AO must lie
  in [0, 1] (with one sample, in {0, 1}).
- ``maps``: zigzag 2x4 .. 256x512 on the fandisk at 32^2 (i_end beyond 16
  bits from 256x512: the uint32 i_end and wide pairs must be taken).
  Figure: the kernel's disagreement with its float64 mirror on AO rays
  (bound 1e-3: float32 rounding only); the Embree disagreement (the
  discretisation, falling with the map count), build time, CSM bytes and the
  build's peak working set are reported beside it.
- ``resolution``: 8^2 .. 1024^2 (zigzag 16x32, fandisk), and 16- and 32-bit
  depth at the given maps and resolution; figures and bounds as ``maps``.
- ``instances``: 1 and 10,000 instances of one CSM (a tilted 512-face torus, on a grid 4
  radii apart), rays leaving the tops of the bodies steeper than 45 deg (only
  their own body can stop them). Figure: disagreement with Embree on the
  one-body scene (the truth for identical relative rays; ``embree_self_hits``
  reports how often Embree asked in the 10,000-body scene, 280 from its
  anchor, differs from it: 0.9 % before its surface epsilon followed the
  coordinates' size, not the bodies' radius); bound: the
  one-instance scene's disagreement plus 1e-3. Time per query reported; plus the kernel against the
  mirror on random rays through the 10,000 (bound 0).
- ``scenes``: receivers only (no caster: visible must be exactly "not below
  or into the ground"; AO exactly the ground's share), and no ground (the
  bunny alone: on rays the ground would not decide, the answers must equal
  those of the same scene with a ground plane; bound 0).

    python benchmarks/extremes_params.py [--rows directions,samples,...] [--maps 64x128]
        [--resolution 128] [--json]
"""
from __future__ import annotations

import sys
import time

import numpy as np
import trimesh



#: the CSM's visibility disagreement with Embree on the AO rays of the bundled
#: scene (0.5 %, benchmarks/README.md): what a mean AO difference is held to
AO_DISAGREEMENT = 0.005
#: the kernel against its float64 mirror: only float32 rounding may differ
MIRROR_BOUND = 1e-3
#: the same over a direction's rays, where the mirror is asked at nudged directions
DIRECTION_MIRROR_BOUND = 2e-3
GENERIC_DIRECTIONS = 8
NEAR_ORDINARY = 4
GRAZING_COS = np.cos(np.radians(80.0))     # surface points at least 10 deg off grazing


def _row(name, figure, bound, ok, **extra):
    """One row; ``bound`` and ``ok`` None for an informational row."""
    return {"row": name, "figure": figure, "bound": bound, "pass": None if ok is None else bool(ok), **extra}


# ---------------------------------------------------------------------------
# shared pieces
# ---------------------------------------------------------------------------
_CACHE: dict = {}


def _unit_transform(mesh, rotation=None, offset=(0.0, 0.0, 0.0)):
    """Transform that puts ``mesh``'s bounding sphere at ``offset`` with radius 1."""
    import pyshadow

    c, r = pyshadow.bounding_sphere(mesh)
    T = np.eye(4)
    if rotation is not None:
        T[:3, :3] = rotation
    T[:3, :3] /= r
    T[:3, 3] = np.asarray(offset, float) - T[:3, :3] @ c
    return T


def _mesh(name):
    import pyshadow

    if name not in _CACHE:
        if name == "torus":       # 512 faces: 10,000 copies stay a small Embree scene
            _CACHE[name] = pyshadow.load_mesh(trimesh.creation.torus(major_radius=0.55, minor_radius=0.22,
                                                                     major_sections=32, minor_sections=8))
        else:
            _CACHE[name] = pyshadow.data.bunny() if name == "bunny" else pyshadow.data.mesh(name)
    return _CACHE[name]


def _csm(name, views, resolution, depth_bits=16):
    """A CSM of a test mesh, built once per (mesh, views, resolution, bits) in this process."""
    import pyshadow

    key = (name, id(views), resolution, depth_bits)
    if key not in _CACHE:
        t0 = time.perf_counter()
        csm = pyshadow.CoherentShadowMap.build(_mesh(name), views, resolution=resolution, progress=False,
                                               depth_bits=depth_bits)
        _CACHE[key] = (csm, time.perf_counter() - t0)
    return _CACHE[key]


def _surface(mesh, T, n, seed):
    """n points sampled on ``mesh`` and their face normals, in the world frame of ``T``."""
    p, face = trimesh.sample.sample_surface(mesh, n, seed=seed)
    R = T[:3, :3] / np.cbrt(np.linalg.det(T[:3, :3]))
    return p @ T[:3, :3].T + T[:3, 3], np.asarray(mesh.face_normals)[face] @ R.T


def _ao_rays(scene, inst, n_points, samples, seed):
    """AO rays (points repeated, directions, surface ids) from surface points of instance ``inst``."""
    import pyshadow

    p, nrm = _surface(scene.instances[inst].mesh, scene.instances[inst].transform, n_points, seed)
    d = pyshadow.sample_directions(nrm, sampling=pyshadow.Sampling(samples, seed=seed))
    return np.repeat(p, samples, axis=0), d.reshape(-1, 3).astype(np.float64), np.full(len(p) * samples, inst)


def _mirror_mismatch(scene, P, D, ids, vis, backend):
    """Fraction of rays where the kernel's answer differs from the float64 mirror's."""
    from pyshadow import visibility

    ref = visibility.visible(scene, P, D, backend="numpy" if backend == "csm" else "numpy-vote",
                             surface_ids=ids)
    return float(np.mean(ref != vis))


# ---------------------------------------------------------------------------
# directions
# ---------------------------------------------------------------------------
def _perpendicular_pair(d):
    """Two unit vectors perpendicular to unit ``d`` and to each other."""
    a = np.cross(d, [0.3, 0.5, 0.7])
    a /= np.linalg.norm(a)
    return a, np.cross(d, a)


def _direction_rays(scene, d, n_disk, rng, surface):
    """Rays along world direction ``d``: bunny surface points facing it, and a disk behind it."""
    p, nrm = surface
    keep = nrm @ d > GRAZING_COS
    a, b = _perpendicular_pair(d)
    r = 1.1 * np.sqrt(rng.uniform(0.0, 1.0, n_disk))
    ang = rng.uniform(0.0, 2.0 * np.pi, n_disk)
    c = scene.instances[0].world_sphere()[0]
    disk = c - 1.05 * d + (r * np.cos(ang))[:, None] * a + (r * np.sin(ang))[:, None] * b
    P = np.vstack([p[keep], disk])
    ids = np.r_[np.zeros(keep.sum(), np.int64), np.full(n_disk, -1)]
    return P, np.repeat(d[None], len(P), axis=0), ids


def special_directions(views):
    """{name: (unit direction in the map frame, turned instance?)} of the direction rows."""
    from pyshadow.views import polar_direction

    T, P = views.params["theta"], views.params["phi"]
    dth, dph = np.pi / T, 2.0 * np.pi / P
    # row i lies at theta (i + row_offset) dth
    i, j = max(1, T // 6) + views.params.get("row_offset", 0.0), max(1, P // 16)
    th = 1.0
    return {
        "pole +y": (np.array([0.0, 1.0, 0.0]), False),
        "pole -y": (np.array([0.0, -1.0, 0.0]), False),
        "pole +y, turned instance": (np.array([0.0, 1.0, 0.0]), True),
        "pole -y, turned instance": (np.array([0.0, -1.0, 0.0]), True),
        "seam z=+0": (np.array([np.sin(th), np.cos(th), 0.0]), False),
        "seam z=-0": (np.array([np.sin(th), np.cos(th), -0.0]), False),
        "seam z=-1e-9": (polar_direction(th, 2.0 * np.pi - 1e-9), False),
        "between 2 maps (phi)": (polar_direction(i * dth, (j + 0.5) * dph), False),
        "between 2 maps (theta)": (polar_direction((i + 0.5) * dth, j * dph), False),
        "between 4 maps": (polar_direction((i + 0.5) * dth, (j + 0.5) * dph), False),
    }


#: the turned instance: a generic rotation (float64 rounding puts the map-frame
#: direction next to, not exactly on, the pole: the seam of the pole row)
TURN = trimesh.transformations.rotation_matrix(0.7, [0.3, 0.9, -0.4])[:3, :3]


def _direction_scene(views, resolution, turned):
    import pyshadow

    key = ("dir-scene", id(views), resolution, turned)
    if key not in _CACHE:
        mesh = _mesh("bunny")
        csm, _ = _csm("bunny", views, resolution)
        scene = pyshadow.Scene()                     # no ground: only the bunny decides
        T = _unit_transform(mesh, TURN if turned else None)
        scene.add(csm, T, mesh=mesh)
        _CACHE[key] = (scene, _surface(mesh, T, 20000, seed=2))
    return _CACHE[key]


def _tied_directions(views, d_obj, R, step=2e-4):
    """World directions the kernel's float32 angles may stand for: ``d_obj`` moved by 0, +-``step`` rad
    in theta and phi (acos_v / atan2_pos_v err by up to 5e-5 rad: they decide ties and the windows of
    directions on grid lines), or at a pole 1e-6 towards each map of the pole's row (phi is free)."""
    from pyshadow.views import polar_direction

    if np.hypot(d_obj[0], d_obj[2]) < 1e-9:
        T, P = views.params["theta"], views.params["phi"]
        row = views.directions[(0 if d_obj[1] > 0 else T - 1) * P:][:P]
        return [R @ ((d_obj + 1e-6 * (m - d_obj)) / np.linalg.norm(d_obj + 1e-6 * (m - d_obj))) for m in row]
    th, ph = np.arccos(np.clip(d_obj[1], -1, 1)), np.arctan2(d_obj[2], d_obj[0])
    return [R @ polar_direction(th + x, ph + y) for x in (0, -step, step) for y in (0, -step, step)]


def _near_ordinary(scene, surface, d, views, n_disk, seed):
    """Informational beside a special direction's bound: the disagreement of NEAR_ORDINARY ordinary
    directions 1.5 map steps (pi / theta) around world direction ``d`` (the same view of the body:
    random directions also vary with what the body looks like from them), per lookup."""
    from pyshadow import embree, visibility

    rng = np.random.default_rng(seed + 1)            # apart from the rows' own rays
    a, b = _perpendicular_pair(d)
    ang = 1.5 * np.pi / views.params["theta"]
    out = {"csm": [], "csm-vote": []}
    for t in rng.uniform(0.0, 2.0 * np.pi, NEAR_ORDINARY):
        g = np.cos(ang) * d + np.sin(ang) * (np.cos(t) * a + np.sin(t) * b)
        P, D, ids = _direction_rays(scene, g, n_disk, rng, surface)
        truth = embree.visible(scene, P, D)
        for be in out:
            out[be].append(float(np.mean(visibility.visible(scene, P, D, backend=be, surface_ids=ids) != truth)))
    return out


def direction_rows(views, resolution, n_disk: int = 10000, seed: int = 5) -> list[dict]:
    from pyshadow import embree, visibility

    rng = np.random.default_rng(seed)
    backends = ("csm", "csm-vote")
    # the bound: the worst of GENERIC_DIRECTIONS ordinary directions, same construction
    scene, surface = _direction_scene(views, resolution, False)
    generic = {b: [] for b in backends}
    for g in rng.normal(size=(GENERIC_DIRECTIONS, 3)):
        P, D, ids = _direction_rays(scene, g / np.linalg.norm(g), n_disk, rng, surface)
        truth = embree.visible(scene, P, D)
        for b in backends:
            generic[b].append(float(np.mean(visibility.visible(scene, P, D, backend=b, surface_ids=ids) != truth)))
    rows, mirror = [], {b: [] for b in backends}
    for name, (d_obj, turned) in special_directions(views).items():
        scene, surface = _direction_scene(views, resolution, turned)
        R = TURN if turned else np.eye(3)
        d = R @ d_obj
        if not turned:
            d = d_obj                                  # exactly as written (keeps -0.0)
        P, D, ids = _direction_rays(scene, d, n_disk, rng, surface)
        truth = embree.visible(scene, P, D)
        near = _near_ordinary(scene, surface, d, views, n_disk, seed)
        for b in backends:
            vis = visibility.visible(scene, P, D, backend=b, surface_ids=ids)
            wrong = float(np.mean(vis != truth))
            bound = max(generic[b])
            # the mirror, at any direction float32 may stand for (ties, grid lines)
            mb = "numpy" if b == "csm" else "numpy-vote"
            refs = [visibility.visible(scene, P, np.repeat(t[None], len(P), 0), backend=mb, surface_ids=ids)
                    for t in _tied_directions(views, d_obj, R)]
            mm = float(np.mean(~np.any([r == vis for r in refs], axis=0)))
            mirror[b].append((mm, name))
            rows.append(_row(f"dir {name}, {b}", wrong, bound, wrong <= bound,
                             unit="fraction of rays disagreeing with Embree (bound: worst generic direction)",
                             rays=len(P), mirror_mismatch=mm, generic=generic[b], near_ordinary=near[b]))
    for b in backends:
        worst, where = max(mirror[b])
        rows.append(_row(f"dir all special, {b} vs float64 mirror", worst, DIRECTION_MIRROR_BOUND,
                         worst <= DIRECTION_MIRROR_BOUND,
                         unit="fraction of rays where the kernel and its mirror differ", worst_direction=where))
    return rows


# ---------------------------------------------------------------------------
# samples
# ---------------------------------------------------------------------------
def _default_scene(views, resolution):
    from pyshadow.data import default_scene
    from pyshadow.render import surface_points

    key = ("default", id(views), resolution)
    if key not in _CACHE:
        scene, camera = default_scene(views=views, resolution=resolution, width=160, height=120)
        _CACHE[key] = (scene, surface_points(scene, camera))
    return _CACHE[key]


def sample_rows(views, resolution, pixels_4096: int = 600) -> list[dict]:
    import pyshadow
    from pyshadow import embree

    scene, sp = _default_scene(views, resolution)
    rows = []
    for S in (1, 4096):
        sel = np.arange(len(sp.points))
        if S > 64:
            sel = np.linspace(0, len(sel) - 1, min(len(sel), pixels_4096)).astype(np.int64)
        p, n, idx, ids = sp.points[sel], sp.normals[sel], sp.index[sel], sp.surface_ids[sel]
        sampling = pyshadow.Sampling(S)
        t0 = time.perf_counter()
        ao = scene.ambient_occlusion(p, n, sampling=sampling, indices=idx, surface_ids=ids)
        t_csm = time.perf_counter() - t0
        ref = embree.ambient_occlusion(scene, p, n, sampling=sampling, indices=idx)
        mad = float(np.abs(ao.astype(np.float64) - ref).mean())
        in_range = bool(((ao >= 0) & (ao <= 1)).all())
        if S == 1:
            in_range &= bool(np.isin(ao, (0.0, 1.0)).all())
        rows.append(_row(f"samples {S}: AO vs Embree AO", mad, AO_DISAGREEMENT, mad <= AO_DISAGREEMENT and in_range,
                         unit="mean absolute AO difference, identical directions", points=len(p),
                         ao_in_range=in_range, seconds=t_csm, mean_ao=float(ao.mean())))
    return rows


# ---------------------------------------------------------------------------
# map counts, resolutions, depth bits
# ---------------------------------------------------------------------------
def _param_row(name, views, resolution, depth_bits=16, mesh="fandisk.obj", points=1500, samples=16):
    """Build, then ask AO rays of the mesh's surface: mirror mismatch (figure) and Embree disagreement."""
    import pyshadow
    from pyshadow import embree

    m = _mesh(mesh)
    csm, seconds = _csm(mesh, views, resolution, depth_bits)
    scene = pyshadow.Scene()
    scene.add(csm, _unit_transform(m), mesh=m)
    P, D, ids = _ao_rays(scene, 0, points, samples, seed=7)
    truth = embree.visible(scene, P, D)
    vis = scene.visible(P, D, surface_ids=ids)
    t0 = time.perf_counter()
    scene.visible(P, D, surface_ids=ids)
    t_query = time.perf_counter() - t0
    k = min(len(P), 6000)
    mm = _mirror_mismatch(scene, P[:k], D[:k], ids[:k], vis[:k], "csm")
    s = csm.stats
    wide_needed = csm.maps > 65536
    wide_ok = (csm.iend.dtype == np.uint32 and csm.pair_wide) if wide_needed else csm.iend.dtype == np.uint16
    ok = mm <= MIRROR_BOUND and wide_ok
    return _row(name, mm, MIRROR_BOUND, ok, unit="fraction of AO rays where the kernel and its mirror differ",
                embree=float(np.mean(vis != truth)), build_seconds=seconds, csm_bytes=s["bytes"],
                peak_bytes=s["peak_bytes"], segments=s["segments"], iend=str(csm.iend.dtype),
                pair_wide=bool(csm.pair_wide), wide_ok=bool(wide_ok), ns_per_query=1e9 * t_query / len(P))


MAP_GRIDS = ((2, 4), (4, 8), (16, 32), (64, 128), (128, 256), (256, 512))
RESOLUTIONS = (8, 32, 128, 512, 1024)


def map_rows(resolution: int = 32, grids=MAP_GRIDS) -> list[dict]:
    import pyshadow

    return [_param_row(f"maps {t}x{p} ({t * p}) at {resolution}^2", pyshadow.ViewSet.zigzag(t, p), resolution)
            for t, p in grids]


def resolution_rows(views, resolution, small=(16, 32), sizes=RESOLUTIONS) -> list[dict]:
    import pyshadow

    v = pyshadow.ViewSet.zigzag(*small)
    rows = [_param_row(f"resolution {R}^2 ({small[0]}x{small[1]} maps)", v, R) for R in sizes]
    for bits in (16, 32):
        rows.append(_param_row(f"depth {bits}-bit ({len(views)} maps, {resolution}^2)", views, resolution, bits))
    return rows


# ---------------------------------------------------------------------------
# instances
# ---------------------------------------------------------------------------
def _instance_scene(csm, mesh, n, T0, spacing=4.0):
    import pyshadow

    scene = pyshadow.Scene(ground=None)
    g = int(np.ceil(np.sqrt(n)))
    for i in range(n):
        T = T0.copy()
        T[:3, 3] += [(i % g) * spacing, 0.0, (i // g) * spacing]
        scene.add(csm, T, mesh=mesh)
    return scene


def instance_rows(views, resolution, counts=(1, 10000), points=2000, samples=8, mirror_rays=200) -> list[dict]:
    """Rays leaving the top of one body steeper than 45 deg: only that body can stop them."""
    import pyshadow
    from pyshadow import embree

    mesh = _mesh("torus")
    csm, _ = _csm("torus", views, resolution)
    rng = np.random.default_rng(11)
    T0 = _unit_transform(mesh, trimesh.transformations.rotation_matrix(0.5, [1, 0, 0])[:3, :3])
    p, nrm = _surface(mesh, T0, 4 * points, seed=3)
    keep = np.flatnonzero(nrm[:, 1] > 0.5)[:points]            # upward faces
    p, nrm = p[keep], nrm[keep]
    d = pyshadow.sample_directions(nrm, sampling=pyshadow.Sampling(samples)).reshape(-1, 3).astype(np.float64)
    P = np.repeat(p, samples, axis=0)
    steep = d[:, 1] > np.sqrt(0.5)
    P, D = P[steep], d[steep]
    rows, base, ref = [], None, None
    for n in counts:
        t0 = time.perf_counter()
        scene = _instance_scene(csm, mesh, n, T0)
        t_add = time.perf_counter() - t0
        which = int(rng.integers(n))
        shift = scene.instances[which].transform[:3, 3] - T0[:3, 3]
        Pw = P + shift
        ids = np.full(len(Pw), which)
        vis = scene.visible(Pw, D, surface_ids=ids)                  # warm-up (atlas, kernel)
        t0 = time.perf_counter()
        vis = scene.visible(Pw, D, surface_ids=ids)
        t_q = time.perf_counter() - t0
        embree_here = embree.visible(scene, Pw, D)
        if ref is None:
            # the truth: only the ray's own body can stop it, so Embree on the one-body scene
            # (small coordinates) answers every scene's identical relative rays
            ref, base, single = embree_here, float(np.mean(vis != embree_here)), vis
        wrong = float(np.mean(vis != ref))
        # random rays through the whole grid: the kernel against its mirror
        ext = np.ptp([inst.world_sphere()[0] for inst in scene.instances], axis=0) + 2.0
        Q = scene.anchor() + rng.uniform(-0.5, 0.5, (mirror_rays, 3)) * ext
        W = rng.normal(size=(mirror_rays, 3))
        mm = _mirror_mismatch(scene, Q, W, None, scene.visible(Q, W), "csm")
        bound = base + MIRROR_BOUND
        rows.append(_row(f"instances {n}", wrong, bound, wrong <= bound and mm == 0.0,
                         unit="fraction of rays disagreeing with Embree on the one-body scene (bound: 1 instance + 1e-3)",
                         rays=len(Pw), us_per_query=1e6 * t_q / len(Pw), add_seconds=t_add,
                         mirror_mismatch=mm, same_as_one=float(np.mean(vis != single)),
                         embree_in_scene=float(np.mean(vis != embree_here)),
                         embree_self_hits=float(np.mean(embree_here != ref)),
                         anchor_distance=float(np.linalg.norm(scene.anchor() - scene.instances[which].transform[:3, 3]))))
    return rows


# ---------------------------------------------------------------------------
# scenes: receivers only, no ground
# ---------------------------------------------------------------------------
def scene_rows(views, resolution, n: int = 20000) -> list[dict]:
    import pyshadow
    from pyshadow import embree, visibility

    rng = np.random.default_rng(13)
    rows = []
    # receivers only: nothing casts, so only the ground decides
    scene = pyshadow.Scene(ground=0.0)
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), casts=False)
    scene.add(_mesh("bunny"), _unit_transform(_mesh("bunny"), offset=(2.0, 1.0, 0.0)), casts=False)
    P = rng.uniform(-3.0, 3.0, (n, 3))
    D = rng.normal(size=(n, 3))
    expect = ~embree.ground_occludes(scene, P, D)
    truth = embree.visible(scene, P, D)
    nrm = rng.normal(size=(n // 10, 3))
    for b in ("csm", "csm-vote"):
        vis = visibility.visible(scene, P, D, backend=b)
        wrong = float(np.mean(vis != expect))
        rows.append(_row(f"receivers only, {b}: visible", wrong, 0.0, wrong == 0.0 and np.array_equal(truth, expect),
                         unit="fraction of rays not exactly 'above the ground'"))
        samp = pyshadow.Sampling(16)
        ao = visibility.ambient_occlusion(scene, P[:len(nrm)], nrm, backend=b, sampling=samp)
        ref = embree.ambient_occlusion(scene, P[:len(nrm)], nrm, sampling=samp)
        worst = float(np.abs(ao - ref).max())
        rows.append(_row(f"receivers only, {b}: AO", worst, 0.0, worst == 0.0,
                         unit="largest AO difference from Embree (the ground alone)"))
    # no ground: the bunny alone, against the same bunny over a ground plane
    mesh = _mesh("bunny")
    csm, _ = _csm("bunny", views, resolution)
    T = _unit_transform(mesh)
    bare, grounded = pyshadow.Scene(), pyshadow.Scene(ground=float((mesh.vertices @ T[:3, :3].T + T[:3, 3])[:, 1].min()))
    for s in (bare, grounded):
        s.add(csm, T, mesh=mesh)
    P, D, ids = _ao_rays(bare, 0, 2000, 16, seed=17)
    truth = embree.visible(bare, P, D)
    free = ~embree.ground_occludes(grounded, P, D)
    for b in ("csm", "csm-vote"):
        v0 = visibility.visible(bare, P, D, backend=b, surface_ids=ids)
        v1 = visibility.visible(grounded, P, D, backend=b, surface_ids=ids)
        diff = float(np.mean(v0[free] != v1[free]))
        ground_wins = bool(not v1[~free].any())
        rows.append(_row(f"no ground, {b}", diff, 0.0, diff == 0.0 and ground_wins,
                         unit="fraction of rays the ground does not decide answered differently without it",
                         embree=float(np.mean(v0 != truth)), downward_rays=int((~free).sum())))
    return rows


ROWS = {"directions": lambda a: direction_rows(a.views, a.resolution),
        "samples": lambda a: sample_rows(a.views, a.resolution),
        "maps": lambda a: map_rows(),
        "resolution": lambda a: resolution_rows(a.views, a.resolution),
        "instances": lambda a: instance_rows(a.views, a.resolution),
        "scenes": lambda a: scene_rows(a.views, a.resolution)}


def _fmt(r):
    extra = []
    if "embree" in r:
        extra.append(f"embree {r['embree']:.4f}")
    if "build_seconds" in r:
        extra.append(f"build {r['build_seconds']:.1f}s {r['csm_bytes'] / 1e6:.2f}MB peak {r['peak_bytes'] / 1e6:.0f}MB"
                     f" iend {r['iend']}{' wide' if r['pair_wide'] else ''}")
    if "mirror_mismatch" in r and not r["row"].startswith("maps"):
        extra.append(f"mirror {r['mirror_mismatch']:.4f}")
    if "us_per_query" in r:
        extra.append(f"{r['us_per_query']:.2f} us/query, add {r['add_seconds']:.2f}s, "
                     f"Embree in this scene off by {r['embree_self_hits']:.4f} at {r['anchor_distance']:.0f} from anchor")
    return "  ".join(extra)


def main(argv=None) -> int:
    import extremes

    return extremes.main(argv, groups=ROWS, benchmark="extremes_params", detail=_fmt)


if __name__ == "__main__":
    sys.exit(main())
