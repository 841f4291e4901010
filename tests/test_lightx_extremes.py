"""Lighting at the extremes (helper lightx): tiny and far rectangle and disc lights, auto exposure of +inf."""
import math
import sys
import warnings

import numpy as np
import pytest

import pyshadow
from pyshadow.lighting import DiscLight, RectLight, auto_exposure
from pyshadow.lighting.area import area_light_radiance
from pyshadow.lighting.area_exact import unshadowed_factor

MIN_EXTENT = math.sqrt(sys.float_info.min)         # pyshadow.lighting.area.MIN_EXTENT: squares stay normal

P = np.array([[0.0, 0.0, 0.0], [0.3, 0.0, 0.2], [5.0, 0.0, 0.0]])
N = np.array([[0.0, 1.0, 0.0]] * 3)


def point_limit(light, p, n):
    """``A cos cos / d^2`` of a light at its centre: its factor G where its size is negligible."""
    dv = light.position - p
    d2 = (dv * dv).sum(axis=1)
    ll = dv / np.sqrt(d2)[:, None]
    return light.area * np.maximum((ll * n).sum(axis=1), 0.0) * np.maximum(-(ll @ light.normal), 0.0) / d2


def gauss_factor(light, p, n, order=12):
    """G of a rectangle by tensor Gauss-Legendre over its area (positive integrand: no cancellation)."""
    x, w = np.polynomial.legendre.leggauss(order)
    a, b = np.meshgrid(x, x)
    y = light.position + a.reshape(-1, 1) * light.u + b.reshape(-1, 1) * light.v
    dv = y - p
    d2 = (dv * dv).sum(axis=1)
    ll = dv / np.sqrt(d2)[:, None]
    f = np.maximum(ll @ n, 0.0) * np.maximum(-(ll @ light.normal), 0.0) / d2
    return float(f @ np.outer(w, w).reshape(-1)) * np.linalg.norm(light.u) * np.linalg.norm(light.v)


@pytest.mark.parametrize("size", [1e-12, 1e-20, 1e-100])
def test_tiny_rectangle_is_its_point_limit(size):
    """A rectangle light of edges ``size`` 1 m away lights as a point of its area: it was 7e-3 off at 1e-12,
    black at 1e-20 (the edge sum's eps d / R), and at 1e-100 its normal was NaN (divide warnings, black)."""
    light = RectLight((0.0, 1.0, 0.0), u=(size, 0.0, 0.0), v=(0.0, 0.0, size), intensity=1.0)
    np.testing.assert_allclose(unshadowed_factor(light, P, N) / light.area, point_limit(light, P, N) / light.area,
                               rtol=1e-12)
    rad, vis = area_light_radiance(pyshadow.Scene(ground=0.0), P, N, light, 1.0, samples=4)
    np.testing.assert_allclose(rad[:, 0] * math.pi, point_limit(light, P, N) / light.area, rtol=1e-12)
    assert (vis == 1).all()


def test_thin_rectangle_far_from_its_width():
    """A 2 mm x 2e-150 m sliver 1 m away: the point limit (2e-6 off), not 0."""
    light = RectLight((0.0, 1.0, 0.0), u=(1e-150, 0.0, 0.0), v=(0.0, 0.0, 1e-3), intensity=1.0)
    got = unshadowed_factor(light, P, N) / light.area
    np.testing.assert_allclose(got, point_limit(light, P, N) / light.area, rtol=1e-5)


@pytest.mark.parametrize("ratio", [1e-7, 1e-8, 1e-10])
def test_far_rectangle_against_quadrature(ratio):
    """Rectangles ``ratio`` of their distance across, turned at random: within 1e-13 of a Gauss quadrature
    (the edge sum was up to 7e-9 off at 1e-7, 5e-8 at 1e-8, 4e-6 at 1e-10)."""
    rng = np.random.default_rng(3)
    worst = 0.0
    for _ in range(20):
        nl = rng.normal(size=3)
        nl /= np.linalg.norm(nl)
        e1 = np.cross(nl, rng.normal(size=3))
        e1 /= np.linalg.norm(e1)
        light = RectLight(rng.normal(size=3), u=e1 * ratio * rng.uniform(0.3, 1.0),
                          v=np.cross(nl, e1) * ratio * rng.uniform(0.3, 1.0), intensity=1.0)
        d = light.normal + 0.3 * rng.normal(size=3)
        d /= np.linalg.norm(d)
        p = light.position + d
        n = -d + 0.3 * rng.normal(size=3)
        n /= np.linalg.norm(n)
        g = unshadowed_factor(light, p[None], n[None])[0]
        worst = max(worst, abs(g / gauss_factor(light, p, n) - 1.0))
    assert worst < 1e-13


