"""The parameter and direction rows of benchmarks/extremes_params.py, at small sizes.

Each test asks the kernel (``csm``, ``csm-vote``) and checks it against its
float64 NumPy mirror (exact but for float32 rounding at ties) or against
Embree with the tolerance the row's bound justifies.
"""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import embree, visibility
from pyshadow.views import polar_direction

from conftest import load, unit_frame

VIEWS = (8, 16)
RES = 32


@pytest.fixture(scope="module")
def bunny_csm():
    return pyshadow.CoherentShadowMap.build(load("stanford-bunny.obj"), pyshadow.ViewSet.zigzag(*VIEWS),
                                            resolution=RES, progress=False)


TURN = trimesh.transformations.rotation_matrix(0.7, [0.3, 0.9, -0.4])[:3, :3]


def _bunny_scene(csm, turned=False, ground=None):
    mesh = load("stanford-bunny.obj")
    scene = pyshadow.Scene(ground=ground)
    scene.add(csm, unit_frame(mesh, rotation=TURN if turned else None), mesh=mesh)
    return scene


def _rays_along(scene, d, n, rng):
    """Points on a disk behind the body (its shadow), all along ``d``."""
    c = scene.instances[0].world_sphere()[0]
    a = np.cross(d, [0.3, 0.5, 0.7])
    a /= np.linalg.norm(a)
    b = np.cross(d, a)
    r = 1.1 * np.sqrt(rng.uniform(0, 1, n))
    t = rng.uniform(0, 2 * np.pi, n)
    disk = c - 1.05 * d + (r * np.cos(t))[:, None] * a + (r * np.sin(t))[:, None] * b
    return disk, np.repeat(np.asarray(d, float)[None], n, axis=0)


GENERIC = 6


@pytest.fixture(scope="module")
def generic_wrong(bunny_csm):
    """The worst Embree disagreement of GENERIC ordinary directions, per lookup (the bound of the
    benchmark's direction rows, here doubled: 3000 rays per direction), and under "angle" the largest
    angle, radians, between one of those directions and its nearest map."""
    scene = _bunny_scene(bunny_csm)
    rng = np.random.default_rng(99)
    out = {"nearest": 0.0, "vote": 0.0, "angle": 0.0}
    for g in rng.normal(size=(GENERIC, 3)):
        out["angle"] = max(out["angle"], _map_angle(bunny_csm.views, g / np.linalg.norm(g)))
        P, D = _rays_along(scene, g / np.linalg.norm(g), 3000, rng)
        truth = embree.visible(scene, P, D)
        for lookup, be in (("nearest", "csm"), ("vote", "csm-vote")):
            out[lookup] = max(out[lookup], float(np.mean(visibility.visible(scene, P, D, backend=be) != truth)))
    return out


def _nudged(views, d_obj, R=np.eye(3), step=2e-4):
    """World directions the kernel's float32 angles may stand for: ``d_obj`` moved by 0, +-``step``
    rad in theta and in phi (acos_v and atan2_pos_v err by up to 5e-5 rad: they decide ties and
    windows on grid lines), or, at a pole, 1e-6 towards each map of the pole's row (phi is free)."""
    th = np.arccos(np.clip(d_obj[1], -1, 1))
    if np.hypot(d_obj[0], d_obj[2]) < 1e-9:
        T, P = views.params["theta"], views.params["phi"]
        row = views.directions[(0 if d_obj[1] > 0 else T - 1) * P:][:P]
        return [R @ ((d_obj + 1e-6 * (m - d_obj)) / np.linalg.norm(d_obj + 1e-6 * (m - d_obj))) for m in row]
    ph = np.arctan2(d_obj[2], d_obj[0])
    return [R @ polar_direction(th + a, ph + b) for a in (0, -step, step) for b in (0, -step, step)]


