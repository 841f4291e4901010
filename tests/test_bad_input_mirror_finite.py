"""Bad input and extremes of the float64 NumPy mirror (pyshadow.visibility.mirror) and of the finite-ray
options (pyshadow.visibility.finite): each is refused with the argument's name, as the CSM backend and
pyshadow.visibility refuse it, or answered as the kernel answers it."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import visibility
from pyshadow.visibility.csm import CSMVisibility
from pyshadow.visibility.finite import check_ao_options
from pyshadow.visibility.mirror import ambient_occlusion_reference, visible_reference


@pytest.fixture(scope="module")
def box_scene():
    """A unit box at the origin, no ground, CSM of 4x8 maps at 16^2."""
    scene = pyshadow.Scene(ground=None, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)))
    return scene


P = np.array([[3.0, 0.0, 0.0], [-3.0, 0.0, 0.2]])
D = np.array([[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
N = np.array([[0.0, 1.0, 0.0], [0.0, 1.0, 0.0]])


def test_far_point_aimed_at_a_caster_answers_without_overflow(box_scene):
    """A point 1e30 from a caster (within float32's range from the scene's anchor), its ray aimed at it:
    the world-frame cull keeps the ray, the chord in the caster's frame misses it (the direction's
    rounding is 1e14 there), so the ray is open -- as the kernel answers.
    Was: the missed row's far point went on to the texel lookup, whose cast to int64 overflowed:
    RuntimeWarning 'invalid value encountered in cast' (an error under warnings-as-errors)."""
    p = np.array([[1e30, 0.1, 5e29]])
    got = visible_reference(box_scene, p, -p)
    assert got.tolist() == [True]
    assert got.tolist() == box_scene.visible(p, -p).tolist()
    # the ordinary rays of the same call are untouched: through the box shadowed, beside it open
    q = np.vstack([p, [[3.0, 0.0, 0.0], [3.0, 0.0, 2.0]]])
    assert visible_reference(box_scene, q, np.vstack([-p, [[-1.0, 0, 0], [-1.0, 0, 0]]])).tolist() == \
        [True, False, True]


@pytest.mark.parametrize("tau", [np.complex64(2 + 1j), np.complex128(2 + 0j)])
def test_complex_obscurance_refused(box_scene, tau):
    """A complex tau is no rate.
    Was: its imaginary part was dropped with a ComplexWarning, tau = 2 (for the mirror, the CSM backend
    and visibility.ambient_occlusion alike: all read it through check_ao_options)."""
    with pytest.raises(TypeError, match="obscurance must be a number"):
        check_ao_options(tau, 16, "error")
    with pytest.raises(TypeError, match="obscurance"):
        ambient_occlusion_reference(box_scene, P, N, sampling=pyshadow.Sampling(4), obscurance=tau)
    assert check_ao_options(np.float32(2.0), 16, "error") == (2.0, 16, "error")


def test_distance_ao_checks_lookup(box_scene):
    """ambient_occlusion_reference(..., lookup=, max_distance=): lookup is 'nearest' or 'vote'.
    Was: with max_distance or obscurance any other lookup ('vote ', 'Vote') was answered as 'nearest'."""
    smp = pyshadow.Sampling(4)
    for bad in ("vote ", "Vote", None):
        with pytest.raises(ValueError, match="lookup must be 'nearest' or 'vote'"):
            ambient_occlusion_reference(box_scene, P, N, sampling=smp, lookup=bad, max_distance=1.0)
        with pytest.raises(ValueError, match="lookup must be 'nearest' or 'vote'"):
            ambient_occlusion_reference(box_scene, P, N, sampling=smp, lookup=bad, obscurance=1.0)


def test_lookup_array_named(box_scene):
    """lookup is one string.
    Was: an array of two strings raised NumPy's 'truth value of an array ... is ambiguous' (and one of
    one string was taken for it)."""
    for bad in (np.array(["nearest", "vote"]), np.array(["vote"])):
        with pytest.raises(ValueError, match="lookup must be 'nearest' or 'vote'"):
            visible_reference(box_scene, P, D, lookup=bad)
        with pytest.raises(ValueError, match="lookup must be 'nearest' or 'vote'"):
            ambient_occlusion_reference(box_scene, P, N, sampling=pyshadow.Sampling(4), lookup=bad)


def test_bent_normals_flag(box_scene):
    """return_bent_normals is True or False, as for the CSM backend.
    Was: the string 'no' (true) returned (ao, bent) from the mirror, where the CSM backend raised."""
    for backend in (CSMVisibility(), visibility.get_backend("numpy")):
        with pytest.raises(TypeError, match="return_bent_normals"):
            backend.ambient_occlusion(box_scene, P, N, sampling=pyshadow.Sampling(4), return_bent_normals="no")
    ao = ambient_occlusion_reference(box_scene, P, N, sampling=pyshadow.Sampling(4), return_bent_normals=False)
    assert isinstance(ao, np.ndarray) and ao.shape == (2,)


def test_sampling_type_named(box_scene):
    """sampling is a pyshadow.Sampling.
    Was: None or 8 raised AttributeError "'NoneType' object has no attribute 'samples'"."""
    for bad in (None, 8, "hammersley"):
        with pytest.raises(TypeError, match="sampling must be a pyshadow.Sampling"):
            ambient_occlusion_reference(box_scene, P, N, sampling=bad)


def test_straddle_checked_where_unused(box_scene):
    """visible_reference's straddle is checked as visibility.visible checks it: also without max_distance
    and for no rays.
    Was: straddle='embre' was silently accepted there by the mirror (visibility.visible raised)."""
    with pytest.raises(ValueError, match="straddle must be one of"):
        visibility.visible(box_scene, P, D, backend="csm", straddle="embre")
    with pytest.raises(ValueError, match="straddle must be one of"):
        visible_reference(box_scene, P, D, straddle="embre")
    with pytest.raises(ValueError, match="straddle must be one of"):
        visible_reference(box_scene, np.zeros((0, 3)), np.zeros((0, 3)), max_distance=1.0, straddle="embre")
    assert visible_reference(box_scene, P, D, straddle="embree").tolist() == [False, True]


def test_distance_ao_options_checked_where_unused(box_scene):
    """ambient_occlusion_reference checks quadrature and straddle as visibility.ambient_occlusion does:
    also without max_distance and obscurance.
    Was: quadrature=0 or straddle='guess' were silently dropped by the mirror."""
    smp = pyshadow.Sampling(4)
    with pytest.raises(ValueError, match="quadrature"):
        ambient_occlusion_reference(box_scene, P, N, sampling=smp, quadrature=0)
    with pytest.raises(ValueError, match="straddle"):
        ambient_occlusion_reference(box_scene, P, N, sampling=smp, straddle="guess")
    with pytest.raises(ValueError, match="quadrature"):
        visibility.ambient_occlusion(box_scene, P, N, backend="numpy", sampling=smp, quadrature=0)


def test_very_long_finite_rays_among_many_casters(box_scene):
    """Among more than 32 casters (where the straddling test asks a k-d tree), rays of length 1e300 or
    the largest float64 end beyond every caster: answered as unbounded rays, by the mirror and the kernel.
    Was: their ends, beyond 1e154, overflowed the tree's squared distances: SciPy's ValueError "The value
    of p too large for this dataset" (a finite length that 32 casters or fewer answered)."""
    from pyshadow.visibility.finite import straddling

    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    csm = box_scene.instances[0].csm
    for i in range(40):
        T = np.eye(4)
        T[:3, 3] = [3.0 * (i % 7), 0.5, 3.0 * (i // 7)]
        scene.add(csm, T)
    p = np.array([[1.5, 0.5, 1.5], [1.5, 0.5, 1.5], [1.5, 0.5, 0.0], [-5.0, 3.0, -5.0]])
    d = np.array([[1.0, 0.2, 0.3], [1.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    unbounded = visible_reference(scene, p, d)
    assert unbounded.tolist() == [True, True, False, False]      # the third through the boxes, the fourth the ground
    for t in (1e300, np.finfo(np.float64).max, np.array([1e300, 1e200, 1e160, 1e155])):
        rows, owners = straddling(scene, p, d / np.linalg.norm(d, axis=1, keepdims=True), np.broadcast_to(t, 4))
        assert rows.tolist() == owners.tolist() == []
        assert visible_reference(scene, p, d, max_distance=t).tolist() == unbounded.tolist()
        assert scene.visible(p, d, max_distance=t).tolist() == unbounded.tolist()
    # a ray that does end inside a caster's sphere is still found
    rows, owners = straddling(scene, p[2:3], d[2:3], np.array([1.5]))
    assert rows.tolist() == [0] and owners.tolist() == [1]
