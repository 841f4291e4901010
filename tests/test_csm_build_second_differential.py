"""Second differential pass over building and storing CSMs: a CSM against its saved and loaded copy where its
view set was given its layout's parameters in other forms than ViewSet.zigzag / ViewSet.hilbert write them."""
import hashlib
import json

import numpy as np
import pytest
import trimesh

from pyshadow import CoherentShadowMap, ViewSet

from conftest import all_pairs


def _given(views, params):
    """``views``' directions and bases as a given ViewSet of its layout with ``params`` (which it accepts)."""
    return ViewSet(views.directions, views.bases, views.layout, params)


def _check_round_trip(csm, path):
    """Save and load ``csm``: every array, the frame and every lookup's answer equal; the loaded view set's
    bases equal the built one's. Returns the loaded CSM."""
    back = CoherentShadowMap.load(csm.save(path))
    for name in ("offsets", "iend", "depth"):
        a, b = getattr(csm, name), getattr(back, name)
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes(), name
    assert back.radius == csm.radius and np.array_equal(back.centre, csm.centre)
    assert np.array_equal(back.box, csm.box)
    assert back.views.bases.tobytes() == csm.views.bases.tobytes()
    m, r, c = all_pairs(csm)
    assert np.array_equal(back.depth_for(m, r, c), csm.depth_for(m, r, c))
    return back


@pytest.mark.parametrize("views, params, written", [
    (ViewSet.zigzag(2, 4), {"theta": np.int64(2), "phi": np.int32(4), "row_offset": 0.5},
     {"theta": 2, "phi": 4, "row_offset": 0.5}),
    (ViewSet.zigzag(2, 4), {"theta": 2, "phi": 4, "row_offset": np.float32(0.5)},
     {"theta": 2, "phi": 4, "row_offset": 0.5}),
    (ViewSet.hilbert(1), {"level": np.int64(1)}, {"level": 1}),
    (ViewSet.hilbert(1, True), {"level": np.uint8(1), "hemispheres": np.True_}, {"level": 1, "hemispheres": True}),
])
def test_a_view_set_given_numpy_parameters_saves_and_loads(tmp_path, views, params, written):
    """Before: a CSM built on a ViewSet given its layout's parameters as NumPy numbers (which ViewSet
    accepts, and builds with) could not be saved: ``TypeError: Object of type int64 is not JSON
    serializable`` (4 of 4 such view sets). Now the file holds them as JSON numbers, and the loaded CSM
    equals the built one in every array and every lookup."""
    box = trimesh.creation.box()
    csm = CoherentShadowMap.build(box, _given(views, params), resolution=4, progress=False)
    back = _check_round_trip(csm, tmp_path / "a.csm")
    assert back.views.params == written
    ref = CoherentShadowMap.build(box, views, resolution=4, progress=False)
    assert ref.depth.tobytes() == back.depth.tobytes() and ref.iend.tobytes() == back.iend.tobytes()


@pytest.mark.parametrize("views, params, written", [
    (ViewSet.hilbert(1), {"level": 1, "hemispheres": False}, {"level": 1}),
    (ViewSet.hilbert(1, True), {"level": 1, "hemispheres": 1}, {"level": 1, "hemispheres": True}),
    (ViewSet.zigzag(2, 4), {"theta": 2, "phi": 4, "row_offset": 0.5, "note": "mine"},
     {"theta": 2, "phi": 4, "row_offset": 0.5}),
])
def test_every_file_save_writes_loads(tmp_path, views, params, written):
    """Before: save wrote the parameters of a given ViewSet as given, and load refused three of these
    files it had just written (3 of 3: ``CSMFormatError: invalid hilbert parameters {'hemispheres': False,
    'level': 1}``; ``hemispheres`` 1; a key beside the zigzag's). Now save writes the layout's own
    parameters (a zigzag's ``row_offset`` only where given: without it a file is the thesis's grid)."""
    csm = CoherentShadowMap.build(trimesh.creation.box(), _given(views, params), resolution=3, progress=False)
    assert _check_round_trip(csm, tmp_path / "a.csm").views.params == written


def _resigned(raw, edit):
    """The bytes ``raw`` of a .csm file with its header changed by ``edit`` and the checksum redone (the
    arrays moved to their 64-byte boundaries after the new header)."""
    from pyshadow.csm.fileformat import array_layout

    hlen = int(np.frombuffer(raw[12:16], "<u4")[0])
    head = json.loads(raw[16:16 + hlen])
    shape = lambda h: (h["resolution"], h["maps"], h["segments"], h["depth_bits"], h["offsets_dtype"])  # noqa: E731
    arrays = [raw[off:off + dt.itemsize * n] for _, dt, n, off in array_layout(16 + hlen, *shape(head))[0]]
    edit(head)
    hb = json.dumps(head, sort_keys=True).encode()
    out = bytearray(raw[:12] + np.uint32(len(hb)).tobytes() + hb)
    for (_, _, _, off), a in zip(array_layout(16 + len(hb), *shape(head))[0], arrays):
        out += b"\0" * (off - len(out)) + a
    return bytes(out) + hashlib.sha256(bytes(out)).digest()


def test_a_file_holding_hemispheres_false_loads(tmp_path):
    """Before: a file whose hilbert parameters held ``"hemispheres": false`` -- what save wrote for a
    ViewSet given ``{"level": 1, "hemispheres": False}`` -- was refused (CSMFormatError, invalid hilbert
    parameters). Now it loads as the one-square layout, equal to the CSM built on ViewSet.hilbert(1)."""
    csm = CoherentShadowMap.build(trimesh.creation.box(), ViewSet.hilbert(1), resolution=3, progress=False)
    path = csm.save(tmp_path / "a.csm")
    path.write_bytes(_resigned(path.read_bytes(), lambda h: h["layout_params"].update(hemispheres=False)))
    back = CoherentShadowMap.load(path)
    assert back.views.params == {"level": 1} and back.views.bases.tobytes() == csm.views.bases.tobytes()
    assert back.depth.tobytes() == csm.depth.tobytes() and back.iend.tobytes() == csm.iend.tobytes()


@pytest.mark.parametrize("params", [{"theta": np.int64(2), "phi": np.int32(4), "row_offset": 0.5},
                                    {"level": 1, "hemispheres": False}])
def test_the_cache_keys_a_given_view_set_as_its_file_holds_it(tmp_path, params):
    """Was: ``CSMCache.csm_key`` wrote the view set's parameters as given into its JSON key, so NumPy numbers
    raised TypeError on every call, and ``csm`` compared a cached file's parameters with the given ones, so
    a view set given ``hemispheres: False`` was rebuilt on every call ("holds different views"). Now both
    read the parameters as the file holds them (``file_params``): the second call is a hit, with the key of
    the layout's own view set."""
    from pyshadow.cache import CSMCache
    from pyshadow.mesh import mesh_hash

    base = ViewSet.zigzag(2, 4) if "theta" in params else ViewSet.hilbert(1)
    views = _given(base, params)
    mesh = trimesh.creation.box((1.0, 0.6, 0.3))
    cache = CSMCache(tmp_path)
    assert cache.csm_key(mesh_hash(mesh), views, 4, 16, "auto") == cache.csm_key(mesh_hash(mesh), base, 4, 16, "auto")
    first, info1 = cache.csm("box", mesh, views, 4, 16)
    again, info2 = cache.csm("box", mesh, views, 4, 16)
    assert (info1["source"], info2["source"]) == ("built", "cached")
    assert again.offsets.tobytes() == first.offsets.tobytes() and again.depth.tobytes() == first.depth.tobytes()
