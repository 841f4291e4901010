"""Cube-map AO and contact footprints under bad or extreme input (pyshadow/cubemap, pyshadow/contact.py).

Each test failed on the code before its fix; its docstring says what happened.
"""
from __future__ import annotations

import re

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import contact, embree
from pyshadow.cubemap import CubeMapAO, CubeMapVisibility, CubeProbe, coverage_grid, quality

VIEWS = pyshadow.ViewSet.zigzag(4, 8)
PROBE = (0.0, 1.0, 2.0)
UP = [0.0, 1.0, 0.0]


def _box_scene(ground=0.0, mesh=None, T=None):
    """A unit box resting on the ground plane (or ``mesh`` placed by ``T``)."""
    scene = pyshadow.Scene(ground=ground, views=VIEWS, resolution=16)
    if mesh is None:
        mesh, T = trimesh.creation.box((1.0, 1.0, 1.0)), trimesh.transformations.translation_matrix([0, ground + .5, 0])
    scene.add(mesh, T)
    return scene


def _open_box_scene(ground=0.0):
    """A unit box without its lid on the ground: its floor lies on the plane, open to the sky."""
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    lidless = trimesh.Trimesh(box.vertices, box.faces[box.face_normals[:, 1] < 0.5], process=False)
    return _box_scene(ground, lidless, trimesh.transformations.translation_matrix([0, ground + 0.5, 0]))


def _wall_scene():
    """Ground y = 0, a thick wall (front face z = 0) and a 0.3 box on the floor in front of it."""
    scene = pyshadow.Scene(ground=0.0, views=VIEWS, resolution=16)
    wall = trimesh.creation.box((40.0, 10.0, 0.5))
    wall.apply_translation([0.0, 5.0, -0.25])
    scene.add(wall)
    scene.add(trimesh.creation.box((0.3, 0.3, 0.3)), trimesh.transformations.translation_matrix([0.0, 0.15, 0.7]))
    return scene


def _maps(scene):
    m = CubeMapAO(scene, 1.0, resolution=16, device=False, sampling=pyshadow.Sampling(8))
    m.add_probe(PROBE)
    return m


@pytest.fixture(scope="module")
def maps():
    return _maps(_wall_scene())


CAMERA = pyshadow.Camera([0.0, 1.0, 2.5], [0.0, 0.0, 0.7], width=8, height=8)


# ---------------------------------------------------------------------------
# contact.py
# ---------------------------------------------------------------------------
def _near_edge(n, ground, seed=2):
    """``n`` float32 ground points in the unit square under the box, within 1 cm of its edge (farther than
    1e-3: nearer, a point is the CSM's)."""
    rng = np.random.default_rng(seed)
    xz = rng.uniform(-0.5, 0.5, (n, 2))
    k = rng.integers(0, 2, n)
    xz[np.arange(n), k] = np.sign(xz[np.arange(n), k]) * (0.5 - rng.uniform(1e-3, 0.01, n))
    return np.column_stack([xz[:, 0], np.full(n, ground), xz[:, 1]]).astype(np.float32)


def test_float32_footprint_points_far_from_the_origin():
    """Was: with the plane at y = 1000.2 a float32 ground point (1000.20001) lay 1.2e-5 above it, beyond
    the tolerance 1e-5 * scale = 8.7e-6 of unit bodies: contact_mask left every point of the box's
    footprint out and the CSM leaked light near its edge (AO up to 0.5 where Embree gives 0)."""
    scene = _box_scene(ground=1000.2)
    p = _near_edge(200, 1000.2)
    assert float(p[0, 1]) - 1000.2 > 1e-5 > 1e-5 * scene.scale()
    assert contact.contact_mask(scene, p).all()
    up = np.tile(UP, (len(p), 1))
    s = pyshadow.Sampling(32)
    assert embree.ambient_occlusion(scene, p, up, sampling=s).max() == 0.0
    assert scene.ambient_occlusion(p, up, sampling=s, surface_ids=-2).max() == 0.0
    # a float64 point as far above the plane in the open stays the plane's, not the box's
    assert contact.contact_mask(scene, [[3.0, 1000.2 + 1.2e-5, 3.0]]).tolist() == [False]


