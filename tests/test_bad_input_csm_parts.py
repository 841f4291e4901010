"""Bad input to the parts around the CSM: the NumPy reference (pyshadow.csm.reference), the surface rule's
covering angle, the open-mesh exposure, and the view-set and SSAO-pass helpers of pyshadow.viz."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.csm import CoherentShadowMap
from pyshadow.csm.exposure import both_sided_faces, exposed_back_faces
from pyshadow.csm.reference import compress_reference, shadow_vote
from pyshadow.csm.surface_rule import covering_angle, surface_horizon


@pytest.fixture(scope="module")
def box_maps():
    box = trimesh.creation.box()
    return pyshadow.render_depth(box, pyshadow.ViewSet.zigzag(2, 4), resolution=4, layers=3, facing=True)


@pytest.fixture(scope="module")
def box_csm():
    return CoherentShadowMap.build(trimesh.creation.box(), pyshadow.ViewSet.zigzag(4, 8), resolution=8,
                                   progress=False)


def _texel_depths(out, texel):
    offsets, _, depth = out
    return depth[offsets[texel]:offsets[texel + 1]]


# ---------------------------------------------------------------------------
# compress_reference
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("bits", [16, 32])
def test_compress_reference_refuses_negative_depths(box_maps, bits):
    """Was: a first depth of -0.25 (map 0, row 0, column 1) was compressed without a word: at 16 bits its
    key wrapped around (the texel's first stored depth 9280, where a depth of 0 stores 17471), at 32 bits it
    was clamped to 0 (0.2666, as a depth of 0); -inf likewise. Depths lie in [0, 1], +inf for no hit."""
    layers, front = box_maps
    assert np.isfinite(layers[0, 0, 0, 1])
    for v in (-0.25, -np.inf):
        bad = layers.copy()
        bad[0, 0, 0, 1] = v
        with pytest.raises(ValueError, match=r"layers: 1 depths are negative .* first at index \(0, 0, 0, 1\)"):
            compress_reference(bad, front, 2, bits)
    # a depth of 0 is valid: both depth widths store the same interval's middle there
    zero = layers.copy()
    zero[0, 0, 0, 1] = 0.0
    got = _texel_depths(compress_reference(zero, front, 2, bits), 1)[0]
    assert (got == 17471) if bits == 16 else (got == np.float32(0.26660883))


@pytest.mark.parametrize("change, err, match", [
    (lambda L, F: (L + 0j, F), TypeError, "layers must hold real numbers"),
    (lambda L, F: (L.astype(str), F), TypeError, "layers must hold real numbers"),
    (lambda L, F: (L, np.where(F, "True", "False")), TypeError, "front must be a bool array"),
    (lambda L, F: (L, F * 0.5), TypeError, "front must be a bool array"),
])
def test_compress_reference_refuses_maps_of_other_dtypes(box_maps, change, err, match):
    """Was: complex depths lost their imaginary part (a ComplexWarning), strings were parsed, and facing
    flags "False" (a string) or 0.5 were read as True (the strings changed the stored depths)."""
    layers, front = box_maps
    with pytest.raises(err, match=match):
        compress_reference(*change(layers, front), 2, 16)


def test_compress_reference_two_sided_is_true_or_false(box_maps):
    """Was: two_sided="no" compressed as two_sided=True (the first stored depth of texel 1 30589 instead of
    32766)."""
    layers, front = box_maps
    for bad in ("no", "False", 1, None):
        with pytest.raises(TypeError, match="two_sided: expected True or False"):
            compress_reference(layers, front, 2, 16, two_sided=bad)
    assert _texel_depths(compress_reference(layers, front, 2, 16, two_sided=False), 1)[0] == 32766
    assert _texel_depths(compress_reference(layers, front, 2, 16, two_sided=True), 1)[0] == 30589


@pytest.mark.parametrize("margin", [np.nan, np.inf, -0.01, True, "0.01", np.array([0.01, 0.02])])
def test_compress_reference_margin_depth_is_finite_and_not_negative(box_maps, margin):
    """Was: margin_depth NaN was cast to a key with a RuntimeWarning, -0.01 moved every bound z2' behind
    its z2 (stored depths up to 33094 where the default margin stores at most 32766), True was a margin of 1."""
    layers, front = box_maps
    with pytest.raises(ValueError, match="margin_depth must be a finite number >= 0"):
        compress_reference(layers, front, 2, 16, margin_depth=margin)
    np.testing.assert_array_equal(compress_reference(layers, front, 2, 16, margin_depth=0.0)[2],
                                  compress_reference(layers, front, 2, 16, margin_depth=np.float32(0))[2])


def test_compress_reference_corners_need_corner_front(box_maps):
    """Was: corners without corner_front failed with "corners must have shape (8, 3, 5, 5), got (8, 3, 5, 5)"
    (the shape of the missing flags, None, was the one that did not match)."""
    layers, front = box_maps
    corners = np.full((8, 3, 5, 5), np.inf, np.float32)
    with pytest.raises(ValueError, match="corner_front must be given with corners"):
        compress_reference(layers, front, 2, 16, corners=corners)
    with pytest.raises(ValueError, match=r"corners and corner_front must have shape \(8, 3, 5, 5\), got "
                                         r"\(8, 3, 5, 5\) and \(8, 3, 4, 4\)"):
        compress_reference(layers, front, 2, 16, corners=corners, corner_front=front)


# ---------------------------------------------------------------------------
# shadow_vote / shadow_taps
# ---------------------------------------------------------------------------
def _queries(csm, n=40):
    rng = np.random.default_rng(3)
    pn = rng.uniform(-0.9, 0.9, (n, 3))
    wn = rng.normal(size=(n, 3))
    wn /= np.linalg.norm(wn, axis=1)[:, None]
    maps = np.asarray(csm.views.nearest(wn), np.int64)[:, None]
    return pn, wn, maps, np.ones((n, 1))


@pytest.mark.parametrize("texels", [True, np.array([1, 4]), 4.0, "4"])
def test_shadow_vote_texels_is_an_int(box_csm, texels):
    """Was: texels=True voted with one texel (True == 1), an array failed with "truth value of an array ...
    is ambiguous", 4.0 was taken as 4 and "4" was refused only as "must be 1 or 4"."""
    pn, wn, maps, w = _queries(box_csm)
    with pytest.raises(TypeError, match="texels must be an int"):
        shadow_vote(box_csm, pn, wn, maps, w, quantum=1e-4, texels=texels)


def test_shadow_vote_refuses_map_indices_outside_the_view_set(box_csm):
    """Was: a map index -1 was read as the last map (31) without a word, so that its vote equalled that of
    map 31; float indices failed with NumPy's "arrays used as indices must be of integer type", indices of
    another length than the points with "operands could not be broadcast"."""
    pn, wn, maps, w = _queries(box_csm)
    for bad in (np.full_like(maps, -1), maps + 32):
        with pytest.raises(ValueError, match=r"maps must lie in 0 \.\. 31"):
            shadow_vote(box_csm, pn, wn, bad, w, quantum=1e-4)
    with pytest.raises(TypeError, match="maps must be integer map indices"):
        shadow_vote(box_csm, pn, wn, maps.astype(float), w, quantum=1e-4)
    with pytest.raises(ValueError, match=r"maps and map_weights must have shape \(N, M\) with N = 40"):
        shadow_vote(box_csm, pn, wn, maps[:5], w[:5], quantum=1e-4)
    with pytest.raises(ValueError, match=r"got \(40, 1\) and \(40, 2\)"):
        shadow_vote(box_csm, pn, wn, maps, np.ones((40, 2)), quantum=1e-4)


@pytest.mark.parametrize("kw, match", [
    (dict(quantum=np.nan), "quantum must be a finite number"),
    (dict(quantum=1e-4, bias=np.nan), "bias must be a finite number"),
    (dict(quantum=1e-4, bias_texels=np.inf), "bias_texels must be a finite number"),
    (dict(quantum=True), "quantum must be a finite number"),
])
def test_shadow_vote_refuses_non_finite_biases(box_csm, kw, match):
    """Was: a NaN quantum or bias made every comparison false: a vote of 0 (lit) for every ray, with no
    warning (here 4 of the 40 rays are shadowed with quantum 1e-4); an infinite bias_texels likewise."""
    pn, wn, maps, w = _queries(box_csm)
    assert int((shadow_vote(box_csm, pn, wn, maps, w, quantum=1e-4) > 0.5).sum()) == 4
    with pytest.raises(ValueError, match=match):
        shadow_vote(box_csm, pn, wn, maps, w, **kw)


def test_shadow_vote_refuses_non_finite_points(box_csm):
    """Was: a NaN point was cast to a texel index with a RuntimeWarning ("invalid value encountered in
    cast"); a direction array of another length failed in NumPy's einsum."""
    pn, wn, maps, w = _queries(box_csm)
    bad = pn.copy()
    bad[3] = np.nan
    with pytest.raises(ValueError, match="pn: 1 rows are not finite"):
        shadow_vote(box_csm, bad, wn, maps, w, quantum=1e-4)
    with pytest.raises(ValueError, match="wn has 39 rows but points has 40"):
        shadow_vote(box_csm, pn, wn[1:], maps, w, quantum=1e-4)


def test_shadow_vote_normals_without_lift_lift_no_row(box_csm):
    """Was: normals with a bias but no ``lift`` failed with "unsupported operand type(s) for &: 'NoneType'
    and 'bool'" (with the default bias no row was lifted). Now lift None means no row, with either bias."""
    pn, wn, maps, w = _queries(box_csm)
    plain = shadow_vote(box_csm, pn, wn, maps, w, quantum=1e-4, bias=0.01)
    got = shadow_vote(box_csm, pn, wn, maps, w, quantum=1e-4, bias=0.01, normals=wn)
    np.testing.assert_array_equal(got, plain)
    np.testing.assert_array_equal(got, shadow_vote(box_csm, pn, wn, maps, w, quantum=1e-4, bias=0.01, normals=wn,
                                                   lift=np.zeros(40, bool)))
    with pytest.raises(ValueError, match=r"lift must be a bool array of shape \(40,\)"):
        shadow_vote(box_csm, pn, wn, maps, w, quantum=1e-4, bias=0.01, normals=wn, lift=np.ones(40))


# ---------------------------------------------------------------------------
# surface rule, exposure
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("lookup", [np.array(["nearest"]), np.array(["nearest", "vote"])])
def test_covering_angle_lookup_is_a_string(lookup):
    """Was: lookup=np.array(['nearest']) failed in the cache with "unhashable type: 'numpy.ndarray'", two
    names with "The truth value of an array ... is ambiguous"."""
    views = pyshadow.ViewSet.zigzag(1, 1)
    with pytest.raises(ValueError, match="lookup must be 'nearest' or 'vote', got"):
        covering_angle(views, lookup)
    assert covering_angle(views, "nearest") == np.pi


def test_surface_horizon_of_a_view_set_names_csm(box_csm):
    """Was: surface_horizon(views) failed with "'ViewSet' object has no attribute 'views'"."""
    with pytest.raises(TypeError, match="csm must be a CoherentShadowMap .* got ViewSet"):
        surface_horizon(box_csm.views)
    assert surface_horizon(box_csm) == np.sin(min(covering_angle(box_csm.views), 0.5 * np.pi))


@pytest.mark.parametrize("two_sided", ["yes", "AUTO", np.array(["auto"]), None, 1])
def test_both_sided_faces_two_sided_as_the_build(two_sided):
    """Was: two_sided "yes", "AUTO", an array or None returned None (no face marked, as False) where the
    build refuses them; on an open box 'auto' marks 10 faces."""
    ob = trimesh.creation.box()
    ob.update_faces(np.arange(len(ob.faces)) != 0)
    frame = pyshadow.bounding_sphere(ob)
    with pytest.raises(TypeError, match="two_sided must be True, False or 'auto', got"):
        both_sided_faces(ob, frame, 2, two_sided)
    auto = both_sided_faces(ob, frame, 2, "auto")
    assert int(auto.sum()) == 10
    np.testing.assert_array_equal(auto, exposed_back_faces(ob, frame))
    assert both_sided_faces(ob, frame, 2, np.bool_(True)) is None


# ---------------------------------------------------------------------------
# viz: view sets, SSAO pass
# ---------------------------------------------------------------------------
def test_view_set_points_radius_is_a_real_number_and_path_a_bool():
    """Was: radius=True drew the maps on the unit sphere, radius="2" on a sphere of radius 2, path="no" drew
    the path and an array path failed with "truth value of an array ... is ambiguous"."""
    viz = pytest.importorskip("pyshadow.viz")
    views = pyshadow.ViewSet.zigzag(4, 8)
    for radius in (True, "2", 2 + 0j, np.array([1.0, 2.0])):
        with pytest.raises(TypeError, match="view_set_points: radius must be a real number"):
            viz.view_set_points(views, radius=radius)
    for path in ("no", np.array([True, False]), 0):
        with pytest.raises(TypeError, match="path: expected True or False"):
            viz.view_set_points(views, path=path)
    poly = viz.view_set_points(views, radius=np.float32(2.0), path=False)
    np.testing.assert_allclose(np.linalg.norm(poly.points, axis=1), 2.0, rtol=1e-12)
    assert poly.n_lines == 0


def test_add_view_set_checks_path_before_drawing():
    """Was: add_view_set(..., path="no") drew the sphere and the path (the string is true)."""
    viz = pytest.importorskip("pyshadow.viz")
    pl = viz.make_plotter(window_size=(64, 48), off_screen=True)
    try:
        with pytest.raises(TypeError, match="path: expected True or False"):
            viz.add_view_set(pl, pyshadow.ViewSet.zigzag(2, 4), path="no")
        assert len(pl.renderer.actors) == 0
    finally:
        pl.close()


@pytest.mark.parametrize("kw, match", [
    (dict(radius=True), "radius must be a real number"),
    (dict(radius="0.5"), "radius must be a real number"),
    (dict(radius=0.5, bias=True), "bias must be a real number"),
    (dict(radius=0.5, blur="no"), "blur: expected True or False"),
])
def test_vtk_ssao_radius_bias_blur_types(kw, match):
    """Was: radius=True rendered with a radius of 1 world unit, "0.5" with 0.5, bias=True with 1, and
    blur="no" blurred."""
    viz = pytest.importorskip("pyshadow.viz")
    scene = pyshadow.Scene(ground=0.0)
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), trimesh.transformations.translation_matrix([0, 0.5, 0]),
              casts=False)
    cam = pyshadow.Camera([0.0, 1.6, 3.0], [0.0, 0.3, 0.0], width=32, height=24)
    with pytest.raises(TypeError, match=match):
        viz.vtk_ssao(scene, cam, kernel_size=4, **kw)
