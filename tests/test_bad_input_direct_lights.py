"""Direct lights and the classic shadow map (pyshadow.lighting.shadow_map, .local, .area): a point light far
from its casters, the light a kept map remembers, and the shared arguments of the local lights' radiance,
each of which used to be misread, accepted or refused by NumPy without a name."""
import re

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import embree, visibility
from pyshadow.lighting import PointLight, SpotLight, point_light_radiance
from pyshadow.lighting.area import DiscLight, RectLight, area_light_radiance
from pyshadow.lighting.shadow_map import ShadowMapVisibility


def _scene():
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(2, 4), resolution=8)
    scene.add(trimesh.creation.icosphere(2, radius=0.5), trimesh.transformations.translation_matrix([0, 1, 0]))
    return scene


@pytest.fixture(scope="module")
def ball():
    """A ball of radius 0.5 at height 1 over the ground y = 0."""
    return _scene()


def _rays(light, p):
    d = light - p
    dist = np.linalg.norm(d, axis=1)
    return d / dist[:, None], dist


@pytest.mark.parametrize("far", [1e4, 1e6])
def test_a_far_point_light_keeps_its_cube_map_shadow(ball, far):
    """A point light 1e4 or 1e6 from the ball: its cube map put the whole ball within one texel (1e4 / 32
    world units at R = 64), whose tolerance (a texel) let every ground point see the light: no shadow at
    all (0 of the ~300 shadowed points). The fitted cube agrees with Embree on all but a few points at the
    shadow's edge (0 to 3 of 3000 seen), shows no acne on the ball's lit side, and a light near the ball
    still gets the plain cube."""
    rng = np.random.default_rng(1)
    p = np.c_[rng.uniform(-1.5, 1.5, 3000), np.zeros(3000), rng.uniform(-1.5, 1.5, 3000)]
    up = np.tile([0.0, 1.0, 0.0], (len(p), 1))
    light = np.array([0.3, 1.0, 0.2]) * far
    w, dist = _rays(light, p)
    sm = ShadowMapVisibility(64)
    got = visibility.visible(ball, p, w, max_distance=dist, backend=sm, normals=up)
    truth = embree.visible(ball, p, w, max_distance=dist)
    assert 200 < (~truth).sum() < 400
    assert (got != truth).sum() <= 10
    mesh = ball.instances[0].mesh
    q = trimesh.sample.sample_surface(mesh, 2000, seed=2)[0]
    nq = q / np.linalg.norm(q, axis=1, keepdims=True)
    wq, dq = _rays(light, q + [0.0, 1.0, 0.0])
    lit = np.einsum("ij,ij->i", nq, wq) > 0.2
    assert sm.visible(ball, q[lit] + [0.0, 1.0, 0.0], wq[lit], max_distance=dq[lit], normals=nq[lit]).all()
    fitted = sm.shadow_map(ball, position=light)
    assert fitted.zoom >= 64 and fitted.zoom == 2.0 ** round(np.log2(fitted.zoom))
    assert sm.shadow_map(ball, position=[0.3, 3.0, 0.2]).zoom == 1.0


def test_a_kept_map_keeps_its_own_light_position():
    """shadow_map(position=array) kept the caller's array itself as the map's light: after the caller
    changed the array in place, the next call found the old map 'at' the new position and answered from
    the old light's cube (renders stayed 1)."""
    scene = _scene()
    sm = ShadowMapVisibility(32)
    pos = np.array([0.0, 3.0, 0.0])
    first = sm.shadow_map(scene, position=pos)
    pos[:] = [3.0, 1.0, 0.0]
    second = sm.shadow_map(scene, position=pos)
    assert sm.renders == 2 and second is not first
    np.testing.assert_array_equal(first.light, [0.0, 3.0, 0.0])
    np.testing.assert_array_equal(second.light, [3.0, 1.0, 0.0])
    # the ball lies along -x from the new light: only the -X face holds depths
    np.testing.assert_array_equal(np.isfinite(second.depth()).any(axis=(1, 2)), [False, True] + [False] * 4)


