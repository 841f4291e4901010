"""Bad input to the visibility layer's host side (pyshadow.visibility: the public calls, the finite
rays' options, the instance grid and tree): refused with messages naming the argument."""
import numpy as np
import pytest

import pyshadow
from pyshadow import visibility
from pyshadow.visibility import bvh, grid


@pytest.fixture(scope="module")
def open_scene():
    return pyshadow.Scene(ground=0.0)


@pytest.mark.parametrize("backend", ["numpy", "csm"])
@pytest.mark.parametrize("value", ["False", np.array([True, False])])
def test_ao_return_bent_normals_must_be_a_bool(open_scene, backend, value):
    """Before: the string "False" was read as True (a tuple came back instead of the AO array), and an array
    raised NumPy's "truth value of an array ... is ambiguous"."""
    p, n = np.array([[0.0, 1.0, 0.0]]), np.array([[0.0, 1.0, 0.0]])
    with pytest.raises(TypeError, match="return_bent_normals"):
        visibility.ambient_occlusion(open_scene, p, n, backend=backend, return_bent_normals=value)
    ao, bent = visibility.ambient_occlusion(open_scene, p, n, backend=backend, return_bent_normals=np.True_)
    # an open sky: AO 1, the bent normal the unit mean of the 36 sample directions (within 2e-2 of the normal)
    assert ao.tolist() == [1.0] and abs(np.linalg.norm(bent) - 1.0) < 1e-6 and bent[0, 1] > 0.999


def test_straddle_given_as_an_array_is_refused_by_name(open_scene):
    """Before: straddle=np.array(['error', 'embree']) raised NumPy's "truth value ... is ambiguous" from
    ``straddle not in STRADDLE``, in visible and in ambient_occlusion."""
    p = np.array([[0.0, 1.0, 0.0]])
    st = np.array(["error", "embree"])
    with pytest.raises(ValueError, match="straddle must be one of"):
        visibility.visible(open_scene, p, p, straddle=st)
    with pytest.raises(ValueError, match="straddle must be one of"):
        visibility.ambient_occlusion(open_scene, p, p, straddle=st)
    assert visibility.visible(open_scene, p, p, straddle=np.str_("error"), max_distance=2.0).tolist() == [True]


@pytest.mark.parametrize("build, name", [(grid.instance_grid, "instance_grid"), (bvh.instance_bvh, "instance_bvh")])
@pytest.mark.parametrize("centre, radius", [([np.nan, 0.0, 0.0], 1.0), ([0.0, 0.0, 0.0], np.inf),
                                            ([0.0, 0.0, 0.0], -1.0), ([np.inf, 0.0, 0.0], 1.0)])
def test_grid_and_tree_refuse_spheres_that_are_not_finite(build, name, centre, radius):
    """Before: the grid silently left a NaN, infinite or negative sphere out of every cell (no item
    listed it: the caster was never asked) and the tree built NaN or inverted boxes, with only
    RuntimeWarnings (errors under pytest's filterwarnings) or nothing at all."""
    c = np.array([centre, [3.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match=rf"{name}: sphere 0 .*radii finite and >= 0"):
        build(c, [radius, 1.0])


def test_grid_refuses_a_margin_that_is_not_finite():
    """Before: a NaN margin built a grid of NaN cells listing no sphere."""
    with pytest.raises(ValueError, match="margin must be finite"):
        grid.instance_grid([[0.0, 0.0, 0.0], [3.0, 0.0, 0.0]], [1.0, 1.0], np.nan)


def test_grid_and_tree_still_take_degenerate_but_valid_sets():
    """Zero radii, all spheres at one point, one or two spheres: built as before (no error)."""
    header, cells, items = grid.instance_grid(np.zeros((5, 3)), np.zeros(5), balanced_only=False)
    assert header["dims"][0].tolist() == [1, 1, 1] and sorted(items["instance"].tolist()) == [0, 1, 2, 3, 4]
    nodes, order, depth = bvh.instance_bvh([[0.0, 0.0, 0.0]], [1.0])
    assert order.tolist() == [0] and depth == 1 and nodes["lo"][0].tolist() == [-1.0, -1.0, -1.0]


@pytest.mark.parametrize("value", ["False", 0, None, np.array([True, False])])
def test_scene_ao_return_bent_normals_must_be_a_bool(small_scene, value):
    """``Scene.ambient_occlusion(..., return_bent_normals="False")`` returned (ao, bent): ``bool("False")``."""
    p, n = np.array([[3.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]])
    with pytest.raises(TypeError, match="return_bent_normals: expected True or False"):
        small_scene.ambient_occlusion(p, n, return_bent_normals=value)
    assert small_scene.ambient_occlusion(p, n, return_bent_normals=np.False_).shape == (1,)
