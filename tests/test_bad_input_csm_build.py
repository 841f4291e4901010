"""Bad input and extremes of building a CSM and predicting one: the build's arguments
(pyshadow.csm.build), its NumPy mirror (pyshadow.csm.reference.compress_reference) and the error
model's rays and geometry (pyshadow.csm.error_model) on meshes without area, at tiny or huge scales.

Each test's docstring says what happened before the fix.
"""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.csm import CoherentShadowMap
from pyshadow.csm.build import check_arguments, layer_rule
from pyshadow.csm.error_model import Body, Layout, ao_rays, near_rays, predict, rays_for, truth_visible
from pyshadow.csm.reference import compress_reference

VIEWS = pyshadow.ViewSet.zigzag(4, 8)


def _tri(vertices, faces):
    return trimesh.Trimesh(np.asarray(vertices, float), np.asarray(faces), process=False)


def _scaled(mesh, s):
    """``mesh`` scaled by ``s`` (trimesh's apply_scale warns of its determinant's overflow at 1e160)."""
    return _tri(np.asarray(mesh.vertices) * s, mesh.faces)


@pytest.fixture(scope="module")
def torus():
    return pyshadow.data.mesh("torus")


@pytest.fixture(scope="module")
def box_maps():
    box = trimesh.creation.box()
    return pyshadow.render_depth(box, pyshadow.ViewSet.zigzag(2, 4), resolution=4, layers=3, facing=True)


@pytest.mark.parametrize("kw, match", [
    (dict(layers=np.array([2, 3])), "layers must be 'auto', 2 or 3"),
    (dict(layers=3 + 0j), "layers must be 'auto', 2 or 3"),
    (dict(depth_bits=np.array([16, 32])), "depth_bits must be 16 or 32"),
    (dict(depth_bits=np.array([16])), "depth_bits must be 16 or 32"),
    (dict(depth_bits=16 + 0j), "depth_bits must be 16 or 32"),
])
def test_array_or_complex_layers_and_depth_bits_refused_by_name(kw, match):
    """Before: layers=np.array([2, 3]) or depth_bits=np.array([16, 32]) failed with NumPy's "truth value
    of an array with more than one element is ambiguous", depth_bits=np.array([16]) with "only 0-dimensional
    arrays can be converted", and a complex 16+0j or 3+0j passed the check (it equals 16 or 3) and failed
    later in int() ("int() argument must be ... not 'complex'"); predict took depth_bits=16+0j the same way."""
    args = dict(views=VIEWS, resolution=16, depth_bits=16, layers="auto")
    args.update(kw)
    with pytest.raises(ValueError, match=match):
        check_arguments(**args)
    with pytest.raises(ValueError, match=match):
        CoherentShadowMap.build(trimesh.creation.box(), VIEWS, resolution=16, progress=False, **kw)
    if "depth_bits" in kw:
        with pytest.raises(ValueError, match=match):
            predict(trimesh.creation.box(), (4, 8), 16, kw["depth_bits"], points=10, samples=2, near=0)
    # the numbers that were accepted still are, as before
    assert [layer_rule(v) for v in (2, np.int8(2), 3.0, np.array(3))] == [2, 2, 3, 3]
    check_arguments(VIEWS, 16, np.uint8(16), np.int64(3))


@pytest.mark.parametrize("args, kw, match", [
    ((1, 16), {}, "rule must be 2 or 3"),
    (("auto", 16), {}, "rule must be 2 or 3"),
    ((2, 8), {}, "depth_bits must be 16 or 32"),
    ((2, 24), {}, "depth_bits must be 16 or 32"),
])
def test_compress_reference_refuses_rules_and_depth_bits_no_build_has(box_maps, args, kw, match):
    """Before: compress_reference took rule 1 (compressed as rule 2) and depth_bits 8 or 24 (compressed
    with float32 keys, as 32 bits) without a word; rule 'auto' failed in a comparison of int and str."""
    layers, front = box_maps
    with pytest.raises(ValueError, match=match):
        compress_reference(layers, front, *args, **kw)


