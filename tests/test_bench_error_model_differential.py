"""Differential checks of the bench's measurements (pyshadow.bench.measure) against independent computations."""
from __future__ import annotations

import numpy as np


def test_from_render_far_camera_points_on_faces():
    """A camera 1e3 times farther than the default one (about 5e3 units from the scene, the view
    narrowed to keep the framing): ``GBuffer.from_render`` built its points from the frame's float32
    depth, up to 7.9e-4 off the points ``Scene.render`` shades (``pyshadow.surface_points``: on the
    faces' planes in float64). The bench's Embree reference on them differed in 189 of 1200 pixels
    (mean AO 0.54 instead of 0.67: rays started behind their surfaces), so every figure measured
    against it was wrong. ``from_render`` had no way to take the scene (TypeError). Now, given the
    scene, its points are ``surface_points``' bit for bit, and so is Embree's AO on them."""
    import pyshadow
    from pyshadow import embree
    from pyshadow.bench import GBuffer
    from pyshadow.data import default_scene
    from pyshadow.render import surface_points

    scene, _ = default_scene(views=pyshadow.ViewSet.zigzag(4, 8), resolution=16, width=40, height=30)
    eye0, target = np.array([2.4, 2.1, 4.8]), np.array([0.8, 0.5, 0.0])
    camera = pyshadow.Camera(target + 1e3 * (eye0 - target), target, fov_y=0.045, width=40, height=30)
    out = scene.render(camera, sampling=pyshadow.Sampling(1))
    gb = GBuffer.from_render(out, camera, scene)
    want = surface_points(scene, camera)
    assert gb.n == 1200
    np.testing.assert_array_equal(gb.sel, want.index)
    np.testing.assert_array_equal(gb.points, want.points)
    sampling = pyshadow.Sampling(12, "halton", patterns=64, seed=3)
    got = embree.ambient_occlusion(scene, gb.points, gb.normals, indices=gb.sel, sampling=sampling)
    ref = embree.ambient_occlusion(scene, want.points, gb.normals, indices=gb.sel, sampling=sampling)
    np.testing.assert_array_equal(got, ref)
    assert abs(float(got.mean()) - 0.673) < 0.01           # as at the ordinary distance (0.656), not 0.54


def test_from_render_ordinary_camera_unchanged_by_scene():
    """At an ordinary distance the scene changes nothing: the float32 depths already place the points."""
    import pyshadow
    from pyshadow.bench import GBuffer
    from pyshadow.data import default_scene

    scene, camera = default_scene(views=pyshadow.ViewSet.zigzag(4, 8), resolution=16, width=24, height=18)
    out = scene.render(camera, sampling=pyshadow.Sampling(1))
    a, b = GBuffer.from_render(out, camera), GBuffer.from_render(out, camera, scene)
    assert a.n > 0 and a.digest() == b.digest()
