"""Bad and extreme options of the visibility queries (pyshadow.visibility: visible, ambient_occlusion),
refused or answered alike by the kernels ("csm", "csm-vote"), their float64 mirror ("numpy") and Embree."""
import warnings

import numpy as np
import pytest

import pyshadow
from pyshadow import visibility
from pyshadow.visibility import ambient_occlusion_reference, finite, visible_reference

BACKENDS = ("csm", "csm-vote", "numpy", "embree")
SAMPLING = pyshadow.Sampling(16)


def rays():
    p = np.array([[3.0, 0.5, 0.0], [3.0, 0.5, 0.0], [0.0, 2.0, 0.0], [3.0, 0.0, 0.0]])
    d = np.array([[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, -1.0, 0.0], [-1.0, 0.0, 0.0]])
    return p, d


def ground_points():
    p = np.array([[3.0, 0.0, 0.0], [0.8, 0.0, 0.0], [1.5, 0.0, 1.5]])
    return p, np.tile([0.0, 1.0, 0.0], (len(p), 1))


@pytest.mark.parametrize("backend", BACKENDS)
def test_nan_bias_is_refused_by_every_backend(small_scene, no_launch, backend):
    """bias=NaN: the kernels raised, but the NumPy mirror answered every ray open (AO 1 everywhere, even
    under the box) and Embree ignored it."""
    p, d = rays()
    with pytest.raises(ValueError, match="bias must be finite"):
        visibility.visible(small_scene, p, d, backend=backend, bias=np.nan)
    g, n = ground_points()
    with pytest.raises(ValueError, match="bias must be finite"):
        visibility.ambient_occlusion(small_scene, g, n, backend=backend, sampling=SAMPLING, bias=np.nan)


def test_mirror_refuses_a_nan_bias_called_directly(small_scene):
    """visible_reference / ambient_occlusion_reference(bias=NaN) answered (all open) where the kernel
    refuses: the mirror must refuse what the kernels refuse."""
    p, d = rays()
    with pytest.raises(ValueError, match="bias must be finite"):
        visible_reference(small_scene, p, d, bias=np.nan)
    g, n = ground_points()
    with pytest.raises(ValueError, match="bias must be finite"):
        ambient_occlusion_reference(small_scene, g, n, sampling=SAMPLING, bias=np.nan)


@pytest.mark.parametrize("backend", ["csm", "csm-vote", "numpy"])
def test_bias_beyond_float32_is_a_value_error(small_scene, backend):
    """bias=1e300 crashed the kernel backends with 'RuntimeWarning: overflow encountered in cast'
    (its float32 cast) and was answered by the mirror."""
    p, d = rays()
    with pytest.raises(ValueError, match="bias must be finite and within float32's range"):
        visibility.visible(small_scene, p, d, backend=backend, bias=1e300)
    g, n = ground_points()
    with pytest.raises(ValueError, match="bias must be finite and within float32's range"):
        visibility.ambient_occlusion(small_scene, g, n, backend=backend, sampling=SAMPLING, bias=-1e300)


@pytest.mark.parametrize("bad", [np.array([0.1]), np.full(4, 0.1), True, "0.1"])
def test_bias_must_be_one_real_number(small_scene, no_launch, bad):
    """An array bias raised 'only 0-dimensional arrays can be converted to Python scalars' (no word of
    bias); True was taken as a bias of 1 (the whole diameter) and "0.1" as 0.1, silently."""
    p, d = rays()
    for backend in BACKENDS:
        with pytest.raises(TypeError, match="bias must be one real number or None"):
            visibility.visible(small_scene, p, d, backend=backend, bias=bad)
        with pytest.raises(TypeError, match="bias must be one real number or None"):
            small_scene.ambient_occlusion(p, d, backend=backend, sampling=SAMPLING, bias=bad)


def test_valid_bias_forms_answer_alike(small_scene):
    """float, int, NumPy scalars and 0-d arrays are one bias (the check passes them through unchanged)."""
    p, d = rays()
    for backend in ("csm", "numpy"):
        ref = visibility.visible(small_scene, p, d, backend=backend, bias=0.25)
        for b in (np.float64(0.25), np.float32(0.25), np.array(0.25)):
            assert np.array_equal(visibility.visible(small_scene, p, d, backend=backend, bias=b), ref)
        assert np.array_equal(visibility.visible(small_scene, p, d, backend=backend, bias=0),
                              visibility.visible(small_scene, p, d, backend=backend, bias=0.0))


@pytest.mark.parametrize("bad", [True, np.ones(4, bool), "2.5", ["1", "2", "3", "4"]])
def test_max_distance_refuses_bools_and_strings(small_scene, no_launch, bad):
    """max_distance=True was a ray of length 1 and "2.5" one of 2.5, silently."""
    p, d = rays()
    for backend in BACKENDS:
        with pytest.raises(TypeError, match="max_distance must be a number"):
            visibility.visible(small_scene, p, d, backend=backend, max_distance=bad)


@pytest.mark.parametrize("bad", [True, np.bool_(True), "2"])
def test_obscurance_refuses_bools_and_strings(small_scene, no_launch, bad):
    """obscurance=True was tau = 1 and "2" tau = 2, silently."""
    g, n = ground_points()
    for backend in BACKENDS:
        with pytest.raises(TypeError, match="obscurance must be a number"):
            visibility.ambient_occlusion(small_scene, g, n, backend=backend, sampling=SAMPLING, obscurance=bad)


