"""Cube texel integrals (pyshadow.lighting.cube): the block and order arguments are checked."""
import math

import numpy as np
import pytest

from pyshadow.lighting import cube
from pyshadow.lighting.sh import sh_basis


@pytest.mark.parametrize("block", [0, -1, -64])
def test_texel_moments_refuses_a_block_below_one(block):
    """Was: texel_moments(4, block=-1) yielded no block at all (range(0, 4, -1) is empty), so a caller summing
    the moments got a cube of total solid angle 0 instead of 4 pi, with no error; block=0 raised range()'s
    "arg 3 must not be zero", naming no argument."""
    with pytest.raises(ValueError, match="block"):
        list(cube.texel_moments(4, block=block))


@pytest.mark.parametrize("block", [0, -1])
def test_cube_basis_integrals_refuses_a_block_below_one(block):
    """Was: cube_basis_integrals(4, sh_basis, block=-1) yielded nothing (every integral silently 0)."""
    with pytest.raises(ValueError, match="block"):
        list(cube.cube_basis_integrals(4, sh_basis, block=block))


def test_cube_basis_integrals_names_a_bad_order():
    """Was: order=0 raised NumPy's "deg must be a positive integer" and order=2.0 its "deg must be an
    integer", naming neither the function's argument nor its limit."""
    with pytest.raises(ValueError, match="order"):
        list(cube.cube_basis_integrals(4, sh_basis, order=0))
    with pytest.raises(TypeError, match="order"):
        list(cube.cube_basis_integrals(4, sh_basis, order=2.0))


@pytest.mark.parametrize("block", [1, 3, 64])
def test_any_block_gives_the_same_integrals_and_the_whole_sphere(block):
    """Blocks of any size >= 1 cover every texel row once: the solid angles sum to 4 pi and the integrals
    equal those of one block (bit for bit: each texel's sum does not depend on its block)."""
    n = 5
    M = np.zeros((n, n, 13))
    for rows, m in cube.texel_moments(n, block=block):
        M[rows] += m
    assert 6 * M[..., 0].sum() == pytest.approx(4 * math.pi, rel=1e-13)
    ref = np.zeros((n, n, 13))
    for rows, m in cube.texel_moments(n, block=n):
        ref[rows] = m
    np.testing.assert_array_equal(M, ref)
    B = np.zeros((6, n, n, 9))
    for f, rows, b in cube.cube_basis_integrals(n, sh_basis, block=block):
        B[f, rows] += b
    assert B[..., 0].sum() == pytest.approx(2 * math.sqrt(math.pi), rel=1e-13)       # integral of Y_0 = 2 sqrt(pi)
