"""ShadowMapVisibility.shadow_map(direction=...) of any length: a direction whose square leaves float64."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.lighting.shadow_map import ShadowMapVisibility


@pytest.fixture(scope="module")
def box_scene():
    sc = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(2, 4), resolution=8)
    sc.add(trimesh.creation.box([1, 1, 1]), trimesh.transformations.translation_matrix([0, 1, 0]))
    return sc


@pytest.mark.parametrize("scale", [1e200, 1e-200])
def test_a_direction_of_any_length_is_the_same_light(box_scene, scale):
    """Was: the direction was divided by np.linalg.norm, whose square overflows or underflows:
    (0.3, 1, 0.2) * 1e200 came out as the light [0, 0, 0] (a frame of NaN, RuntimeWarnings from the fit),
    * 1e-200 was refused as 'the light's direction must not be zero'. Now both are the unit direction, and
    the map is the one of (0.3, 1, 0.2) (kept: no second render)."""
    d = np.array([0.3, 1.0, 0.2])
    smv = ShadowMapVisibility(64)
    ref = smv.shadow_map(box_scene, direction=d)
    got = smv.shadow_map(box_scene, direction=d * scale)
    np.testing.assert_allclose(got.light, d / np.linalg.norm(d), rtol=0, atol=1e-15)
    assert got is ref and smv.renders == 1
    fresh = ShadowMapVisibility(64).shadow_map(box_scene, direction=d * scale)
    np.testing.assert_array_equal(fresh.depth(), ref.depth())
    assert np.isfinite(fresh.frame).all() and np.isfinite(fresh.depth()).sum() > 100
    with pytest.raises(ValueError, match="must not be zero"):       # a zero direction is still refused
        ShadowMapVisibility(64).shadow_map(box_scene, direction=d * 0.0)
