"""Bad and extreme input to the environment lighting: maps, skies, the sun's extraction, SH, transfer, cubes.

Each test names what happened before in its docstring; valid input is unchanged (the audit compared
hashes of every touched function's output on ordinary input before and after).
"""
import math
import warnings

import numpy as np
import pytest

from pyshadow.lighting import EnvironmentMap, Lighting, clear_sky, cube, extract_sun, overcast_sky, sh_transfer
from pyshadow.lighting.sh import latlong_basis_integrals

UP = [0.0, 1.0, 0.0]


@pytest.mark.parametrize("flag", ["no", "False", 0, 1, None, np.array([True, False]), [False]])
def test_clear_sky_sun_must_be_a_bool(flag):
    """clear_sky(..., sun="no") (or "False", [False], 1) was taken as true and drew the sun's disc
    (its energy, sun_irradiance, added to the map); None or 0 as false; an array raised NumPy's "truth value of an array
    ... is ambiguous", naming no argument."""
    with pytest.raises(TypeError, match=r"sun: expected True or False \(got "):
        clear_sky(UP, height=4, sun=flag)


def test_clear_sky_sun_takes_numpy_bools():
    for value in (True, False):
        np.testing.assert_array_equal(clear_sky(UP, height=4, sun=np.bool_(value)).radiance,
                                      clear_sky(UP, height=4, sun=value).radiance)
    from pyshadow.lighting import sun_irradiance

    drawn = clear_sky(UP, height=4, sun=np.bool_(True)).integral() - clear_sky(UP, height=4, sun=False).integral()
    np.testing.assert_allclose(drawn, sun_irradiance(UP), rtol=1e-9)         # the disc's energy, to rounding


@pytest.mark.parametrize("env", [overcast_sky(height=4), overcast_sky(height=4, ground_albedo=0.2),
                                 EnvironmentMap(np.ones((1, 2, 3))), EnvironmentMap(np.ones((6, 2, 2, 3)))],
                         ids=["overcast", "overcast-ground", "latlong-1x2", "cube-2"])
def test_a_sky_without_a_sun_gives_no_sun_however_coarse(env):
    """extract_sun on a 4 x 8 overcast sky (no sun) returned a sun of 9858 lux (8239 with a ground of
    albedo 0.2) and a sky of a third of the map's energy: the background was fitted to a ring reaching
    past pi / 2 from the axis, where the tangent coordinates fold the ground onto the sky, and
    extrapolated below zero. On a uniform 1 x 2 map the ring was empty, the fit zero, and the whole map
    (4 pi) became the sun. Now a map without a sun keeps all of it as sky, bit for bit (the 2 x 2 cube, right
    before by chance, now has 4 ring texels within pi / 2: too few for the fit, so no sun)."""
    sun, sky = extract_sun(env)
    np.testing.assert_array_equal(sun.irradiance, np.zeros(3))
    assert len(sun.texels) == 0
    np.testing.assert_array_equal(sky.radiance, env.radiance)


def test_a_coarse_clear_sky_keeps_its_ground():
    """The ring past pi / 2 from a zenith sun held the black ground: on a 4 x 8 clear sky the sun took
    1.47 times sun_irradiance and left the sky 41 % of its energy (now 1.15 and 81 %; the 6-row map:
    1.26 / 67 % before, 1.15 / 81 % now). The fit is still a fit to few texels: the bounds allow that."""
    from pyshadow.lighting.sky import LUMINANCE_WEIGHTS, sun_irradiance

    for h in (4, 6):
        sun, sky = extract_sun(clear_sky(UP, height=h))
        bare = clear_sky(UP, height=h, sun=False)
        ratio = (LUMINANCE_WEIGHTS @ sun.irradiance) / (LUMINANCE_WEIGHTS @ sun_irradiance(UP))
        kept = (LUMINANCE_WEIGHTS @ sky.integral()) / (LUMINANCE_WEIGHTS @ bare.integral())
        assert 1.0 < ratio < 1.2 and 0.8 < kept < 1.0, (h, ratio, kept)


@pytest.mark.parametrize("layout", ["", 0, False, np.array("vertical-cross"), np.array(["vertical-cross"] * 2)])
def test_a_cube_is_written_in_a_named_cross_only(layout):
    """to_image("") (or 0, False) on a cube map silently wrote a horizontal cross (the falsy value was
    taken for the default); a NumPy string raised "unhashable type: 'numpy.ndarray'", two of them
    "truth value of an array ... is ambiguous"."""
    env = EnvironmentMap(np.ones((6, 2, 2, 3)))
    with pytest.raises(ValueError, match="layout: a cube is written as 'horizontal-cross' or 'vertical-cross'"):
        env.to_image(layout)
    assert env.to_image().shape == (6, 8, 3) and env.to_image("vertical-cross").shape == (8, 6, 3)


def test_layouts_that_are_no_strings_are_named():
    """EnvironmentMap(image, np.array(["horizontal-cross"])) raised "unhashable type: 'numpy.ndarray'",
    np.array(["latlong"] * 2) (and a lat-long map's to_image of it) "truth value ... is ambiguous"."""
    two = np.array(["latlong"] * 2)
    with pytest.raises(ValueError, match="layout: expected one of auto, latlong"):
        EnvironmentMap(np.ones((3, 4, 3)), np.array(["horizontal-cross"]))
    with pytest.raises(ValueError, match="layout: expected one of auto, latlong"):
        EnvironmentMap(np.ones((2, 4, 3)), two)
    with pytest.raises(ValueError, match="layout: a lat-long map is written as 'latlong'"):
        EnvironmentMap(np.ones((2, 4, 3))).to_image(two)


