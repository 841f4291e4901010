"""The .csm file format (pyshadow.csm.fileformat): round trips, atomic writes, fuzzing, and
validation of everything the kernels trust."""
import hashlib
import json
import os

import numpy as np
import pytest

import pyshadow
from pyshadow import CoherentShadowMap, CSMFormatError
from pyshadow.csm import FRONT_MARGIN_TEXELS, fileformat

from conftest import all_pairs, load


@pytest.fixture(scope="module")
def small_csm():
    return CoherentShadowMap.build(load("stanford-bunny.obj"), pyshadow.ViewSet.zigzag(8, 16), resolution=32,
                                   progress=False)


@pytest.mark.parametrize("mmap", [True, False])
@pytest.mark.parametrize("bits", [16, 32])
@pytest.mark.parametrize("hemispheres", [False, True])
def test_csm_save_load_round_trip_is_bit_identical(tmp_path, mmap, bits, hemispheres):
    views = pyshadow.ViewSet.hilbert(3, hemispheres)
    csm = CoherentShadowMap.build(load("teapot.obj"), views, resolution=32, depth_bits=bits, progress=False)
    path = csm.save(tmp_path / "teapot.csm")
    back = CoherentShadowMap.load(path, mmap=mmap)
    for name in ("offsets", "iend", "depth"):
        a, b = getattr(csm, name), getattr(back, name)
        assert a.dtype == b.dtype
        assert a.tobytes() == b.tobytes()
    assert isinstance(back.depth, np.memmap) == mmap
    np.testing.assert_array_equal(back.centre, csm.centre)
    assert back.radius == csm.radius and back.mesh_hash == csm.mesh_hash
    assert back.views.layout == "hilbert" and back.views.params == views.params
    np.testing.assert_array_equal(back.views.bases, csm.views.bases)
    assert back.depth_bits == bits and back.layer_rule == csm.layer_rule
    assert back.front_margin_texels == csm.front_margin_texels
    assert back.footprint is False
    maps, rows, cols = all_pairs(csm)
    np.testing.assert_array_equal(back.depth_for(maps, rows, cols), csm.depth_for(maps, rows, cols))
    # a second save gives the same bytes
    again = back.save(tmp_path / "again.csm")
    assert again.read_bytes() == path.read_bytes()


def test_csm_save_is_atomic(tmp_path, small_csm, monkeypatch):
    path = tmp_path / "a.csm"
    small_csm.save(path)
    before = path.read_bytes()

    def fail(*a, **k):
        raise OSError("disk full")
    monkeypatch.setattr(os, "fsync", fail)
    with pytest.raises(OSError, match="disk full"):
        small_csm.save(path)
    assert path.read_bytes() == before                     # old file untouched
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.csm"]   # no temp file left


def test_csm_load_fuzz(tmp_path, small_csm):
    path = small_csm.save(tmp_path / "good.csm")
    good = path.read_bytes()
    ref = np.asarray(small_csm.depth).copy()
    rng = np.random.default_rng(2024)
    outcomes = {"error": 0, "same": 0}
    for i in range(200):
        data = bytearray(good)
        if i % 2 == 0:
            data = data[: rng.integers(0, len(data))]
        else:
            for _ in range(rng.integers(1, 4)):
                pos = rng.integers(0, len(data))
                data[pos] ^= 1 << int(rng.integers(0, 8))
        bad = tmp_path / f"fuzz{i}.csm"
        bad.write_bytes(bytes(data))
        try:
            back = CoherentShadowMap.load(bad, mmap=bool(i % 3))
        except CSMFormatError:
            outcomes["error"] += 1
        else:
            assert bytes(data) == good or np.array_equal(np.asarray(back.depth), ref)
            assert np.array_equal(np.asarray(back.offsets), small_csm.offsets)
            outcomes["same"] += 1
        finally:
            bad.unlink()
    assert outcomes["error"] >= 195


