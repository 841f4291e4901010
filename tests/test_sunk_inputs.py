"""Inputs a user types that were accepted silently or refused unclearly: a Lighting's albedos naming an instance
the scene never held (the albedo coloured nothing), and tonemap(exposure="Auto") (refused as "must be a number",
though "auto" is one of its values)."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.lighting import (DirectionalLight, Lighting, PhongLighting, phong_shade, reference_radiance, shade,
                               tonemap)

P, N = np.array([[3.0, 0.0, 3.0]]), np.array([[0.0, 1.0, 0.0]])
SUN = DirectionalLight([0.0, 1.0, 0.0], 2.0)


@pytest.fixture(scope="module")
def scene():
    s = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(8, 16), resolution=16)
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    s.add(box, trimesh.transformations.translation_matrix([0.0, 0.5, 0.0]))
    s.add(box, trimesh.transformations.translation_matrix([2.0, 0.5, 0.0]))
    return s


CAMERA = pyshadow.Camera(eye=[3.0, 2.0, 3.0], target=[0.0, 0.3, 0.0], width=8, height=6)


@pytest.mark.parametrize("call", ["render", "shade_terms", "reference_radiance", "phong_shade"])
def test_albedos_of_an_id_the_scene_never_held_are_refused(scene, call):
    light = Lighting(sun=SUN, albedos={0: 0.2, 7: 0.5})
    with pytest.raises(ValueError, match=r"Lighting\(albedos=\) names instance id 7, which the scene has never "
                                         r"held \(its instance ids: 0 \.\. 1"):
        if call == "render":
            pyshadow.render.render(scene, CAMERA, lighting=light, sampling=pyshadow.Sampling(4))
        elif call == "shade_terms":
            shade(scene, P, N, light)
        elif call == "reference_radiance":
            reference_radiance(scene, P, N, light, samples=4)
        else:
            phong_shade(scene, P, N, [0.0, 5.0, 0.0], PhongLighting([0.0, 4.0, 0.0], albedos={7: 0.5}, ao="off"))


def test_albedos_of_a_removed_instance_are_accepted(scene):
    """Scene.remove keeps ids (not given again): an albedo for a removed body colours nothing, and a lighting
    kept across the removal still shades; ids the scene holds shade as before."""
    s = scene.__copy__()
    s.remove(1)
    light = Lighting(sun=SUN, albedos={0: 0.2, 1: 0.5})
    np.testing.assert_array_equal(shade(s, P, N, light, surface_ids=-2),
                                  shade(s, P, N, Lighting(sun=SUN, albedos={0: 0.2}), surface_ids=-2))
    f = pyshadow.render.render(s, CAMERA, lighting=light, sampling=pyshadow.Sampling(4))
    assert np.isfinite(f.radiance).all()


@pytest.mark.parametrize("exposure", ["Auto", "AUTO", " auto", "auto "])
def test_tonemap_names_auto_written_otherwise(exposure):
    with pytest.raises(ValueError, match=r"exposure: expected a number > 0 or 'auto' \(lower case, no spaces; "
                                         r"got '" + exposure.replace(" ", r"\s") + "'"):
        tonemap(np.ones((2, 2, 3)), exposure=exposure)
    assert tonemap(np.ones((2, 2, 3)), exposure="auto").shape == (2, 2, 3)


@pytest.mark.parametrize("points", [P, np.zeros((0, 3))])
def test_shade_checks_sampling_where_no_ao_is_asked(scene, points):
    """A Lighting without a sky asks no AO: its ``sampling=16`` (or any non-Sampling) went unread and unrefused;
    with a sky (or in render) it was a TypeError."""
    with pytest.raises(TypeError, match="sampling must be a pyshadow.Sampling, got 16"):
        shade(scene, points, np.tile([0.0, 1.0, 0.0], (len(points), 1)), Lighting(sun=SUN), sampling=16)


@pytest.mark.parametrize("extract", [True, False])
def test_from_environment_names_sun_radius(extract):
    """A bad sun_radius was refused as "radius: ..." (extract_sun's own name), and not at all with extract=False."""
    from pyshadow.lighting import EnvironmentMap

    env = EnvironmentMap(np.ones((8, 16, 3)))
    with pytest.raises(ValueError, match=r"^sun_radius: must be a finite number > 0 \(got -1.0\)"):
        Lighting.from_environment(env, sun_radius=-1.0, extract=extract)
