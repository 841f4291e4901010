"""pyshadow.lighting.shadow_fit.split_casters: the groups of casters a directional light's map is split
over, their cells; scenes of bodies close together keep their one map."""
import numpy as np
import trimesh

from pyshadow.lighting.shadow_fit import MAX_PARTS, SPLIT_RATIO, cell_points, split_casters
from pyshadow.lighting.shadow_map import ShadowMapVisibility
from test_sunfit_far import boxes, sun


def test_close_bodies_keep_one_map():
    """Was and is: bodies within SPLIT_RATIO of each other (boxes 3 m apart, a sphere over them) keep the one
    map fitted to all (answers as before); so do a field of bodies (narrow gaps) and a body 4 m past its edge."""
    scene = boxes((0.0, 0.0), (3.0, 0.0), (0.0, -3.0))
    scene.add(trimesh.creation.icosphere(2, radius=0.4), trimesh.transformations.translation_matrix([1, 2, 1]))
    for l in (sun(10, 40), sun(200, 3), [0.0, 1.0, 0.0]):
        assert ShadowMapVisibility(64).shadow_map(scene, direction=l).parts == ()
    x = np.arange(20.0)
    field = np.c_[np.repeat(x, 20) * 2.0, np.zeros(400), np.tile(x, 20) * 2.0]
    field = np.r_[field, [[42.0, 0.0, 20.0]]]                  # 4 m past the field's edge at 38 m
    for l in (sun(0, 90), sun(30, 50), sun(0, 2)):
        assert len(split_casters(field, np.full(len(field), 0.87), l)[1]) == 1


def test_split_cells_tile_the_plane_and_hold_their_casters():
    """Was: one map over all casters, 60 bodies in 12 clumps 2e4 apart in one map of 2e4 / R texels. Now
    split_casters: at most MAX_PARTS groups; every caster in exactly one; each caster's sphere inside its
    cell across the light; every point in exactly one cell."""
    rng = np.random.default_rng(3)
    centres = np.concatenate([rng.normal(0, 1, (5, 3)) + rng.uniform(-1e4, 1e4, 3) for _ in range(12)])
    radii = rng.uniform(0.1, 0.5, len(centres))
    d = sun(33, 27)
    axes, groups = split_casters(centres, radii, d)
    assert 2 <= len(groups) <= MAX_PARTS
    np.testing.assert_array_equal(np.sort(np.concatenate([k for k, _, _ in groups])), np.arange(len(centres)))
    uv = centres @ axes.T
    for k, lo, hi in groups:
        assert (uv[k] - radii[k, None] > lo).all() and (uv[k] + radii[k, None] < hi).all()
    pts = np.concatenate([centres, rng.uniform(-2e4, 2e4, (5000, 3))])
    cells = cell_points(pts, axes, [(lo, hi) for _, lo, hi in groups])
    np.testing.assert_array_equal(np.sort(np.concatenate(cells)), np.arange(len(pts)))
    assert SPLIT_RATIO > 1




def test_four_bodies_at_the_corners_of_a_square_get_four_maps():
    """Was: one map, texels of 1 km / R. Now four 1 m bodies at the corners of a 1 km square (no single line
    leaves a small group): two cuts, then four groups of one, each cell holding its body."""
    xz = np.array([[0.0, 0.0], [1000.0, 0.0], [0.0, 1000.0], [1000.0, 1000.0]])
    centres = np.c_[xz[:, 0], np.full(4, 0.5), xz[:, 1]]
    axes, groups = split_casters(centres, np.full(4, 0.87), np.array([0.0, 1.0, 0.0]))
    assert sorted(len(k) for k, _, _ in groups) == [1, 1, 1, 1]
    cells = cell_points(centres, axes, [(lo, hi) for _, lo, hi in groups])
    assert [c.tolist() for c in cells] == [k.tolist() for k, _, _ in groups]


def test_split_maps_stay_within_their_texel_budget():
    """Was: one map (no split). Now part_limit: MAX_PARTS maps at 1024^2, fewer where they would hold over
    MAX_TEXELS texels, but 2; the split honours it (eight bodies in a row 1 km apart: 8 groups at 1024^2, 2 at
    8192^2)."""
    from pyshadow.lighting.shadow_fit import MAX_TEXELS, part_limit

    assert part_limit(1024) == MAX_PARTS and part_limit(4096) == 4 and part_limit(8192) == 2
    assert all(part_limit(R) * R * R <= max(MAX_TEXELS, 2 * R * R) for R in (8, 256, 2048, 8192))
    centres = np.c_[np.arange(8) * 1000.0, np.full(8, 0.5), np.zeros(8)]
    for R, want in ((1024, 8), (8192, 2)):
        assert len(split_casters(centres, np.full(8, 0.87), np.array([0.0, 1.0, 0.0]), part_limit(R))[1]) == want