def _rewrite(path, out, edit_header=None, edit_arrays=None):
    """Rewrite a .csm file with edits and a *valid* checksum (a hostile writer)."""
    import hashlib
    raw = bytearray(path.read_bytes())
    hlen = int(np.frombuffer(bytes(raw[12:16]), "<u4")[0])
    head = json.loads(raw[16:16 + hlen])
    body = raw[16 + hlen:-32]
    if edit_header:
        edit_header(head)
    if edit_arrays:
        body = edit_arrays(head, bytearray(body), 16 + hlen)
    hb = json.dumps(head, sort_keys=True).encode()
    if len(hb) <= hlen:                  # keep the arrays where they were
        hb = hb + b" " * (hlen - len(hb))
    else:                                # a longer header: the arrays move to the next 64-byte boundaries
        old = json.loads(raw[16:16 + hlen])
        moved = bytearray()
        for (_, dt, n, a), (_, _, _, b) in zip(*(fileformat.array_layout(
                st, old["resolution"], old["maps"], old["segments"], old["depth_bits"], old["offsets_dtype"])[0]
                for st in (16 + hlen, 16 + len(hb)))):
            moved += b"\0" * (b - 16 - len(hb) - len(moved)) + body[a - 16 - hlen:a - 16 - hlen + dt.itemsize * n]
        body = moved
    data = bytes(raw[:12]) + np.uint32(len(hb)).tobytes() + hb + bytes(body)
    out.write_bytes(data + hashlib.sha256(data).digest())
    return out


def test_csm_load_rejects_foreign_and_truncated(tmp_path, small_csm):
    png = tmp_path / "x.csm"
    png.write_bytes(b"\x89PNG\r\n\x1a\n" + b"\0" * 100)
    with pytest.raises(CSMFormatError, match="not a pyshadow CSM"):
        CoherentShadowMap.load(png)
    empty = tmp_path / "e.csm"
    empty.write_bytes(b"")
    with pytest.raises(CSMFormatError, match="too short"):
        CoherentShadowMap.load(empty)
    good = small_csm.save(tmp_path / "g.csm")
    cut = tmp_path / "cut.csm"
    cut.write_bytes(good.read_bytes()[:-100])
    with pytest.raises(CSMFormatError, match="checksum"):
        CoherentShadowMap.load(cut)
    with pytest.raises(FileNotFoundError):
        CoherentShadowMap.load(tmp_path / "missing.csm")


def test_csm_load_validates_what_kernels_trust(tmp_path, small_csm):
    good = small_csm.save(tmp_path / "g.csm")
    S = small_csm.segments

    def arrays(head, start):
        layout, _ = fileformat.array_layout(start, 32, head["maps"], head["segments"],
                                                    head["depth_bits"], head["offsets_dtype"])
        return {name: (dt, n, off - start) for name, dt, n, off in layout}

    def poke(name, fn):
        def edit(head, body, start):
            dt, n, off = arrays(head, start)[name]
            a = np.frombuffer(bytes(body[off:off + dt.itemsize * n]), dt).copy()
            fn(a)
            body[off:off + dt.itemsize * n] = a.tobytes()
            return body
        return edit

    cases = [
        ("version", dict(edit_header=lambda h: h.update(version=2)), "pyshadow-csm version 1"),
        ("layout", dict(edit_header=lambda h: h.update(layout="spiral")), "unknown view layout"),
        ("maps", dict(edit_header=lambda h: h.update(maps=h["maps"] + 1)), "maps"),
        # a layout of 2^32 maps, consistent with "maps": rejected from the sizes,
        # before a view set that large is built (no hang, no memory error)
        # (build_seconds is dropped to make room in the header)
        ("huge layout", dict(edit_header=lambda h: (h.pop("build_seconds"), h.update(
            layout_params={"theta": 65536, "phi": 65536}, maps=65536 ** 2))), "beyond the 2097152"),
        ("huge hilbert", dict(edit_header=lambda h: (h.pop("build_seconds"), h.update(
            layout="hilbert", layout_params={"level": 10}, maps=4 ** 10))), "does not match the header"),
        ("radius", dict(edit_header=lambda h: h.update(radius=-1.0)), "radius"),
        ("bits", dict(edit_header=lambda h: h.update(depth_bits=8)), "depth_bits"),
        ("margin nan", dict(edit_header=lambda h: h.update(front_margin_texels=float("nan"))), "front_margin"),
        ("margin type", dict(edit_header=lambda h: h.update(front_margin_texels="x")), "front_margin"),
        ("footprint type", dict(edit_header=lambda h: h.update(footprint=1)), "footprint"),
        # numbers beyond float64 (JSON integers) and float32, and a header that is no object
        ("radius bigint", dict(edit_header=lambda h: h.update(radius=10 ** 400)), "radius"),
        ("radius float32", dict(edit_header=lambda h: h.update(radius=1e300)), "radius"),
        ("centre bigint", dict(edit_header=lambda h: h.update(centre=[0, 10 ** 400, 0])), "centre"),
        ("margin bigint", dict(edit_header=lambda h: h.update(front_margin_texels=10 ** 400)), "front_margin"),
        ("seconds text", dict(edit_header=lambda h: h.update(build_seconds="abc")), "build_seconds"),
        ("seconds list", dict(edit_header=lambda h: h.update(build_seconds=[1])), "build_seconds"),
        ("wide offsets", dict(edit_header=lambda h: h.update(offsets_dtype="<u8")), "offsets dtype"),
        ("offset past end", dict(edit_arrays=poke("offsets", lambda a: a.__setitem__(5, S + 10))), "offset"),
        ("offsets decrease", dict(edit_arrays=poke("offsets", lambda a: a.__setitem__(5, a[4]))), "empty or offsets decrease"),
        ("iend beyond D", dict(edit_arrays=poke("iend", lambda a: a.__setitem__(0, 60000))), "beyond the last map"),
        ("list end", dict(edit_arrays=poke("iend", lambda a: a.__setitem__(-1, a[-1] - 1))), "does not end"),
        ("not increasing", dict(edit_arrays=poke("iend", lambda a: a.__setitem__(
            int(np.argmax(np.diff(small_csm.offsets.astype(int)) > 2)) and
            int(small_csm.offsets[np.argmax(np.diff(small_csm.offsets.astype(int)) > 2)]) + 1,
            0))), "strictly increasing"),
    ]
    for label, kw, match in cases:
        bad = _rewrite(good, tmp_path / f"{label}.csm", **kw)
        with pytest.raises(CSMFormatError, match=match):
            CoherentShadowMap.load(bad)


