"""The visibility backends (pyshadow.visibility): the CSM kernels against their float64 NumPy
mirrors, every registered backend through the same calls, and the registry."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import Sampling, embree, visibility
from pyshadow.visibility import visible_reference
from pyshadow.visibility.csm import CSMVisibility, _device_atlas

from conftest import load, on_ground, surface_queries, unit_frame



# ---------------------------------------------------------------------------
# the CSM kernels against their float64 NumPy mirrors
# ---------------------------------------------------------------------------
COARSE_VIEWS = {"zigzag": lambda: pyshadow.ViewSet.zigzag(16, 32), "hilbert": lambda: pyshadow.ViewSet.hilbert(4),
                "hilbert2": lambda: pyshadow.ViewSet.hilbert(4, True)}


def coarse_two_body_queries(layout, rng):
    """Bunny and a turned fandisk on the ground, CSMs of 512 or 256 maps at 64^2,
    with rays from both surfaces and the surface id of each."""
    bunny, fan = load("stanford-bunny.obj"), load("fandisk.obj")
    scene = pyshadow.Scene(ground=0.0, views=COARSE_VIEWS[layout](), resolution=64)
    scene.add(bunny, on_ground(bunny, unit_frame(bunny)))
    scene.add(fan, on_ground(fan, unit_frame(fan, 0.7, rotation=trimesh.transformations.rotation_matrix(
        0.5, [0, 1, 0])[:3, :3], offset=(1.6, 0, 0.3))))
    p0, d0 = surface_queries(scene, 0, 2000, 8, rng)
    p1, d1 = surface_queries(scene, 1, 1000, 8, rng)
    ids = np.concatenate([np.zeros(len(p0), int), np.ones(len(p1), int)])
    return scene, np.concatenate([p0, p1]), np.concatenate([d0, d1]), ids


@pytest.mark.parametrize("layout", list(COARSE_VIEWS))
def test_visible_kernel_matches_numpy_reference(layout, rng):
    """The kernel against the float64 NumPy reference of the same rules."""
    scene, p, d, ids = coarse_two_body_queries(layout, rng)
    for kwargs in ({}, {"surface_ids": ids}, {"bias": 0.01}):
        ours = scene.visible(p, d, **kwargs)
        ref = visible_reference(scene, p, d, **kwargs)
        assert 0.2 < ref.mean() < 0.95
        assert (ours == ref).mean() > 0.999, kwargs
    # int32 ids of an all-caster scene are passed through unmapped: same answers
    assert (scene.visible(p, d, surface_ids=ids.astype(np.int32))
            == scene.visible(p, d, surface_ids=ids)).all()


@pytest.mark.parametrize("row_offset", [0.5, 0.0])
@pytest.mark.parametrize("lookup", ["nearest", "vote"])
def test_kernel_matches_numpy_reference_in_the_polar_caps(row_offset, lookup, rng):
    """Directions within half a row step of either pole, where the centred grid's window reaches
    across the pole (the thesis grid: its pole row, and its last row repeated): kernel == mirror."""
    bunny = load("stanford-bunny.obj")
    T, P = 16, 32
    scene = pyshadow.Scene(views=pyshadow.ViewSet.zigzag(T, P, row_offset=row_offset), resolution=64)
    scene.add(bunny, unit_frame(bunny))
    c, r = scene.instances[0].world_sphere()
    n = 6000
    th = rng.uniform(0.0, 0.5 * np.pi / T, n)
    ph = rng.uniform(0.0, 2.0 * np.pi, n)
    y = np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    d = np.column_stack([np.sin(th) * np.cos(ph), y * np.cos(th), np.sin(th) * np.sin(ph)])
    d[:4] = [[0, 1, 0], [0, -1, 0], [0, 1, 0], [0, -1, 0]]          # exactly at the poles too
    disk = rng.uniform(-1.0, 1.0, (n, 3)) * [r, 0, r]
    p = c + disk - 1.2 * r * d                                          # behind the body along -d
    ours = scene.visible(p, d, lookup=lookup)
    ref = visible_reference(scene, p, d, lookup=lookup)
    assert 0.2 < ref.mean() < 0.95
    assert (ours == ref).mean() > 0.999


@pytest.mark.parametrize("layout", list(COARSE_VIEWS))
def test_vote_kernel_matches_numpy_reference(layout, rng):
    """lookup="vote": the kernel against the float64 reference of the same
    vote (the four maps of ViewSet.filter_window x the four texels around the
    point). On these coarse CSMs the vote agrees with Embree on more rays
    than the one-texel lookup (measured: 0.4-0.5 points more)."""
    scene, p, d, ids = coarse_two_body_queries(layout, rng)
    for kwargs in ({}, {"surface_ids": ids}, {"bias": 0.01}):
        ours = scene.visible(p, d, lookup="vote", **kwargs)
        ref = visible_reference(scene, p, d, lookup="vote", **kwargs)
        assert 0.2 < ref.mean() < 0.95
        assert (ours == ref).mean() > 0.999, kwargs
    truth = embree.visible(scene, p, d)
    plain = (scene.visible(p, d, surface_ids=ids) == truth).mean()
    vote = (scene.visible(p, d, surface_ids=ids, lookup="vote") == truth).mean()
    # 24000 rays; the two lookups differ on ~1.5 % of them, so the gain has a
    # standard error of ~0.08 points
    assert vote > plain + 0.002, (plain, vote)


def test_mixed_16_and_32_bit_scene_matches_numpy_reference(rng):
    """A 16-bit and a 32-bit CSM in one scene share a 32-bit atlas: the 16-bit
    depths are converted, not reinterpreted (misread, the bunny's answers would
    fall to chance)."""
    bunny, fan = load("stanford-bunny.obj"), load("fandisk.obj")
    views = pyshadow.ViewSet.zigzag(16, 32)
    scene = pyshadow.Scene(ground=0.0)
    scene.add(pyshadow.CoherentShadowMap.build(bunny, views, resolution=64, depth_bits=16, progress=False),
              on_ground(bunny, unit_frame(bunny)), mesh=bunny)
    scene.add(pyshadow.CoherentShadowMap.build(fan, views, resolution=64, depth_bits=32, progress=False),
              on_ground(fan, unit_frame(fan, 0.7, offset=(1.6, 0, 0.3))), mesh=fan)
    assert _device_atlas(scene)[0]["ntypes"] == 2
    p0, d0 = surface_queries(scene, 0, 2000, 8, rng)
    p1, d1 = surface_queries(scene, 1, 1000, 8, rng)
    p, d = np.concatenate([p0, p1]), np.concatenate([d0, d1])
    ids = np.r_[np.zeros(len(p0), int), np.ones(len(p1), int)]
    ours = scene.visible(p, d, surface_ids=ids)
    assert (ours == visible_reference(scene, p, d, surface_ids=ids)).mean() > 0.999
    truth = embree.visible(scene, p, d)
    assert (ours[: len(p0)] == truth[: len(p0)]).mean() > 0.97
    assert (ours[len(p0):] == truth[len(p0):]).mean() > 0.97


# ---------------------------------------------------------------------------
# every backend through pyshadow.visibility
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("kernel, mirror", [("csm", "numpy"), ("csm-vote", "numpy-vote")])
def test_csm_backend_matches_its_numpy_mirror(kernel, mirror, rng):
    """The kernel backends against their float64 mirrors on the same rays, through
    pyshadow.visibility.visible and .ambient_occlusion.

    Tolerance, as in test_visible_kernel_matches_numpy_reference: the mirror
    applies the kernel's rules in float64, so the two differ only where float32
    rounding decides (a direction almost exactly between two maps, a depth
    within a rounding of the bias, a vote of almost exactly one half): at most
    1 ray in 1000. An AO value is the mean of its points' rays, so the mean
    |AO difference| is at most the fraction of differing rays: <= 0.001 too.
    The AO mirror traces sample_directions_reference's float64 directions (the
    kernel's agree with them to 1e-6), which adds nothing measurable."""
    scene, p, d, ids = coarse_two_body_queries("zigzag", rng)
    for kwargs in ({}, {"surface_ids": ids}, {"bias": 0.01}):
        ours = visibility.visible(scene, p, d, backend=kernel, **kwargs)
        ref = visibility.visible(scene, p, d, backend=mirror, **kwargs)
        assert ours.dtype == ref.dtype == np.bool_ and ours.shape == ref.shape == (len(p),)
        assert 0.2 < ref.mean() < 0.95
        assert (ours == ref).mean() > 0.999, kwargs
    pts, nrm = scene.vertex_points(0)
    pick = np.random.default_rng(5).choice(len(pts), 800, replace=False)
    pts, nrm = pts[pick], nrm[pick]
    ok = np.linalg.norm(nrm, axis=1) > 0
    pts, nrm = pts[ok], nrm[ok]
    s = Sampling(32, "halton", 64, 7)
    idx = np.arange(len(pts)) * 3 + 11
    ao, bent = visibility.ambient_occlusion(scene, pts, nrm, backend=kernel, sampling=s, return_bent_normals=True,
                                            indices=idx, surface_ids=0)
    ref_ao, ref_bent = visibility.ambient_occlusion(scene, pts, nrm, backend=mirror, sampling=s,
                                                    return_bent_normals=True, indices=idx, surface_ids=0)
    assert ao.dtype == ref_ao.dtype == np.float32 and bent.dtype == ref_bent.dtype == np.float32
    assert 0.2 < ref_ao.mean() < 0.95
    assert np.abs(ao - ref_ao).mean() <= 0.001
    # a point whose AO differs differs by at least 1/samples: at most samples x 0.001 of them
    same = ao == ref_ao
    assert same.mean() >= 1 - s.samples * 0.001
    # where the AO is equal the same rays are open (two differing rays of one point that
    # cancel are far rarer still), so the bent normals sum the same directions: equal up
    # to the float32 rounding of the directions (1e-6) and of the sum
    np.testing.assert_allclose(bent[same], ref_bent[same], atol=1e-4)
    np.testing.assert_array_equal(visibility.ambient_occlusion(scene, pts, nrm, backend=kernel, sampling=s,
                                                               indices=idx, surface_ids=0), ao)