def _map_angle(views, d_obj) -> float:
    """Angle, radians, between the object-frame direction ``d_obj`` and its nearest map."""
    d = np.asarray(d_obj, float) / np.linalg.norm(d_obj)
    return float(np.arccos(np.clip(views.directions[views.nearest(d[None])[0]] @ d, -1.0, 1.0)))


def _check_direction(scene, d, rng, lookup, generic, accept, d_obj=None):
    """Kernel == mirror at one of the ``accept`` directions; Embree within twice the worst generic,
    scaled by the direction's angle to its nearest map over the largest generic one where it is larger.

    A lookup's texel misses the ray's path by the angle between the ray and its map times the distance
    along the ray's chord, so disagreement grows with that angle. The thesis's zigzag grid
    (``row_offset=0``) has a map at the +y pole and none at -y, which lies pi / T from its nearest maps,
    the largest angle of that layout; the default centred rows put both poles half a step from their
    nearest maps, below the worst generic direction's angle, so the scale is 1 there."""
    P, D = _rays_along(scene, d, 3000, rng)
    be = "csm" if lookup == "nearest" else "csm-vote"
    vis = visibility.visible(scene, P, D, backend=be)
    mirror = "numpy" if lookup == "nearest" else "numpy-vote"
    refs = [visibility.visible(scene, P, np.repeat(np.asarray(t)[None], len(P), 0), backend=mirror)
            for t in accept]
    off = np.mean(~np.any([r == vis for r in refs], axis=0))
    assert off <= 2e-3, f"{off:.4f} of the rays differ from the mirror along {d}"
    wrong = np.mean(vis != embree.visible(scene, P, D))
    views = scene.instances[0].csm.views
    scale = max(1.0, _map_angle(views, d if d_obj is None else d_obj) / generic["angle"])
    assert wrong <= 2 * scale * generic[lookup], \
        f"{wrong:.3f} disagree with Embree along {d} (generic {generic[lookup]:.3f}, angle scale {scale:.2f})"
    return vis


@pytest.mark.parametrize("lookup", ["nearest", "vote"])
@pytest.mark.parametrize("pole", [1.0, -1.0])
def test_direction_at_pole(bunny_csm, generic_wrong, lookup, pole, rng):
    """Row 'dir pole +-y': exactly at the pole of the map frame, both lookups. With centred rows
    neither pole lies farther from its maps than the worst generic direction (no angle scale)."""
    d = np.array([0.0, pole, 0.0])
    assert _map_angle(bunny_csm.views, d) <= generic_wrong["angle"]
    _check_direction(_bunny_scene(bunny_csm), d, rng, lookup, generic_wrong, _nudged(bunny_csm.views, d))


@pytest.mark.parametrize("lookup", ["nearest", "vote"])
@pytest.mark.parametrize("pole", [1.0, -1.0])
def test_direction_at_pole_turned_instance(bunny_csm, generic_wrong, lookup, pole, rng):
    """Row 'dir pole, turned instance': the pole reached through a rotation (float64 rounding puts the
    map-frame direction beside the pole). The kernel must answer as the mirror does at the pole."""
    scene = _bunny_scene(bunny_csm, turned=True)
    d0 = np.array([0.0, pole, 0.0])
    _check_direction(scene, TURN @ d0, rng, lookup, generic_wrong, _nudged(bunny_csm.views, d0, TURN), d_obj=d0)


