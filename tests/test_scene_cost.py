"""Unused features cost nothing: a scene without casters builds no CSM and compiles no CSM lookup,
one without a ground plane compiles no ground test, and one with neither launches no kernel for
``visible`` or AO (``CSMVisibility.query_defines``; the kernels' ``#if NTYPES`` / ``#if GROUND``).

Shown three ways: the defines every requested kernel was built with and the launches (a spy on
``pyshadow._cl.kernel``), a build of the kernel source in which the excluded functions' names are
made invalid tokens (it compiles only if the preprocessor drops their code), and the timing of
``benchmarks/scene_cost.py`` at a small size. The answers are exact: all True and all 1 for an open
sky, the NumPy mirror's analytic ground for a receivers-only scene on a ground plane, and bent
normals and SH transfer bit-identical to those of a scene whose caster blocks nothing.
"""
import sys

import numpy as np
import pytest
import trimesh

from conftest import REPO

sys.path.insert(0, str(REPO / "benchmarks"))
import scene_cost  # noqa: E402

import pyshadow  # noqa: E402
from pyshadow import _cl, visibility  # noqa: E402
from pyshadow._cl import KernelBuildError  # noqa: E402
from pyshadow.visibility import CSMVisibility  # noqa: E402
from pyshadow.visibility.mirror import ambient_occlusion_reference, visible_reference  # noqa: E402

BACKENDS = ("csm", "csm-vote")


class KernelSpy:
    """Records the defines of every query kernel (visibility.cl) requested through ``_cl.kernel`` and
    counts their launches (the CSM builder's kernels pass through)."""

    def __init__(self, monkeypatch):
        self.built, self.launches = [], 0
        real = _cl.kernel

        def kernel(source_file, name, defines=None):
            k = real(source_file, name, defines)
            if source_file != "visibility.cl":
                return k
            self.built.append((name, dict(defines or {})))
            return Counted(k, self)
        monkeypatch.setattr(_cl, "kernel", kernel)


class Counted:
    """A kernel whose launches the spy counts (its other attributes are the kernel's)."""

    def __init__(self, k, spy):
        self._k, self._spy = k, spy

    def __call__(self, *args, **kwargs):
        self._spy.launches += 1
        return self._k(*args, **kwargs)

    def __getattr__(self, name):
        return getattr(self._k, name)


@pytest.fixture
def spy(monkeypatch):
    return KernelSpy(monkeypatch)