def test_embree_backend_is_embree(two_object_scene, rng):
    """backend="embree" answers with pyshadow.embree's functions, bit for bit."""
    scene = two_object_scene
    p, d = surface_queries(scene, 0, 2000, 8, rng)
    want = embree.visible(scene, p, d)
    np.testing.assert_array_equal(visibility.visible(scene, p, d, backend="embree"), want)
    np.testing.assert_array_equal(scene.visible(p, d, backend="embree"), want)
    pts, nrm = scene.vertex_points(1)
    pts, nrm = pts[:1500], nrm[:1500]
    s = Sampling(24, "stratified", 32, 5)
    idx = np.arange(len(pts))[::-1].copy()
    ao, bent = embree.ambient_occlusion(scene, pts, nrm, sampling=s, return_bent_normals=True, indices=idx)
    got_ao, got_bent = visibility.ambient_occlusion(scene, pts, nrm, backend="embree", sampling=s,
                                                    return_bent_normals=True, indices=idx)
    np.testing.assert_array_equal(got_ao, ao)
    np.testing.assert_array_equal(got_bent, bent)
    np.testing.assert_array_equal(scene.ambient_occlusion(pts, nrm, sampling=s, indices=idx, backend="embree"), ao)
    np.testing.assert_array_equal(visibility.ambient_occlusion(scene, pts, nrm, backend="embree"),
                                  embree.ambient_occlusion(scene, pts, nrm, sampling=Sampling()))
    assert 0.2 < ao.mean() < 0.95