def test_float32_points_on_an_open_floor_far_from_the_origin():
    """Was: at y = 1000.2 the float32 points of the ground under a lidless box's floor (1.2e-5 above the
    plane) kept the ground's slot (-2): asked as the ground, the coincident floor shadowed about half of
    their rays (at 16 x 32 views, 64 texels: mean AO 0.11 where Embree gives 0.21 and the same scene at
    y = 0 gives 0.21); now the answer of the scene at y = 0, bit for bit."""
    scene = _open_box_scene(1000.2)
    rng = np.random.default_rng(2)
    xz = rng.uniform(-0.45, 0.45, (200, 2))
    p = np.column_stack([xz[:, 0], np.full(200, 1000.2), xz[:, 1]]).astype(np.float32)
    assert (contact.ground_sheet_slots(scene, p, np.full(200, -2, np.int32)) == 0).all()
    near = _open_box_scene(0.0)
    p0 = np.column_stack([xz[:, 0], np.zeros(200), xz[:, 1]]).astype(np.float32)
    up = np.tile(UP, (200, 1))
    s = pyshadow.Sampling(16)
    far = scene.ambient_occlusion(p, up, sampling=s, surface_ids=-2)
    assert np.array_equal(far, near.ambient_occlusion(p0, up, sampling=s, surface_ids=-2))   # as at y = 0


def test_footprint_of_a_mesh_in_tiny_units():
    """Was: a closed box of side 1e-160 (scaled up to 1 by its transform) lost every face as zero-area (its
    areas underflowed float64): no footprint, the ground under it left to the CSM."""
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    tiny = trimesh.Trimesh(box.vertices * 1e-160, box.faces, process=False)
    T = np.diag([1e160, 1e160, 1e160, 1.0])
    T[1, 3] = 0.5
    scene = _box_scene(mesh=tiny, T=T)
    (tri, outline), = contact.footprints(scene)
    assert tri.shape == (2, 3, 2) and outline.shape == (4, 2, 2)
    np.testing.assert_allclose(np.abs(tri), 0.5, rtol=1e-12, atol=0)    # the unit square's corners (x, z)
    assert contact.contact_mask(scene, [[0.1, 0.0, 0.2], [2.0, 0.0, 0.0]]).tolist() == [True, False]


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("size", [1e-300, 1e-155, 1e155, 1e200])
def test_closed_surface_at_extreme_sizes(size):
    """Was: sizes below about 1e-154 dropped every face (areas underflowed to 0); above 1e154 the areas
    overflowed (RuntimeWarning) and from about 1e160 on became NaN: every face dropped, the box open."""
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    u, f = contact._closed_surface(trimesh.Trimesh(box.vertices * size, box.faces, process=False))
    assert len(u) == 8 and len(f) == 12




def test_ground_sheet_slots_own_as_a_list():
    """Was: a list of slots failed deep inside ('only integer scalar arrays can be converted to a scalar
    index'); a float array was taken as slots."""
    scene = _open_box_scene()
    p = np.array([[0.1, 0.0, 0.1], [5.0, 0.0, 5.0]])
    got = contact.ground_sheet_slots(scene, p, [-2, -2])
    assert got.dtype == np.int32 and got.tolist() == [0, -2]
    assert contact.ground_sheet_slots(scene, p, np.array([-2, -2], np.int32)).tolist() == [0, -2]
    with pytest.raises(TypeError, match=r"^own must hold integer caster slots, got dtype float64$"):
        contact.ground_sheet_slots(scene, p, np.array([-2.0, -2.0]))


