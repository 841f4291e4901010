"""The surface rule (pyshadow.csm.surface_rule): rays leaving a caster's own surface at a known normal.

Grazing rays over a flat face were shadowed by the face itself (23 % of rays
0.5-3 degrees above a plate, benchmarks/extremes.py); with the normal known
the lookup raises the direction to the view set's covering angle and lifts
the point where the map is grazing. Kernel (both lookups) against its float64
mirror and against Embree.
"""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import embree, visibility
from pyshadow.csm.surface_rule import covering_angle
from pyshadow.scene import GROUND_ID

from conftest import load, on_ground, unit_frame


def _plate_scene(maps=(16, 32), resolution=64):
    plate = trimesh.creation.box((1.0, 0.003, 1.0))
    csm = pyshadow.CoherentShadowMap.build(plate, pyshadow.ViewSet.zigzag(*maps), resolution=resolution,
                                           progress=False)
    scene = pyshadow.Scene()
    scene.add(csm, mesh=plate)
    return scene


def _grazing_rays(rng, n, lo_deg, hi_deg, top=0.0015):
    p = np.column_stack([rng.uniform(-0.45, 0.45, n), np.full(n, top), rng.uniform(-0.45, 0.45, n)])
    e = np.radians(rng.uniform(lo_deg, hi_deg, n))
    az = rng.uniform(0.0, 2.0 * np.pi, n)
    d = np.column_stack([np.cos(e) * np.cos(az), np.sin(e), np.cos(e) * np.sin(az)])
    return p, d, np.tile([0.0, 1.0, 0.0], (n, 1))


@pytest.mark.parametrize("lookup", ["nearest", "vote"])
def test_covering_angle_bounds_every_map_the_lookup_asks(lookup, rng):
    """Random directions, the poles and the phi seam: every map the lookup picks lies within the
    covering angle (else a raised ray could still be looked up in a map below its surface)."""
    views = pyshadow.ViewSet.zigzag(16, 32)
    d = rng.normal(size=(20000, 3))
    d = np.vstack([d, [[0, 1, 0], [0, -1, 0], [1, 0, 0], [1, 1e-9, 0], [1, -1e-9, 1e-12]]])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    maps = views.nearest(d)[:, None] if lookup == "nearest" else views.filter_window(d)[0]
    angle = np.arccos(np.clip(np.einsum("ij,imj->im", d, views.directions[maps]), -1, 1)).max()
    cover = covering_angle(views, lookup)
    assert angle <= cover
    # and it is tight: within the sampling spacing it adds (0.56 degrees) of the largest angle found
    assert cover - angle < np.radians(1.0)


@pytest.mark.parametrize("backend", ["csm", "csm-vote"])
def test_grazing_rays_over_a_plate_are_not_shadowed_by_it(backend, rng):
    """Rays 0.01-6 degrees above a plate's top face: Embree sees the sky on every one; with the
    face's normal the CSM must too (without it, the documented limit: many are shadowed)."""
    scene = _plate_scene()
    p, d, nrm = _grazing_rays(rng, 4000, 0.01, 6.0)
    truth = embree.visible(scene, p, d)
    assert truth.all()
    with_normals = visibility.visible(scene, p, d, backend=backend, surface_ids=0, normals=nrm)
    assert with_normals.all()
    without = visibility.visible(scene, p, d, backend=backend, surface_ids=0)
    assert (~without).mean() > 0.01          # the failure the rule removes is really exercised here


@pytest.mark.parametrize("backend", ["csm", "csm-vote"])
def test_point_on_an_open_plate_has_ao_one(backend):
    """AO always knows the normal: every cosine sample from the plate's top face reaches the sky."""
    scene = _plate_scene()
    g = np.linspace(-0.4, 0.4, 9)
    p = np.column_stack([np.repeat(g, 9), np.full(81, 0.0015), np.tile(g, 9)])
    ao = visibility.ambient_occlusion(scene, p, np.tile([0.0, 1.0, 0.0], (81, 1)), backend=backend,
                                      sampling=pyshadow.Sampling(256), surface_ids=0)
    assert np.array_equal(ao, np.ones(81, np.float32))


@pytest.mark.parametrize("backend", ["csm", "csm-vote"])
def test_sphere_under_the_sun_has_no_self_shadowed_point(backend):
    """A tessellated sphere lit by a directional light: no point with n.l > 0.05 is shadowed
    (Embree: none is)."""
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    scene = pyshadow.Scene(views=pyshadow.ViewSet.zigzag(16, 32), resolution=64)
    scene.add(sphere)
    pts, face = trimesh.sample.sample_surface(sphere, 20000, seed=4)
    nrm = sphere.face_normals[face]
    for sun in ([0.3, 0.8, -0.52], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]):
        sun = np.asarray(sun) / np.linalg.norm(sun)
        sel = nrm @ sun > 0.05
        d = np.tile(sun, (int(sel.sum()), 1))
        assert embree.visible(scene, pts[sel], d).all()
        assert visibility.visible(scene, pts[sel], d, backend=backend, surface_ids=0, normals=nrm[sel]).all()


