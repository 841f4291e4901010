"""Forms a user writes: Scene.render(lighting=), a grey sun irradiance, one light not in a list."""
import numpy as np
import pytest
import trimesh

import pyshadow
import pyshadow.lighting as L


def test_scene_render_takes_lighting_as_render_does():
    """Was: Scene.render(camera, lighting=...) raised TypeError (only pyshadow.render.render took lighting=).
    Now the same frame, bit for bit."""
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    scene.add(box, trimesh.transformations.translation_matrix([0.0, 0.5, 0.0]))
    cam = pyshadow.Camera(eye=[0.0, 2.0, 4.0], target=[0.0, 0.3, 0.0], width=32, height=24)
    light = L.Lighting(L.EnvironmentMap(np.full((8, 16, 3), 0.5)), sun=L.DirectionalLight([0.3, 0.9, 0.3] /
                       np.linalg.norm([0.3, 0.9, 0.3]), 3.0))
    s = pyshadow.Sampling(8)
    got = scene.render(cam, sampling=s, lighting=light)
    want = pyshadow.render.render(scene, cam, sampling=s, lighting=light)
    assert got.radiance is not None and (got.radiance > 0).any()
    np.testing.assert_array_equal(got.radiance, want.radiance)
    np.testing.assert_array_equal(got.ao, want.ao)


def test_a_scalar_sun_irradiance_is_grey():
    """Was: DirectionalLight(d, 3.0) refused ('expected an RGB 3-vector') where PointLight(p, 3.0) took a
    scalar as grey."""
    d = np.array([0.0, 1.0, 0.0])
    np.testing.assert_array_equal(L.DirectionalLight(d, 3.0).irradiance, [3.0, 3.0, 3.0])
    np.testing.assert_array_equal(L.DirectionalLight(d, np.float32(0.5)).irradiance, [0.5, 0.5, 0.5])
    with pytest.raises(ValueError, match="must be finite and >= 0"):
        L.DirectionalLight(d, -1.0)
    with pytest.raises(ValueError, match="an RGB 3-vector or a scalar"):
        L.DirectionalLight(d, [1.0, 2.0])


def test_one_light_not_in_a_list_says_so():
    """Was: Lighting(lights=PointLight(...)) said only 'expected point, spot, disc or rectangle lights (got
    PointLight(...))', as if a point light were not one; now it names the sequence."""
    with pytest.raises(TypeError, match=r"in a sequence \(one light: lights=\[light\]\)"):
        L.Lighting(lights=L.PointLight([0.0, 1.0, 0.0], 3.0))
    with pytest.raises(TypeError, match=r"rectangle lights \(got 5\)"):
        L.Lighting(lights=5)