def test_in_place_outputs_must_be_arrays():
    """Was: a list as ``visible`` (or ``ao``) failed with 'only integer scalar arrays can be converted to a
    scalar index', naming nothing."""
    scene = _box_scene()
    p = np.array([[0.1, 0.0, 0.1], [3.0, 0.0, 3.0]])
    up = np.tile(UP, (2, 1))
    assert contact.occlude_contacts(scene, p, up, np.array([True, True])).tolist() == [False, True]
    with pytest.raises(TypeError, match=r"^visible must be a NumPy array \(it is changed in place\), got list$"):
        contact.occlude_contacts(scene, p, up, [True, True])
    with pytest.raises(TypeError, match=r"^ao must be a NumPy array \(it is changed in place\), got list$"):
        contact.close_contacts(scene, p, up, [1.0, 1.0], np.zeros((2, 3)))


# ---------------------------------------------------------------------------
# cube maps
# ---------------------------------------------------------------------------
def test_stale_probes_are_announced_by_project_assign_and_place():
    """Was: after set_transform moved the box away, project and assign answered from the old maps (the
    floor still darkened by the box, pixels it had covered unseen) without a word. They still answer so
    (the moving study of benchmarks/methods.py measures that error), with a UserWarning."""
    scene = _wall_scene()
    maps = _maps(scene)
    before = maps.project(CAMERA, fallback=-1.0).ao
    assert (before == -1.0).sum() == 0
    scene.set_transform(1, trimesh.transformations.translation_matrix([5.0, 0.15, 0.7]))
    stale = "the probes are stale (the scene changed since they were rendered) and answer for the scene as it was: " \
            "call refresh()"
    with pytest.warns(UserWarning, match=f"^{re.escape(f'CubeMapAO.project: {stale}')}$"):
        old = maps.project(CAMERA, fallback=-1.0).ao
    with pytest.warns(UserWarning, match=f"^{re.escape(f'CubeMapAO.assign: {stale}')}$"):
        assert maps.assign([[1.0, 0.0, 1.0]])[0].tolist() == [0]
    with pytest.warns(UserWarning, match=f"^{re.escape(f'CubeMapAO.project: {stale}')}$"):
        maps.place(CAMERA, threshold=1e-9)
    assert maps.refresh() == 1
    fresh = _maps(scene).project(CAMERA, fallback=-1.0).ao
    assert np.array_equal(maps.project(CAMERA, fallback=-1.0).ao, fresh)
    assert (old == -1.0).sum() == 2 and (fresh == -1.0).sum() == 0     # where the box was: unseen
    assert (before < 1.0).sum() > (fresh < 1.0).sum()                  # and its shade is gone


@pytest.mark.parametrize("centre", [np.array([0.0, 1.0, 2.0 + 1.0j]), ["0", "1", "2"], np.array([False, True, True]),
                                    "abc"])
def test_probe_centre_must_be_real_numbers(maps, centre):
    """Was: strings were converted ('2' as 2.0; 'abc' a NumPy error naming nothing), booleans read as 0 and 1
    and a complex centre lost its imaginary part (ComplexWarning)."""
    with pytest.raises(ValueError, match=r"^CubeProbe: centre must be 3 finite numbers, got "):
        CubeProbe(maps.scene, centre, 16)


@pytest.mark.parametrize("ids, err, msg", [
    ("a", TypeError, "surface_ids must be integers, got <U1"),
    (0.5, TypeError, "surface_ids must be integers, got float64"),
    ([[0, 0]], ValueError, "surface_ids must be one id or one per point, shape (K,), got shape (1, 2)")])
def test_assign_surface_ids_must_be_integer_ids(maps, ids, err, msg):
    """Was: string or float ids never equalled a texel's and every point came back 'seen by no probe' (-1);
    a (1, K) array was flattened."""
    pts = [[1.0, 0.0, 1.0], [1.2, 0.0, 1.5]]
    assert maps.assign(pts, surface_ids=-2)[0].tolist() == [0, 0]
    with pytest.raises(err, match=f"^{re.escape(msg)}$"):
        maps.assign(pts, surface_ids=ids)
    with pytest.raises(err, match=f"^{re.escape(msg)}$"):
        CubeMapVisibility(maps).visible(maps.scene, pts, [UP, UP], surface_ids=ids)


