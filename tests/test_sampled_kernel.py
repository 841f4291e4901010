"""The "sampled" sky summed in the AO kernel (SKY_SAMPLED=1, kernels/envmap.h; issue 19 item 4).

The kernel route (CSMVisibility.sampled_sky, taken by sampled_sky_radiance for a CSM backend and a
lat-long map) against the host route (sample_visibility + EnvironmentMap.lookup in float64) on the
same directions: equal to float32 rounding except for samples whose direction lies within float
rounding of a texel edge.
"""
import math

import numpy as np
import pytest

import pyshadow
from pyshadow import Sampling, render, visibility
from pyshadow.lighting import EnvironmentMap, Lighting, clear_sky, sampled
from pyshadow.lighting.shade import sampled_sky_radiance
from pyshadow.lighting.transfer import sample_visibility
from pyshadow.visibility.csm import CSMVisibility

S = 36
EPS32 = 2.0 ** -24          # float32 unit roundoff


@pytest.fixture(scope="module")
def bundled():
    """The bundled scene with every covered pixel of a 48 x 36 view as a shading point."""
    scene, cam = pyshadow.data.default_scene(views=pyshadow.ViewSet.zigzag(16, 32), resolution=64, width=48,
                                             height=36)
    return scene, render.surface_points(scene, cam)


@pytest.fixture(scope="module")
def sky_map():
    """A sky that varies from texel to texel: the clear sky (no sun disc) at 32 x 64."""
    d = np.array([0.6, 0.5, 0.4])
    return clear_sky(d / np.linalg.norm(d), height=32, sun=False)


def both_routes(monkeypatch, scene, sp, light, sampling):
    """sampled_sky_radiance by the kernel route and by the host route (DEVICE_SKY off)."""
    alb = light.albedo_of(sp.surface_ids, len(sp.index))
    args = (scene, sp.points, sp.normals, light, alb)
    kw = dict(sampling=sampling, surface_ids=sp.surface_ids, indices=sp.index)
    dev = sampled_sky_radiance(*args, **kw)
    monkeypatch.setattr(sampled, "DEVICE_SKY", False)
    host = sampled_sky_radiance(*args, **kw)
    monkeypatch.setattr(sampled, "DEVICE_SKY", True)
    return dev, host, alb


def near_edge(dirs, h, w):
    """Whether each direction lies within float32 evaluation error of a lat-long texel edge.

    The kernel evaluates theta = acos(y), phi = atan2(z, x) in float32 on the float32 direction
    normalised in float32: y carries <= 2 roundings (error <= 2 eps), acos and atan2 <= 6 ulp
    (OpenCL 1.2, full profile), so theta is off by <= 2 eps / sin(theta) + 6 ulp(pi) and phi by
    <= 2 eps / sin(theta) (x, z relative to their length sin(theta)) + 6 ulp(2 pi), and the
    scaled coordinates by one more rounding each. Taken 4 times over as the margin.
    """
    d = dirs.astype(np.float64)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    th = np.arccos(np.clip(d[:, 1], -1.0, 1.0))
    ph = np.mod(np.arctan2(d[:, 2], d[:, 0]), 2.0 * math.pi)
    s = np.maximum(np.sin(th), 1e-12)
    e_th = 2 * EPS32 / s + 6 * 2 * EPS32 * math.pi
    e_ph = 2 * EPS32 / s + 6 * 2 * EPS32 * 2 * math.pi
    u, v = th * h / math.pi, ph * w / (2 * math.pi)
    du = 4 * (e_th * h / math.pi + 2 * EPS32 * u)
    dv = 4 * (e_ph * w / (2 * math.pi) + 2 * EPS32 * v)
    return (np.abs(u - np.round(u)) <= du) | (np.abs(v - np.round(v)) <= dv)


