"""A map without a sun: Lighting.from_environment adds no light whose shadow rays can add nothing."""
import numpy as np
import pytest
import trimesh

import pyshadow
import pyshadow.lighting as L
from pyshadow import visibility


def _scene():
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    csm = pyshadow.CoherentShadowMap.build(box, pyshadow.ViewSet.zigzag(4, 8), resolution=16, progress=False)
    scene = pyshadow.Scene(ground=0.0)
    scene.add(csm, trimesh.transformations.translation_matrix([0.0, 0.5, 0.0]), mesh=box)
    return scene


@pytest.mark.parametrize("env", [L.EnvironmentMap(np.full((16, 32, 3), 0.7)), L.overcast_sky(height=32),
                                 L.EnvironmentMap(np.zeros((8, 16, 3)))], ids=["flat", "overcast", "black"])
@pytest.mark.parametrize("mode", ["bent", "sampled"])
def test_a_map_without_a_sun_gets_no_sun_and_traces_none(monkeypatch, env, mode):
    """Was: from_environment kept the extracted sun of zero irradiance as a DirectionalLight, whose shadow rays
    every shade and render traced (a sampled render of an overcast sky 1.0 s against 0.5 s without it) for an
    image equal to the one without it, bit for bit."""
    lit = L.Lighting.from_environment(env, mode=mode)
    assert lit.sun is None
    scene = _scene()
    rng = np.random.default_rng(0)
    p = np.c_[rng.uniform(-2, 2, 200), np.zeros(200), rng.uniform(-2, 2, 200)]
    n = np.tile([0.0, 1.0, 0.0], (200, 1))
    sampling = pyshadow.Sampling(8)
    plain = L.shade_terms(scene, p, n, L.Lighting.from_environment(env, extract=False, mode=mode), sampling=sampling)
    calls = []
    real = visibility.visible
    monkeypatch.setattr(visibility, "visible", lambda *a, **k: calls.append(len(a[1])) or real(*a, **k))
    got = L.shade_terms(scene, p, n, lit, sampling=sampling)
    assert sum(calls) <= (len(p) * sampling.samples if mode == "sampled" else 0)      # the sky's own rays only
    np.testing.assert_array_equal(got.radiance, plain.radiance)


def test_a_map_with_a_sun_keeps_it():
    """Guard: a sun disc on a sky is still extracted, with its irradiance."""
    d = L.latlong_directions(64, 128)
    img = np.full((64, 128, 3), 0.5)
    sd = np.array([0.3, 0.8, 0.2]) / np.linalg.norm([0.3, 0.8, 0.2])
    img[(d @ sd) > np.cos(0.06)] = 500.0
    lit = L.Lighting.from_environment(L.EnvironmentMap(img))
    assert lit.sun is not None and (lit.sun.irradiance > 1.0).all()
    assert np.degrees(np.arccos(np.clip(lit.sun.direction @ sd, -1, 1))) < 2.0
