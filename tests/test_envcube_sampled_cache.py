"""The "sampled" sky's device copy of the map (pyshadow.visibility.sampled_sky, pyshadow.lighting.sampled):
uploaded once per read-only map and context, never stale.

Was: every call of sampled_sky_radiance on a CSM backend converted the map to float32, checked it and
uploaded it again: a 4096 x 2048 map cost 0.18 s a call (0.217 s a call in all at 1728 points and 64
samples; 0.046 s with the kept copy), on PoCL CPU.
"""
import copy
import gc

import numpy as np
import pytest

from pyshadow import Sampling, _cl
from pyshadow.lighting import EnvironmentMap, Lighting, sampled
from pyshadow.lighting.shade import sampled_sky_radiance
from pyshadow.visibility import sampled_sky as vsky
from pyshadow.visibility.csm import CSMVisibility

H = 8


def top_points(n=4):
    """Points on the small scene's box top (y = 0.5), normals up."""
    g = np.linspace(-0.3, 0.3, n)
    p = np.column_stack([np.repeat(g, n), np.full(n * n, 0.5), np.tile(g, n)])
    return p, np.tile([0.0, 1.0, 0.0], (len(p), 1))


def a_map(seed):
    return EnvironmentMap(np.random.default_rng(seed).random((H, 2 * H, 3)) + 0.1)


@pytest.fixture
def uploads(monkeypatch):
    """Counts the uploads of (H, 2 H, 3) maps by the sampled sky."""
    seen = []
    real = _cl.to_device

    def counting(a, dtype=None):
        if np.shape(a) == (H, 2 * H, 3):
            seen.append(np.array(a))
        return real(a, dtype)
    monkeypatch.setattr(_cl, "to_device", counting)
    return seen


def sky(scene, env, samples=16):
    p, n = top_points()
    light = Lighting(env, mode="sampled")
    return sampled_sky_radiance(scene, p, n, light, np.ones((len(p), 3)), sampling=Sampling(samples),
                                surface_ids=0)[0]


def test_a_map_is_uploaded_once_and_answers_the_same(small_scene, uploads):
    """Was: 3 calls on one map uploaded it 3 times (0.18 s a call at 4096 x 2048)."""
    env = a_map(1)
    first = sky(small_scene, env)
    for _ in range(2):
        np.testing.assert_array_equal(sky(small_scene, env), first)
    assert len(uploads) == 1
    assert sky(small_scene, env, samples=32).shape == first.shape and len(uploads) == 1   # any S: the same copy


def test_a_changed_map_is_never_stale(small_scene, uploads, monkeypatch):
    """Another map, or with_radiance, gives that map's answer (the host route's to float32 rounding).
    Was: every call uploaded (right, but slow); this pins that the kept copy changes with the map."""
    a, b = a_map(1), a_map(2)
    c = a.with_radiance(2.0 * a.radiance)
    got = [sky(small_scene, e) for e in (a, b, c, a)]
    monkeypatch.setattr(sampled, "DEVICE_SKY", False)
    want = [sky(small_scene, e) for e in (a, b, c, a)]
    for g, w in zip(got, want):
        np.testing.assert_allclose(g, w, rtol=1e-5)
    np.testing.assert_allclose(got[2], 2.0 * got[0], rtol=1e-6)
    assert len(uploads) == 3 + (vsky.MAX_CACHED_MAPS < 3)     # a, b, c; a again only if it was dropped


def test_radiance_is_read_only():
    """Was: env.radiance[...] = x changed the map in place, unchecked (NaN and negative texels got in) and
    unseen by what was derived from it (Lighting's SH, the device copy)."""
    env = a_map(1)
    with pytest.raises(ValueError, match="read-only"):
        env.radiance[0, 0] = np.nan
    assert vsky.frozen(env.radiance) and vsky.frozen(env.radiance[2:])
    assert not vsky.frozen(np.zeros((2, 4, 3)))
    view = np.zeros((2, 4, 3))[:]
    view.flags.writeable = False
    assert not vsky.frozen(view)                 # a read-only view of a writeable owner may change


def test_a_writeable_array_is_uploaded_every_call(small_scene, uploads):
    """CSMVisibility.sampled_sky with a writeable array: changed in place, the next call sees it."""
    p, n = top_points()
    rad = np.array(a_map(1).radiance)
    csm = CSMVisibility()
    s1 = csm.sampled_sky(small_scene, p, n, rad, sampling=Sampling(16), surface_ids=0)[0]
    rad *= 3.0
    s2 = csm.sampled_sky(small_scene, p, n, rad, sampling=Sampling(16), surface_ids=0)[0]
    np.testing.assert_allclose(s2, 3.0 * s1, rtol=1e-6)
    assert len(uploads) == 2


def test_copies_are_bounded_and_freed_with_their_map(small_scene, uploads):
    """At most MAX_CACHED_MAPS copies kept; a map that is gone leaves none behind."""
    envs = [a_map(s) for s in range(vsky.MAX_CACHED_MAPS + 2)]
    for e in envs:
        sky(small_scene, e)
    assert len(vsky._maps) <= vsky.MAX_CACHED_MAPS
    ids = {id(e.radiance) for e in envs}
    del envs, e
    gc.collect()
    assert not ids & {k[0] for k in vsky._maps}


def test_a_deep_copy_is_read_only_too():
    """Was: copy.deepcopy of a map gave it writeable radiance (NumPy's copy), changeable in place."""
    env = EnvironmentMap(np.ones((6, 2, 2, 3)))
    c = copy.deepcopy(env)
    assert c.layout == "cube" and not c.radiance.flags.writeable and vsky.frozen(c.radiance)
    np.testing.assert_array_equal(c.radiance, env.radiance)
    assert copy.copy(env).radiance is env.radiance