def test_vote_in_the_polar_caps_asks_the_four_sides_of_the_pole(bunny_csm, rng):
    """Directions beyond the first and last centred row (within half a row step of a pole): the vote's
    kernel asks the mirror's window there -- four of the row's maps a quarter turn apart -- so they
    agree but at float32 ties (1 ray in 500, as at the poles); the window before it (two pairs across
    the pole) answers measurably differently on the same rays, so the agreement is the window's."""
    from pyshadow.views import ViewSet

    scene = _bunny_scene(bunny_csm)
    half = 0.5 * np.pi / VIEWS[0]
    kernel, mirror, pairs = [], [], []
    own = ViewSet._zigzag_window
    for north in (True, False):
        for th, ph in zip(half * np.sqrt(rng.uniform(0.02, 0.98, 3)), rng.uniform(0, 2 * np.pi, 3)):
            d = polar_direction(th if north else np.pi - th, ph)
            P, D = _rays_along(scene, d, 3000, rng)
            kernel.append(visibility.visible(scene, P, D, backend="csm-vote"))
            mirror.append(visibility.visible(scene, P, D, backend="numpy-vote"))
            ViewSet._zigzag_window = lambda self, d, cap=False: own(self, d, cap=False)
            try:
                pairs.append(visibility.visible(scene, P, D, backend="numpy-vote"))
            finally:
                ViewSet._zigzag_window = own
    kernel, mirror, pairs = (np.concatenate(x) for x in (kernel, mirror, pairs))
    assert np.mean(kernel != mirror) <= 2e-3
    assert np.mean(pairs != mirror) > 5e-3


@pytest.mark.parametrize("lookup", ["nearest", "vote"])
@pytest.mark.parametrize("z", [0.0, -0.0, -1e-9, -1e-7])
def test_direction_on_seam(bunny_csm, generic_wrong, lookup, z, rng):
    """Row 'dir seam': phi exactly 0, -0 and just below 2 pi (float32 rounds that to 2 pi: the
    mirror's answer at phi = 0+ is accepted too). Just below 2 pi the kernel took its candidate maps'
    offsets from the wrapped column (an offset of 2 pi: garbage maps, 26 % of rays wrong) until
    kernels/views_zigzag.h measured them from the unwrapped one."""
    d = np.array([np.sin(1.0), np.cos(1.0), z])
    d /= np.linalg.norm(d)
    accept = _nudged(bunny_csm.views, d)
    _check_direction(_bunny_scene(bunny_csm), d, rng, lookup, generic_wrong, accept)


def _between(kind, views):
    T, P = VIEWS
    dth, dph = np.pi / T, 2 * np.pi / P
    r = 2 + views.params["row_offset"]         # row 2's polar angle, in steps
    th, ph = {"phi": (r * dth, 3.5 * dph), "theta": ((r + 0.5) * dth, 3 * dph),
              "four": ((r + 0.5) * dth, 3.5 * dph)}[kind]
    return polar_direction(th, ph)


@pytest.mark.parametrize("lookup", ["nearest", "vote"])
@pytest.mark.parametrize("kind", ["phi", "theta", "four"])
def test_direction_between_maps(bunny_csm, generic_wrong, lookup, kind, rng):
    """Row 'dir between maps': equidistant from two (four) map directions. float32 decides the tie:
    the kernel's answer must be that of one of the tied maps."""
    d = _between(kind, bunny_csm.views)
    accept = _nudged(bunny_csm.views, d)
    _check_direction(_bunny_scene(bunny_csm), d, rng, lookup, generic_wrong, accept)


@pytest.mark.parametrize("samples", [1, 4096])
def test_ao_samples_extremes(bunny_csm, samples, rng):
    """Row 'samples 1 / 4096': AO against Embree AO on identical directions (and the mirror)."""
    mesh = load("stanford-bunny.obj")
    scene = _bunny_scene(bunny_csm, ground=-1.0)
    n_pts = 400 if samples == 1 else 12
    p, face = trimesh.sample.sample_surface(mesh, n_pts, seed=4)
    T = scene.instances[0].transform
    p = p @ T[:3, :3].T + T[:3, 3]
    nrm = mesh.face_normals[face]
    s = pyshadow.Sampling(samples)
    ao = scene.ambient_occlusion(p, nrm, sampling=s, surface_ids=0)
    ref = embree.ambient_occlusion(scene, p, nrm, sampling=s)
    assert ((ao >= 0) & (ao <= 1)).all()
    if samples == 1:
        assert np.isin(ao, (0.0, 1.0)).all()
    # mean AO difference <= the per-ray disagreement of this coarse CSM (measured ~2-4 %)
    assert np.abs(ao - ref).mean() < 0.06
    if samples == 4096:
        mirror = visibility.ambient_occlusion(scene, p[:3], nrm[:3], backend="numpy", sampling=s, surface_ids=0)
        np.testing.assert_allclose(ao[:3], mirror, atol=2.0 / samples)