def test_sh_order_that_is_no_number_is_named():
    """sh(order=np.array([3, 3])) raised "truth value of an array ... is ambiguous"."""
    env = EnvironmentMap(np.ones((2, 4, 3)))
    with pytest.raises(ValueError, match=r"order: only order 3 \(9 coefficients\) is implemented"):
        env.sh(np.array([3, 3]))
    with pytest.raises(ValueError, match="order: only order 3"):
        env.sh("3")
    np.testing.assert_array_equal(env.sh(3), env.sh())


@pytest.mark.parametrize("d, match", [([[0.0, 0.0, 0.0]], "directions: 1 rows are zero vectors"),
                                      ([[np.nan, 0.0, 1.0]], "directions: 1 rows are not finite"),
                                      ([0.0, 1.0, 0.0], r"directions must have shape \(N, 3\)")])
def test_cube_lookup_refuses_directions_with_no_face(d, match):
    """cube_lookup of a zero or NaN direction raised "RuntimeWarning: invalid value encountered in divide"
    (with warnings ignored: row and column -2**63); a (3,) direction NumPy's AxisError "axis 1 is out of
    bounds for array of dimension 1"."""
    with pytest.raises(ValueError, match=match):
        cube.cube_lookup(np.array(d), 4)


@pytest.mark.parametrize("call, exc, match", [
    (lambda: cube.cube_lookup(np.array([[0.0, 1.0, 0.0]]), 0), ValueError, "n must be >= 1, got 0"),
    (lambda: cube.face_directions(2.5), TypeError, "n must be an int, got 2.5"),
    (lambda: cube.face_solid_angles(-1), ValueError, "n must be >= 1, got -1"),
    (lambda: latlong_basis_integrals(-1, 4), ValueError, "height must be >= 1, got -1"),
    (lambda: latlong_basis_integrals(True, 2), TypeError, "height must be an int, got True"),
    (lambda: latlong_basis_integrals(2, 0), ValueError, "width must be >= 1, got 0"),
])
def test_cube_and_grid_sizes_are_ints_of_at_least_one(call, exc, match):
    """cube_lookup(d, 0) returned row -1 and column -1 (the last texel of a face of none);
    face_directions(2.5) a face of 3 x 3 texels spaced for 2.5; face_solid_angles(-1) raised
    "all elements of broadcast shape must be non-negative"; latlong_basis_integrals(-1, 4) an IndexError,
    (True, 2) the integrals of a 1-row map, (2, 0) a (0, 9) phi factor."""
    with pytest.raises(exc, match=match):
        call()
    np.testing.assert_array_equal(cube.cube_lookup(np.array([[0.0, 1.0, 0.0]]), np.int64(2)),
                                  ([2], [1], [1]))


@pytest.fixture(scope="module")
def box_scene():
    import trimesh

    import pyshadow

    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)))
    return scene


P2 = np.array([[2.0, 0.0, 0.0], [0.0, 0.5, 0.0]])
N2 = np.array([UP, UP])


@pytest.mark.parametrize("backend", ["numpy", "csm"])
@pytest.mark.parametrize("g, match", [(np.full((2, 3), np.nan), "geometric_normals: 2 rows are not finite"),
                                      (np.zeros((2, 3)), "geometric_normals: 2 rows are zero vectors"),
                                      (np.ones((3, 3)), "geometric_normals has 3 rows but points has 2"),
                                      (np.ones(3), r"geometric_normals must have shape \(N, 3\)")])
def test_sh_transfer_checks_geometric_normals(box_scene, backend, g, match):
    """NaN or zero geometric normals were accepted: no direction fell below their plane, so the hemisphere
    rule was silently off; 3 rows for 2 points raised NumPy's "operands could not be broadcast together",
    a (3,) vector "einstein sum subscripts string contains too many subscripts" (as
    shading_normals.ambient_occlusion checks them, they are named now)."""
    import pyshadow

    with pytest.raises(ValueError, match=match):
        sh_transfer(box_scene, P2, N2, backend=backend, sampling=pyshadow.Sampling(samples=16),
                    geometric_normals=g)


def test_sh_transfer_names_surface_ids_of_the_wrong_length(box_scene):
    """With geometric normals (or a backend without an SH kernel) surface_ids of 3 rows for 2 points
    raised NumPy's "operands could not be broadcast together"; the CSM kernels named them."""
    import pyshadow

    with pytest.raises(ValueError, match=r"surface_ids must be one id or 2 \(one a query\), got shape \(3,\)"):
        sh_transfer(box_scene, P2, N2, backend="numpy", sampling=pyshadow.Sampling(samples=16),
                    surface_ids=[0, 1, 2], geometric_normals=N2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ao, _, t = sh_transfer(box_scene, P2, N2, backend="numpy", sampling=pyshadow.Sampling(samples=16),
                               surface_ids=[-2], geometric_normals=N2)
    assert ao[0] == 1.0 and math.isclose(t[0, 0], math.pi * 0.5 / math.sqrt(math.pi), rel_tol=1e-6)


@pytest.mark.parametrize("extract", ["no", "False", 1, None, [False], np.array([1, 0])])
def test_from_environment_extract_must_be_a_bool(extract):
    """``Lighting.from_environment(env, extract="no")`` extracted a sun of about 1e5 lux ("no" is true);
    ``extract=np.array([1, 0])`` raised NumPy's "truth value ... ambiguous"."""
    env = clear_sky([0.0, 0.8, 0.6], height=16)
    with pytest.raises(TypeError, match=r"extract: expected True or False"):
        Lighting.from_environment(env, extract=extract)
    assert Lighting.from_environment(env, extract=np.bool_(False)).sun is None
    assert Lighting.from_environment(env, extract=True).sun is not None
