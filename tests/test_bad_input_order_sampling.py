"""Bad input to the coherent ray order, the sample patterns, the exposed-backs test and the camera."""
import re

import numpy as np
import pytest

import pyshadow
from pyshadow.camera import Camera
from pyshadow.csm.exposure import both_sided_faces, escape_fractions, exposed_back_faces
from pyshadow.sampling import local_directions
from pyshadow.visibility import order

from test_exposure import _box, _open_box


# ------------------------------------------------------------------------------------ coherent order
def test_a_nan_origin_leaves_the_other_rays_origin_cells():
    """A batch of exactly MIN_RAYS rays (the subsample takes every 16th row) with a NaN origin in the
    subsample, and two rows of NaN and infinite coordinates: the other rays' keys are those of the batch
    with an interior point in place of the NaN row. Before, the NaN made the subsample's box NaN and every
    ray's origin cell 0 (the key kept only its direction part)."""
    rng = np.random.default_rng(3)
    n = order.MIN_RAYS
    p, w = rng.uniform(-2.0, 5.0, (n, 3)), rng.normal(size=(n, 3))
    p[0] = 1.5                                   # the box's centre: inside the box of the other rows
    want = order.ray_key(p, w)
    bad = p.copy()
    bad[0] = np.nan
    bad[16] = (np.inf, np.nan, -np.inf)          # another subsample row without a finite entry
    got = order.ray_key(bad, w)
    keep = np.ones(n, bool)
    keep[[0, 16]] = False
    np.testing.assert_array_equal(got[keep], want[keep])
    c3 = order.CELLS ** 3
    assert len(np.unique(got[keep] % c3)) == c3                 # every origin cell still in use
    assert (got.astype(np.int64) < order.DIR_BINS ** 2 * c3).all()
    # the permutation sorts by that key, and its inverse undoes it exactly
    perm = order.coherent_order(bad, w)
    np.testing.assert_array_equal(np.diff(got[perm].astype(np.int64)) >= 0, True)
    np.testing.assert_array_equal(perm[order.inverse_permutation(perm)], np.arange(n))


@pytest.mark.parametrize("points, directions, name, dtype", [
    (np.ones((3, 3), complex), np.ones((3, 3)), "points", "complex128"),
    (np.ones((3, 3)), np.ones((3, 3), bool), "directions", "bool"),
    ([["1", "2", "3"]], [[0.0, 1.0, 0.0]], "points", "<U1"),
])
def test_ray_key_takes_real_numbers(points, directions, name, dtype):
    """Before: complex rows lost their imaginary part (a ComplexWarning), bools were read as 0 and 1,
    strings raised NumPy's conversion error without a name."""
    with pytest.raises(TypeError, match=re.escape(f"{name} must hold real numbers, got dtype {dtype}")):
        order.ray_key(points, directions)
    with pytest.raises(TypeError, match=name):
        order.coherent_order(points, directions)


def test_inverse_permutation_is_exact_and_checked():
    """Before: an empty list raised IndexError (float64 indices), a repeated index returned uninitialised
    memory in the missing slot, a negative index wrapped around, a 2-D array was accepted."""
    rng = np.random.default_rng(0)
    perm = rng.permutation(1000)
    for p in (perm, perm.astype(np.uint32), perm.tolist()):
        inv = order.inverse_permutation(p)
        assert inv.dtype == np.int64
        np.testing.assert_array_equal(inv[perm], np.arange(1000))
        np.testing.assert_array_equal(inv, np.argsort(perm))
    for empty in ([], np.zeros(0, np.int32)):
        got = order.inverse_permutation(empty)
        assert got.dtype == np.int64 and got.shape == (0,)
    with pytest.raises(ValueError, match=re.escape("perm must be a permutation of 0 .. 2: 1 of them are missing")):
        order.inverse_permutation([0, 0, 1])
    with pytest.raises(ValueError, match=re.escape("perm must be a permutation of 0 .. 2, got indices from -1 to 1")):
        order.inverse_permutation([-1, 0, 1])
    with pytest.raises(ValueError, match=re.escape("got indices from 0 to 5")):
        order.inverse_permutation([0, 5])
    with pytest.raises(TypeError, match="perm must hold integers, got dtype float64"):
        order.inverse_permutation([0.0, 2.0, 1.0])
    with pytest.raises(ValueError, match=re.escape("perm must be one-dimensional, got shape (2, 2)")):
        order.inverse_permutation([[0, 1], [1, 0]])