def test_scene_lookup_is_the_csm_backends(two_object_scene, rng):
    """Scene's lookup="nearest" / "vote" are the "csm" / "csm-vote" backends, bit for bit."""
    scene = two_object_scene
    p, d = surface_queries(scene, 1, 2000, 8, rng)
    ids = np.ones(len(p), np.int32)
    for lookup, name in (("nearest", "csm"), ("vote", "csm-vote")):
        np.testing.assert_array_equal(scene.visible(p, d, lookup=lookup, surface_ids=ids),
                                      visibility.visible(scene, p, d, backend=name, surface_ids=ids))
        np.testing.assert_array_equal(scene.visible(p, d, lookup=lookup, bias=0.002),
                                      visibility.visible(scene, p, d, backend=name, bias=0.002))
    np.testing.assert_array_equal(scene.visible(p, d), visibility.visible(scene, p, d))
    vote = scene.visible(p, d, lookup="vote", surface_ids=ids)
    assert (vote != scene.visible(p, d, surface_ids=ids)).any()          # the two lookups differ somewhere
    pts, nrm = scene.vertex_points(1)
    pts, nrm = pts[:1000], nrm[:1000]
    s = Sampling(16, "halton")
    for lookup, name in (("nearest", "csm"), ("vote", "csm-vote")):
        a, b = scene.ambient_occlusion(pts, nrm, sampling=s, lookup=lookup, surface_ids=1, return_bent_normals=True)
        a2, b2 = visibility.ambient_occlusion(scene, pts, nrm, backend=name, sampling=s, surface_ids=1,
                                              return_bent_normals=True)
        np.testing.assert_array_equal(a, a2)
        np.testing.assert_array_equal(b, b2)


