"""Smooth-normal AO's bent normal of a fully occluded point, and bools refused as albedos (shading, round 2)."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import Sampling, load_mesh
from pyshadow import visibility as vis
from pyshadow.lighting import Lighting
from pyshadow.shading_normals import ambient_occlusion


@pytest.fixture(scope="module")
def closed_box():
    scene = pyshadow.Scene(views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)     # quick to build
    scene.add(load_mesh(trimesh.creation.box(extents=[2.0, 2.0, 2.0])), np.eye(4))
    return scene


@pytest.mark.parametrize("length", [1.0, 2.0, 1e-3])
def test_bent_normal_of_a_fully_occluded_tilted_point_is_the_unit_normal(closed_box, length):
    """Was: a point with every direction occluded (inside a closed box, on Embree) whose shading normal
    differs from its geometric one came back with the shading normal as given for its bent normal:
    (0.3, 1, 0) of length 1.044, (0.6, 2, 0) and (3e-4, 1e-3, 0) (length 1e-3), where
    ``visibility.ambient_occlusion`` (and the untilted points) give the unit normal (0.287, 0.958, 0)."""
    p = np.array([[0.0, 0.0, 0.0], [0.1, 0.2, 0.0]])
    ng = np.array([[0.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
    n = np.array([[0.3, 1.0, 0.0], [0.0, 1.0, 0.0]]) * length
    s = Sampling(16)
    ao, bent = ambient_occlusion(closed_box, p, n, ng, backend="embree", sampling=s)
    plain_ao, plain_bent = vis.ambient_occlusion(closed_box, p, n, backend="embree", sampling=s,
                                                 return_bent_normals=True)
    np.testing.assert_array_equal(ao, [0.0, 0.0])
    np.testing.assert_array_equal(plain_ao, [0.0, 0.0])
    np.testing.assert_allclose(np.linalg.norm(bent.astype(np.float64), axis=1), 1.0, atol=1e-6)
    np.testing.assert_array_equal(bent, plain_bent)       # the same unit normal as the backend's, bit for bit


@pytest.mark.parametrize("kw", [dict(albedo=True), dict(albedo=np.True_), dict(ground_albedo=(True, False, True)),
                                dict(albedos={0: np.array([True, True, False])})])
def test_bools_are_no_albedo(kw):
    """Was: ``Lighting(albedo=True)`` was taken as albedo 1 (white) and ``(True, False, True)`` as
    (1, 0, 1), while ``phong_shade(albedo=True)``, the lights' intensities and colours refuse bools."""
    with pytest.raises(ValueError, match="albedo"):
        Lighting(**kw)
    with pytest.raises(ValueError, match="albedo"):
        pyshadow.lighting.PhongLighting([0.0, 1.0, 0.0], **kw)


def test_ordinary_albedos_still_accepted():
    lt = Lighting(albedo=np.array([0, 1, 0], np.uint8), ground_albedo=0.25, albedos={3: (0.1, 0.2, 0.3)})
    np.testing.assert_array_equal(lt.albedo, [0.0, 1.0, 0.0])
    np.testing.assert_array_equal(lt.albedos[3], [0.1, 0.2, 0.3])
