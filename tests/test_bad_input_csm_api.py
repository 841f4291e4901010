"""The CSM object's query helpers, its build arguments and the CSM cache on bad or extreme input.

Each test of a fixed defect says in its docstring what happened before. Every cache test keeps
``PYSHADOW_CACHE`` and its folders inside ``tmp_path``.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.cache import CSMCache, default_cache_dir
from pyshadow.csm import CoherentShadowMap
from pyshadow.csm.reference import segment_index_reference
from pyshadow.mesh import mesh_hash

from conftest import load
from test_cache import Log

R, VIEWS = 8, (2, 4)


@pytest.fixture(autouse=True)
def _cache_env(tmp_path, monkeypatch):
    monkeypatch.setenv("PYSHADOW_CACHE", str(tmp_path / "env-cache"))


@pytest.fixture(scope="module")
def mesh():
    return load("spot.obj")


@pytest.fixture(scope="module")
def views():
    return pyshadow.ViewSet.zigzag(*VIEWS)


@pytest.fixture(scope="module")
def csm(mesh, views):
    return CoherentShadowMap.build(mesh, views, resolution=R, progress=False)


def _grid(csm):
    return [a.ravel() for a in np.meshgrid(np.arange(csm.maps), np.arange(R), np.arange(R), indexing="ij")]


# ----------------------------------------------------------------------------------------------
# the query helpers: segment_index, depth_for, segment_index_reference, stored_to_depth
# ----------------------------------------------------------------------------------------------
QUERIES = ("segment_index", "depth_for", "segment_index_reference")


@pytest.mark.parametrize("query", QUERIES)
@pytest.mark.parametrize("args, match", [
    ((0.5, 0, 0), "map index"), ((0, 1.7, 0), "row/column"), ((0, 0, [0, 2.25]), "row/column"),
    ((np.nan, 0, 0), "map index"), ((0, np.inf, 0), "row/column"), ((0, 0, -np.inf), "row/column"),
])
def test_fractional_and_non_finite_indices_refused(csm, query, args, match):
    """Before: a fractional map index, row or column was truncated towards zero without a word
    (map 0.5 answered map 0, row 1.7 row 1), and NaN or inf failed inside NumPy's cast with a
    RuntimeWarning ("invalid value encountered in cast")."""
    with pytest.raises(ValueError, match=match):
        getattr(csm, query)(*args)


@pytest.mark.parametrize("query", QUERIES)
def test_whole_float_indices_answer_as_ints(csm, query):
    m, r, c = _grid(csm)
    got = getattr(csm, query)(m.astype(np.float64), r.astype(np.float32), c.astype(np.float64))
    np.testing.assert_array_equal(got, getattr(csm, query)(m, r, c))


@pytest.mark.parametrize("query", QUERIES)
@pytest.mark.parametrize("bad", [True, np.array([True, False]), 1 + 0j, "a", None, [object()]])
def test_non_numeric_indices_refused_by_name(csm, query, bad):
    """Before: True was map 1 (a bool taken as an int), a complex index dropped its imaginary
    part with a ComplexWarning, a string or None failed in int() ("invalid literal",
    "NoneType")."""
    for pos, name in ((0, "map_index"), (1, "rows"), (2, "cols")):
        args = [0, 0, 0]
        args[pos] = bad
        with pytest.raises(TypeError, match=name):
            getattr(csm, query)(*args)


@pytest.mark.parametrize("query", QUERIES)
def test_huge_indices_refused_as_out_of_range(csm, query):
    """Before: a Python int beyond int64 (2**64) failed with OverflowError ("Python int too large
    to convert to C long")."""
    for args, match in (((2**64, 0, 0), "map index"), ((0, 2**70, 0), "row/column"),
                        ((np.uint64(2**63 + 5), 0, 0), "map index")):
        with pytest.raises(ValueError, match=match):
            getattr(csm, query)(*args)


@pytest.mark.parametrize("args, match", [
    ((-1, 0, 0), "map index"), ((8, 0, 0), "map index"), ((0, -1, 0), "row/column"),
    ((0, 0, -1), "row/column"), ((0, R, 0), "row/column"), ((0, 0, R), "row/column"),
    ((0, 2**40, 0), "row/column"), ((0, -2**62, 0), "row/column"), ((0, 0, np.uint64(2**63)), "row/column"),
])
def test_reference_search_refuses_indices_out_of_range(csm, args, match):
    """Before: segment_index_reference checked nothing: map -1 or 8 of 8 answered a segment,
    column -1 wrapped to the last texel, column R read the next row's texel, row R failed with
    IndexError, a huge negative row answered segment 0: reads out of bounds or wrapped, where
    segment_index raised ValueError."""
    with pytest.raises(ValueError, match=match):
        csm.segment_index_reference(*args)
    with pytest.raises(ValueError, match=match):
        segment_index_reference(csm, *args)
    with pytest.raises(ValueError, match=match):
        csm.segment_index(*args)


@pytest.mark.parametrize("query", QUERIES)
def test_shapes_that_do_not_broadcast_named(csm, query):
    """Before: NumPy's "shape mismatch: objects cannot be broadcast" (arg 0, arg 1), not the names."""
    with pytest.raises(ValueError, match="map_index, rows and cols"):
        getattr(csm, query)([0, 1], [0, 1, 2], 0)


def test_queries_keep_their_shapes_and_agree(csm):
    m, r, c = _grid(csm)
    seg = csm.segment_index(m, r, c)
    np.testing.assert_array_equal(seg, csm.segment_index_reference(m, r, c))
    assert seg.dtype == np.uint32 and seg.shape == m.shape
    assert csm.segment_index(1, 2, 3).shape == () and csm.depth_for(1, 2, 3).shape == ()
    assert csm.segment_index(0, 0, [[1], [2]]).shape == (2, 1)
    assert csm.segment_index_reference(0, 0, [[1], [2]]).shape == (2,)       # flat, as it always was
    assert csm.depth_for(np.array([], int), [], []).shape == (0,)
    assert csm.segment_index_reference(np.array([], int), [], []).shape == (0,)
    np.testing.assert_array_equal(csm.segment_index(np.uint8(3), np.int16(2), np.uint64(1)),
                                  csm.segment_index(3, 2, 1))


@pytest.mark.parametrize("stored", [-1, 65536, 70000, [0, -3], 1.5, np.nan, np.array([np.inf])])
def test_stored_to_depth_refuses_values_no_16_bit_file_holds(csm, stored):
    """Before: a 16-bit CSM decoded any number: -1 gave depth -1.5e-5, 70000 gave 1.068 (beyond the
    far plane, and not the miss), 1.5 gave a depth between two keys, NaN gave NaN."""
    assert csm.depth_bits == 16
    with pytest.raises(ValueError, match="stored"):
        csm.stored_to_depth(stored)


def test_stored_to_depth_of_valid_values_unchanged(csm):
    """Valid stored values decode as before; before, a string failed in NumPy's float cast
    ("could not convert string to float"), not naming the argument."""
    keys = np.array([0, 1, 32767, 65534, 65535])
    want = np.where(keys == 65535, np.inf, keys / 65534)
    for a in (keys.astype(np.uint16), keys, keys.astype(np.uint32), keys.astype(np.float64)):
        np.testing.assert_array_equal(csm.stored_to_depth(a), want)
    assert csm.stored_to_depth(np.array([], np.uint16)).shape == (0,)
    with pytest.raises(TypeError, match="stored"):
        csm.stored_to_depth("x")


# ----------------------------------------------------------------------------------------------
# build's arguments and extreme meshes
# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("block", [np.nan, np.inf, 2.5, True, "3"])
def test_build_block_must_be_an_int(mesh, views, block):
    """Before: block=nan failed with "cannot convert float NaN to integer", inf with an
    OverflowError, 2.5 was truncated to 2, True was one map per block and "3" three."""
    with pytest.raises(TypeError, match="block"):
        CoherentShadowMap.build(mesh, views, resolution=R, block=block, progress=False)


def test_build_block_as_numpy_int_same_answer(mesh, views, csm):
    other = CoherentShadowMap.build(mesh, views, resolution=R, block=np.int64(3), progress=False)
    for k in ("offsets", "iend", "depth"):
        np.testing.assert_array_equal(getattr(other, k), getattr(csm, k))


def _tri(vertices, faces):
    return trimesh.Trimesh(np.asarray(vertices, float), np.asarray(faces), process=False)


@pytest.mark.parametrize("name, mesh_", [
    ("one triangle", _tri([[0, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2]])),
    ("planar square", _tri([[0, 0, 0], [0, 1, 0], [0, 1, 1], [0, 0, 1]], [[0, 1, 2], [0, 2, 3]])),
])
def test_flat_meshes_build_and_answer(name, mesh_):
    views = pyshadow.ViewSet.zigzag(1, 1)       # one map, along the x axis: it sees the y-z plane face on
    c = CoherentShadowMap.build(mesh_, views, resolution=3, progress=False)
    assert c.layer_rule == 2 and c.maps == 1 and repr(c).startswith("<CoherentShadowMap zigzag 1 maps 3^2")
    z = c.depth_for(*np.meshgrid([0], np.arange(3), np.arange(3), indexing="ij"))[0]
    first = pyshadow.render_depth(mesh_, views, resolution=3, layers=2)[0, 0]
    np.testing.assert_array_equal(np.isfinite(z), np.isfinite(first))
    hit = np.isfinite(z)
    assert hit.any() and (np.abs(z[hit] - first[hit]) < 2 / 65534).all()
    assert c.stats["maps"] == 1 and c.stats["ratio"] > 0


def test_coincident_vertices_refused_clearly():
    with pytest.raises(ValueError, match="coincide"):
        CoherentShadowMap.build(_tri([[1, 2, 3]] * 3, [[0, 1, 2]]), pyshadow.ViewSet.zigzag(1, 1), resolution=4,
                                progress=False)


@pytest.mark.parametrize("scale", [1e-6, 1e6])
def test_mesh_units_do_not_change_the_maps(mesh, views, csm, scale):
    other = mesh.copy()
    other.apply_scale(scale)
    c = CoherentShadowMap.build(other, views, resolution=R, progress=False)
    # at 1e-6 units the sphere fit falls back to the box's centre (pyshadow.mesh.bounding_sphere; a
    # frame 0.5 % wider, valid but not minimal): the maps differ a little, never by a lot
    assert c.radius == pytest.approx(csm.radius * scale, rel=1e-2)
    m, r, cc = _grid(c)
    a, b = c.depth_for(m, r, cc), csm.depth_for(m, r, cc)
    assert (np.isfinite(a) == np.isfinite(b)).mean() > 0.9
    hit = np.isfinite(a) & np.isfinite(b)
    assert hit.sum() > 100 and np.median(np.abs(a[hit] - b[hit])) < 0.05


@pytest.mark.parametrize("resolution", [1, 2, 3, 13])
def test_small_and_odd_resolutions(mesh, resolution):
    """Resolutions 1, 2, 3, 13 build and both searches agree; before, the reference search read
    row R (past the last texel) without a check."""
    views = pyshadow.ViewSet.zigzag(1, 3)
    c = CoherentShadowMap.build(mesh, views, resolution=resolution, progress=False)
    m, r, cc = (a.ravel() for a in np.meshgrid(np.arange(3), np.arange(resolution), np.arange(resolution),
                                                indexing="ij"))
    np.testing.assert_array_equal(c.segment_index(m, r, cc), c.segment_index_reference(m, r, cc))
    with pytest.raises(ValueError, match="row/column"):
        c.segment_index_reference(0, resolution, 0)


def test_views_sliced_from_another_set_refused_by_layout(mesh, views):
    with pytest.raises(ValueError, match="zigzag"):
        CoherentShadowMap.build(mesh, views[1:3], resolution=R, progress=False)


# ----------------------------------------------------------------------------------------------
# the cache
# ----------------------------------------------------------------------------------------------
def test_sidecar_that_is_not_an_object_is_ignored(tmp_path, mesh, views):
    """Before: a sidecar .json holding a list, a number or a string (valid JSON, not an object)
    failed the call with AttributeError ("'list' object has no attribute 'get'")."""
    cache = CSMCache(tmp_path / "c")
    _, info = cache.csm("spot", mesh, views, R, 16)
    side = Path(info["file"]).with_suffix(".json")
    key = json.loads(side.read_text())["key"]
    for text in ("[1, 2]", "5", '"x"', "null"):
        side.write_text(text)
        _, info = cache.csm("spot", mesh, views, R, 16)
        assert info["source"] == "cached" and info["build_seconds"] is None
    for seconds in ("12", "nan", float("inf"), -1.0, True, None):
        side.write_text(json.dumps({"key": key, "build_seconds": seconds, "name": "spot"}))
        assert cache.csm("spot", mesh, views, R, 16)[1]["build_seconds"] is None, seconds
    side.write_text(json.dumps({"key": key, "build_seconds": 2.5, "name": "spot"}))
    assert cache.csm("spot", mesh, views, R, 16)[1]["build_seconds"] == 2.5


@pytest.mark.parametrize("kw, error, match", [
    ({"resolution": 8.7}, TypeError, "resolution"), ({"resolution": True}, TypeError, "resolution"),
    ({"depth_bits": 16.5}, ValueError, "depth_bits"), ({"layers": 2.5}, ValueError, "layers"),
    ({"views": [1, 2]}, TypeError, "ViewSet"),
])
def test_cache_checks_the_arguments_before_a_hit(tmp_path, mesh, views, kw, error, match):
    """Before: the key rounded resolution and depth_bits with int(), so resolution=8.7 or
    depth_bits=16.5 was answered by the cached CSM of resolution 8 and 16 bits, where build
    refuses them; a list for views failed with AttributeError ("no attribute 'layout'")."""
    cache = CSMCache(tmp_path / "c")
    cache.csm("spot", mesh, views, R, 16)
    args = {"views": views, "resolution": R, "depth_bits": 16, "layers": "auto"}
    args.update(kw)
    with pytest.raises(error, match=match):
        cache.csm("spot", mesh, args["views"], args["resolution"], args["depth_bits"], args["layers"])
    with pytest.raises(error, match=match):
        cache.csm_key(mesh_hash(mesh), args["views"], args["resolution"], args["depth_bits"], args["layers"])


def test_cache_key_unchanged_for_equal_layers(mesh, views):
    cache = CSMCache(None)
    mh = mesh_hash(mesh)
    assert cache.csm_key(mh, views, R, 16, np.int64(2)) == cache.csm_key(mh, views, R, 16, 2)
    assert cache.csm_key(mh, views, np.int32(R), np.int64(16), 3) == cache.csm_key(mh, views, R, 16, 3)
    assert len({cache.csm_key(mh, views, R, 16, layers) for layers in ("auto", 2, 3)}) == 3


def test_cached_file_of_another_layer_rule_rebuilt(tmp_path, mesh, views):
    """Before: a valid CSM of layers=2 under the key of layers=3 (or 'auto' on a closed mesh) was
    returned as 'cached' with layer_rule 2: the checks on load covered mesh, maps, resolution,
    depth bits and views, not the layer rule."""
    log = Log()
    cache = CSMCache(tmp_path / "c", log)
    _, two = cache.csm("spot", mesh, views, R, 16, layers=2)
    _, three = cache.csm("spot", mesh, views, R, 16, layers=3)
    _, auto = cache.csm("spot", mesh, views, R, 16)
    two_bytes = Path(two["file"]).read_bytes()
    os.replace(two["file"], three["file"])
    c, info = cache.csm("spot", mesh, views, R, 16, layers=3)
    assert info["source"] == "rebuilt" and c.layer_rule == 3 and "layer_rule" in log.text()
    Path(auto["file"]).write_bytes(two_bytes)                 # 'auto' on a closed mesh is rule 3
    c, info = cache.csm("spot", mesh, views, R, 16)
    assert info["source"] == "rebuilt" and c.layer_rule == 3


def test_cached_footprint_or_two_sided_file_rebuilt(tmp_path, mesh, views):
    """Before: a valid CSM built with footprint=True (which the cache never builds) under a cache
    key was returned as 'cached'."""
    cache = CSMCache(tmp_path / "c", Log())
    _, info = cache.csm("spot", mesh, views, R, 16)
    CoherentShadowMap.build(mesh, views, resolution=R, footprint=True, progress=False).save(info["file"])
    c, info = cache.csm("spot", mesh, views, R, 16)
    assert info["source"] == "rebuilt" and not c.footprint


@pytest.mark.parametrize("key", ["../../outside", "a/b", "", ".hidden", "x\0y"])
def test_array_keys_that_are_not_file_names_refused(tmp_path, key):
    """Before: put_array("../../outside", a) wrote tmp_path/outside.npz, outside the cache folder,
    and array() read it back; "a/b" was silently not cached, "" wrote a hidden ".npz"."""
    cache = CSMCache(tmp_path / "c" / "d")
    with pytest.raises(ValueError, match="key"):
        cache.put_array(key, np.ones(3))
    with pytest.raises(ValueError, match="key"):
        cache.array(key)
    assert not [p for p in tmp_path.rglob("*") if p.is_file()]


@pytest.mark.parametrize("key", [5, None, b"ab" * 20])
def test_array_keys_must_be_strings(tmp_path, key):
    """Before: an int or None key failed with "'int' object is not subscriptable"."""
    cache = CSMCache(tmp_path / "c")
    with pytest.raises(TypeError, match="key"):
        cache.put_array(key, np.ones(3))
    with pytest.raises(TypeError, match="key"):
        cache.array(key)


def test_put_array_refuses_what_float32_cannot_hold(tmp_path):
    """Before: 1e300 was stored as inf (a RuntimeWarning "overflow encountered in cast"), a complex
    array lost its imaginary part (ComplexWarning)."""
    cache = CSMCache(tmp_path / "c")
    with pytest.raises(ValueError, match="float32"):
        cache.put_array("ab" * 20, np.array([1.0, 1e300]))
    with pytest.raises(TypeError, match="real"):
        cache.put_array("ab" * 20, np.array([1 + 2j]))
    assert cache.array("ab" * 20) is None
    a = np.array([np.nan, np.inf, -np.inf, 3.4e38, 0.1])         # float32 holds these (rounded)
    cache.put_array("ab" * 20, a)
    np.testing.assert_array_equal(cache.array("ab" * 20), a.astype(np.float32))
    cache.put_array("cd" * 20, np.arange(5))
    np.testing.assert_array_equal(cache.array("cd" * 20), np.arange(5, dtype=np.float32))


def test_relative_root_stays_where_it_was_made(tmp_path, mesh, views, monkeypatch):
    """Before: CSMCache("rel") resolved the folder against the working directory at every call:
    after a chdir it built the CSM again into another folder, and the earlier info["file"]
    (relative) named a file that was no longer the one written."""
    monkeypatch.chdir(tmp_path)
    cache = CSMCache("rel")
    _, first = cache.csm("spot", mesh, views, R, 16)
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")
    _, again = cache.csm("spot", mesh, views, R, 16)
    assert first["source"] == "built" and again["source"] == "cached"
    assert Path(first["file"]).is_absolute() and first["file"] == again["file"]
    assert not (tmp_path / "elsewhere" / "rel").exists()


@pytest.mark.parametrize("root", ["", "   "])
def test_empty_root_refused(root):
    """Before: CSMCache("") cached into the working directory ("." with csm/ and reference/
    folders), while PYSHADOW_CACHE="" means the default folder and None disables the cache."""
    with pytest.raises(ValueError, match="None"):
        CSMCache(root)


def test_pyshadow_cache_empty_or_relative(tmp_path, monkeypatch):
    """PYSHADOW_CACHE="" means the default folder; a relative one is fixed against the working
    directory when the cache is made (before: kept relative, see the test above)."""
    import platformdirs

    monkeypatch.setenv("PYSHADOW_CACHE", "")
    assert str(default_cache_dir()) == platformdirs.user_cache_dir("pyshadow")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("PYSHADOW_CACHE", "rel/c")
    assert CSMCache(default_cache_dir()).root == tmp_path / "rel" / "c"


def test_cache_folder_is_a_file_or_read_only(tmp_path, mesh, views, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    log = Log()
    _, info = CSMCache(blocker, log).csm("spot", mesh, views, R, 16)
    assert info["source"] == "built" and info["file"] is None and "not caching" in log.text()
    assert blocker.read_text() == "x"
    # read-only (root ignores permissions: refuse the writes instead)
    import pyshadow.cache as cache_module

    def refuse(path, *args, **kwargs):
        raise PermissionError(13, "Permission denied", str(path))

    monkeypatch.setattr(CoherentShadowMap, "save", lambda self, path, **kw: refuse(path))
    monkeypatch.setattr(cache_module, "write_bytes_atomic", refuse)
    log = Log()
    cache = CSMCache(tmp_path / "ro", log)
    c, info = cache.csm("spot", mesh, views, R, 16)
    assert info["source"] == "built" and info["file"] is None and "cannot write" in log.text()
    cache.put_array("ab" * 20, np.ones(2))
    assert cache.array("ab" * 20) is None
    assert not [p for p in (tmp_path / "ro").rglob("*") if p.is_file()]


@pytest.mark.parametrize("cut", [0, 10, 100, -1])
def test_truncated_entry_rebuilt(tmp_path, mesh, views, cut):
    cache = CSMCache(tmp_path / "c", Log())
    c1, info = cache.csm("spot", mesh, views, R, 16)
    p = Path(info["file"])
    p.write_bytes(p.read_bytes()[:cut])
    c2, info = cache.csm("spot", mesh, views, R, 16)
    assert info["source"] == "rebuilt"
    np.testing.assert_array_equal(c1.depth, c2.depth)
    assert CSMCache(tmp_path / "c").csm("spot", mesh, views, R, 16)[1]["source"] == "cached"


def test_two_caches_writing_the_same_key(tmp_path, mesh, views):
    a, b = CSMCache(tmp_path / "c"), CSMCache(tmp_path / "c")
    ca, ia = a.csm("spot", mesh, views, R, 16)
    p = Path(ia["file"])
    p.unlink()
    cb, ib = b.csm("spot", mesh, views, R, 16)          # b builds and renames over a's (gone) entry
    _, ia2 = a.csm("spot", mesh, views, R, 16)
    assert ib["source"] == "built" and ia2["source"] == "cached" and ia2["file"] == ib["file"]
    assert not [q for q in p.parent.iterdir() if q.name.startswith(".")]     # no temporary left
    np.testing.assert_array_equal(ca.depth, cb.depth)


def test_keys_of_meshes_differing_in_float_rounding(mesh, views):
    other = mesh.copy()
    v = np.array(other.vertices)
    v[0, 0] = np.nextafter(v[0, 0], np.inf)
    other.vertices = v
    cache = CSMCache(None)
    assert cache.csm_key(mesh_hash(mesh), views, R, 16, "auto") != cache.csm_key(mesh_hash(other), views, R, 16,
                                                                                   "auto")


def test_a_cache_root_starting_with_a_tilde_is_the_home_folder(tmp_path, monkeypatch):
    """CSMCache("~/cache") made a folder literally named '~' in the working directory (pyshadow-bench
    expanded it itself, PYSHADOW_CACHE too; the class did not)."""
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.chdir(tmp_path)
    c = CSMCache("~/cache")
    assert c.root == tmp_path / "home" / "cache"
    c.put_array("ab12", np.ones(3, np.float32))
    assert (tmp_path / "home" / "cache").is_dir() and not (tmp_path / "~").exists()
    np.testing.assert_array_equal(c.array("ab12"), np.ones(3, np.float32))
