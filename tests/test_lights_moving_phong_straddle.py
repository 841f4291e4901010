"""Thesis 000's Phong light (pyshadow.lighting.phong) moved into a caster's bounding sphere: the refusal names the
setting that answers it, and following that advice answers as Embree."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.lighting.phong import PhongLighting, phong_shade


def test_a_lamp_inside_a_casters_sphere_names_phong_lightings_straddle():
    """Was: the refusal advised "pass straddle='embree'", a keyword phong_shade does not take (a TypeError for the
    user who followed it); the setting is PhongLighting(straddle='embree'), which answers as Embree."""
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(2, 4), resolution=8)
    scene.add(trimesh.creation.box((0.6, 1.0, 0.6)), trimesh.transformations.translation_matrix([0, 0.5, 0]))
    p = np.c_[np.linspace(-2.0, 2.0, 41), np.zeros(41), np.full(41, 0.2)]
    up = np.tile([0.0, 1.0, 0.0], (len(p), 1))
    eye = np.array([0.0, 3.0, 4.0])
    lamp = PhongLighting([0.45, 0.5, 0.0], ao="off")          # beside the box, within its bounding sphere
    with pytest.raises(ValueError, match=r"pass PhongLighting\(straddle='embree'\)") as err:
        phong_shade(scene, p, up, eye, lamp)
    assert "pass straddle=" not in str(err.value)
    lamp = lamp.replace(straddle="embree")
    c, _, v = phong_shade(scene, p, up, eye, lamp)
    c_e, _, v_e = phong_shade(scene, p, up, eye, lamp, backend="embree")
    np.testing.assert_array_equal(v, v_e)
    np.testing.assert_array_equal(c, c_e)
    assert 5 < (v == 0).sum() < 30
