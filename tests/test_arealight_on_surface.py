"""An area light lying on a surface (a lamp on a table top, a panel set in the floor): the surface's own points
under it lie on the light's plane within its extent, facing the way it emits."""
import math

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import visibility
from pyshadow.lighting import DiscLight, Lighting, RectLight
from pyshadow.lighting.area import area_light_radiance

BOX = trimesh.creation.box((1.0, 1.0, 1.0))


def test_points_under_a_light_lying_on_their_surface_get_none(monkeypatch):
    """Was: ValueError "lies on the DiscLight's plane within its extent ... its irradiance is undefined" for
    points of the lid a disc light lies on (facing up, as their normals): every direction from them to the
    light lies in its plane, where it emits nothing (E = 0, and 0 just in front of it too). Now 0, lit share
    0, no ray; points facing into the light (normal -n_L: about pi L just in front, 0 behind) are still
    refused."""
    calls = []
    monkeypatch.setattr(visibility, "visible", lambda *a, **k: calls.append(1))
    scene = pyshadow.Scene(ground=0.0)
    rng = np.random.default_rng(1)
    for light in (DiscLight([1.5, 1.0, 0.0], [0.0, 1.0, 0.0], 0.3, intensity=1.0),
                  RectLight.facing([0.0, 0.0, 2.0], [0.0, 1.0, 0.0], 1.0, 0.5, intensity=1.0),
                  RectLight([1e4, 2.0, -3.0], [0.0, 0.0, 0.25], [0.0, 0.4, 0.0], intensity=1.0)):   # a wall lamp, x far
        ab = rng.uniform(-0.7, 0.7, (50, 2))
        p = light.sample(ab)
        q = p - light.position
        np.testing.assert_allclose(q @ light.normal, 0.0, atol=1e-12 * np.abs(light.position).max())
        for n in (np.tile(light.normal, (50, 1)), light.normal + rng.uniform(-0.3, 0.3, (50, 3))):
            rad, vis = area_light_radiance(scene, p, n, light, 0.5, samples=16)
            assert (rad == 0).all() and (vis == 0).all()
            rad, vis = area_light_radiance(scene, p + 1e-7 * light.normal, np.tile(light.normal, (50, 1)),
                                           light, 0.5, samples=16)
            assert (rad == 0).all()                                # just in front, facing along n_L: 0 as well
        with pytest.raises(ValueError, match="facing into the light"):
            area_light_radiance(scene, p, -np.tile(light.normal, (50, 1)), light, 0.5)
    assert not calls


def test_render_with_a_disc_lying_on_a_box_lid():
    """Was: rendering a scene with a disc light lying on a box's lid (test_light_on_a_surface.py's setup) failed
    with ValueError "point 651 lies on the DiscLight's plane within its extent (22 such points)" for the lid's
    pixels under the disc; a floor panel on the ground failed the same way (46 points). Now the frame renders;
    the lid's pixels under the disc get no light from it (their radiance equals the frame's without the
    light) and the sphere beside it is lit."""
    s = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(8, 16), resolution=32)
    s.add(trimesh.creation.icosphere(2, radius=0.5), trimesh.transformations.translation_matrix([0, 1, 0]))
    s.add(BOX, trimesh.transformations.translation_matrix([1.5, 0.5, 0]))
    cam = pyshadow.Camera(eye=[1.5, 4.0, 3.0], target=[1.0, 0.5, 0.0], width=48, height=36)
    disc = DiscLight([1.5, 1.0, 0.0], [0.0, 1.0, 0.0], 0.3, intensity=10.0)
    frames = [pyshadow.render.render(s, cam, visibility="embree", sampling=pyshadow.Sampling(4),
                                     lighting=Lighting(lights=lights, straddle="embree")) for lights in ([disc], [])]
    pos = frames[0].position
    under = (np.abs(pos[..., 1] - 1.0) < 1e-6) & (np.hypot(pos[..., 0] - 1.5, pos[..., 2]) < 0.3)
    assert under.sum() >= 10
    np.testing.assert_array_equal(frames[0].radiance[under], frames[1].radiance[under])
    sphere = np.isfinite(pos[..., 0]) & (np.linalg.norm(np.nan_to_num(pos) - [0, 1, 0], axis=-1) < 0.51)
    lit = (frames[0].radiance - frames[1].radiance)[sphere].max(axis=-1)
    assert (lit > 0).sum() >= 10 and math.isfinite(lit.max())
