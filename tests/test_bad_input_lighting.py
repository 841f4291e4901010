"""Bad and extreme input to the lighting package: environment maps, SH, skies, the sun, Lighting, tone mapping.

Each test names what happened before in its docstring; valid input is unchanged (the audit compared
hashes of every touched function's output on ordinary input before and after).
"""
import math
import warnings

import numpy as np
import pytest

from pyshadow.lighting import (DirectionalLight, EnvironmentMap, Lighting, add_sun_disc, extract_sun,
                               irradiance_sh, overcast_sky, sh_basis, shade, sun_position, tonemap,
                               transfer_irradiance)
from pyshadow.lighting import _checks
from pyshadow.scene import GROUND_ID

POINTS = np.array([[0.0, 0.5, 0.0], [5.0, 0.0, 0.0]])
UP = np.array([[0.0, 1.0, 0.0], [0.0, 1.0, 0.0]])


def test_a_negative_seed_is_named_when_the_lighting_is_made(small_scene):
    """Lighting(seed=-1) was accepted; shading with a soft sun then failed inside NumPy with
    "expected non-negative integer", naming no argument."""
    with pytest.raises(ValueError, match=r"seed: expected an int >= 0 \(got -1\)"):
        Lighting(seed=-1)
    with pytest.raises(ValueError, match="seed"):
        Lighting(seed=np.int64(-5))
    sun = DirectionalLight([0.6, 0.8, 0.0], [1.0, 1.0, 1.0], 0.01)
    a = shade(small_scene, POINTS, UP, Lighting(sun=sun, seed=np.uint64(2 ** 64 - 1), sun_samples=4),
              backend="numpy")
    assert np.isfinite(a).all()


@pytest.mark.parametrize("backend, mode", [("numpy", "bent"), ("numpy", "sampled"), ("csm", "sampled"),
                                           ("csm", "transfer")])
def test_radiance_beyond_float32_is_inf_without_a_warning(small_scene, backend, mode):
    """A map of 1e300 cd/m^2 (finite, accepted) raised "RuntimeWarning: overflow encountered in cast" in
    shade_terms' float32 output (and, for the CSM "sampled" sky, in the cast of the map for the kernel,
    whose comment promised the float64 host route instead); as write_radiance, +inf now comes out."""
    env = EnvironmentMap(np.full((8, 16, 3), 1e300))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = shade(small_scene, POINTS, UP, Lighting(env, mode=mode), backend=backend,
                    surface_ids=np.array([0, GROUND_ID]))
    assert out.dtype == np.float32 and np.isposinf(out).all()


def test_a_sun_beyond_float32_is_inf_without_a_warning(small_scene):
    """A sun of 1e40 lux raised "overflow encountered in cast" (filterwarnings=error: a crash)."""
    light = Lighting(sun=DirectionalLight([0.0, 1.0, 0.0], [1e40, 1e40, 1e40]))
    out = shade(small_scene, POINTS, UP, light, backend="numpy")
    assert np.isposinf(out).all()


@pytest.mark.parametrize("shape", [(8, 16, 3), (6, 2, 2, 3), (3, 4, 3)])
def test_maps_whose_integrals_overflow_are_refused(shape):
    """A map of 1e308 (finite, >= 0, accepted) gave sh() = inf silently and raised "overflow encountered
    in matmul" in integral() and "in add" in a cube's sh(); extract_sun / from_environment crashed."""
    with pytest.raises(ValueError, match=r"above 1\.756e\+305 \(the map's integrals would overflow"):
        EnvironmentMap(np.full(shape, 1e308))


