"""Camera and render_gbuffer against Embree primary rays and the NumPy reference."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import embree
from pyshadow.gbuffer import check_transform, render_gbuffer_reference

from conftest import load


def unit_frame(mesh):
    c, r = pyshadow.bounding_sphere(mesh)
    T = np.eye(4)
    T[:3, :3] /= r
    T[:3, 3] = -c / r
    return T


def two_objects_on_ground(offset=0.0, scale=1.0):
    bunny = load("stanford-bunny.obj")
    fan = load("fandisk.obj")
    place = np.eye(4)
    place[:3, :3] *= scale
    place[:3, 3] = offset
    rot = trimesh.transformations.rotation_matrix(0.7, [0, 1, 0])
    rot[:3, 3] = [2.2, 0.3, 0.0]
    ground = trimesh.Trimesh([[-5, -1, -5], [5, -1, -5], [5, -1, 5], [-5, -1, 5]], [[0, 2, 1], [0, 3, 2]])
    items = [(bunny, place @ unit_frame(bunny)), (fan, place @ rot @ unit_frame(fan)), (ground, place)]
    eye = np.array([1.0, 1.5, 5.0]) * scale + offset
    target = np.array([1.0, 0.0, 0.0]) * scale + offset
    return items, pyshadow.Camera(eye, target, width=320, height=240)


@pytest.mark.parametrize("offset, scale", [(0.0, 1.0), (1e5, 1.0), (0.0, 1e-3), (0.0, 1e4), (1e5, 1e3),
                                           (0.0, 1e-20), (0.0, 1e20)])
def test_gbuffer_positions_agree_with_embree(offset, scale):
    items, cam = two_objects_on_ground(offset, scale)
    g = pyshadow.render_gbuffer(items, cam)
    e = embree.gbuffer(items, cam)
    covered = e["object_id"] >= 0
    assert covered.mean() > 0.5 and (~covered).any()
    assert set(np.unique(e["object_id"])) == {-1, 0, 1, 2}
    size = 10.0 * scale                                 # the scene's extent
    err = np.linalg.norm(g["position"].astype(np.float64) - e["position"], axis=-1)
    ok = (g["object_id"] == e["object_id"]) & (err <= 1e-4 * size + 4 * np.spacing(np.float32(offset + size)))
    assert ok[covered].mean() >= 0.995
    assert (g["object_id"] == e["object_id"]).mean() >= 0.999
    np.testing.assert_allclose(g["depth"][covered & ok], e["depth"][covered & ok], rtol=1e-4)


def test_gbuffer_matches_numpy_reference():
    sphere = trimesh.creation.icosphere(2)
    box = trimesh.creation.box(extents=(8, 0.2, 8))
    box.apply_translation([0, -1.1, 0])
    items = [(sphere, np.eye(4)), (box, np.eye(4))]
    cam = pyshadow.Camera([1.0, 1.5, 5.0], [0.0, 0.0, 0.0], width=64, height=48)
    g = pyshadow.render_gbuffer(items, cam)
    r = render_gbuffer_reference(items, cam)
    np.testing.assert_array_equal(g["object_id"], r["object_id"])
    np.testing.assert_array_equal(g["face"], r["face"])
    hit = r["object_id"] >= 0
    np.testing.assert_allclose(g["position"][hit], r["position"][hit], atol=1e-5)
    np.testing.assert_allclose(g["normal"][hit], r["normal"][hit], atol=1e-5)
    assert np.isnan(g["position"][~hit]).all() and np.isinf(g["depth"][~hit]).all()


@pytest.mark.parametrize("scene", ["two objects", "camera on the floor", "far off-screen corners"])
def test_gbuffer_rasterisers_are_bit_identical(scene, monkeypatch):
    """Every way of rasterising gives every G-buffer array bit for bit: two passes (depth, then the
    index of its winner) or one pass of 64-bit atomics on (depth, index) where the device has them;
    wide triangles a row to a work-item, each row between its edges (widened), whatever the
    threshold (0: every triangle by rows; 64; none)."""
    from pyshadow import _cl, gbuffer

    if scene == "two objects":
        items, cam = two_objects_on_ground()
    else:
        h = 100.0 if scene == "camera on the floor" else 1e4
        floor = trimesh.Trimesh([[-h, 0, -h], [h, 0, -h], [h, 0, h], [-h, 0, h]], [[0, 2, 1], [0, 3, 2]])
        wall = trimesh.Trimesh([[-3, 0, -6], [3, 0, -6], [3, 4, -6], [-3, 4, -6]], [[0, 1, 2], [0, 2, 3]])
        items = [(floor, np.eye(4)), (wall, np.eye(4))]
        cam = pyshadow.Camera([0.3, 0.5, 0], [0, 0.2, -5], width=160, height=120, fov_y=90)
    passes = (False, True) if "cl_khr_int64_extended_atomics" in _cl.device().extensions.split() else (False,)
    out = {}
    for one_pass in passes:
        for wide in (10 ** 9, 64, 0):
            monkeypatch.setattr(gbuffer, "ONE_PASS", one_pass)
            monkeypatch.setattr(gbuffer, "WIDE_PIXELS", wide)
            assert gbuffer._one_pass() == one_pass
            if wide < 10 ** 9:
                tris, *_ = gbuffer.gbuffer_triangles(items, cam)
                assert gbuffer._wide_rows(tris, cam.width, cam.height, 1.0, 1.0)[0].any()
            out[one_pass, wide] = pyshadow.render_gbuffer(items, cam)
    base = out[False, 10 ** 9]
    assert (base["object_id"] >= 0).mean() > 0.3
    for key, g in out.items():
        for k, v in base.items():
            np.testing.assert_array_equal(g[k], v, err_msg=f"{k} with (one pass, WIDE_PIXELS) = {key}")


def test_gbuffer_row_spans_hold_every_covered_pixel_of_far_flung_triangles(monkeypatch):
    """Wide triangles by rows find every pixel the per-triangle rasteriser finds, bit for bit, for
    planes in many orientations that pass the camera closely: near-clipped, their corners land
    far off the image (beyond 1e6 pixels), where each row's span rests on the float32 error bound
    of its edges' crossings (gbuffer_raster_rows)."""
    from pyshadow import gbuffer

    rng = np.random.default_rng(7)
    cam = pyshadow.Camera([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], width=96, height=72, fov_y=80)
    fy = cam.height / (2.0 * cam.tan_half)
    far_flung = 0
    for _ in range(24):
        h = 10.0 ** rng.uniform(2, 5)
        quad = trimesh.Trimesh([[-h, 0, -h], [h, 0, -h], [h, 0, h], [-h, 0, h]], [[0, 2, 1], [0, 3, 2]])
        T = trimesh.transformations.random_rotation_matrix(rng.random(3))
        T[:3, 3] = rng.normal(size=3) * 0.3 + [0.0, 0.0, -rng.uniform(0.5, 20.0)]
        items = [(quad, T)]
        tris, *_ = gbuffer.gbuffer_triangles(items, cam)
        sx, sy = gbuffer._screen(tris, cam.width, cam.height, fy, fy)
        out = {}
        for wide in (10 ** 9, 0):
            monkeypatch.setattr(gbuffer, "WIDE_PIXELS", wide)
            out[wide] = pyshadow.render_gbuffer(items, cam)
        for k, v in out[10 ** 9].items():
            np.testing.assert_array_equal(out[0][k], v, err_msg=k)
        far_flung += bool(np.nanmax(np.abs(np.r_[sx.ravel(), sy.ravel()])) > 1e6
                          and 0.2 < (out[0]["object_id"] >= 0).mean() < 1)
    assert far_flung >= 8                               # planes with an edge across the image, corners far off


