"""Differential checks of building and storing CSMs: a CSM against its saved and loaded copy, the cache's
answer against a fresh build, a crafted file against the loader's documented error."""
import hashlib
import json

import numpy as np
import pytest
import trimesh

from pyshadow import CoherentShadowMap, ViewSet
from pyshadow.cache import CSMCache
from pyshadow.csm import CSMFormatError


def _turned(views):
    """``views`` with every map's ``u, v`` turned a quarter about its direction: the same grid, other
    bases (a ViewSet accepts any bases on a zigzag or hilbert grid)."""
    b = views.bases.copy()
    b[:, 0], b[:, 1] = views.bases[:, 1], -views.bases[:, 0]
    return ViewSet(views.directions, b, views.layout, views.params)


@pytest.fixture(scope="module")
def box():
    return trimesh.creation.box((1.0, 0.3, 2.0))


def _arrays(csm):
    return tuple(np.asarray(a).tobytes() for a in (csm.offsets, csm.iend, csm.depth))


def test_save_refuses_a_view_set_whose_bases_the_file_cannot_hold(box, tmp_path):
    """Before: a CSM built on ViewSet.zigzag(2, 4)'s grid with its maps turned a quarter was saved
    without a word; load rebuilt the layout's own bases, so every map of the loaded CSM was read turned
    (in a zigzag(4, 8) CSM of this box at 16^2, rays from points below it disagreed with Embree on 502
    of 4000, against 237 for the CSM as built). Now save is a ValueError naming the bases, and writes
    nothing; the layout's own view set still comes back bit for bit."""
    views = ViewSet.zigzag(2, 4)
    turned = _turned(views)
    csm = CoherentShadowMap.build(box, turned, resolution=4, progress=False)
    path = tmp_path / "turned.csm"
    with pytest.raises(ValueError, match=r"bases are not those of its zigzag layout .*map 0 off by 1, 8 of 8"):
        csm.save(path)
    assert not path.exists() and list(tmp_path.iterdir()) == []
    plain = CoherentShadowMap.build(box, views, resolution=4, progress=False)
    plain.save(path)
    back = CoherentShadowMap.load(path)
    assert np.array_equal(back.views.bases, views.bases) and _arrays(back) == _arrays(plain)
    # the turned maps are another CSM: its lists differ from the layout's
    assert _arrays(csm) != _arrays(plain)


def test_cache_never_answers_other_bases_with_the_layouts_csm(box, tmp_path):
    """Before: the cache keyed a CSM by the view set's layout and parameters only, so asking for the
    turned maps after the layout's own got the layout's CSM back ('cached', its bases those of
    ViewSet.zigzag(2, 4), its lists another CSM's); asked first, the turned CSM was stored and came
    back with the layout's bases. Now a view set of other bases is built and not cached (file None,
    a note in the log), and the layout's own is cached as before."""
    views = ViewSet.zigzag(2, 4)
    turned = _turned(views)
    log = []
    cache = CSMCache(tmp_path, log=log.append)
    fresh = CoherentShadowMap.build(box, turned, resolution=4, progress=False)
    sources = []
    for v in (turned, views, turned, views):
        csm, info = cache.csm("box", box, v, 4, 16)
        sources.append(info["source"])
        assert np.array_equal(csm.views.bases, v.bases)
        assert (info["file"] is None) == (v is turned)
        if v is turned:
            assert _arrays(csm) == _arrays(fresh)
    assert sources == ["built", "built", "built", "cached"]
    assert sum("not caching the CSM of box" in m and "bases" in m for m in log) == 2


def _resigned(path, edit):
    """The bytes of the .csm file ``path`` with its header changed by ``edit`` and the checksum redone
    (the arrays moved to their 64-byte boundaries after the new header)."""
    from pyshadow.csm.fileformat import array_layout

    raw = path.read_bytes()
    hlen = int(np.frombuffer(raw[12:16], "<u4")[0])
    head = json.loads(raw[16:16 + hlen])
    old, _ = array_layout(16 + hlen, head["resolution"], head["maps"], head["segments"], head["depth_bits"],
                          head["offsets_dtype"])
    arrays = [raw[off:off + dt.itemsize * n] for _, dt, n, off in old]
    edit(head)
    hb = json.dumps(head).encode()
    new, _ = array_layout(16 + len(hb), head["resolution"], head["maps"], head["segments"],
                          head["depth_bits"], head["offsets_dtype"])
    out = bytearray(raw[:12] + np.uint32(len(hb)).tobytes() + hb)
    for (_, _, _, off), a in zip(new, arrays):
        out += b"\0" * (off - len(out)) + a
    return bytes(out) + hashlib.sha256(bytes(out)).digest()


@pytest.mark.parametrize("views, key", [(ViewSet.hilbert(1), "level"), (ViewSet.zigzag(1, 4), "theta")])
def test_load_refuses_layout_parameters_of_true(box, tmp_path, views, key):
    """Before: a file whose layout_params held ``true`` for hilbert's level 1 (or a one-row zigzag's
    theta) passed the header checks (a bool is an int, True == 1) and failed in ViewSet with a
    TypeError, which load does not document. Now it is the CSMFormatError naming the parameters; the
    same file with the integer 1 loads, equal to the CSM saved."""
    csm = CoherentShadowMap.build(box, views, resolution=2, progress=False)
    path = tmp_path / "a.csm"
    csm.save(path)
    bad = tmp_path / "b.csm"
    bad.write_bytes(_resigned(path, lambda h: h["layout_params"].__setitem__(key, True)))
    for mmap in (False, True):
        with pytest.raises(CSMFormatError, match=rf"invalid {views.layout} parameters .*'{key}': True"):
            CoherentShadowMap.load(bad, mmap=mmap)
    bad.write_bytes(_resigned(path, lambda h: h["layout_params"].__setitem__(key, 1)))
    back = CoherentShadowMap.load(bad)
    assert _arrays(back) == _arrays(csm) and np.array_equal(back.views.bases, csm.views.bases)


@pytest.mark.parametrize("resolution, bits", [(1, 16), (2, 32), (4, 16)])
def test_a_csm_of_fewer_segments_than_maps_loads(tmp_path, resolution, bits):
    """Before: load refused every file with fewer segments than maps ("4 segments cannot cover 32
    maps"), though a run of maps is one segment: an icosphere's CSM on ViewSet.zigzag(4, 8) at 1^2,
    2^2 and 4^2 texels (31, 4 and 16 segments) was saved and could not be read back, and the cache
    rebuilt it on every call ('rebuilt'). Now it loads equal to the CSM saved, mapped or read, and the
    cache's second call is 'cached'."""
    sphere = trimesh.creation.icosphere(2)
    views = ViewSet.zigzag(4, 8)
    csm = CoherentShadowMap.build(sphere, views, resolution=resolution, depth_bits=bits, progress=False)
    assert csm.segments < csm.maps
    csm.save(tmp_path / "s.csm")
    for mmap in (False, True):
        back = CoherentShadowMap.load(tmp_path / "s.csm", mmap=mmap)
        assert _arrays(back) == _arrays(csm) and back.depth.dtype == csm.depth.dtype
        assert np.array_equal(back.depth_for(np.arange(32), 0, 0), csm.depth_for(np.arange(32), 0, 0))
    cache = CSMCache(tmp_path / "cache")
    sources = [cache.csm("sphere", sphere, views, resolution, bits)[1]["source"] for _ in range(2)]
    assert sources == ["built", "cached"]