def test_shadow_map_bias_and_light_are_numbers(ball):
    """bias=True was read as a 1 world-unit bias; a light position 'abc' met NumPy's unnamed 'could not
    convert string to float' and a complex one lost its imaginary part (or raised NumPy's error)."""
    for name in ("bias", "bias_texels"):
        for value in (True, np.True_):
            with pytest.raises(ValueError, match=f"^{name} must be a finite number"):
                ShadowMapVisibility(32, **{name: value})
    sm = ShadowMapVisibility(32)
    with pytest.raises(ValueError, match="^bias must be a finite number"):
        sm.visible(ball, [[3.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]], bias=True)
    for bad in ("abc", [1.0, 2.0, 1j]):
        with pytest.raises(ValueError, match="^the light's position: expected 3 numbers"):
            sm.shadow_map(ball, position=bad)
    with pytest.raises(ValueError, match="^the light's direction: expected 3 numbers"):
        sm.shadow_map(ball, direction="up")
    assert sm.renders == 0


LIGHTS = [(point_light_radiance, PointLight([0.0, 4.0, 0.0], 1.0, radius=0.2)),
          (area_light_radiance, DiscLight([0.0, 4.0, 0.0], [0.0, -1.0, 0.0], 0.3, intensity=1.0)),
          (area_light_radiance, RectLight([0.0, 4.0, 0.0], [0.3, 0.0, 0.0], [0.0, 0.0, 0.2], intensity=1.0))]
P = np.array([[2.0, 0.0, 0.0], [3.0, 0.0, 0.0], [0.0, 0.0, 2.0]])
N = np.tile([0.0, 1.0, 0.0], (3, 1))


@pytest.mark.parametrize("fn, light", LIGHTS)
@pytest.mark.parametrize("albedo, message", [
    ([0.5, 0.5], "got shape (2,)"),
    (np.full((4, 3), 0.5), "got shape (4, 3)"),
    ("abc", "got 'abc'"),
    (0.5 + 1j, "got (0.5+1j)"),
])
def test_local_light_albedo_is_checked_by_name(ball, no_launch, fn, light, albedo, message):
    """A wrong albedo met NumPy's unnamed 'operands could not be broadcast together', 'could not convert
    string to float' or 'float() argument must be ... a real number, not complex'."""
    with pytest.raises(ValueError, match="^" + re.escape(f"albedo: expected a scalar, an RGB triple or (3, 3) "
                                                         f"values ({message})")):
        fn(ball, P, N, light, albedo, backend="embree")


@pytest.mark.parametrize("fn, light", LIGHTS)
@pytest.mark.parametrize("samples", [1, 4])
@pytest.mark.parametrize("seed", [-1, 1.5, "a"])
def test_local_light_seed_is_checked_by_name(ball, no_launch, fn, light, samples, seed):
    """seed=-1, 1.5 or 'a' met NumPy's 'expected non-negative integer' / 'SeedSequence expects int' (no
    argument named) with several samples, and was accepted unread with one."""
    with pytest.raises(ValueError, match=re.escape(f"seed: expected an int >= 0 (got {seed!r})")):
        fn(ball, P, N, light, 0.5, backend="embree", samples=samples, seed=seed)


@pytest.mark.parametrize("fn, light", LIGHTS)
def test_local_light_surface_ids_of_the_wrong_length(ball, no_launch, fn, light):
    """Four surface ids for three points met NumPy's unnamed 'operands could not be broadcast together'."""
    with pytest.raises(ValueError, match=re.escape("surface_ids must be one id or 3 (one a query), got shape (4,)")):
        fn(ball, P, N, light, 0.5, backend="embree", surface_ids=[0, 0, 0, 0])


@pytest.mark.parametrize("fn, light", LIGHTS)
@pytest.mark.parametrize("gn, message", [
    (np.tile([np.nan, 1.0, 0.0], (3, 1)), "geometric_normals: 3 rows are not finite"),
    (np.zeros((3, 3)), "geometric_normals: 3 rows are zero vectors"),
    (np.tile([0.0, 1.0, 0.0], (2, 1)), "geometric_normals has 2 rows but points has 3"),
    (np.tile([0.0, 1.0, 0.0], (1, 1)), "geometric_normals has 1 rows but points has 3"),
])
def test_local_light_geometric_normals_are_checked(ball, no_launch, fn, light, gn, message):
    """NaN geometric normals shadowed nothing (NaN <= 0 is False: the points came out lit, radiance as
    without them); zero ones shadowed everything; two rows for three points met NumPy's 'operands could
    not be broadcast' (point light) or 'cannot reshape array of size 6 into shape (3,3)' (area lights), one
    row was silently used for every point (point light)."""
    with pytest.raises(ValueError, match="^" + re.escape(message)):
        fn(ball, P, N, light, 0.5, backend="embree", geometric_normals=gn)