def test_gbuffer_normals_face_the_camera_and_are_unit():
    items, cam = two_objects_on_ground()
    g = pyshadow.render_gbuffer(items, cam)
    hit = g["object_id"] >= 0
    n = g["normal"][hit]
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1, atol=1e-5)
    view = g["position"][hit] - cam.eye
    assert (np.einsum("ij,ij->i", n, view) <= 0).all()
    # the ground plane's normal is +y from above
    ground = g["object_id"] == 2
    np.testing.assert_allclose(g["normal"][ground], np.broadcast_to([0, 1, 0], (ground.sum(), 3)), atol=1e-6)


def test_gbuffer_camera_inside_geometry_clips_near_plane():
    # the camera stands on a huge floor that crosses the near plane
    floor = trimesh.Trimesh([[-100, 0, -100], [100, 0, -100], [100, 0, 100], [-100, 0, 100]],
                            [[0, 2, 1], [0, 3, 2]])
    cam = pyshadow.Camera([0, 0.5, 0], [0, 0, -5], width=80, height=60)
    g = pyshadow.render_gbuffer([(floor, np.eye(4))], cam)
    e = embree.gbuffer([(floor, np.eye(4))], cam)
    np.testing.assert_array_equal(g["object_id"], e["object_id"])
    hit = e["object_id"] == 0
    np.testing.assert_allclose(g["position"][hit], e["position"][hit], atol=1e-3)


