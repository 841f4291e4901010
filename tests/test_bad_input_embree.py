"""Bad and extreme input to the Embree ground truth (pyshadow.embree) and to mesh loading (pyshadow.mesh).

Each test's docstring says what happened before the fix.
"""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import embree
from pyshadow.mesh import bounding_sphere, float32_unit, load_mesh, mesh_hash, normalised_vertices

BOX = trimesh.creation.box((1.0, 1.0, 1.0))
DOWN = np.array([[0.0, -1.0, 0.0]])
ABOVE = np.array([[0.0, 2.0, 0.0]])


def _first_hit64(o, d, tri):
    """Float64 Moller-Trumbore: the first hit distance of each ray (inf: none), double-sided."""
    v0, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    out = np.full(len(o), np.inf)
    for i in range(len(o)):
        pv = np.cross(d[i], e2)
        det = np.einsum("ij,ij->i", e1, pv)
        inv = 1.0 / np.where(det == 0, np.inf, det)
        tv = o[i] - v0
        u = np.einsum("ij,ij->i", tv, pv) * inv
        qv = np.cross(tv, e1)
        v = (qv @ d[i]) * inv
        t = np.einsum("ij,ij->i", e2, qv) * inv
        hit = (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
        if hit.any():
            out[i] = t[hit].min()
    return out


# ---------------------------------------------------------------------------
# EmbreeScene: rays Embree would misread
# ---------------------------------------------------------------------------
def test_embree_scene_refuses_fewer_directions_than_origins():
    """Before: 10 origins with 2 directions read the direction array past its end -- garbage answers
    (distances like 5.7e-31 for rays that miss), and a crash waiting to happen."""
    rays = embree.EmbreeScene(BOX.triangles)
    o = np.repeat(ABOVE, 10, axis=0)
    for call in (rays.occluded, rays.intersect):
        with pytest.raises(ValueError, match="directions has 2 rows but origins has 10"):
            call(o, np.repeat(DOWN, 2, axis=0))
        with pytest.raises(ValueError, match="directions has 10 rows but origins has 1"):
            call(ABOVE, np.repeat(DOWN, 10, axis=0))
    # one direction for all origins stays allowed (embreex repeats it)
    np.testing.assert_array_equal(rays.occluded(o, DOWN), np.ones(10, bool))


def test_embree_scene_refuses_rows_that_are_not_triples():
    """Before: (3, 2) origins and directions were reshaped into 2 rays of 3 and answered silently."""
    rays = embree.EmbreeScene(BOX.triangles)
    with pytest.raises(ValueError, match=r"origins must have shape \(N, 3\), got \(3, 2\)"):
        rays.occluded(np.zeros((3, 2)), np.ones((3, 2)))


def test_embree_scene_refuses_negative_or_nan_tfar():
    """Before: occluded() with tfar = -1 answered True (occluded) for a ray of negative length, and a NaN
    tfar answered as a miss."""
    rays = embree.EmbreeScene(BOX.triangles)
    for bad in (-1.0, np.nan):
        with pytest.raises(ValueError, match="tfar must be >= 0"):
            rays.occluded(ABOVE, DOWN, bad)
        with pytest.raises(ValueError, match="tfar must be >= 0"):
            rays.intersect(ABOVE, DOWN, bad)
    assert not rays.occluded(ABOVE, DOWN, 0.0)[0]
    assert rays.occluded(ABOVE, DOWN, 1e39)[0]          # beyond float32: unbounded, no overflow warning


@pytest.mark.parametrize("origin, direction, match", [
    ([[np.nan, 2.0, 0.0]], DOWN, "origins: 1 rows are not finite"),
    ([[0.0, 1e39, 0.0]], DOWN, "origins: 1 rows are not finite as float32"),
    (ABOVE, [[np.nan, -1.0, 0.0]], "directions: 1 rows are not finite"),
    (ABOVE, [[0.0, -1e39, 0.0]], "directions: 1 rows are not finite as float32"),
    (ABOVE, [[0.0, 0.0, 0.0]], "directions: 1 rows are zero vectors"),
])
def test_embree_scene_refuses_rays_it_cannot_trace(origin, direction, match):
    """Before: a NaN origin or direction, or a zero direction, answered 'not occluded' / a miss; a
    coordinate beyond float32 raised numpy's 'overflow encountered in cast' RuntimeWarning."""
    rays = embree.EmbreeScene(BOX.triangles)
    with pytest.raises(ValueError, match=match):
        rays.occluded(origin, direction)
    with pytest.raises(ValueError, match=match):
        rays.intersect(origin, direction)


def test_embree_scene_refuses_triangles_that_are_not_finite():
    """Before: a triangle with a NaN or inf corner was dropped by Embree: rays passed through it."""
    tri = BOX.triangles.copy()
    tri[3, 1, 2] = np.nan
    with pytest.raises(ValueError, match="EmbreeScene: 1 triangles have corners that are not finite"):
        embree.EmbreeScene(tri)


def test_embree_scene_of_a_tiny_scene_takes_a_huge_tfar_or_subnormal_triangles():
    """Before: tfar = 1e300 on a scene scaled up by its power-of-two unit raised numpy's 'overflow
    encountered in multiply'; triangles of subnormal size raised 'overflow encountered in scalar power'
    (float32_unit returned inf)."""
    rays = embree.EmbreeScene(BOX.triangles * 1e-9)
    assert rays.occluded(ABOVE * 1e-9, DOWN, 1e300)[0]
    tiny = embree.EmbreeScene(BOX.triangles * 1e-310)
    assert np.isfinite(tiny.unit) and tiny.occluded(ABOVE * 1e-310, DOWN)[0]
    assert np.isfinite(float32_unit(1e-310)) and float32_unit(5e-324) == 2.0 ** 1023


def test_ray_epsilon_beyond_float32():
    """Before: ray_epsilon(inf) returned NaN and ray_epsilon(1e39) raised 'overflow encountered in cast'."""
    big = embree.ray_epsilon(3.4e38)
    assert embree.ray_epsilon(1e39) == big == embree.ray_epsilon(np.inf) == 64.0 * 2.0 ** 104


# ---------------------------------------------------------------------------
# the threaded tracer
# ---------------------------------------------------------------------------
@pytest.fixture(scope="module")
def box_scene():
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    T = np.eye(4)
    T[1, 3] = 0.5                       # the unit box standing on the ground
    scene.add(BOX, T)
    return scene


@pytest.mark.parametrize("threads, error", [(0, ValueError), (-1, ValueError), (None, TypeError),
                                            (2.5, TypeError)])
def test_embree_tracer_names_a_bad_thread_count(box_scene, threads, error):
    """Before: 0 or -1 threads raised ThreadPoolExecutor's 'max_workers must be greater than 0', None
    'int() argument must be ...', and 2.5 became 2 threads silently."""
    with pytest.raises(error, match="EmbreeTracer: threads must be"):
        embree.EmbreeTracer(box_scene, threads)


def test_embree_tracer_refuses_mismatched_rays_and_use_after_close(box_scene):
    """Before: 5 origins with 2 directions read past the directions (answers for rays never given); after
    close(), occluded() raised 'cannot schedule new futures after shutdown'."""
    tracer = embree.EmbreeTracer(box_scene, 1)
    o = np.repeat(ABOVE, 5, axis=0).astype(np.float32) - tracer.anchor.astype(np.float32)
    d = np.repeat(DOWN, 5, axis=0).astype(np.float32)
    assert tracer.occluded(o, d).all()
    with pytest.raises(ValueError, match=r"must both have shape \(n, 3\), got \(5, 3\) and \(2, 3\)"):
        tracer.occluded(o, d[:2])
    tracer.close()
    with pytest.raises(RuntimeError, match="EmbreeTracer.occluded: the tracer is closed"):
        tracer.occluded(o, d)


def test_embree_tracer_prepare_checks_its_rays(box_scene):
    """Before: a NaN point gave NaN ray origins (never occluded, silently), samples=-1 raised 'negative
    dimensions are not allowed' and too few directions a broadcasting error."""
    n = np.repeat([[0.0, 1.0, 0.0]], 2, axis=0)
    d32 = np.repeat(DOWN, 4, axis=0).astype(np.float32)
    with embree.EmbreeTracer(box_scene, 1) as tracer:
        with pytest.raises(ValueError, match="points: 1 rows are not finite"):
            tracer.prepare(np.array([[np.nan, 2.0, 0.0], [0.0, 2.0, 0.0]]), n, d32, 2)
        with pytest.raises(ValueError, match="samples must be >= 1"):
            tracer.prepare(np.zeros((2, 3)), n, d32, -1)
        with pytest.raises(ValueError, match=r"dirs32 must have shape \(4, 3\)"):
            tracer.prepare(np.zeros((2, 3)), n, d32[:3], 2)


def test_caster_scene_refuses_a_bad_anchor(box_scene):
    """Before: a NaN anchor made every caster triangle NaN (no ray ever occluded); a 2-vector raised a
    broadcasting error."""
    for bad in ([0.0, np.nan, 0.0], [0.0, 1.0]):
        with pytest.raises(ValueError, match="caster_scene: anchor must be 3 finite numbers"):
            embree.caster_scene(box_scene, bad)


# ---------------------------------------------------------------------------
# depth layers and the G-buffer
# ---------------------------------------------------------------------------
VIEWS = pyshadow.ViewSet.zigzag(4, 8)


@pytest.mark.parametrize("kw, error, match", [
    ({"frame": (np.zeros(3), 0.0)}, ValueError, "frame: radius must be finite and > 0"),
    ({"frame": (np.zeros(3), np.nan)}, ValueError, "frame: radius must be finite and > 0"),
    ({"frame": (np.zeros(2), 1.0)}, ValueError, "frame: centre must be 3 finite numbers"),
    ({"resolution": -1}, ValueError, "resolution must be >= 1"),
    ({"resolution": 2.7}, TypeError, "resolution must be an int"),
    ({"layers": -1}, ValueError, "layers must be >= 0"),
])
def test_depth_layers_names_bad_options(kw, error, match):
    """Before: radius 0 raised 'divide by zero' (RuntimeWarning), a NaN radius gave all-inf depths
    silently, resolution/layers -1 'negative dimensions are not allowed', resolution 2.7 became 2."""
    with pytest.raises(error, match=match):
        embree.depth_layers(BOX, VIEWS, **{"resolution": 4, **kw})


def test_depth_layers_checks_a_mesh_object():
    """Before: a face index past the vertices raised IndexError 'index 99 is out of bounds'; with a
    frame, a NaN vertex silently dropped its triangles (all-inf depths)."""
    bad = trimesh.Trimesh(BOX.vertices, np.r_[BOX.faces, [[0, 1, 99]]], process=False)
    with pytest.raises(ValueError, match="a face refers to a vertex that does not exist"):
        embree.depth_layers(bad, VIEWS, resolution=4)
    v = BOX.vertices.copy()
    v[0] = np.nan
    with pytest.raises(ValueError, match="vertices are not finite"):
        embree.depth_layers(trimesh.Trimesh(v, BOX.faces, process=False), VIEWS, resolution=4,
                            frame=(np.zeros(3), 1.0))


def test_embree_gbuffer_of_no_triangles_is_all_miss_and_items_are_checked():
    """Before: gbuffer([], camera) raised IndexError 'index 0 is out of bounds for axis 0 with size 0'
    (render_gbuffer returns an all-miss buffer); a NaN vertex silently removed its triangles; an item
    that is not a pair raised 'cannot unpack non-iterable Trimesh object'."""
    cam = pyshadow.camera.Camera([0, 0.5, 4], [0, 0, 0], width=8, height=6)
    g = embree.gbuffer([], cam)
    assert (g["object_id"] == -1).all() and (g["face"] == -1).all() and np.isinf(g["depth"]).all()
    assert np.isnan(g["position"]).all() and (g["normal"] == 0).all()
    assert g["depth"].shape == (6, 8) and g["position"].shape == (6, 8, 3)
    v = BOX.vertices.copy()
    v[0] = np.nan
    with pytest.raises(ValueError, match="item 0: 1 of 8 vertices are not finite"):
        embree.gbuffer([(trimesh.Trimesh(v, BOX.faces, process=False), np.eye(4))], cam)
    with pytest.raises(ValueError, match=r"item 0 must be a \(mesh, 4x4 transform\) pair"):
        embree.gbuffer([BOX], cam)


def test_visible_far_from_the_origin_matches_float64_ray_triangle_tests():
    """(Held before the fixes too.) Bodies 1e7 m from the origin, sized 1e-6 and 1e6 m: Embree's float32
    answers, asked relative to the casters' anchor, are those of a float64 ray-triangle test."""
    rng = np.random.default_rng(5)
    mesh = load_mesh(trimesh.creation.icosphere(1))
    for scale in (1e-6, 1e6):
        c = np.array([1e7, 3e6, -1e7])
        T = np.eye(4)
        T[:3, :3] *= scale
        T[:3, 3] = c
        scene = pyshadow.Scene(views=VIEWS, resolution=16)
        scene.add(mesh, T)
        p = c + rng.uniform(-1.2, 1.2, (200, 3)) * scale
        p[:, 0] = c[0] + 1.5 * scale * np.sign(rng.uniform(-1, 1, 200))       # off the sphere
        d = np.c_[-np.sign(p[:, 0] - c[0]), rng.normal(0, 0.2, (200, 2))]
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        world = (mesh.vertices @ T[:3, :3].T + T[:3, 3])[mesh.faces]      # the float64 world triangles
        t = _first_hit64(p - c, d, world - c)
        want = ~np.isfinite(t)
        assert 0.1 < want.mean() < 0.9
        np.testing.assert_array_equal(embree.visible(scene, p, d), want)


# ---------------------------------------------------------------------------
# mesh loading
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("scale", [1e-5, 1e-6, 1e-7])
def test_load_mesh_keeps_the_detail_of_a_tiny_mesh(scale):
    """Before: vertices closer than 1e-8 m (absolute) were merged: the bunny scaled to 1.6 micrometres
    kept 1,600 of its 69,451 faces (only a MeshCleanupWarning said so), to 16 cm: 10 faces."""
    bunny = pyshadow.data.mesh("stanford-bunny")
    tiny = load_mesh(trimesh.Trimesh(bunny.vertices * scale, bunny.faces, process=False))
    assert len(tiny.faces) == len(bunny.faces)
    np.testing.assert_array_equal(tiny.faces, bunny.faces)
    np.testing.assert_array_equal(tiny.vertices, bunny.vertices * scale)


@pytest.mark.parametrize("offset", [1e11, 1e12])
def test_load_mesh_far_beyond_1e11(offset):
    """Before: merging rounded v * 1e8 to int64, which overflows beyond 9.2e10: 'invalid value encountered
    in cast', and every vertex merged into one ('every face is degenerate')."""
    m = load_mesh(trimesh.Trimesh(BOX.vertices * 10.0 + offset, BOX.faces, process=False))
    assert len(m.faces) == 12


def test_load_mesh_of_a_huge_mesh():
    """Before: a box of 1e300 m raised OverflowError 'Numerical result out of range' (the area threshold
    squared), one of 1e12..1e160 m 'invalid value encountered in cast'."""
    for s in (1e12, 1e160, 1e300):
        m = load_mesh(trimesh.Trimesh(BOX.vertices * s, BOX.faces, process=False))
        assert len(m.faces) == 12
        assert bounding_sphere(m)[1] == pytest.approx(s * np.sqrt(3) / 2, rel=1e-8)


def test_normalised_vertices_names_a_bad_frame():
    """Before: radius 0 raised 'divide by zero' (RuntimeWarning), NaN gave NaN vertices silently."""
    for r in (0.0, np.nan, -1.0):
        with pytest.raises(ValueError, match="normalised_vertices: radius must be finite and > 0"):
            normalised_vertices(BOX, np.zeros(3), r)


def test_mesh_functions_name_objects_that_are_not_meshes():
    """Before: mesh_hash and check_mesh of a PointCloud or a Scene raised AttributeError ('no attribute
    faces'); stand_on_ground(radius='a') 'ufunc isfinite not supported'."""
    pc = trimesh.PointCloud(np.eye(3))
    with pytest.raises(TypeError, match="mesh_hash: expected a trimesh.Trimesh, got PointCloud"):
        mesh_hash(pc)
    with pytest.raises(TypeError, match="expected a trimesh.Trimesh, got Scene"):
        pyshadow.mesh.check_mesh(trimesh.Scene())
    with pytest.raises(TypeError, match="stand_on_ground: radius must be a number"):
        pyshadow.mesh.stand_on_ground(BOX, radius="a")


@pytest.mark.parametrize("name, k", [("stanford-bunny", -12), ("stanford-bunny", -16), ("spot", -16), ("spot", -19)])
def test_the_bounding_sphere_of_a_mesh_in_micrometres_is_that_at_size_1_scaled(name, k):
    """Extents of about 1e-6 to 5e-5 (between float32_unit's band and qhull's absolute tolerances) made
    the sphere fit fail and fall back to the box's centre: 0.8 % wider than the sphere at size 1 for
    the bunny at 2**-12, so its CSM's frame and texels were not those of the same mesh in metres. Now
    the fit sees the mesh scaled by a power of two, and the sphere (and so the CSM) is exactly the
    unit one's scaled."""
    m = pyshadow.data.mesh(name)
    s = 2.0 ** k
    small = trimesh.Trimesh(m.vertices * s, m.faces, process=False)
    c0, r0 = pyshadow.mesh.bounding_sphere(m)
    c, r = pyshadow.mesh.bounding_sphere(small)
    assert np.array_equal(c / s, c0) and r / s == r0
    views = pyshadow.ViewSet.zigzag(4, 8)
    a = pyshadow.CoherentShadowMap.build(m, views, resolution=16, progress=False)
    b = pyshadow.CoherentShadowMap.build(small, views, resolution=16, progress=False)
    for f in ("offsets", "iend", "depth"):
        assert np.array_equal(getattr(a, f), getattr(b, f)), f


def test_float32_surface_points_far_from_the_origin_leave_their_surface():
    """Was: the vertices of a unit sphere placed at (1e3, 0, -1e3), given as float32, lie up to 0.87 of a
    float32 spacing there (6e-5) off the sphere, beyond Embree's lift (1e-5, of coordinates relative to
    the anchor): 209 of 600 outward rays hit their own sphere and the AO fell to 0.81 (float64 points:
    0 and 1.0). A point float32 holds exactly is now lifted 4 spacings of its own coordinates."""
    sphere = trimesh.creation.icosphere(subdivisions=3)
    scene = pyshadow.Scene(views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    scene.add(sphere, trimesh.transformations.translation_matrix([1e3, 0.0, -1e3]))
    n = np.asarray(sphere.vertex_normals)[:600]
    p = (np.asarray(sphere.vertices)[:600] + [1e3, 0.0, -1e3]).astype(np.float32)
    assert embree.visible(scene, p, n).all()
    ao = embree.ambient_occlusion(scene, p, n, sampling=pyshadow.Sampling(16))
    assert ao.min() == 1.0
    eps = embree.surface_epsilon(scene, p)
    assert (eps == 4.0 * np.spacing(np.float32(1e3))).all()         # |coordinates| in [512, 1024)
    # float64 points off the float32 grid keep the lift of before
    q = p.astype(np.float64) + 1e-9
    assert (embree.surface_epsilon(scene, q) < eps).all()