def test_csm_load_refuses_headers_that_are_not_objects(tmp_path, small_csm):
    """A header that parses but is no JSON object (a list, a number), or nests past Python's recursion
    limit, is a CSMFormatError, which the cache takes for a bad file (not an AttributeError or a
    RecursionError)."""
    good = small_csm.save(tmp_path / "g.csm")
    raw = good.read_bytes()
    hlen = int(np.frombuffer(raw[12:16], "<u4")[0])
    for label, text, match in (("list", b"[]", "not a JSON object"), ("number", b"7", "not a JSON object"),
                               ("deep", b"[" * 100000, "unreadable header")):
        body = raw[:12] + np.uint32(len(text)).tobytes() + text + raw[16 + hlen:-32]
        bad = tmp_path / f"{label}.csm"
        bad.write_bytes(body + hashlib.sha256(body).digest())
        with pytest.raises(CSMFormatError, match=match):
            CoherentShadowMap.load(bad)


def test_a_file_changed_after_load_never_reaches_a_kernel(tmp_path, small_csm):
    """What load checked is what the device gets. Read into memory (the default), a CSM keeps its answers
    when its file is then written over in place; mapped (``mmap=True``), the arrays a device upload takes
    are checked again, so a list emptied in place since is refused by name, not searched out of bounds."""
    path = small_csm.save(tmp_path / "c.csm")
    rng = np.random.default_rng(3)
    m = rng.integers(0, small_csm.maps, 500)
    r, c = rng.integers(0, 32, 500), rng.integers(0, 32, 500)
    want = small_csm.segment_index(m, r, c)
    in_memory, mapped = CoherentShadowMap.load(path), CoherentShadowMap.load(path, mmap=True)
    emptied = _rewrite(path, tmp_path / "emptied.csm", edit_arrays=_empty_first_list)
    with open(path, "r+b") as f:                    # in place, as cp does: same inode, same size
        f.write(emptied.read_bytes())
    np.testing.assert_array_equal(in_memory.segment_index(m, r, c), want)
    with pytest.raises(CSMFormatError, match="changed since it was loaded"):
        mapped.segment_index(m, r, c)
    scene = pyshadow.Scene()
    scene.add(mapped, np.eye(4))
    with pytest.raises(CSMFormatError, match="changed since it was loaded"):
        scene.visible(np.zeros((1, 3)), np.array([[0.0, 1.0, 0.0]]))


def _empty_first_list(head, body, start):
    """offsets[1] = 0: texel 0's list empty (the checksum made valid by _rewrite)."""
    layout, _ = fileformat.array_layout(start, head["resolution"], head["maps"], head["segments"],
                                        head["depth_bits"], head["offsets_dtype"])
    _, dt, n, off = layout[0]
    a = np.frombuffer(bytes(body[off - start:off - start + dt.itemsize * n]), dt).copy()
    a[1] = 0
    body[off - start:off - start + dt.itemsize * n] = a.tobytes()
    return body


def test_footprint_flag_survives_save_and_load(tmp_path):
    csm = CoherentShadowMap.build(load("teapot.obj"), pyshadow.ViewSet.zigzag(4, 8), resolution=16,
                                  progress=False, footprint=True)
    back = CoherentShadowMap.load(csm.save(tmp_path / "fp.csm"))
    assert back.footprint is True and back.stats["footprint"] is True
    assert back.depth.tobytes() == csm.depth.tobytes() and back.iend.tobytes() == csm.iend.tobytes()