def receivers(ground):
    """Two mesh receivers (no CSM) and optionally a ground plane y = 0."""
    s = pyshadow.Scene(ground=ground, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    s.add(trimesh.creation.box((1.0, 1.0, 1.0)), casts=False)
    T = np.eye(4)
    T[:3, 3] = [3.0, 0.5, 0.0]
    s.add(trimesh.creation.icosphere(1), T, casts=False)
    return s


def rays(rng, n=3000):
    return rng.uniform(-2, 2, (n, 3)), rng.normal(size=(n, 3))


def assert_no_csm(scene):
    assert scene.casters == [] and all(i.csm is None for i in scene.instances)
    assert scene.caster_types() == ([], {}) and scene._built == {}


@pytest.mark.parametrize("backend", BACKENDS)
def test_open_sky_launches_nothing(backend, rng, spy):
    """Receivers only, no ground: visible is all True and AO all 1, with no kernel built or launched."""
    scene = receivers(None)
    assert_no_csm(scene)
    P, D = rays(rng)
    for p, d, extra in ((P, D, {}), (P.astype(np.float32), D.astype(np.float32), {}),
                        (P, D, {"normals": D, "surface_ids": 0})):
        v = visibility.visible(scene, p, d, backend=backend, **extra)
        assert v.dtype == np.bool_ and v.shape == (len(P),) and v.all()
    ao = visibility.ambient_occlusion(scene, P[:500], D[:500], backend=backend, sampling=pyshadow.Sampling(16))
    assert ao.dtype == np.float32 and ao.shape == (500,) and (ao == 1.0).all()
    assert spy.built == [] and spy.launches == 0
    b = visibility.get_backend(backend)
    assert b.query_defines(scene) is None
    assert b.query_defines(scene, "scene_ao", SAMPLES=16, BENT_NORMALS=0, TRANSFER=0) is None
    # the checks of the inputs still come first
    with pytest.raises(ValueError, match="directions"):
        scene.visible(P[:4], np.zeros((4, 3)))
    with pytest.raises(ValueError, match="normals"):
        scene.ambient_occlusion(P[:4], np.zeros((4, 3)))


@pytest.mark.parametrize("backend", BACKENDS)
def test_open_sky_bent_normals_and_transfer_are_the_kernels(backend, rng, spy):
    """Bent normals and SH transfer of an open sky still come from the AO kernel, built with NTYPES=0 and
    GROUND=0 (it only sums its samples): bit-identical to a scene whose caster blocks no sample."""
    scene = receivers(None)
    far = receivers(None)
    T = np.eye(4)
    T[1, 3] = -1000.0                    # below every sample direction of the normals below
    far.add(trimesh.creation.box((1.0, 1.0, 1.0)), T)
    n = rng.normal(size=(400, 3))
    n[:, 1] = np.abs(n[:, 1]) + 0.5
    p = rng.uniform(-2, 2, (400, 3))
    s = pyshadow.Sampling(16)
    b = visibility.get_backend(backend)

    def answers(sc):
        return (*b.ambient_occlusion(sc, p, n, sampling=s, return_bent_normals=True),
                *b.sh_transfer(sc, p, n, sampling=s))
    got = answers(scene)
    assert [d["NTYPES"] for _, d in spy.built] == [0, 0] and [d["GROUND"] for _, d in spy.built] == [0, 0]
    assert spy.launches == 2
    want = answers(far)
    assert [d["NTYPES"] for _, d in spy.built[2:]] == [1, 1]
    assert (want[0] == 1.0).all()        # the far caster stops nothing
    for g, w in zip(got, want):
        assert g.dtype == w.dtype and np.array_equal(g, w)
    ref = ambient_occlusion_reference(scene, p, n, sampling=s, return_bent_normals=True)[1]
    np.testing.assert_allclose(got[1], ref, atol=2e-6)


@pytest.mark.parametrize("backend", BACKENDS)
def test_receivers_on_the_ground_compile_no_lookup(backend, rng, spy):
    """Receivers only, on a ground plane: no CSM; the kernel holds the ground test alone (NTYPES=0) and
    answers exactly as the NumPy mirror's analytic ground."""
    scene = receivers(0.0)
    assert_no_csm(scene)
    P, D = rays(rng)
    P[:200, 1] = 0.0                                       # points on the plane
    v = visibility.visible(scene, P, D, backend=backend)
    np.testing.assert_array_equal(v, visible_reference(scene, P, D))
    np.testing.assert_array_equal(v, np.where(P[:, 1] >= 0, D[:, 1] >= 0, D[:, 1] <= 0))
    assert 0.3 < v.mean() < 0.7
    s = pyshadow.Sampling(16)
    ao = visibility.ambient_occlusion(scene, P[:300], D[:300], backend=backend, sampling=s)
    np.testing.assert_array_equal(ao, ambient_occlusion_reference(scene, P[:300], D[:300], sampling=s))
    assert [name for name, _ in spy.built] == ["scene_visible", "scene_ao"] and spy.launches == 2
    for _, d in spy.built:
        assert (d["NTYPES"], d["GROUND"], d["INSTANCE_BVH"], d["INSTANCE_GRID"], d["LAYOUT_ZIGZAG"],
                d["LAYOUT_HILBERT"]) == (0, 1, 0, 0, 0, 0)


@pytest.mark.parametrize("backend", BACKENDS)
def test_no_ground_compiles_no_ground_test(backend, rng, spy):
    """Casters without a ground plane: GROUND=0, and the answers are the NumPy mirror's."""
    scene = pyshadow.Scene(views=pyshadow.ViewSet.zigzag(8, 16), resolution=32)
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)))
    scene.add(trimesh.creation.icosphere(1), casts=False)
    P = rng.uniform(-1.5, 1.5, (2000, 3))
    P = P[np.abs(P).max(axis=1) > 0.55]                    # off the box
    D = rng.normal(size=(len(P), 3))
    v = visibility.visible(scene, P, D, backend=backend)
    ref = visible_reference(scene, P, D, lookup="nearest" if backend == "csm" else "vote")
    assert (v == ref).mean() >= 0.999 and 0.5 < v.mean() < 0.95     # float32 rounding aside (mirror.py)
    visibility.ambient_occlusion(scene, P[:100], D[:100], backend=backend, sampling=pyshadow.Sampling(8))
    assert [(name, d["NTYPES"], d["GROUND"]) for name, d in spy.built] == [("scene_visible", 1, 0),
                                                                          ("scene_ao", 1, 0)]


