"""Rigid transforms written out with a few decimals are placed, as the nearest scaled rotation.

Before, ``check_transform(rigid=True)`` allowed a rotation 1e-6 of slack (max |Q^T Q - I|): a rotation
written with 6 decimals (the common "%f") deviates by up to about 3e-6, and one in ten was refused as "not
rigid" by ``Scene.add``, ``Scene.set_transform`` and ``pyshadow-bake``'s motion files. Now up to 1e-4 is
allowed (5 decimals), and such a transform is replaced by the nearest scaled rotation, whose inverse is its
transpose as the kernels take it; one within 1e-6 is kept as given, bit for bit.
"""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow._validate import RIGID_EXACT, RIGID_TOL, check_transform


def _rotations(n, seed=0):
    rng = np.random.default_rng(seed)
    out = []
    for q in rng.normal(size=(n, 4)):
        T = trimesh.transformations.quaternion_matrix(q / np.linalg.norm(q))
        T[:3, 3] = rng.uniform(-5, 5, 3)
        out.append(T)
    return out


def _deviation(A):
    s = np.cbrt(np.linalg.det(A))
    Q = A / s
    return np.abs(Q.T @ Q - np.eye(3)).max()


@pytest.mark.parametrize("decimals", [5, 6])
@pytest.mark.parametrize("scale", [1.0, 2.5e-3, 4e3])
def test_rotations_with_rounded_digits_are_snapped_to_rotations(decimals, scale):
    refused = 0
    for T in _rotations(200, seed=decimals):
        T = T.copy()
        T[:3, :3] *= scale
        written = np.round(T / scale, decimals) * scale if scale != 1.0 else np.round(T, decimals)
        written[3] = [0.0, 0.0, 0.0, 1.0]
        got = check_transform(written, rigid=True)
        err = _deviation(written[:3, :3])
        refused += err > RIGID_EXACT             # what the old bound refused
        if err > RIGID_EXACT:
            assert _deviation(got[:3, :3]) < 1e-14                             # a scaled rotation now
            assert np.abs(got[:3, :3] - written[:3, :3]).max() <= 2 * err * scale  # and near what was written
        else:
            np.testing.assert_array_equal(got, written)                        # kept bit for bit
        np.testing.assert_array_equal(got[:, 3], written[:, 3])                # the translation as given
        s_written = np.cbrt(np.linalg.det(written[:3, :3]))                  # its uniform scale is kept
        assert np.cbrt(np.linalg.det(got[:3, :3])) == pytest.approx(s_written, rel=1e-12)
    if decimals == 5:
        assert refused > 150                     # 5 decimals: nearly all were refused before
    else:
        assert refused > 5                       # 6 decimals: about one in ten


def test_shear_and_stretch_beyond_the_bound_are_still_refused():
    T = np.eye(4)
    T[0, 1] = 3 * RIGID_TOL                      # a shear of 3e-4
    with pytest.raises(ValueError, match=r"is not rigid.*by 0.0003 .*0.0001 is allowed"):
        check_transform(T, rigid=True)
    with pytest.raises(ValueError, match="is not rigid"):
        check_transform(np.diag([1.0, 1.0002, 1.0, 1.0]), rigid=True)


def test_a_scene_places_a_rounded_rotation_as_its_snapped_rotation():
    """Placed from a rotation written with 5 decimals, a box answers as the snapped rotation's box: the same
    answers as a scene given that exact rotation, and nearly those of the unrounded one."""
    T = _rotations(1, seed=3)[0]
    T[:3, 3] = [0.0, 0.5, 0.0]
    written = np.round(T, 5)
    assert _deviation(written[:3, :3]) > RIGID_EXACT          # refused before
    box = trimesh.creation.box((1.0, 1.0, 1.0))

    def scene(M):
        s = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
        s.add(box, M)
        return s

    a = scene(written)
    placed = a.transform(0)
    np.testing.assert_array_equal(placed, check_transform(written, rigid=True))
    rng = np.random.default_rng(5)
    p = rng.uniform(-3, 3, (4000, 3)) + [0.0, 3.5, 0.0]
    w = rng.normal(size=(4000, 3))
    np.testing.assert_array_equal(a.visible(p, w), scene(placed).visible(p, w))
    assert (a.visible(p, w) == scene(T).visible(p, w)).mean() > 0.999