class _OpenSky:
    """A minimal visibility backend: every ray reaches the sky (AO 1, bent normal = normal)."""

    name = "test-open-sky"

    def __init__(self):
        self.calls = []

    def visible(self, scene, points, directions, *, bias=None, surface_ids=None):
        self.calls.append(("visible", bias, surface_ids))
        return np.ones(len(points), bool)

    def ambient_occlusion(self, scene, points, normals, *, sampling, return_bent_normals=False, bias=None,
                          indices=None, surface_ids=None):
        self.calls.append(("ambient_occlusion", sampling, return_bent_normals, bias, surface_ids))
        n = np.asarray(normals, np.float64)
        ao = np.ones(len(n), np.float32)
        bent = (n / np.linalg.norm(n, axis=1, keepdims=True)).astype(np.float32)
        return (ao, bent) if return_bent_normals else ao


@pytest.fixture
def registry(monkeypatch):
    """The registry, restored after the test (registrations here do not leak)."""
    from pyshadow.visibility import base

    monkeypatch.setattr(base, "_REGISTRY", dict(base._REGISTRY))
    return base


def test_registry_lists_the_built_in_backends():
    assert {"csm", "csm-vote", "numpy", "numpy-vote", "embree"} <= set(visibility.backends())
    assert visibility.backends() == sorted(visibility.backends())
    for name in visibility.backends():
        b = visibility.get_backend(name)
        assert isinstance(b, visibility.VisibilityBackend) and b.name == name
    assert isinstance(visibility.get_backend("csm"), CSMVisibility)