def _ao_rays(scene, n, samples, seed):
    inst = scene.instances[0]
    p, face = trimesh.sample.sample_surface(inst.mesh, n, seed=seed)
    T = inst.transform
    p = p @ T[:3, :3].T + T[:3, 3]
    d = pyshadow.sample_directions(inst.mesh.face_normals[face] @ inst.rotation.T,
                                   sampling=pyshadow.Sampling(samples, seed=seed))
    return np.repeat(p, samples, axis=0), d.reshape(-1, 3).astype(np.float64)


def _param_check(views, resolution, depth_bits=16, embree_tol=0.2):
    mesh = load("fandisk.obj")
    csm = pyshadow.CoherentShadowMap.build(mesh, views, resolution=resolution, progress=False,
                                           depth_bits=depth_bits)
    scene = pyshadow.Scene()
    scene.add(csm, unit_frame(mesh), mesh=mesh)
    P, D = _ao_rays(scene, 300, 8, seed=3)
    vis = scene.visible(P, D, surface_ids=0)
    ref = visibility.visible(scene, P, D, backend="numpy", surface_ids=0)
    assert np.mean(vis != ref) <= 1e-3
    assert np.mean(vis != embree.visible(scene, P, D)) < embree_tol
    return csm, scene


@pytest.mark.parametrize("grid", [(2, 4), (4, 8)])
def test_map_count_small(grid):
    """Row 'maps 2x4': the coarsest grid (grid steps of 90 deg) answers as its mirror."""
    csm, _ = _param_check(pyshadow.ViewSet.zigzag(*grid), 16)
    assert csm.iend.dtype == np.uint16 and not csm.pair_wide


def test_map_count_wide_iend():
    """Row 'maps 256x512' in small: more than 65536 maps take uint32 i_end and wide pairs, and the
    kernel's segment search lands where searchsorted does on maps beyond 16 bits."""
    views = pyshadow.ViewSet.zigzag(2, 32769)         # 65538 maps: i_end beyond 16 bits
    csm, scene = _param_check(views, 4, embree_tol=0.5)
    assert csm.iend.dtype == np.uint32 and csm.pair_wide
    assert int(csm.iend.max()) == 65537
    rng = np.random.default_rng(1)
    m = rng.integers(65530, 65538, 400)
    r, c = rng.integers(0, 4, 400), rng.integers(0, 4, 400)
    np.testing.assert_array_equal(csm.segment_index(m, r, c), csm.segment_index_reference(m, r, c))


@pytest.mark.parametrize("resolution", [8, 256])
def test_resolution_extremes(resolution):
    """Rows 'resolution 8^2 .. 1024^2' in small: the kernel answers as its mirror; CSM bytes grow."""
    csm, _ = _param_check(pyshadow.ViewSet.zigzag(4, 8), resolution, embree_tol=0.25)
    assert csm.stats["bytes"] >= (resolution * resolution + 1) * 4


@pytest.mark.parametrize("bits", [16, 32])
def test_depth_bits(bits):
    """Rows 'depth 16/32-bit': both encodings answer as the mirror; 32-bit takes the wide pairs."""
    csm, _ = _param_check(pyshadow.ViewSet.zigzag(8, 16), 32, depth_bits=bits, embree_tol=0.06)
    assert csm.depth_bits == bits and csm.pair_wide == (bits == 32)