@pytest.mark.parametrize("shape", [(1, 2, 3), (8, 16, 3), (6, 1, 1, 3), (6, 3, 3, 3)])
def test_maps_at_the_largest_radiance_stay_finite(shape):
    env = EnvironmentMap(np.full(shape, _checks.MAX_RADIANCE))
    n = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for x in (env.sh(), env.integral(), env.irradiance(n), irradiance_sh(env.sh(), n),
                  transfer_irradiance(env.sh(), np.full((2, 9), math.pi))):
            assert np.isfinite(x).all()
        sun, sky = extract_sun(env)
        assert np.isfinite(sun.irradiance).all() and np.isfinite(Lighting(sky).sh).all()


def test_sh_coefficients_that_overflow_are_refused():
    """Coefficients of 1e308 (finite) were accepted by Lighting and raised "overflow encountered in
    multiply" when shaded; irradiance_sh and transfer_irradiance raised RuntimeWarnings as well."""
    big = np.full((9, 3), 1e308)
    with pytest.raises(ValueError, match=r"sky: \|coefficient\| up to 1e\+308"):
        Lighting(big)
    with pytest.raises(ValueError, match=r"coefficients: \|coefficient\| up to 1e\+308"):
        irradiance_sh(big, [0.0, 1.0, 0.0])
    with pytest.raises(ValueError, match="transfer_irradiance: E not finite"):
        transfer_irradiance(big, np.ones((2, 9)))
    ok = np.full((9, 3), _checks.MAX_SH)
    assert np.isfinite(irradiance_sh(ok, [[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]])).all()
    assert np.isfinite(Lighting(ok).sh).all()


def test_transfer_with_nan_is_named():
    """transfer_irradiance gave NaN irradiance from NaN coefficients or transfer vectors."""
    with pytest.raises(ValueError, match="transfer_irradiance: coefficients not finite"):
        transfer_irradiance(np.full((9, 3), np.nan), np.ones((2, 9)))
    with pytest.raises(ValueError, match="transfer_irradiance: transfer not finite"):
        transfer_irradiance(np.ones((9, 3)), np.full((2, 9), np.nan))


_C = np.array([0.0, 1.0, 0.0], complex)