def test_fallback_and_threshold_are_named(maps):
    """Was: NumPy's 'could not convert string to float' or 'float() argument must be ...', naming nothing."""
    with pytest.raises(TypeError, match=r"^fallback: must be a number \(got 'x'\)$"):
        maps.project(CAMERA, fallback="x")
    with pytest.raises(TypeError, match=r"^fallback: must be a number \(got \[0\.5, 0\.2\]\)$"):
        maps.project(CAMERA, fallback=[0.5, 0.2])
    with pytest.raises(TypeError, match=r"^threshold: must be a number \(got None\)$"):
        maps.place(CAMERA, threshold=None)
    assert np.isnan(maps.project(CAMERA, fallback=np.nan, on_empty="fallback").ao).sum() \
        == np.isnan(maps.project(CAMERA, on_empty="fallback").ao).sum()


def test_quality_checks_its_arrays():
    """Was: two normals for one point were broadcast into two answers, a NaN point or centre gave NaN
    (outside the documented [0, 1]), a centre of 2 numbers a broadcast error."""
    p, n = np.zeros((1, 3)), np.array([UP])
    assert quality(p, n, [0, 1, 0], 1.0).tolist() == [0.5]
    with pytest.raises(ValueError, match=r"^normals has 2 rows but points has 1 \(shapes must match\)$"):
        quality(p, [UP, UP], [0, 1, 0], 1.0)
    with pytest.raises(ValueError, match=r"^points: 1 rows are not finite$"):
        quality([[np.nan, 0, 0]], n, [0, 1, 0], 1.0)
    with pytest.raises(ValueError, match=r"^centre must be 3 finite numbers, got \[0, nan, 0\]$"):
        quality(p, n, [0, np.nan, 0], 1.0)
    with pytest.raises(ValueError, match=r"^centre must be 3 finite numbers, got \[0, 1\]$"):
        quality(p, n, [0, 1], 1.0)


def test_coverage_grid_of_integer_masks():
    """Was: an int 0/1 background went through '~' as -1 and -2: every cell counted shaded (1.0 for an
    image with nothing shaded); a float image failed in NumPy's '~'."""
    cov = np.zeros((16, 16), bool)
    bg = np.zeros((16, 16), bool)
    cov[:, :12] = True
    bg[:2, :] = True
    assert coverage_grid(cov, bg, 8) == 42 / 56
    assert coverage_grid(cov.astype(np.uint8), bg.astype(np.int64), 8) == 42 / 56
    assert coverage_grid(np.zeros((16, 16), int), np.zeros((16, 16), int), 8) == 0.0
    with pytest.raises(TypeError, match=r"^covered must be a bool image \(or of 0 and 1 only\), got dtype float64$"):
        coverage_grid(cov.astype(float), bg, 8)
    with pytest.raises(TypeError, match=r"^background must be a bool image \(or of 0 and 1 only\), got dtype int64$"):
        coverage_grid(cov, bg * 2, 8)


# ---------------------------------------------------------------------------
# cubemap/analysis.py
# ---------------------------------------------------------------------------
RAY_P, RAY_W = [[0.0, 0.0, 1.0]], [[0.0, 0.5, -1.0]]