def test_many_instances(rng):
    """Row 'instances 10,000' in small (2,000 of a tilted 512-face torus): accepted, and rays leaving a
    body's top steeper than 45 deg get the same answers as with that body alone (4 radii apart: no
    other body can stop them); random rays through the grid match the mirror."""
    mesh = pyshadow.load_mesh(trimesh.creation.torus(major_radius=0.55, minor_radius=0.22,
                                                     major_sections=32, minor_sections=8))
    csm = pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(*VIEWS), resolution=RES, progress=False)
    T0 = unit_frame(mesh, rotation=trimesh.transformations.rotation_matrix(0.5, [1, 0, 0])[:3, :3])
    single = pyshadow.Scene()
    single.add(csm, T0, mesh=mesh)
    many = pyshadow.Scene()
    for i in range(2000):
        T = T0.copy()
        T[:3, 3] += [(i % 45) * 4.0, 0.0, (i // 45) * 4.0]
        many.add(csm, T, mesh=mesh)
    P, D = _ao_rays(single, 600, 8, seed=5)
    keep = D[:, 1] > np.sqrt(0.5)
    P, D = P[keep], D[keep]
    k = 1234
    shift = many.instances[k].transform[:3, 3] - T0[:3, 3]
    a = single.visible(P, D, surface_ids=0)
    b = many.visible(P + shift, D, surface_ids=k)
    assert (~a).sum() > 20                       # the torus does stop some of them
    assert np.mean(a != b) <= 2e-3
    assert np.mean(b != embree.visible(many, P + shift, D)) <= np.mean(a != embree.visible(single, P, D)) + 2e-3
    Q = many.anchor() + rng.uniform(-90, 90, (60, 3)) * [1, 0.02, 1]
    W = rng.normal(size=(60, 3))
    np.testing.assert_array_equal(many.visible(Q, W), visibility.visible(many, Q, W, backend="numpy"))


@pytest.mark.parametrize("backend", ["csm", "csm-vote"])
def test_receivers_only(backend, rng):
    """Row 'receivers only': nothing casts, so visible is exactly 'not into the ground', AO the ground's."""
    scene = pyshadow.Scene(ground=0.0)
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), casts=False)
    P = rng.uniform(-2, 2, (3000, 3))
    D = rng.normal(size=(3000, 3))
    vis = visibility.visible(scene, P, D, backend=backend)
    np.testing.assert_array_equal(vis, ~embree.ground_occludes(scene, P, D))
    assert 0.2 < vis.mean() < 0.8
    s = pyshadow.Sampling(16)
    nrm = rng.normal(size=(200, 3))
    np.testing.assert_array_equal(visibility.ambient_occlusion(scene, P[:200], nrm, backend=backend, sampling=s),
                                  embree.ambient_occlusion(scene, P[:200], nrm, sampling=s))


@pytest.mark.parametrize("backend", ["csm", "csm-vote"])
def test_no_ground(bunny_csm, backend):
    """Row 'no ground': without a ground plane, rays it would not decide get the same answers as with it,
    and downward rays are decided by the bunny alone."""
    mesh = load("stanford-bunny.obj")
    bare = _bunny_scene(bunny_csm)
    foot = float((mesh.vertices @ bare.instances[0].transform[:3, :3].T + bare.instances[0].transform[:3, 3])[:, 1].min())
    grounded = _bunny_scene(bunny_csm, ground=foot)
    P, D = _ao_rays(bare, 400, 8, seed=9)
    free = ~embree.ground_occludes(grounded, P, D)
    v0 = visibility.visible(bare, P, D, backend=backend, surface_ids=0)
    v1 = visibility.visible(grounded, P, D, backend=backend, surface_ids=0)
    np.testing.assert_array_equal(v0[free], v1[free])
    assert not v1[~free].any() and (~free).sum() > 100
    assert v0[~free].mean() > 0.3            # the bunny alone lets many downward rays through