def test_registered_backend_answers_every_query(registry, small_scene):
    sky = _OpenSky()
    visibility.register(sky.name, sky)
    assert sky.name in visibility.backends() and visibility.get_backend(sky.name) is sky
    p = np.array([[0.0, 0.2, 0.0], [3.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    d = np.array([[0.0, -1.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]])
    assert not small_scene.visible(p, d).all()                # the CSM kernel sees the ground and the box
    np.testing.assert_array_equal(visibility.visible(small_scene, p, d, backend=sky.name), [True] * 3)
    np.testing.assert_array_equal(small_scene.visible(p, d, backend=sky.name, bias=0.5, surface_ids=0),
                                  [True] * 3)
    assert sky.calls[-1] == ("visible", 0.5, 0)
    np.testing.assert_array_equal(visibility.visible(small_scene, p, d, backend=sky), [True] * 3)   # an object
    ao = small_scene.ambient_occlusion(p, d, backend=sky.name, sampling=Sampling(8))
    np.testing.assert_array_equal(ao, 1.0)
    assert sky.calls[-1] == ("ambient_occlusion", Sampling(8), False, None, None)
    ao, bent = visibility.ambient_occlusion(small_scene, p, d, backend=sky.name, return_bent_normals=True)
    assert sky.calls[-1][1] == Sampling()                   # the default sampling reaches the backend
    np.testing.assert_allclose(bent, d / np.linalg.norm(d, axis=1, keepdims=True), atol=1e-7)
    ao = small_scene.vertex_ao(0, backend=sky.name)
    assert ao.shape == (len(small_scene.instances[0].mesh.vertices),) and (ao == 1).all()
    assert sky.calls[-1][1] == Sampling(64) and sky.calls[-1][4] == 0
    # and the render stage
    cam = pyshadow.Camera([2.0, 1.5, 3.0], [0.0, 0.3, 0.0], width=24, height=16)
    frame = small_scene.render(cam, backend=sky.name)
    assert (frame.ao == 1).all() and (frame.object_id >= 0).any()


def test_registry_refuses_duplicates_and_non_backends(registry):
    sky = _OpenSky()
    csm = visibility.get_backend("csm")
    with pytest.raises(ValueError, match="'csm' is registered already"):
        visibility.register("csm", sky)
    assert visibility.get_backend("csm") is csm
    visibility.register(sky.name, sky)
    with pytest.raises(ValueError, match="registered already"):
        visibility.register(sky.name, _OpenSky())
    other = _OpenSky()
    visibility.register(sky.name, other, replace=True)
    assert visibility.get_backend(sky.name) is other
    for bad in (object(), "csm", lambda *a: None):
        with pytest.raises(TypeError, match="not a visibility backend"):
            visibility.register("test-bad", bad)

    class HalfBackend:                                       # visible() but no ambient_occlusion()
        name = "half"

        def visible(self, scene, points, directions, *, bias=None, surface_ids=None):
            return np.ones(len(points), bool)
    with pytest.raises(TypeError, match="not a visibility backend"):
        visibility.register("test-half", HalfBackend())
    assert "test-bad" not in visibility.backends() and "test-half" not in visibility.backends()
    for name in ("", None, 3):
        with pytest.raises(ValueError, match="non-empty string"):
            visibility.register(name, _OpenSky())


def test_unknown_backend_names_the_registered_ones(registry, small_scene):
    visibility.register("test-open-sky", _OpenSky())
    p, d = np.zeros((1, 3)), np.array([[0.0, 1.0, 0.0]])
    for call in (lambda: visibility.get_backend("nope"),
                 lambda: visibility.visible(small_scene, p, d, backend="nope"),
                 lambda: visibility.ambient_occlusion(small_scene, p, d, backend="nope"),
                 lambda: small_scene.visible(p, d, backend="nope"),
                 lambda: small_scene.ambient_occlusion(p, d, backend="nope")):
        with pytest.raises(ValueError, match="unknown visibility backend 'nope'") as err:
            call()
        for name in visibility.backends():
            assert name in str(err.value)
        assert "test-open-sky" in str(err.value)
    for bad in (object(), 3, None):
        with pytest.raises(TypeError, match="visibility backend must be a name or a backend object"):
            visibility.get_backend(bad)
    with pytest.raises(TypeError, match="visibility backend must be a name or a backend object"):
        visibility.visible(small_scene, p, d, backend=object())