def test_kernel_sky_is_the_host_route_but_at_texel_edges(bundled, sky_map, monkeypatch):
    """Per point: equal to float32 rounding (S summands: relative error <= (S + 2) eps), except
    points with an open sample near a texel edge (near_edge), which differ by at most their count
    of such samples x the map's largest texel difference / S; those are a few of the points."""
    scene, sp = bundled
    s = Sampling(S, seed=3)
    (dev, ao_d, bent_d), (host, ao_h, _), alb = both_routes(monkeypatch, scene, sp,
                                                           Lighting(sky_map, mode="sampled"), s)
    np.testing.assert_array_equal(ao_d, ao_h)
    assert (ao_d < 0.9).mean() > 0.1                     # the scene really occludes
    dirs, lit = sample_visibility(scene, sp.points, sp.normals, backend="csm", sampling=s, indices=sp.index,
                                  surface_ids=sp.surface_ids)
    h, w = sky_map.grid_shape
    edge = (near_edge(dirs.reshape(-1, 3), h, w).reshape(lit.shape) & lit).sum(axis=1)
    spread = sky_map.radiance.reshape(-1, 3).max(axis=0) - sky_map.radiance.reshape(-1, 3).min(axis=0)
    err = np.abs(dev - host)
    tol = (S + 2) * EPS32 * np.abs(host) + 1e-300
    exact = edge == 0
    assert np.all(err[exact] <= tol[exact])
    assert np.all(err <= tol + alb * edge[:, None] * spread / S)
    assert edge.astype(bool).mean() < 0.02               # a few points only
    assert np.mean(np.any(err > tol, axis=1)) < 0.02


def test_kernel_ao_and_bent_are_ambient_occlusions(bundled, sky_map):
    """The sky sums ride along the AO kernel: its AO and bent normals are ambient_occlusion's bit for bit."""
    scene, sp = bundled
    s = Sampling(S, seed=7)
    sky, ao, bent = CSMVisibility().sampled_sky(scene, sp.points, sp.normals, sky_map.radiance, sky_map.grid_shape,
                                                sampling=s, indices=sp.index, surface_ids=sp.surface_ids)
    ao_r, bent_r = visibility.ambient_occlusion(scene, sp.points, sp.normals, sampling=s, return_bent_normals=True,
                                                indices=sp.index, surface_ids=sp.surface_ids)
    np.testing.assert_array_equal(ao, ao_r)
    np.testing.assert_array_equal(bent, bent_r)
    assert sky.dtype == np.float32 and sky.shape == (len(sp.index), 3)


def test_constant_sky_gives_c_times_ao(bundled):
    """A constant map c (exact in float32): the sum of k open samples is k c exactly (k <= S, c = 2^-1 ..
    2^1), so the mean is c AO to one division's rounding."""
    scene, sp = bundled
    c = np.array([0.5, 1.0, 2.0])
    sky, ao, _ = CSMVisibility().sampled_sky(scene, sp.points, sp.normals, np.tile(c, (16, 32, 1)),
                                             sampling=Sampling(S), indices=sp.index, surface_ids=sp.surface_ids)
    want = (ao.astype(np.float64) * S).round()[:, None] * c / S
    np.testing.assert_allclose(sky, want, rtol=EPS32, atol=0)


def test_cube_map_takes_the_host_route(bundled, sky_map, monkeypatch):
    """A cube-layout map is not looked up on the device: the result is the host route's, bit for bit."""
    scene, sp = bundled
    faces = np.stack([np.full((8, 8, 3), 0.1 * (f + 1)) for f in range(6)])
    light = Lighting(EnvironmentMap(faces), mode="sampled")

    def refuse(*a, **k):
        raise AssertionError("the kernel route was taken for a cube map")
    monkeypatch.setattr(CSMVisibility, "sampled_sky", refuse)
    dev, host, _ = both_routes(monkeypatch, scene, sp, light, Sampling(S))
    for a, b in zip(dev, host):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("bad", [np.ones((4, 8)), np.ones((4, 8, 4)), np.ones((0, 8, 3)),
                                 np.full((4, 8, 3), np.inf)])
def test_bad_map_is_refused_before_any_launch(bundled, bad, no_launch):
    scene, sp = bundled
    with pytest.raises(ValueError):
        CSMVisibility().sampled_sky(scene, sp.points[:4], sp.normals[:4], bad, sampling=Sampling(S))


def test_layout_shape_must_match(bundled, no_launch):
    scene, sp = bundled
    with pytest.raises(ValueError, match="layout_shape"):
        CSMVisibility().sampled_sky(scene, sp.points[:4], sp.normals[:4], np.ones((4, 8, 3)), (8, 16),
                                    sampling=Sampling(S))