@pytest.mark.parametrize("call, match", [
    (lambda: Lighting(np.ones((9, 3), complex)), "sky: expected an EnvironmentMap or SH coefficients"),
    (lambda: Lighting("sky.exr"), "sky: expected an EnvironmentMap or SH coefficients"),
    (lambda: Lighting([[1, 2], [3]]), "sky: expected"),
    (lambda: DirectionalLight([0.0, 1.0, 0.0], "abc"), "sun irradiance: expected an RGB 3-vector"),
    (lambda: DirectionalLight([0.0, 1.0, 0.0], [1j, 1, 1]), "sun irradiance: expected an RGB 3-vector"),
    (lambda: DirectionalLight(_C, [1.0, 1.0, 1.0]), "sun direction: expected a 3-vector"),
    (lambda: add_sun_disc(overcast_sky(height=4), [0, 1, 0], "abc"), "radiance: expected 3 finite values"),
    (lambda: add_sun_disc(overcast_sky(height=4), [0, 1, 0], [1j, 1, 1]), "radiance: expected 3 finite values"),
    (lambda: add_sun_disc(np.ones((2, 4, 3)), [0, 1, 0], [1, 1, 1]), "env: expected an EnvironmentMap"),
    (lambda: transfer_irradiance(np.ones((9, 3), complex), np.ones((2, 9))), "coefficients: expected SH"),
    (lambda: transfer_irradiance("abc", np.ones((2, 9))), "coefficients: expected SH"),
    (lambda: transfer_irradiance(np.ones((9, 3)), [["x"] * 9]), "transfer: expected transfer vectors"),
    (lambda: sh_basis(_C), "sh_basis: directions: expected finite numbers"),
    (lambda: sh_basis("abc"), "sh_basis: directions: expected finite numbers"),
    (lambda: sh_basis([1e200, 0.0, 0.0]), r"sh_basis: directions must be finite.*\|x\| <= 1e150"),
    (lambda: EnvironmentMap([[[1, 1, 1], [1, 1]]]), "radiance: expected an RGB image"),
    (lambda: EnvironmentMap(np.ones((6, 2, 2, 3))).to_image(["x"]), "layout: a cube is written as"),
    (lambda: Lighting(lights=5), "lights: expected point, spot, disc or rectangle lights"),
])
def test_inputs_that_are_no_numbers_are_named(call, match):
    """Before: "could not convert string to float: 'sky.exr'", "float() argument must be ...", "setting
    an array element with a sequence", "unhashable type: 'list'", "'int' object is not iterable",
    AttributeError 'numpy.ndarray' object has no attribute 'layout', a ComplexWarning (complex SH
    coefficients, a complex direction: the imaginary part dropped), or "overflow encountered in
    multiply" (a direction of length 1e200) -- none naming the argument."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises((ValueError, TypeError), match=match):
            call()


@pytest.mark.parametrize("call, name", [
    (lambda: sun_position(True, 172, 12), "latitude"),
    (lambda: tonemap(np.ones((2, 2, 3)), True), "exposure"),
    (lambda: tonemap(np.ones((2, 2, 3)), 1.0, "exponential", gamma=np.True_), "gamma"),
    (lambda: DirectionalLight([0.0, 1.0, 0.0], [1.0, 1.0, 1.0], True), "angular_radius"),
    (lambda: overcast_sky(True), "horizontal_illuminance"),
])
def test_bools_are_no_numbers(call, name):
    """True was taken as 1 (latitude 1 deg, exposure 1, a sun of 1 rad radius ...), as ``height=True``
    already was not."""
    with pytest.raises(TypeError, match=f"{name}: must be a number"):
        call()


def test_extract_sun_radius_is_an_angle_below_a_hemisphere():
    """extract_sun(radius=10.0) returned a SunLight of angular_radius 10 rad (no disc) whenever the disc
    was narrower than a texel; Lighting then refused it as "sun angular_radius"."""
    a = np.zeros((8, 16, 3))
    a[2, 3] = 1e6
    with pytest.raises(ValueError, match=r"radius: the sun's angular radius must lie in \(0, MAX_SUN_RADIUS"):
        extract_sun(EnvironmentMap(a), radius=10.0)
    with pytest.raises(ValueError, match=r"radius: the sun's angular radius must lie in \(0, MAX_SUN_RADIUS"):
        extract_sun(EnvironmentMap(a), radius=math.pi / 2)     # a sun Lighting refuses
    assert extract_sun(EnvironmentMap(a), radius=math.pi / 4)[0].irradiance.max() > 0


def _write_exr(path, names, data):
    import OpenImageIO as oiio

    spec = oiio.ImageSpec(data.shape[1], data.shape[0], data.shape[2], "float")
    spec.channelnames = tuple(names)
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec)
    assert out.write_image(np.ascontiguousarray(data, np.float32))
    out.close()
    return path


@pytest.mark.parametrize("names", [("Z", "X", "depth"), ("Y", "RY", "BY"), ("R", "G", "B", "Z")])
def test_exr_of_channels_other_than_rgb_is_refused(tmp_path, names):
    """An EXR of Z, X, depth (or Y, RY, BY luminance-chroma) was read as if R, G, B: a silently wrong map."""
    p = _write_exr(tmp_path / "odd.exr", names, np.ones((4, 8, len(names))))
    with pytest.raises(ValueError, match="needs channels R, G, B"):
        EnvironmentMap.from_file(p)


@pytest.mark.parametrize("names", [("R", "G", "B"), ("R", "G", "B", "A"), ("diffuse.R", "diffuse.G", "diffuse.B")])
def test_exr_of_rgb_channels_is_read(tmp_path, names):
    data = np.random.default_rng(0).random((4, 8, len(names)))
    env = EnvironmentMap.from_file(_write_exr(tmp_path / "rgb.exr", names, data))
    np.testing.assert_array_equal(env.radiance, data[..., :3].astype(np.float32))
