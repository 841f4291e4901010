"""Direct lighting at its extremes (pyshadow.lighting.shadow_map_cube, pyshadow.lighting._checks): a point light
standing on a caster's vertex, answered by the cube shadow map and checked against Embree, and light directions
given in float16. Each test's docstring says what happened before the fix."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import embree
from pyshadow.lighting import DirectionalLight, PointLight, SpotLight, point_light_radiance
from pyshadow.lighting.shadow_map import ShadowMapVisibility


def scene_of(mesh):
    sc = pyshadow.Scene(views=pyshadow.ViewSet.zigzag(2, 4), resolution=8)
    sc.add(mesh)
    return sc


def rays_to(light, points):
    d = np.asarray(light) - points
    t = np.linalg.norm(d, axis=1)
    return d / t[:, None], t


def points_around(centre, m=400):
    return np.random.default_rng(0).normal(size=(m, 3)) * 2.0 + centre


@pytest.mark.parametrize("offset", [(0.0, 0.0, 0.0), (1e4, 0.0, -1e4)])
def test_a_lamp_on_each_corner_of_a_box_lights_what_embree_lights(offset):
    """Was: a point light on the box's corners (0.5, 0, -0.5) and (0.5, 0, 0.5) was refused by the shadow map
    with "render_gbuffer: item 0 has a vertex in view 2.02e-17 from the eye, nearer than the near plane 1e-06"
    (2 of the 8 corners; the faces meeting there are seen edge-on from the light, so none counted as a near
    face, and the G-buffer's near-plane refusal met the corner itself). Now every corner answers, each of 400
    points as Embree does."""
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    box.apply_translation(np.array([0.0, 0.5, 0.0]) + offset)
    sc = scene_of(box)
    p = points_around(np.array([0.0, 0.5, 0.0]) + offset)
    for corner in box.vertices:
        w, t = rays_to(corner, p)
        got = ShadowMapVisibility(128).visible(sc, p, w, max_distance=t)
        truth = embree.visible(sc, p, w, max_distance=t)
        assert 40 < (~truth).sum() < 200
        assert (got == truth).all(), corner


def test_point_light_radiance_of_a_lamp_at_the_centre_of_a_cone_base():
    """Was: a lamp at the centre vertex of a cone's base (trimesh's cone moved by (0.1234567, 0.5, 0.7654321): a
    lamp at the centre of a round plate, where the plate's fan of triangles meets) was refused by the shadow
    map ("item 0 has a vertex in view 5.55e-17 from the eye"). Now its radiance equals Embree's on 400 points
    (0 on those the cone hides)."""
    offset = np.array([0.1234567, 0.5, 0.7654321])
    cone = trimesh.creation.cone(0.4, 0.8)
    cone.apply_translation(offset)
    sc = scene_of(cone)
    centre = cone.vertices[np.argmin(np.linalg.norm(cone.vertices - offset, axis=1))]
    assert np.abs(centre - offset).max() < 1e-15
    p = points_around(cone.centroid)
    n = rays_to(centre, p)[0]                           # facing the lamp: every point's cosine is 1
    lamp = PointLight(centre, [1.0, 2.0, 3.0])
    rad, vis = point_light_radiance(sc, p, n, lamp, 0.5, backend=ShadowMapVisibility(128))
    rad_e, vis_e = point_light_radiance(sc, p, n, lamp, 0.5, backend="embree")
    assert 0.3 < vis_e.mean() < 0.8
    np.testing.assert_array_equal(vis, vis_e)
    np.testing.assert_allclose(rad, rad_e, rtol=1e-12)


def test_a_lamp_at_a_vertex_no_face_uses():
    """Was: an open tube (a cylinder whose caps' faces were dropped, their centre vertices kept, as a mesh loaded
    with process=False keeps them) with the lamp at the top cap's centre was refused by the shadow map
    ("item 0 has a vertex in view 2.44e-17 from the eye"): no face touches the lamp. Now the floor below and
    the points around answer as Embree's."""
    cyl = trimesh.creation.cylinder(radius=0.3, height=0.4, sections=48)
    tube = trimesh.Trimesh(cyl.vertices, cyl.faces[np.abs(cyl.face_normals[:, 2]) < 0.5], process=False)
    tube.apply_transform(trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0]))
    tube.apply_translation([0.0, 1.5, 0.0])
    both = trimesh.Trimesh(tube.vertices, np.r_[tube.faces, tube.faces[:, ::-1]], process=False)   # two-sided
    sc = scene_of(both)
    lamp = tube.vertices[np.argmin(np.linalg.norm(tube.vertices - [0.0, 1.7, 0.0], axis=1))]   # the cap's centre
    assert np.abs(lamp - [0.0, 1.7, 0.0]).max() < 1e-15
    rng = np.random.default_rng(3)
    p = np.c_[rng.uniform(-4, 4, 600), np.zeros(600), rng.uniform(-4, 4, 600)]
    w, t = rays_to(lamp, p)
    n = np.tile([0.0, 1.0, 0.0], (len(p), 1))
    got = ShadowMapVisibility(256).visible(sc, p, w, max_distance=t, normals=n)
    truth = embree.visible(sc, p, w, max_distance=t)
    assert 20 < truth.sum() < 200
    # a texel's worth of rays grazing the tube's bottom rim may go either way
    assert (got != truth).sum() <= 2


@pytest.mark.parametrize("make", [lambda d: DirectionalLight(d, [1.0, 1.0, 1.0]),
                                  lambda d: SpotLight([0.0, 2.0, 0.0], 1.0, direction=-d, angle=0.5)])
def test_a_float16_unit_direction_is_a_unit_direction(make):
    """Was: the unit direction (0.48, 0.8, 0.36) given as float16 (length 0.99987: float16 rounds each component
    to 2^-11) was refused: "sun direction: not a unit vector (length 0.999873064, allowed 1 +- 1e-06)"; so was
    the spot's. Now a float input is a unit vector to 4 epsilons of its dtype (float16: 1 +- 0.0039, float32 and
    float64 unchanged at 1e-6); the light's direction is the float16 vector normalised in float64."""
    d16 = np.array([0.48, 0.8, 0.36], np.float16)
    light = make(d16)
    want = d16.astype(np.float64) / np.linalg.norm(d16.astype(np.float64))
    got = light.direction if isinstance(light, DirectionalLight) else -light.direction
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)
    with pytest.raises(ValueError, match="not a unit vector"):      # 1 % long stays refused in float16
        make(np.array([0.5, 0.8, 0.36], np.float16))
    with pytest.raises(ValueError, match="not a unit vector"):      # float32 keeps the 1e-6 tolerance
        make(np.array([0.48, 0.8, 0.36], np.float32) * np.float32(1.00001))
