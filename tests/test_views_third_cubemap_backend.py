"""The cube-map visibility backend over probes built for either estimator: its rays are always marched
(the "raymarch" rule), so the horizon estimator's own options must not reach the march. Reference: the
same rays marched through the same probe by raymarch_visible directly."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.cubemap import CubeMapAO, CubeMapVisibility, raymarch_visible

D = 1.0
CENTRE = (0.0, 1.0, 1.0)


@pytest.fixture(scope="module")
def scene():
    """Ground y = 0 and a 0.3 box on it, beside the probe."""
    sc = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    sc.add(trimesh.creation.box((0.3, 0.3, 0.3)), trimesh.transformations.translation_matrix([0.5, 0.15, 0.0]))
    return sc


def _rays():
    """Two floor points beside the box; one ray towards it (occluded), one away (open)."""
    P = np.array([[0.2, 0.0, 0.0], [0.0, 0.0, 0.3]])
    W = np.array([[1.0, 0.1, 0.0], [-1.0, 0.2, 0.0]])
    return P, W / np.linalg.norm(W, axis=1, keepdims=True)


@pytest.mark.parametrize("options", [dict(estimator="horizon", directions=8, steps=8),
                                     dict(estimator="horizon", steps=4),
                                     dict(estimator="raymarch", directions=6, bias=2e-3)])
def test_backend_over_maps_with_horizon_options_marches_its_rays(scene, options):
    """Was: TypeError "raymarch_visible() got multiple values for argument 'directions'" from every
    visible() and ambient_occlusion() of a CubeMapVisibility over a CubeMapAO built with the horizon
    estimator's ``directions=`` (its ``steps=``: TypeError "march_defaults() got an unexpected keyword
    argument 'steps'"), though the backend's estimator "does not matter". Now the rays are marched with
    the maps' march options only, as raymarch_visible marches them."""
    maps = CubeMapAO(scene, D, resolution=16, sampling=pyshadow.Sampling(4), device=False, **options)
    maps.add_probe(CENTRE)
    march = {k: v for k, v in options.items() if k in ("bias",)}
    backend = CubeMapVisibility(maps, unseen="open")
    P, W = _rays()
    got = backend.visible(scene, P, W)
    ref = raymarch_visible(maps.probes[0], P, W, D, device=False, **march)
    assert got.tolist() == ref.tolist() == [False, True]
    n = np.array([[0.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
    ao = backend.ambient_occlusion(scene, P, n, sampling=pyshadow.Sampling(16))
    dirs = pyshadow.Sampling(16).directions(n).astype(np.float64)
    vis = raymarch_visible(maps.probes[0], np.repeat(P, 16, axis=0), dirs.reshape(-1, 3), D, device=False, **march)
    np.testing.assert_array_equal(ao, vis.reshape(2, 16).mean(axis=1).astype(np.float32))
    assert ao[0] < 1.0                                           # the box occludes some of the first point's rays
    assert maps.march_options == march


def test_march_options_of_probes_without_ao_are_checked_when_built(scene):
    """Was: CubeMapAO(estimator=None, step=10.0) was built (its march options were checked only for the
    raymarch estimator), and every query of its CubeMapVisibility then raised "step must be in (0, 4]
    texels". Now the maps refuse it when built, as with estimator="raymarch"."""
    with pytest.raises(ValueError, match="step must be in"):
        CubeMapAO(scene, D, resolution=16, estimator=None, step=10.0)
    with pytest.raises(ValueError, match="step must be in"):
        CubeMapAO(scene, D, resolution=16, estimator="raymarch", step=10.0)


@pytest.mark.parametrize("options, error, match", [(dict(directions=0), ValueError, "directions must be an int"),
                                                   (dict(steps=1000), ValueError, "steps must be an int"),
                                                   (dict(thickness=0.1), TypeError, "takes no thickness")])
def test_horizon_options_are_checked_before_a_probe_is_rendered(scene, options, error, match):
    """Was: CubeMapAO(estimator="horizon", directions=0) (or steps=1000, or a march option such as
    thickness=) was built, and each add_probe rendered its six faces before texel_ao refused the option
    (the probe's render lost). Now the maps refuse it when built, as the march options already were."""
    with pytest.raises(error, match=match):
        CubeMapAO(scene, D, resolution=16, estimator="horizon", **options)
    maps = CubeMapAO(scene, D, resolution=16, estimator="horizon", directions=4, steps=2)
    maps.add_probe(CENTRE)
    assert np.isfinite(maps.ao_maps[0]).any()