def test_options_are_checked_when_unused(small_scene, no_launch):
    """straddle= of visible without max_distance, and quadrature= / straddle= of AO without distance
    options, were dropped unchecked (a typo such as straddle='embre' passed silently)."""
    p, d = rays()
    g, n = ground_points()
    for backend in BACKENDS:
        with pytest.raises(ValueError, match="straddle must be one of"):
            visibility.visible(small_scene, p, d, backend=backend, straddle="embre")
        with pytest.raises(ValueError, match="quadrature must be an int"):
            visibility.ambient_occlusion(small_scene, g, n, backend=backend, sampling=SAMPLING, quadrature=0)
        with pytest.raises(ValueError, match="straddle must be one of"):
            visibility.ambient_occlusion(small_scene, g, n, backend=backend, sampling=SAMPLING, straddle="nope")


def test_tiny_obscurance_does_not_overflow():
    """obscurance (tau) below ~1e-308 crashed every CSM backend and the mirror with 'RuntimeWarning:
    overflow encountered in divide' (the quadrature's nodes -log(1 - u) / tau beyond float64)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        nodes = finite.ao_nodes(np.array([np.inf, 2.0]), 1e-308, 16)
    assert np.isinf(nodes[0, -1]) and (nodes[1] == 2.0).all() and (nodes[0, :-1] <= nodes[0, 1:]).all()


@pytest.mark.parametrize("backend", ["csm", "numpy"])
def test_tiny_obscurance_is_plain_ao(small_scene, backend):
    """With tau -> 0 every node lies beyond float32 (unbounded): the AO of before, not a crash."""
    g, n = ground_points()
    plain = visibility.ambient_occlusion(small_scene, g, n, backend=backend, sampling=SAMPLING, surface_ids=-2)
    for tau in (1e-300, 1e-308, 5e-324):
        got = visibility.ambient_occlusion(small_scene, g, n, backend=backend, sampling=SAMPLING, surface_ids=-2,
                                           obscurance=tau, quadrature=4)
        assert np.array_equal(got, plain), tau
    assert plain.min() < 1.0


@pytest.mark.parametrize("bad", [np.zeros(4, np.int64), np.zeros(2, np.int64), np.zeros((3, 1), np.int64)])
def test_numpy_ao_names_surface_ids_of_the_wrong_shape(small_scene, bad):
    """The mirror's AO broadcast surface_ids before checking them: 'operands could not be broadcast
    together with remapped shapes' (or 'input operand has more dimensions...'), no word of surface_ids."""
    g, n = ground_points()
    for backend in ("numpy", "numpy-vote", "csm"):
        with pytest.raises(ValueError, match=r"surface_ids must be one id or 3 \(one a query\)"):
            visibility.ambient_occlusion(small_scene, g, n, backend=backend, sampling=SAMPLING, surface_ids=bad)


def test_the_kernel_backend_called_directly_refuses_a_bias_beyond_float32(small_scene):
    """CSMVisibility().visible(..., bias=1e300), past the dispatcher's check, raised numpy's
    'overflow encountered in cast' (a RuntimeWarning) while packing the float32 argument."""
    from pyshadow.visibility import CSMVisibility

    p, d = rays()
    for bias in (1e300, -1e300, np.inf):
        with pytest.raises(ValueError, match="bias must be finite and within float32"):
            CSMVisibility().visible(small_scene, p, d, bias=bias)


def test_unsigned_surface_ids_beyond_int64_are_refused_not_wrapped(small_scene):
    """uint64 ids of 2**63 and more wrapped negative when cast to int64: 2**64 - 1 became -1 (unknown
    surface) and 2**64 - 2 became -2 (the ground), silently."""
    for ids in (np.uint64(2 ** 64 - 1), np.array([2 ** 64 - 2, 0], np.uint64)):
        with pytest.raises(ValueError, match="surface_ids must be instance ids"):
            small_scene.caster_slots(ids, 2)
    assert small_scene.caster_slots(np.array([0, 0], np.uint64), 2).tolist() == [0, 0]


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_positive_length_below_float32s_range_still_meets_a_surface_at_the_point(small_scene, backend):
    """A point on the ground, its ray straight down, max_distance 1e-300: the kernels rounded the
    length to float32 0 and answered visible where the mirror and Embree answer blocked."""
    p = np.array([[3.0, 0.0, 0.0], [3.0, 0.0, 0.0]])
    d = np.array([[0.0, -1.0, 0.0], [0.0, 1.0, 0.0]])
    for t in (1e-300, 1e-40, 1e-38):
        got = visibility.visible(small_scene, p, d, backend=backend, max_distance=t, straddle="embree")
        assert got.tolist() == [False, True], (t, got)


def test_a_lookup_that_is_not_a_name_is_refused_by_name(small_scene, no_launch):
    """Scene.visible(lookup=np.array(["vote"])) raised NumPy's 'truth value of an array ... is ambiguous'
    from the membership test, and AssetParams(lookup=...) the same."""
    from pyshadow.bake import AssetParams

    p, d = rays()
    for bad in (np.array(["vote", "nearest"]), np.array(["vote"]), ["vote"], 1):
        with pytest.raises(ValueError, match="lookup must be 'nearest' or 'vote'"):
            small_scene.visible(p, d, lookup=bad)
    with pytest.raises(ValueError, match="AssetParams.lookup must be one of"):
        AssetParams(lookup=np.array(["vote", "nearest"]))