def test_csm_file_without_margin_field_loads(tmp_path):
    """Files written before the margin existed carry no front_margin_texels: 0."""
    csm = CoherentShadowMap.build(load("fandisk.obj"), pyshadow.ViewSet.zigzag(2, 4), resolution=16,
                                  progress=False)
    assert csm.layer_rule == 3 and csm.stats["front_margin_texels"] == FRONT_MARGIN_TEXELS
    old = _rewrite(csm.save(tmp_path / "f.csm"), tmp_path / "old.csm",
                   edit_header=lambda h: [h.pop("front_margin_texels"), h.pop("footprint")])
    back = CoherentShadowMap.load(old)
    assert back.layer_rule == 3 and back.front_margin_texels == 0.0 and back.footprint is False
    assert back.depth.tobytes() == csm.depth.tobytes()


def test_csm_load_rejects_nan_depth(tmp_path):
    csm = CoherentShadowMap.build(load("suzanne.ply"), pyshadow.ViewSet.zigzag(2, 4), resolution=16,
                                  depth_bits=32, progress=False)
    good = csm.save(tmp_path / "g.csm")

    def edit(head, body, start):
        layout, _ = fileformat.array_layout(start, 16, head["maps"], head["segments"], 32,
                                                    head["offsets_dtype"])
        _, dt, n, off = layout[2]
        a = np.frombuffer(bytes(body[off - start:off - start + 4 * n]), "<f4").copy()
        a[3] = np.nan
        body[off - start:off - start + 4 * n] = a.tobytes()
        return body
    bad = _rewrite(good, tmp_path / "nan.csm", edit_arrays=edit)
    with pytest.raises(CSMFormatError, match="miss value"):
        CoherentShadowMap.load(bad)


def test_box_survives_save_and_load_and_old_files_have_none(tmp_path, small_csm):
    """The mesh's box (normalised frame) is saved exactly; a file from before boxes loads with none (the
    lookup then cuts chords by the sphere alone); a box that is not 2 x 3 numbers with lo <= hi inside
    [-1, 1] is refused by name."""
    assert small_csm.box is not None and small_csm.box.shape == (2, 3)
    path = small_csm.save(tmp_path / "b.csm")
    back = CoherentShadowMap.load(path)
    np.testing.assert_array_equal(back.box, small_csm.box)
    old = CoherentShadowMap.load(_rewrite(path, tmp_path / "old.csm", edit_header=lambda h: h.pop("box")))
    assert old.box is None and old.depth.tobytes() == small_csm.depth.tobytes()
    for label, box in (("shape", [[0.0, 0.0, 0.0]]), ("inverted", [[0.5, 0, 0], [-0.5, 1, 1]]),
                       ("outside", [[-2.0, -1, -1], [1, 1, 1]]), ("nan", [[float("nan"), 0, 0], [1, 1, 1]]),
                       ("type", "x")):
        bad = _rewrite(path, tmp_path / f"{label}.csm", edit_header=lambda h, b=box: h.update(box=b))
        with pytest.raises(CSMFormatError, match="box"):
            CoherentShadowMap.load(bad)


def test_zigzag_row_offset_survives_save_and_load_and_old_files_are_the_thesis_grid(tmp_path, small_csm):
    """A zigzag CSM's row offset is saved; a file from before the offset (no ``row_offset``) loads as the
    thesis's grid (offset 0, row 0 on the north pole); an offset other than 0 or 0.5, or not a number, is
    refused by name."""
    assert small_csm.views.layout == "zigzag" and small_csm.views.params["row_offset"] == 0.5
    path = small_csm.save(tmp_path / "z.csm")
    back = CoherentShadowMap.load(path)
    assert back.views.params == small_csm.views.params
    np.testing.assert_array_equal(back.views.directions, small_csm.views.directions)

    old = CoherentShadowMap.load(_rewrite(path, tmp_path / "old.csm",
                                          edit_header=lambda h: h["layout_params"].pop("row_offset")))
    T, P = small_csm.views.params["theta"], small_csm.views.params["phi"]
    assert old.views.params["row_offset"] == 0.0
    np.testing.assert_array_equal(old.views.directions[0], [0.0, 1.0, 0.0])
    np.testing.assert_array_equal(old.views.directions,
                                  pyshadow.ViewSet.zigzag(T, P, row_offset=0.0).directions)
    for label, off in (("one", 1.0), ("negative", -1), ("text", "x"), ("two", 2), ("quarter", 0.2)):
        bad = _rewrite(path, tmp_path / f"{label}.csm",
                       edit_header=lambda h, o=off: h["layout_params"].update(row_offset=o))
        with pytest.raises(CSMFormatError, match="row_offset"):
            CoherentShadowMap.load(bad)


