"""``scene_arrays.cube_groups``: the far points' cubes as wide as the max-norm rule of pyshadow.anchor_reach allows.

A point may be asked relative to an anchor whose largest coordinate difference from it is at most its reach;
a cube's centre lies within half its side of every point in it, coordinate by coordinate, so a cube may be
twice the point's reach wide. The cubes were at most the reach wide (their half diagonal within it), which
made fields of tiny casters split the queries into 1.2 to 3.7 times the groups, each a kernel launch with its
instance tables.
"""
import numpy as np
import pytest

from pyshadow.anchor_reach import caster_buckets
from pyshadow.scene_arrays import ANCHOR_REACH_RADII, cube_groups


def _field(seed, n=2000, half=50.0, radius=5e-4, points=4000, offset=(0.0, 0.0, 0.0)):
    """``n`` casters of ``radius`` on a square of side 2 ``half`` m, ``points`` ground points over it."""
    rng = np.random.default_rng(seed)
    off = np.asarray(offset, np.float64)
    centres = off + np.column_stack([rng.uniform(-half, half, n), np.full(n, radius), rng.uniform(-half, half, n)])
    radii = np.full(n, radius)
    p = off + np.column_stack([rng.uniform(-half, half, points), np.zeros(points), rng.uniform(-half, half, points)])
    return centres, radii, p


def _reach(centres, radii, p):
    """reach(p) by brute force, float64: min over casters of max(512 r, |c - p| - r)."""
    out = np.full(len(p), np.inf)
    for s in range(0, len(p), 500):
        d = np.linalg.norm(p[s:s + 500, None] - centres[None], axis=2) - radii
        out[s:s + 500] = np.maximum(ANCHOR_REACH_RADII * radii, d).min(axis=1)
    return out


def _groups(centres, radii, p, anchor):
    return cube_groups(p, anchor, ANCHOR_REACH_RADII * radii.min(), None, lambda: caster_buckets(centres, radii))


@pytest.mark.parametrize("offset", [(0.0, 0.0, 0.0), (1e4, 0.0, -1e4)])
def test_tiny_caster_field_groups(offset):
    """Was: 2,000 casters of 1 mm over 100 x 100 m, 4,000 ground points: 3,622 anchor groups (18 s of AO),
    every point within half its reach of its anchor (3,604 here). Now under 3,300 (3,076), every point still within
    its reach (the largest coordinate, float32-rounded as the kernels read it), and most cubes wider than
    before (some point beyond 0.6 of its reach)."""
    centres, radii, p = _field(0, offset=offset)
    anchor = np.asarray(offset, np.float64)
    groups = _groups(centres, radii, p, anchor)
    assert len(groups) < 3300
    reach = _reach(centres, radii, p)
    seen = np.zeros(len(p), int)
    worst = 0.0
    for rows, a in groups:
        rows = np.arange(len(p)) if rows is None else rows
        seen[rows] += 1
        d = np.abs((p[rows] - a).astype(np.float32).astype(np.float64)).max(axis=1)
        assert (d <= reach[rows]).all()
        worst = max(worst, float((d / reach[rows]).max()))
    assert (seen == 1).all()
    assert 0.6 < worst <= 1.0


def test_five_centimetre_field_groups():
    """Was: 2,000 casters of 5 cm over 100 x 100 m, 4,000 ground points: 193 anchor groups (0.42 s of AO).
    193 here. Now under 100 (65)."""
    centres, radii, p = _field(1, radius=2.5e-2)
    assert len(_groups(centres, radii, p, np.zeros(3))) < 100


@pytest.mark.parametrize("reach", [0.25, 0.3, 1.0, 7.0])
@pytest.mark.parametrize("far", [0.0, 1e4, 1e5])
def test_cube_faces_and_power_of_two_reach(reach, far):
    """Was: cubes of side 2**floor(log2(reach)), within half the reach. Now 2**e with reach = m 2**e, m in
    [0.5, 1): a reach that is a power of two gets cubes of exactly twice its width; points on cube faces,
    at their corners and just inside them, up to 1e5 from the origin, stay within the reach of their cube's
    centre in every coordinate, in float64 and rounded to float32."""
    rng = np.random.default_rng(int(reach * 10 + far))
    side = np.ldexp(1.0, np.frexp(reach)[1])
    assert reach < side <= 2 * reach
    cells = rng.integers(-40, 40, (3000, 3)) + np.floor(far / side)
    frac = rng.choice([0.0, 0.5, 1.0 - 2.0 ** -40, 2.0 ** -40], (3000, 3))
    p = (cells + frac) * side
    p[:300] = np.nextafter(p[:300], np.inf)
    p[300:600] = np.nextafter(p[300:600], -np.inf)
    anchor = np.full(3, far + 1e3 * side)         # every point far from it: all in cubes
    groups = cube_groups(p, anchor, reach)
    assert groups[0][0] is not None and sum(len(r) for r, _ in groups) == len(p)
    for rows, a in groups:
        d = p[rows] - a
        assert np.abs(d).max() <= reach and np.abs(d.astype(np.float32)).max() <= reach
    # a cube per distinct cell of twice the reach's power of two: no wider (the points of one cell share it)
    assert len(groups) == len(np.unique(np.floor(p / side), axis=0))
