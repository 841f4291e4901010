"""Faces whose back side is open to the outside (pyshadow.csm.exposure), and the build's 'auto' margin."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import CoherentShadowMap
from pyshadow.csm import compress_reference, escape_fractions, exposed_back_faces, open_sheet
from pyshadow.raster import render_depth_reference


def _box(size=(1, 1, 1), centre=(0, 0.5, 0)):
    return trimesh.creation.box(size, trimesh.transformations.translation_matrix(centre))


def _open_box():
    box = _box()
    f = np.asarray(box.faces)[box.face_normals[:, 1] < 0.5]
    return trimesh.Trimesh(np.asarray(box.vertices), f, process=False)


def _frame(mesh):
    return pyshadow.bounding_sphere(mesh)


def test_exposed_back_faces_follow_the_geometry():
    """A closed box wound outwards: no back is open; wound inwards: every one; an open box: every face
    (its inside is seen through the missing lid); a single triangle: its one face; a closed box floating
    inside the open box: none of its own, whatever the outer box's (clear of the floor's centroids, which
    are where the rays start)."""
    closed = _box()
    assert not exposed_back_faces(closed, _frame(closed)).any()
    inverted = trimesh.Trimesh(np.asarray(closed.vertices), np.asarray(closed.faces)[:, ::-1], process=False)
    assert exposed_back_faces(inverted, _frame(inverted)).all()
    ob = _open_box()
    assert exposed_back_faces(ob, _frame(ob)).all()
    tri = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], process=False)
    assert exposed_back_faces(tri, _frame(tri)).tolist() == [True]
    inner = _box((0.2, 0.2, 0.2), (0, 0.3, 0))
    both = trimesh.util.concatenate([ob, inner])
    got = exposed_back_faces(both, _frame(both))
    assert got[: len(ob.faces)].all() and not got[len(ob.faces):].any()
    # the answer does not depend on where the mesh lies or on its size (the rays run in its normalised frame)
    far = both.copy()
    far.apply_scale(1e-4)
    far.apply_translation([1e3, -2e3, 5e2])
    np.testing.assert_array_equal(exposed_back_faces(far, _frame(far)), got)


def test_escape_fractions_count_the_rays_that_leave():
    """Sealed backs 0, backs facing open space 1, the open box's inside between; a face is exposed at a
    lattice exactly where some ray of that lattice leaves (the teapot, open at its lid and spout)."""
    closed = _box()
    assert (escape_fractions(closed, _frame(closed), 256) == 0.0).all()
    inverted = trimesh.Trimesh(np.asarray(closed.vertices), np.asarray(closed.faces)[:, ::-1], process=False)
    assert (escape_fractions(inverted, _frame(inverted), 256) == 1.0).all()
    ob = _open_box()
    f = escape_fractions(ob, _frame(ob), 1024)
    assert ((f > 0) & (f < 1)).all()
    # a floor triangle's centroid sees the unit-square opening one unit up over the solid angle of a
    # rectangle above a point (the sum of atan(x z / (h sqrt(x^2 + z^2 + h^2))) over its corners, signed),
    # 0.1218 of the hemisphere; the lattice's 512 back directions count it within 5 directions
    floor = ob.face_normals[:, 1] < -0.5
    for share, (px, py, pz) in zip(f[floor], ob.triangles_center[floor]):
        h = 1.0 - py
        omega = sum(sx * sz * np.arctan(x * z / (h * np.sqrt(x * x + z * z + h * h)))
                    for sx, x in ((1, 0.5 - px), (-1, -0.5 - px)) for sz, z in ((1, 0.5 - pz), (-1, -0.5 - pz)))
        assert abs(share - omega / (2 * np.pi)) < 0.01
    teapot = pyshadow.data.mesh("teapot")
    fr = _frame(teapot)
    for d in (32, 64):
        np.testing.assert_array_equal(escape_fractions(teapot, fr, d) > 0, exposed_back_faces(teapot, fr, d))


def test_a_zero_area_face_is_not_exposed():
    m = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]], [[0, 1, 2], [0, 1, 3]], process=False)
    assert exposed_back_faces(m, _frame(m)).tolist() == [True, False]


def test_both_sides_flags_equal_the_numpy_reference():
    """The rasteriser's facing flags with faces marked both-sided: bit for bit the reference's where the
    depth orders agree; a marked face reads as facing the light from every side."""
    ob = _open_box()
    ob.apply_transform(trimesh.transformations.rotation_matrix(0.4, [1, 0.3, 0.2]))
    views = pyshadow.ViewSet.zigzag(3, 6)
    both = np.zeros(len(ob.faces), bool)
    both[::3] = True
    ours, front = pyshadow.render_depth(ob, views, resolution=24, layers=2, facing=True, both_sides=both)
    ref, ref_front = render_depth_reference(ob, views, resolution=24, layers=2, facing=True, both_sides=both)
    hit = np.isfinite(ref)
    np.testing.assert_array_equal(np.isfinite(ours), hit)
    same = hit & (np.abs(np.where(hit, ours, 0) - np.where(hit, ref, 0)) <= 1e-5)
    np.testing.assert_array_equal(front[same], ref_front[same])
    _, plain = pyshadow.render_depth(ob, views, resolution=24, layers=2, facing=True)
    assert (front >= plain).all() and (front & ~plain).any()        # marking only adds facing flags
    every = pyshadow.render_depth(ob, views, resolution=24, layers=2, facing=True,
                                  both_sides=np.ones(len(ob.faces), bool))[1]
    np.testing.assert_array_equal(every, hit)
    with pytest.raises(ValueError, match="both_sides"):
        pyshadow.render_depth(ob, views, resolution=24, facing=True, both_sides=both[:-1])
    with pytest.raises(ValueError, match="facing"):
        pyshadow.render_depth(ob, views, resolution=24, both_sides=both)


@pytest.mark.parametrize("bits", [16, 32])
def test_auto_build_equals_the_reference_with_the_exposed_faces(bits):
    """two_sided='auto' (the default): the fold of the facing flags with the exposed faces marked, bit for
    bit the NumPy compressor's. An open box: every face is exposed, so 'auto' is two_sided=True; a
    closed box built with layers=2: none, so 'auto' is two_sided=False; a closed box inside the open box:
    only the outer box's faces keep the margin from both sides."""
    views = pyshadow.ViewSet.zigzag(8, 16)
    tilt = trimesh.transformations.rotation_matrix(0.4, [1, 0.3, 0.2])
    ob, closed = _open_box(), _box()
    both = trimesh.util.concatenate([_open_box(), _box((0.2, 0.2, 0.2), (0, 0.3, 0))])
    for m in (ob, closed, both):
        m.apply_transform(tilt)

    def build(m, **kw):
        c = CoherentShadowMap.build(m, views, resolution=24, depth_bits=bits, layers=2, progress=False, **kw)
        return c.offsets.tobytes() + c.iend.tobytes() + np.asarray(c.depth).tobytes()

    assert build(ob) == build(ob, two_sided=True) != build(ob, two_sided=False)
    assert build(closed) == build(closed, two_sided=False)
    csm = CoherentShadowMap.build(both, views, resolution=24, depth_bits=bits, layers=2, progress=False)
    flags = exposed_back_faces(both, pyshadow.bounding_sphere(both))
    assert 0 < flags.sum() < len(flags)
    assert (csm.stats["two_sided"], csm.stats["both_sided_faces"]) == ("auto", int(flags.sum()))
    for m, kw, want in ((ob, {}, len(ob.faces)), (ob, {"two_sided": True}, len(ob.faces)), (closed, {}, 0),
                        (both, {"two_sided": False}, 0)):     # the open box: every face exposed
        c = CoherentShadowMap.build(m, views, resolution=8, layers=2, progress=False, **kw)
        assert (c.two_sided, c.both_sided_faces) == (kw.get("two_sided", "auto"), want)
    layer_maps, front = pyshadow.render_depth(both, views, resolution=24, layers=2, facing=True, both_sides=flags)
    assert open_sheet(both, flags)                  # the open box's faces hold most of the area
    offsets, iend, depth = compress_reference(layer_maps, front, 2, bits, open_air=True)
    np.testing.assert_array_equal(csm.offsets.astype(np.int64), offsets)
    np.testing.assert_array_equal(csm.iend.astype(np.int64), iend)
    assert depth.tobytes() == np.asarray(csm.depth).tobytes()
    assert build(both) not in (build(both, two_sided=True), build(both, two_sided=False))


def test_two_sided_takes_auto_true_or_false_only():
    with pytest.raises(TypeError, match="two_sided"):
        CoherentShadowMap.build(_open_box(), pyshadow.ViewSet.zigzag(2, 4), resolution=8, two_sided="yes",
                                progress=False)
    with pytest.raises(TypeError, match="two_sided"):
        CoherentShadowMap.build(_open_box(), max_error=0.05, two_sided=False, progress=False)