@pytest.mark.parametrize("kernel, mirror", [("csm", "numpy"), ("csm-vote", "numpy-vote")])
def test_rule_kernel_matches_its_numpy_mirror(kernel, mirror, rng):
    """Rays from the bunny and a turned fandisk on the ground, half of them grazing (elevation under
    the covering angle): the kernel with normals against the float64 mirror with normals. The
    tolerance of test_csm_backend_matches_its_numpy_mirror (float32 rounding decides at most 1 ray
    in 1000)."""
    bunny, fan = load("stanford-bunny.obj"), load("fandisk.obj")
    views = pyshadow.ViewSet.zigzag(16, 32)
    scene = pyshadow.Scene(ground=0.0, views=views, resolution=64)
    scene.add(bunny, on_ground(bunny, unit_frame(bunny)))
    rot = trimesh.transformations.rotation_matrix(0.9, [0.3, 1.0, 0.2])[:3, :3]
    scene.add(fan, on_ground(fan, unit_frame(fan, scale=0.8, rotation=rot, offset=(1.7, 0.0, 0.4))))
    ps, ds, ns, ids = [], [], [], []
    for k in (0, 1):
        inst = scene.instances[k]
        local, face = trimesh.sample.sample_surface(inst.mesh, 1500, seed=k + 1)
        p = local @ inst.transform[:3, :3].T + inst.transform[:3, 3]
        n = inst.mesh.face_normals[face] @ inst.rotation.T
        t = np.cross(n, rng.normal(size=n.shape))
        t /= np.linalg.norm(t, axis=1, keepdims=True)
        e = np.where(rng.random(len(p)) < 0.5, rng.uniform(0.0, 12.0, len(p)), rng.uniform(0.0, 90.0, len(p)))
        e = np.radians(e)
        ps.append(p), ds.append(np.cos(e)[:, None] * t + np.sin(e)[:, None] * n), ns.append(n)
        ids.append(np.full(len(p), k))
    p, d, n, ids = map(np.concatenate, (ps, ds, ns, ids))
    ours = visibility.visible(scene, p, d, backend=kernel, surface_ids=ids, normals=n)
    ref = visibility.visible(scene, p, d, backend=mirror, surface_ids=ids, normals=n)
    assert 0.2 < ref.mean() < 0.98
    assert (ours == ref).mean() > 0.999
    # the rule changed answers here (else this compares nothing new)
    assert (visibility.visible(scene, p, d, backend=mirror, surface_ids=ids) != ref).sum() > 10


def test_rule_leaves_points_on_other_bodies_and_the_ground_alone(two_body_scene_small, rng):
    """Points on the ground or on a receiver: their answers with normals equal those without."""
    scene = two_body_scene_small
    n = 3000
    p = np.column_stack([rng.uniform(-2, 3, n), np.zeros(n), rng.uniform(-2, 2, n)])
    d = rng.normal(size=(n, 3))
    d[:, 1] = np.abs(d[:, 1]) * 0.1                 # low over the ground
    up = np.tile([0.0, 1.0, 0.0], (n, 1))
    for backend in ("csm", "csm-vote"):
        a = visibility.visible(scene, p, d, backend=backend, surface_ids=GROUND_ID)
        b = visibility.visible(scene, p, d, backend=backend, surface_ids=GROUND_ID, normals=up)
        assert np.array_equal(a, b)
        assert 0.05 < (~a).mean() < 0.95


@pytest.fixture(scope="module")
def two_body_scene_small():
    bunny = load("stanford-bunny.obj")
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(16, 32), resolution=64)
    scene.add(bunny, on_ground(bunny, unit_frame(bunny)))
    box = trimesh.creation.box((0.6, 0.6, 0.6))
    scene.add(box, on_ground(box, unit_frame(box, offset=(1.6, 0.0, 0.0), scale=0.5)))
    return scene


@pytest.mark.parametrize("bad, why", [
    (np.zeros((4, 3)), "normals"),
    (np.full((4, 3), np.nan), "normals"),
    (np.ones((3, 3)), "normals"),
    (np.ones((4, 2)), "normals"),
])
def test_bad_normals_are_refused_before_any_launch(bad, why, no_launch):
    scene = pyshadow.Scene()
    scene.add(trimesh.creation.box((1, 1, 1)), casts=False)
    p, d = np.zeros((4, 3)), np.tile([0.0, 1.0, 0.0], (4, 1))
    with pytest.raises(ValueError, match=why):
        visibility.visible(scene, p, d, normals=bad)