@pytest.mark.parametrize("fn, light", LIGHTS)
def test_local_light_valid_shared_arguments_still_shade(ball, fn, light):
    """The checks pass valid arguments through: a (3, 3) albedo, an np.int64 seed, one surface id, unit
    geometric normals give the same radiance as the plain call (the ground points here are all lit)."""
    plain, vis = fn(ball, P, N, light, [0.2, 0.4, 0.6], backend="embree", samples=4, seed=3)
    assert (vis == 1).all() and (plain > 0).all()
    same, _ = fn(ball, P, N, light, np.tile([0.2, 0.4, 0.6], (3, 1)), backend="embree", samples=4,
                 seed=np.int64(3), surface_ids=-2, geometric_normals=N)
    np.testing.assert_array_equal(same, plain)


def test_spot_light_far_from_its_caster_shadows_through_the_shadow_map(ball):
    """A spot light 1e5 above the ball, through the shadow map: the ground under the ball was lit (no
    shadow, the cube map's texel 3e3 wide); now point_light_radiance's visibility equals Embree's but for
    a few edge points, and the radiance is equal where they agree."""
    rng = np.random.default_rng(4)
    p = np.c_[rng.uniform(-1.0, 1.0, 1500), np.zeros(1500), rng.uniform(-1.0, 1.0, 1500)]
    up = np.tile([0.0, 1.0, 0.0], (len(p), 1))
    light = SpotLight([0.0, 1e5, 0.0], 1e10, direction=[0.0, -1.0, 0.0], angle=0.1)
    rad, vis = point_light_radiance(ball, p, up, light, 0.5, backend=ShadowMapVisibility(64))
    rad_e, vis_e = point_light_radiance(ball, p, up, light, 0.5, backend="embree")
    assert (vis_e == 0).sum() > 200
    assert (vis != vis_e).sum() <= 5
    same = vis == vis_e
    np.testing.assert_allclose(rad[same], rad_e[same], rtol=1e-12)


def test_lights_radiance_checks_its_points_and_lighting(ball):
    """lights_radiance with no local lights gave a (3, 3) array of zeros for one point of shape (3,) (its
    three coordinates read as three points) and (2, 3) zeros for (2, 2) points; lighting=None met
    AttributeError: 'NoneType' object has no attribute 'lights'."""
    from pyshadow.lighting import Lighting
    from pyshadow.lighting.local import lights_radiance

    up = np.array([[0.0, 1.0, 0.0]])
    with pytest.raises(ValueError, match=re.escape("points must have shape (N, 3), got (3,)")):
        lights_radiance(ball, np.zeros(3), up[0], Lighting(), 0.5)
    with pytest.raises(ValueError, match=re.escape("points must have shape (N, 3), got (2, 2)")):
        lights_radiance(ball, np.zeros((2, 2)), up[:, :2], Lighting(), 0.5)
    for bad in (None, "sun"):
        with pytest.raises(TypeError, match="^lighting: expected a pyshadow.lighting.Lighting"):
            lights_radiance(ball, P, N, bad, 0.5)
    np.testing.assert_array_equal(lights_radiance(ball, P, N, Lighting(), 0.5), np.zeros((3, 3)))


@pytest.mark.parametrize("make, message", [
    (lambda: PointLight([True, False, True], 1.0), "light position: expected a finite 3-vector"),
    (lambda: PointLight([0.0, 1.0, 0.0], np.array([True, True, False])), "light intensity: expected an RGB"),
    (lambda: SpotLight([0.0, 1.0, 0.0], True, direction=[0.0, -1.0, 0.0]), "light intensity: expected an RGB"),
    (lambda: DiscLight([0.0, 1.0, 0.0], [0.0, -1.0, 0.0], 0.5, power=True), "light power: expected an RGB"),
    (lambda: RectLight([0.0, 1.0, 0.0], [True, False, False], [0.0, 0.0, 1.0], intensity=1.0),
     "rectangle light edge u: expected a finite 3-vector"),
])
def test_light_vectors_are_not_booleans(make, message):
    """Booleans were read as numbers: PointLight([True, False, True], 1.0) stood at (1, 0, 1), an intensity
    or power True was 1, an edge [True, False, False] was the unit x edge."""
    with pytest.raises(ValueError, match="^" + re.escape(message)):
        make()