def test_two_sided_record_survives_save_and_load_and_old_files_have_none(tmp_path, small_csm):
    """The build's two_sided and its count of faces kept from either side are saved; a file from before
    the record loads with None for both; a record that is not 'auto'/true/false with a count >= 0 (or
    neither) is refused by name."""
    n = small_csm.both_sided_faces                     # the bunny is open: its bottom's inside is exposed
    assert small_csm.two_sided == "auto" and n >= 1000
    path = small_csm.save(tmp_path / "t.csm")
    back = CoherentShadowMap.load(path)
    assert (back.two_sided, back.both_sided_faces) == ("auto", n)
    assert (back.stats["two_sided"], back.stats["both_sided_faces"]) == ("auto", n)
    old = CoherentShadowMap.load(_rewrite(path, tmp_path / "old.csm",
                                          edit_header=lambda h: [h.pop("two_sided"), h.pop("both_sided_faces")]))
    assert old.two_sided is None and old.both_sided_faces is None
    assert old.depth.tobytes() == small_csm.depth.tobytes()
    for label, rec in (("word", ("yes", 3)), ("int", (1, 3)), ("count", ("auto", -1)), ("bool", (True, True)),
                       ("half", ("auto", None)), ("float", (False, 2.0))):
        bad = _rewrite(path, tmp_path / f"{label}.csm",
                       edit_header=lambda h, r=rec: h.update(two_sided=r[0], both_sided_faces=r[1]))
        with pytest.raises(CSMFormatError, match="two_sided"):
            CoherentShadowMap.load(bad)


def test_save_errors_name_the_path_asked_for(tmp_path, small_csm, monkeypatch):
    """A missing folder is named before anything is written; an error on the hidden temporary file (here a
    refused open) names the file asked for, not the temporary one, and leaves nothing behind."""
    with pytest.raises(FileNotFoundError, match="no folder") as e:
        small_csm.save(tmp_path / "nodir" / "x.csm")
    assert e.value.filename == str(tmp_path / "nodir" / "x.csm")

    def refuse(file, *args, **kw):
        raise PermissionError(13, "Permission denied", str(file))
    monkeypatch.setattr(fileformat, "open", refuse, raising=False)
    with pytest.raises(PermissionError) as e:
        small_csm.save(tmp_path / "x.csm")
    assert e.value.filename == str(tmp_path / "x.csm") and ".tmp" not in str(e.value)
    assert os.listdir(tmp_path) == []


def test_save_writes_through_links_and_refuses_what_is_no_file(tmp_path, small_csm):
    """A symbolic link is written through (its target gets the CSM, the link stays a link); a folder or a
    FIFO at the path is refused, not replaced by a file."""
    target = tmp_path / "target.csm"
    target.write_bytes(b"old")
    link = tmp_path / "link.csm"
    link.symlink_to(target)
    small_csm.save(link)
    assert link.is_symlink() and CoherentShadowMap.load(target).depth.tobytes() == small_csm.depth.tobytes()
    (tmp_path / "folder.csm").mkdir()
    os.mkfifo(tmp_path / "fifo.csm")
    for name in ("folder.csm", "fifo.csm"):
        with pytest.raises(FileExistsError, match="not a regular file"):
            small_csm.save(tmp_path / name)
    assert (tmp_path / "folder.csm").is_dir() and not (tmp_path / "fifo.csm").is_file()


def test_a_mesh_beyond_float32_builds_no_csm_and_one_within_round_trips(tmp_path):
    """A CSM's centre and radius must fit float32 (the lookup's frame, and what load accepts): a mesh
    beyond that is refused at build, not saved into a file that cannot be loaded."""
    import trimesh
    huge = trimesh.creation.box()
    huge.apply_scale(1e39)
    with pytest.raises(ValueError, match="beyond float32's range"):
        CoherentShadowMap.build(huge, pyshadow.ViewSet.zigzag(2, 4), resolution=8, progress=False)
    big = trimesh.creation.box()
    big.apply_scale(1e30)
    csm = CoherentShadowMap.build(big, pyshadow.ViewSet.zigzag(2, 4), resolution=8, progress=False)
    back = CoherentShadowMap.load(csm.save(tmp_path / "big.csm"))
    assert back.radius == csm.radius and back.depth.tobytes() == csm.depth.tobytes()