def test_camera_pixel_convention():
    cam = pyshadow.Camera([0, 0, 0], [0, 0, -1], fov_y=90.0, width=4, height=2)
    d = cam.ray_directions()
    assert d.shape == (2, 4, 3)
    assert d[0, 0, 0] < 0 and d[0, 0, 1] > 0      # row 0 is the top, column 0 the left
    assert d[1, 3, 0] > 0 and d[1, 3, 1] < 0
    np.testing.assert_allclose(d[..., 2].min(), -1 / np.linalg.norm([0.5, 0.5, 1]), rtol=1e-12)


def _rays_by_formula(cam):
    """The Camera docstring's pixel rays, normalised by np.linalg.norm."""
    x = (2 * (np.arange(cam.width) + 0.5) / cam.width - 1) * cam.tan_half * cam.aspect
    y = (1 - 2 * (np.arange(cam.height) + 0.5) / cam.height) * cam.tan_half
    d = cam.forward + x[None, :, None] * cam.right + y[:, None, None] * cam.up
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def test_camera_rays_are_kept_until_the_camera_changes():
    """The kept rays equal the formula bit for bit, are shared read-only within the package, and are
    recomputed when the size or field of view changes; ray_directions() hands out a writable copy."""
    cam = pyshadow.Camera([1.0, 2.0, 3.0], [0.0, 0.5, 0.0], width=40, height=30)
    kept = cam._rays()
    assert cam._rays() is kept and not kept.flags.writeable
    np.testing.assert_array_equal(kept, _rays_by_formula(cam))
    mine = cam.ray_directions()
    mine[:] = 0.0                                   # the caller's copy, not the kept rays
    np.testing.assert_array_equal(cam._rays(), _rays_by_formula(cam))
    cam.fov_y, cam.width = 30.0, 24
    assert cam._rays().shape == (30, 24, 3)
    np.testing.assert_array_equal(cam._rays(), _rays_by_formula(cam))


@pytest.mark.parametrize("kwargs, match", [
    (dict(eye=[0, 0, 0], target=[0, 0, 0]), "coincide"),
    (dict(eye=[0, 0, 0], target=[0, 1, 0]), "parallel"),
    (dict(eye=[0, 0, 0], target=[0, 0, 1], fov_y=0), "fov_y"),
    (dict(eye=[0, 0, 0], target=[0, 0, 1], fov_y=180), "fov_y"),
    (dict(eye=[0, 0, 0], target=[0, 0, 1], width=0), "width"),
    (dict(eye=[np.nan, 0, 0], target=[0, 0, 1]), "eye"),
])
def test_camera_rejects_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        pyshadow.Camera(**kwargs)


def test_check_transform_rigid():
    R = trimesh.transformations.rotation_matrix(0.3, [1, 2, 3])
    R[:3, :3] *= 2.5
    check_transform(R, rigid=True)
    S = np.diag([1.0, 2.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="not rigid"):
        check_transform(S, rigid=True)
    with pytest.raises(ValueError, match="4x4"):
        check_transform(np.eye(3))
    P = np.eye(4)
    P[3, 0] = 0.1
    with pytest.raises(ValueError, match="affine"):
        check_transform(P)


def test_a_scene_below_the_smallest_near_plane_is_told_to_scale_up():
    """Was: a box of side 2**-120 seen from 3 of its sides away was refused as "nearer than the near plane 1e-30
    (1e-6 of the farthest geometry in view, 3.04e-36 ...)": 1e-30 is not 1e-6 of 3e-36. Now the message names the
    G-buffer's smallest near plane and asks for the scene scaled up."""
    m = trimesh.creation.box((2.0**-120,) * 3)
    cam = pyshadow.Camera(eye=(0, 0, 3 * 2.0**-120), target=(0, 0, 0), width=8, height=6)
    with pytest.raises(ValueError, match=r"near plane 1e-30 \(the smallest the G-buffer takes; .* scale the scene"):
        pyshadow.render_gbuffer([(m, np.eye(4))], cam)