def _build(defines, poison):
    """Build visibility.cl with ``defines`` and the names in ``poison`` defined as an invalid token."""
    d = {**defines, "LANES": _cl.lanes(), **{name: "@" for name in poison}}
    _cl.build_source(_cl.kernel_source("visibility.cl"), "visibility.cl", d)


LOOKUP = ("batch_instance", "instance_v", "stored_v", "sphere_v", "box_v")


def test_excluded_code_is_not_compiled():
    """The preprocessor drops the CSM lookup without casters and the ground test without ground: with
    those functions' names made invalid tokens the kernels still build, and with casters or ground
    present they do not (so the build would notice code that is compiled in)."""
    fp64 = int(_cl.has_fp64())
    extra = {"HAVE_FP64": fp64, "POINTS_F64": fp64, "DIRS_F64": fp64, "SURFACE_NORMALS": 1, "SAMPLES": 16,
             "BENT_NORMALS": 1, "TRANSFER": 1}
    b = CSMVisibility("vote")
    bare = b.query_defines(receivers(None), "scene_ao", **extra)
    ground_only = b.query_defines(receivers(0.0), "scene_ao", **extra)
    caster = pyshadow.Scene(views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    caster.add(trimesh.creation.box((1.0, 1.0, 1.0)))
    with_caster = b.query_defines(caster, "scene_ao", **extra)
    assert (bare["NTYPES"], bare["GROUND"]) == (0, 0) and (ground_only["NTYPES"], ground_only["GROUND"]) == (0, 1)
    assert (with_caster["NTYPES"], with_caster["GROUND"]) == (1, 0)
    _build(bare, LOOKUP + ("ground_v",))
    _build(ground_only, LOOKUP)
    _build(with_caster, ("ground_v",))
    with pytest.raises(KernelBuildError):
        _build(ground_only, ("ground_v",))
    with pytest.raises(KernelBuildError):
        _build(with_caster, ("instance_v",))


def test_query_defines_rejects_unknown_kernels():
    with pytest.raises(ValueError, match="kernel"):
        CSMVisibility().query_defines(receivers(None), "scene_render")


def test_unused_features_cost_nothing():
    """benchmarks/scene_cost.py at 1,000,000 rays (every one open in every scene), 7 interleaved
    rounds: removing the ground, or the caster, or both does not make ``visible`` slower. The medians
    of the per-round ratios measured about 1.0, 0.8 and 0.3 (2-core PoCL CPU), and at most 1.13 with
    two busy processes on the two cores; the bound 1.5 leaves room for a noisy machine. (At 200,000
    rays, calls of 2 ms, such load swung them to 1.75: hence the size.)"""
    sc = scene_cost.scenes()
    assert [scene_cost.query_defines(s)["visible"] for s in sc.values()] == [
        None, {"NTYPES": 0, "GROUND": 1, "INSTANCE_BVH": 0, "INSTANCE_GRID": 0},
        {"NTYPES": 1, "GROUND": 0, "INSTANCE_BVH": 0, "INSTANCE_GRID": 0},
        {"NTYPES": 1, "GROUND": 1, "INSTANCE_BVH": 0, "INSTANCE_GRID": 0}]
    P, D, pts, nrm = scene_cost.workload(1_000_000)
    times = scene_cost.measure(sc, P, D, pts, nrm, rounds=7)      # raises unless every scene answers alike
    r = scene_cost.ratios(times)
    assert all(x < 1.5 for x in r.values()), r
