"""PhongLighting with an ambient colour of 0: its ambient factor A weighs nothing, so none is asked."""
import numpy as np
import pytest

import pyshadow.visibility as vis
from pyshadow.lighting import ShadowMapVisibility
from pyshadow.lighting.phong import PhongLighting, phong_shade
from pyshadow.render import render
from test_leftovers_gbuffer_background import box_scene

LIGHT = [1.0, 3.0, 0.5]


@pytest.fixture(scope="module")
def setup():
    return box_scene()


@pytest.mark.parametrize("mode", ["ao", "normal"])
@pytest.mark.parametrize("ambient", [0.0, (0, 0, 0)])
def test_zero_ambient_shades_on_a_shadow_map(setup, mode, ambient):
    """Was: ValueError "render: the lighting needs ambient occlusion for its ambient term (ao='ao'), and the
    visibility backend <ShadowMapVisibility ...> answers only light rays" although A is multiplied by a zero
    ambient colour. The colour is that of ao="off" (A = 1 times 0); Frame.ao is NaN on covered pixels, as for
    every lighting needing no AO on such a backend."""
    scene, cam = setup
    sm = ShadowMapVisibility(64)
    got = render(scene, cam, visibility=sm, lighting=PhongLighting(LIGHT, ambient=ambient, ao=mode), ground_size=4.0)
    want = render(scene, cam, visibility=sm, lighting=PhongLighting(LIGHT, ambient=ambient, ao="off"), ground_size=4.0)
    np.testing.assert_array_equal(got.radiance, want.radiance)
    assert np.isfinite(got.radiance).all() and (got.radiance > 0).any()
    assert np.isnan(got.ao[got.object_id != -1]).all()


def test_nonzero_ambient_with_ao_is_still_refused_on_a_shadow_map(setup):
    scene, cam = setup
    with pytest.raises(ValueError, match=r"needs ambient occlusion for its ambient term \(ao='ao'\)"):
        render(scene, cam, visibility=ShadowMapVisibility(64), lighting=PhongLighting(LIGHT, ambient=(0, 0, 0.1)),
               ground_size=4.0)


def test_zero_ambient_traces_no_normal_rays(setup, monkeypatch):
    """Was: ao="normal" traced one ray along every normal for a factor multiplied by 0 (its colour unchanged)."""
    scene, _ = setup
    p = np.array([[0.3, 0.0, 1.2], [1.5, 0.0, -0.2], [0.2, 1.0, 0.1]])
    n = np.array([[0.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
    calls = []
    real = vis.visible
    monkeypatch.setattr(vis, "visible", lambda *a, **k: calls.append(len(a[1])) or real(*a, **k))
    lt = PhongLighting(LIGHT, ambient=0.0, ao="normal", specular=0.3)
    c, a, v = phong_shade(scene, p, n, [2.0, 2.0, 2.0], lt, backend="embree")
    assert calls == [3]                                     # the light's shadow rays only
    off, _, v_off = phong_shade(scene, p, n, [2.0, 2.0, 2.0], PhongLighting(LIGHT, ambient=0.0, ao="off",
                                                                            specular=0.3), backend="embree")
    np.testing.assert_array_equal(c, off)
    np.testing.assert_array_equal(v, v_off)
    assert np.isnan(a).all()


def test_zero_ambient_needs_no_ao_values(setup):
    """phong_shade with ao="ao" and ambient 0: no AO given, or NaN (Frame.ao where none was asked), gives the
    colour of any AO; given values are still checked and returned as A."""
    scene, _ = setup
    p, n, eye = np.array([[0.3, 0.0, 1.2]]), np.array([[0.0, 1.0, 0.0]]), [2.0, 2.0, 2.0]
    lt = PhongLighting(LIGHT, ambient=0.0, specular=0.3)
    c, a, _ = phong_shade(scene, p, n, eye, lt, backend="embree")
    c_nan, _, _ = phong_shade(scene, p, n, eye, lt, [np.nan], backend="embree")
    c_half, a_half, _ = phong_shade(scene, p, n, eye, lt, [0.5], backend="embree")
    np.testing.assert_array_equal(c, c_half)
    np.testing.assert_array_equal(c_nan, c_half)
    assert np.isnan(a).all() and a_half.tolist() == [0.5]
    with pytest.raises(ValueError, match=r"ao: expected \(1,\) values in \[0, 1\]"):
        phong_shade(scene, p, n, eye, lt, [1.5], backend="embree")
    with pytest.raises(ValueError, match="ao: the AO values are needed with ao='ao'"):
        phong_shade(scene, p, n, eye, PhongLighting(LIGHT, ambient=0.1), backend="embree")