@pytest.mark.parametrize("kw, err, msg", [
    (dict(samples=0), ValueError, "samples must be >= 1, got 0"),
    (dict(samples=-1), ValueError, "samples must be >= 1, got -1"),
    (dict(max_distance=-1.0), ValueError, "max_distance must be a finite distance > 0 (world units), got -1.0"),
    (dict(directions=[[0.0, 0.0, 0.0]]), ValueError, "directions: 1 rows are zero vectors"),
    (dict(points=RAY_P * 2), ValueError, "directions has 1 rows but points has 2 (shapes must match)"),
    (dict(margin=1.0), ValueError, "unseen_rays: margin > 0 needs the points' normals (normals=)"),
])
def test_unseen_rays_checks_its_input(maps, kw, err, msg):
    """Was: samples 0 or -1 and a negative max_distance tested no point (every ray answered 'seen',
    False); a zero direction gave a RuntimeWarning, two points with one direction two answers, margin
    without normals NumPy's 'cannot reshape array of size 1 into shape (3)'."""
    from pyshadow.cubemap.analysis import unseen_rays

    args = dict(points=RAY_P, directions=RAY_W, max_distance=1.0)
    assert unseen_rays(maps.scene, maps.probes[0], **args).tolist() == [False]
    args.update(kw)
    with pytest.raises(err, match=f"^{re.escape(msg)}$"):
        unseen_rays(maps.scene, maps.probes[0], **args)


def test_analysis_directions_of_any_length(maps):
    """Was: a direction of length 1e-200 (1e200) was divided by its norm, which underflowed to 0 (overflowed
    to inf): RuntimeWarning, NaN (zero) directions; an ``answer`` of another length was not noticed."""
    from pyshadow.cubemap.analysis import ambiguous_rays, unseen_rays

    probe, w = maps.probes[0], np.array(RAY_W)
    for f in (1e-200, 1e200):
        assert np.array_equal(unseen_rays(maps.scene, probe, RAY_P, w * f, 1.0),
                              unseen_rays(maps.scene, probe, RAY_P, w, 1.0))
        assert np.array_equal(ambiguous_rays(maps.scene, probe, RAY_P, [UP], w * f, 1.0),
                              ambiguous_rays(maps.scene, probe, RAY_P, [UP], w, 1.0))
    with pytest.raises(ValueError, match=r"^answer must have shape \(1,\) \(one per ray\), got \(2,\)$"):
        ambiguous_rays(maps.scene, probe, RAY_P, [UP], w, 1.0, answer=[True, False])


@pytest.mark.parametrize("device", ["no", None, 0])
def test_cubemap_device_flag_is_a_bool(maps, device):
    """Was: device='no' was true (the OpenCL device ran), None and 0 false, without a word."""
    with pytest.raises(TypeError, match=rf"^device: expected True or False \(got {re.escape(repr(device))}\)$"):
        CubeMapAO(maps.scene, 1.0, resolution=16, device=device)


@pytest.mark.parametrize("name", ["ao", "depth", "normal"])
def test_seed_filter_needs_real_images(name):
    """Was: a complex image lost its imaginary part with a ComplexWarning; strings were converted."""
    from pyshadow.cubemap import seed_box_filter

    args = dict(ao=np.full((3, 3), 0.5, np.float32), depth=np.ones((3, 3), np.float32), normal=np.tile(UP, (3, 3, 1)))
    assert seed_box_filter(**args).tolist() == [[0.5] * 3] * 3
    args[name] = args[name].astype(complex)
    with pytest.raises(TypeError, match=rf"^{name} must hold real numbers, got dtype complex128$"):
        seed_box_filter(**args)
    args[name] = np.real(args[name]).astype(str)
    with pytest.raises(TypeError, match=rf"^{name} must hold real numbers, got dtype <U"):
        seed_box_filter(**args)


@pytest.mark.parametrize("options, error", [(dict(thickness=-1.0), ValueError), (dict(step=True), TypeError),
                                            (dict(max_steps=0), ValueError), (dict(stride=2), TypeError)])
def test_march_options_are_checked_before_any_probe(small_scene, options, error):
    """``CubeMapAO(scene, 1.0, thickness=-1)`` was accepted; the error came from add_probe, after the probe's
    six faces were rendered (or, for place(), after the camera's G-buffer)."""
    from pyshadow.cubemap import CubeMapAO

    with pytest.raises(error):
        CubeMapAO(small_scene, 1.0, resolution=16, **options)
    assert CubeMapAO(small_scene, 1.0, resolution=16, thickness=0.5, step=2.0).options == dict(thickness=0.5,
                                                                                                  step=2.0)