def test_compress_reference_refuses_layers_of_the_wrong_shape_or_nan(box_maps):
    """Before: maps that are not square failed with IndexError (index 43 is out of bounds), a single map
    (D, L, R) with "too many indices", no maps at all returned one segment per texel ending at map -1,
    and a NaN depth was cast to a key with a RuntimeWarning ("invalid value encountered in cast")."""
    layers, front = box_maps
    for a, f in ((layers[..., :3], front[..., :3]), (layers[0], front[0]), (layers[:0], front[:0])):
        with pytest.raises(ValueError, match=r"layers must have shape \(D, L, R, R\)"):
            compress_reference(a, f, 2, 16)
    bad = layers.copy()
    bad[1, 0, 2, 2] = np.nan
    with pytest.raises(ValueError, match="layers: 1 depths are NaN"):
        compress_reference(bad, front, 2, 16)
    # the valid maps give what the build gives (the mirror's contract)
    csm = CoherentShadowMap.build(trimesh.creation.box(), pyshadow.ViewSet.zigzag(2, 4), resolution=4, layers=2,
                                  progress=False)
    offsets, iend, depth = compress_reference(layers, front, 2.0, np.int64(16))
    np.testing.assert_array_equal(offsets, csm.offsets)
    np.testing.assert_array_equal(iend, csm.iend)
    np.testing.assert_array_equal(depth, csm.depth)


def test_truth_is_scale_free_below_float32s_normal_range(torus):
    """Before: Embree's answers for the model were traced with an offset of at least float32's smallest
    normal number (1.2e-38): a torus scaled by 1e-45 had its rays start past its surfaces (11 of 240 own
    and 199 of 300 near rays answered unlike the unit torus) and its prediction came out 0.0646 / 0.0833
    instead of 0.0208 / 0.0041; at 1e-100 the offsets overflowed float32 once scaled ("origins: 480 rows
    are not finite as float32")."""
    rays = rays_for(torus, points=60, samples=4, near=300, seed=3)
    unit = [Body(torus, np.eye(4), Layout.for_mesh(torus, (8, 16), 32))]
    for s in (1e-45, 1e-100, 2.0 ** -700):
        small = _scaled(torus, s)
        body = [Body(small, np.eye(4), Layout.for_mesh(small, (8, 16), 32))]
        for r in rays.values():
            np.testing.assert_array_equal(truth_visible(body, r["p"] * s, r["d"]), truth_visible(unit, r["p"], r["d"]))
    kw = dict(points=60, samples=4, near=300, seed=3)
    ref = predict(torus, (8, 16), 32, **kw)
    small = _scaled(torus, 1e-45)
    got = predict(small, (8, 16), 32, **kw)
    for k in ("own", "near"):
        assert got[k]["disagreement"] == pytest.approx(ref[k]["disagreement"], rel=1e-9, abs=1e-15), k


@pytest.mark.parametrize("scale", [1e100, 1e160])
def test_prediction_refuses_meshes_no_csm_can_be_built_of(torus, scale):
    """Before: build refused a torus scaled by 1e100 (its bounding sphere beyond float32's range), but
    predict went on and predicted a disagreement of 0.0 on its own rays, with RuntimeWarnings of overflow;
    at 1e160 it failed with OverflowError (34, 'Numerical result out of range')."""
    big = _scaled(torus, scale)
    with pytest.raises(ValueError, match="beyond float32's range"):
        CoherentShadowMap.build(big, VIEWS, resolution=16, progress=False)
    with pytest.raises(ValueError, match="beyond float32's range"):
        predict(big, (8, 16), 32, points=60, samples=4, near=300, seed=3)
    with pytest.raises(ValueError, match="beyond float32's range"):
        Layout.for_mesh(big)