@pytest.mark.parametrize("make", [lambda r: DiscLight((0, 1, 0), normal=(0, -1, 0), radius=r, intensity=1.0),
                                  lambda r: RectLight((0, 1, 0), u=(r, 0, 0), v=(0, 0, 1.0), intensity=1.0)])
def test_lights_below_min_extent_refused(make):
    """A radius or edge whose square underflows: a ValueError naming it (a disc of 1e-200 lit NaN, 1e-160 inf)."""
    with pytest.raises(ValueError, match=r"(disc light radius|edge u: length): must be at least MIN_EXTENT"):
        make(1e-160)
    make(MIN_EXTENT)                    # the smallest accepted


def test_tiny_disc_lights_as_a_point():
    light = DiscLight((0.0, 1.0, 0.0), normal=(0.0, -1.0, 0.0), radius=2.0 * MIN_EXTENT, intensity=1.0)
    rad, _ = area_light_radiance(pyshadow.Scene(ground=0.0), P, N, light, 1.0, samples=4)
    np.testing.assert_allclose(rad[:, 0] * math.pi, point_limit(light, P, N) / light.area, rtol=1e-12)


def test_radiance_overflow_refused():
    """A tiny, bright light whose radiance I / A leaves float64: refused by name (it lit inf and NaN)."""
    with pytest.raises(ValueError, match="light intensity: .* radiance beyond float64"):
        DiscLight((0, 1, 0), normal=(0, -1, 0), radius=1e-150, intensity=1e300)
    with pytest.raises(ValueError, match="light intensity: .* radiance beyond float64"):
        RectLight((0, 1, 0), u=(1e-150, 0, 0), v=(0, 0, 1e-150), power=1e300)


def test_auto_exposure_of_infinite_covered_pixels():
    """Covered +inf pixels at the percentile: 1.0 as documented, no 'invalid value' warning (it raised one)."""
    a = np.ones((10, 10, 3))
    a[0] = np.inf
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert auto_exposure(a, covered=np.ones((10, 10), bool)) == 1.0
        assert auto_exposure(a) == pytest.approx(0.8)          # default: finite pixels only


def test_bright_spot_light_outside_its_cone_is_dark():
    """A spot of 1e308 1 mm above the ground: beneath it +inf (beyond float64), beside it, outside its cone, 0; no
    NaN and no overflow warning (``I f`` overflowed to inf and times the unlit 0 gave NaN)."""
    from pyshadow.lighting import Lighting, SpotLight, point_light_radiance, shade

    scene = pyshadow.Scene(ground=0.0)
    light = SpotLight((0.0, 1e-3, 0.0), 1e308, direction=(0.0, -1.0, 0.0))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rad, vis = point_light_radiance(scene, P[:2], N[:2], light, 1.0)
        out = shade(scene, P[:2], N[:2], Lighting(lights=[light]))
    assert np.isposinf(rad[0]).all() and (rad[1] == 0).all() and vis.tolist() == [1.0, 0.0]
    assert np.isposinf(out[0]).all() and (out[1] == 0).all()


def test_auto_exposure_of_subnormal_radiance():
    """Radiance of 1e-320 beside black: "auto" maps it as it maps the same image scaled by 1e300 (its exposure
    overflowed to inf: white, and inf times the black pixels NaN)."""
    from pyshadow.lighting import tonemap

    a = np.zeros((4, 4, 3))
    a[:2] = 1e-320
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        got = tonemap(a, "auto")
    np.testing.assert_array_equal(got, tonemap(a * 1e300, "auto"))
    assert got[0, 0, 0] == 231 and got[3, 3, 0] == 0