# ----------------------------------------------------------------------------------- sample patterns
@pytest.mark.parametrize("points, dtype", [(np.array([[0.5 + 1j, 0.5]]), "complex128"), ([["0.5", "0.5"]], "<U3"),
                                           ([[True, False]], "bool")])
def test_local_directions_take_real_numbers(points, dtype):
    """Before: a complex array lost its imaginary part (a ComplexWarning), strings of digits and bools
    were read as numbers."""
    with pytest.raises(TypeError, match=re.escape(f"points: expected real numbers (got dtype {dtype})")):
        local_directions(points)
    # integers still read as numbers: (1, 0) is the direction at the rim, x axis
    np.testing.assert_array_equal(local_directions(np.array([[1, 0]], np.uint8)), [[1.0, 0.0, 0.0]])


# ------------------------------------------------------------------------------------- exposed backs
@pytest.mark.parametrize("directions, exc, msg", [
    (0, ValueError, "directions must be >= 1 (the rays of the lattice), got 0"),
    (-3, ValueError, "directions must be >= 1 (the rays of the lattice), got -3"),
    (2.5, TypeError, "directions must be an int, got 2.5"),
    (True, TypeError, "directions must be an int, got True"),
    ("64", TypeError, "directions must be an int, got '64'"),
])
def test_exposure_directions_must_be_a_positive_int(directions, exc, msg):
    """Before: 0 or a negative count traced no ray and reported every face of the open box sealed (False,
    escape fraction 0); 2.5 was truncated to 2 and True read as 1 direction; '64' was parsed."""
    ob = _open_box()
    fr = pyshadow.bounding_sphere(ob)
    with pytest.raises(exc, match=re.escape(msg)):
        exposed_back_faces(ob, fr, directions)
    with pytest.raises(exc, match=re.escape(msg)):
        escape_fractions(ob, fr, directions)
    assert exposed_back_faces(ob, fr, np.int64(64)).tolist() == [True] * 10


@pytest.mark.parametrize("radius, msg", [
    (-1.0, "frame: the radius must be finite and > 0, got -"),
    (np.inf, "frame: the radius must be finite and > 0, got inf"),
    (1e-3, "frame: a vertex lies 0.866025 from the centre, outside the radius 0.001"),
])
def test_exposure_frame_is_checked_as_the_build_checks_it(radius, msg):
    """Before: a negative radius mirrored the closed box through its centre and every back read as
    exposed (all 12 True); an infinite one reported no face of the open box exposed; one smaller than
    the mesh was used as given."""
    closed, ob = _box(), _open_box()
    centre, r = pyshadow.bounding_sphere(closed)
    rad = -r if radius == -1.0 else radius
    for mesh in (closed, ob):
        with pytest.raises(ValueError, match=re.escape(msg)):
            exposed_back_faces(mesh, (centre, rad))
        with pytest.raises(ValueError, match=re.escape(msg)):
            escape_fractions(mesh, (centre, rad), 16)
    assert not exposed_back_faces(closed, (centre, r)).any()
    assert exposed_back_faces(ob, (centre, r)).all()


def test_both_sided_faces_takes_layer_rule_2_or_3():
    """Before: layer_rule=5 returned None (no face marked) and '2' was parsed as 2."""
    ob = _open_box()
    fr = pyshadow.bounding_sphere(ob)
    assert both_sided_faces(ob, fr, 2).tolist() == [True] * 10
    assert both_sided_faces(ob, fr, np.int32(3)) is None
    with pytest.raises(ValueError, match=re.escape("layer_rule must be in 2..3 (the layers a map keeps per "
                                                   "texel), got 5")):
        both_sided_faces(ob, fr, 5)
    with pytest.raises(TypeError, match=re.escape("layer_rule must be an int, got '2'")):
        both_sided_faces(ob, fr, "2")


# -------------------------------------------------------------------------------------------- camera
@pytest.mark.parametrize("eye", [(True, False, True), ["0", "0", "5"], np.array([1, 2, 3], object)])
def test_camera_positions_are_numbers(eye):
    """Before: (True, False, True) was read as the eye (1, 0, 1), strings of digits and an object array
    were parsed."""
    with pytest.raises(ValueError, match=re.escape(f"Camera: eye must be 3 finite numbers, got {eye!r}")):
        Camera(eye, (0, 0, 0))
    with pytest.raises(ValueError, match="Camera: up must be 3 finite numbers"):
        Camera((0, 0, 5), (0, 0, 0), up=eye)
    c = Camera(np.array([0, 0, 5], np.int8), (0, 0, 0))
    np.testing.assert_array_equal(c.forward, [0.0, 0.0, -1.0])