def test_a_mesh_without_area_has_no_ao_rays_named():
    """Before: a mesh whose faces are all degenerate (collinear corners) built, but the error model's AO
    rays divided a zero normal by its zero length (RuntimeWarning "invalid value encountered in divide")
    and failed with "normals: 40 rows are not finite"; so did build(max_error=...)."""
    flat = _tri([[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 1, 2]])
    with pytest.raises(ValueError, match=r"ao_rays: the mesh has no surface area \(its 1 faces"):
        ao_rays(flat, 10, 4)
    with pytest.raises(ValueError, match="no surface area"):
        CoherentShadowMap.build(flat, max_error=0.05, progress=False)
    # one degenerate face among good ones is never drawn: the rays are those of the good face
    one = _tri([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]], [[0, 1, 2], [0, 1, 3]])
    p, d, n = ao_rays(one, 20, 2)
    assert np.all(p[:, 2] == 0) and np.all(p[:, 0] + p[:, 1] <= 1 + 1e-12)
    np.testing.assert_array_equal(n, np.tile([0.0, 0.0, 1.0], (40, 1)))


@pytest.mark.parametrize("exp", [-600, 600])
def test_ao_rays_of_tiny_and_huge_meshes_are_the_unit_meshs_scaled(torus, exp):
    """Before: the face areas that weigh the draw underflowed to 0 for a torus scaled by 2**-600 (every
    point was drawn on face 0) and overflowed at 2**600 (RuntimeWarning "overflow encountered in multiply",
    every point drawn on face 1); the points are now the unit torus's times the scale, exactly (a power
    of two)."""
    s = 2.0 ** exp
    m = _scaled(torus, s)
    p0, d0, n0 = ao_rays(torus, 50, 2, seed=4)
    p, d, n = ao_rays(m, 50, 2, seed=4)
    np.testing.assert_array_equal(p, p0 * s)
    np.testing.assert_allclose(n, n0, atol=1e-12)
    np.testing.assert_allclose(d, d0, atol=1e-9)


@pytest.mark.parametrize("kw, error, match", [
    (dict(points=0), ValueError, "points must be >= 1, got 0"),
    (dict(points=-3), ValueError, "points must be >= 1"),
    (dict(points=2.5), TypeError, "points must be an int"),
    (dict(near=-5), ValueError, "near must be >= 0, got -5"),
    (dict(near=2.5), TypeError, "near must be an int"),
    (dict(near=np.nan), TypeError, "near must be an int"),
    (dict(seed=-1), ValueError, "seed must be >= 0"),
    (dict(seed=1.5), TypeError, "seed must be an int"),
])
def test_ray_counts_and_seed_checked_by_name(kw, error, match):
    """Before: points=0 drew no own AO rays at all and the model judged a CSM on nothing (a choice with
    near=0 too was 'met' by the smallest candidate); negative counts failed with NumPy's "negative
    dimensions are not allowed", seed=-1 with "expected non-negative integer", near=2.5 with "'float'
    object cannot be interpreted as an integer", points=2.5 with "expected a sequence of integers"."""
    args = dict(points=10, samples=2, near=20, seed=3)
    args.update(kw)
    with pytest.raises(error, match=match):
        rays_for(trimesh.creation.box(), **args)
    if "near" in kw:
        with pytest.raises(error, match=match.replace("near", "count")):
            near_rays(trimesh.creation.box(), kw["near"])
    # near=0 stays the documented "no near rays"
    assert set(rays_for(trimesh.creation.box(), points=10, samples=2, near=0)) == {"own"}


@pytest.mark.parametrize("maps", [(4, 8, 0), (4,), 4, ((4, 8), 2, 1)])
def test_predicted_maps_must_be_a_pair(maps):
    """Before: maps=(4, 8, 0) passed its third entry to ViewSet.zigzag as row_offset and predicted a grid
    with row 0 on the pole, another than build(ViewSet.zigzag(4, 8)) gives, labelled '4x8'; maps=(4,)
    failed with IndexError (tuple index out of range), maps=4 with "argument after * must be an iterable"."""
    box = trimesh.creation.box()
    with pytest.raises(ValueError, match=r"maps must be a pair \(theta, phi\)"):
        predict(box, maps, 8, points=10, samples=2, near=0)
    with pytest.raises(ValueError, match=r"maps must be a pair \(theta, phi\)"):
        Layout.for_mesh(box, maps)
    assert Layout.for_mesh(box, [4, 8]).views.params == pyshadow.ViewSet.zigzag(4, 8).params


@pytest.mark.parametrize("cands, error, match", [
    ([(4, 8)], ValueError, r"candidates must hold \(theta, phi, resolution\) triples, got \(4, 8\)"),
    ([(4, 8, 16, 1)], ValueError, "candidates must hold"),
    ([4], ValueError, "candidates must hold"),
    ("abc", ValueError, "candidates must hold"),
    ([(4, 8, 0)], ValueError, "candidate resolution must be in 1..4096, got 0"),
    ([(0, 8, 16)], ValueError, "candidate theta must be in"),
    ([(4, 8, 16.0)], TypeError, "candidate resolution must be an int"),
    ([(4, True, 16)], TypeError, "candidate phi must be an int"),
])
def test_candidates_checked_before_any_ray_is_drawn(monkeypatch, cands, error, match):
    """Before: a candidate that is not a (theta, phi, resolution) triple of ints was found out only after
    the rays were drawn and the three pilots built, with "size_model.<locals>.predict() missing 1 required
    positional argument" ((4, 8)), "takes 3 positional arguments but 4 were given", "argument after * must
    be an iterable" (4), or the error model's own "resolution must be ..."."""
    import pyshadow.csm.choose as choose

    def no_rays(*a, **k):
        raise AssertionError("rays drawn before the candidates were checked")
    monkeypatch.setattr(choose, "rays_for", no_rays)
    for f, limit in ((choose.choose_csm, 0.05), (choose.choose_within, 10 ** 6)):
        with pytest.raises(error, match=match):
            f(trimesh.creation.box(), limit, candidates=cands)


def test_candidates_given_as_lists_are_built(monkeypatch):
    """Before: candidates=[[4, 8, 16]] (lists, as JSON gives them) failed with "unhashable type: 'list'"
    when the chosen CSM was kept by its candidate."""
    import pyshadow.csm.choose as choose

    def fake(mesh, maps, resolution, depth_bits, lookup, *, rays=None):
        return {"layout": f"{maps[0]}x{maps[1]} r{resolution} {depth_bits}b", "maps": [int(maps[0]), int(maps[1])],
                "resolution": int(resolution), "depth_bits": int(depth_bits), "lookup": lookup, "disagreement": 0.0}
    monkeypatch.setattr(choose, "predict", fake)
    monkeypatch.setattr(choose, "size_model", lambda *a, **k: ((lambda t, p, r: 1.0), {}))
    kw = dict(points=10, samples=2, near=0, verify=False)
    for f, limit in ((choose.choose_csm, 0.05), (choose.choose_within, 10 ** 6)):
        csm, c = f(trimesh.creation.box(), limit, candidates=[[4, 8, 16]], **kw)
        assert (csm.maps, csm.resolution, c["maps"], c["resolution"]) == (32, 16, [4, 8], 16)


@pytest.mark.parametrize("views", [[1, 2], None, "zigzag", np.zeros((4, 3))])
def test_covering_angle_names_views_that_are_not_a_view_set(views):
    """Before: covering_angle([1, 2]) (or None, a string, an array of directions) failed in its cache with
    "cannot create weak reference to 'list' object" (an array: "unhashable type")."""
    from pyshadow.csm.surface_rule import covering_angle

    with pytest.raises(TypeError, match="views must be a pyshadow.ViewSet, got"):
        covering_angle(views)
    assert covering_angle(pyshadow.ViewSet.zigzag(1, 1)) == np.pi       # one map: the far side is pi away
