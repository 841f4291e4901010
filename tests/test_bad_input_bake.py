"""Bad input to the bake's building blocks: motion files, AssetParams, the baked mesh's bytes, done records
and the CSM choice. Each test is a defect found in an audit: the wrong result it had is in its docstring."""
import io
import json
import zipfile
from decimal import Decimal
from fractions import Fraction

import numpy as np
import pytest
import trimesh

from pyshadow.bake import AssetParams, asset_key
from pyshadow.bake.assets import baked_mesh_bytes
from pyshadow.bake.choose import choose_csm
from pyshadow.bake.motion import default_motion, read_motion, write_motion
from pyshadow.bake.records import done, store

EYE = np.eye(4).tolist()


def _json(path, obj=None, raw=None):
    path.write_text(raw if raw is not None else json.dumps(obj))
    return path


def _npz(path, **arrays):
    with open(path, "wb") as f:
        np.savez(f, **arrays)
    return path


# ---------------------------------------------------------------- motion files
def test_read_motion_json_names_must_be_a_list_of_strings(tmp_path):
    """A string was split into characters ("ab" named 2 bodies 'a' and 'b'), numbers became names,
    and a number raised a bare TypeError."""
    two = [[EYE, EYE]]
    for names in ("ab", [1, 2], [["a"], "b"], {"a": 1, "b": 2}, 5):
        with pytest.raises(ValueError, match="names must be"):
            read_motion(_json(tmp_path / "m.json", {"names": names, "frames": two}))
    assert read_motion(_json(tmp_path / "m.json", {"names": ["a", "b"], "frames": two}))[1] == ["a", "b"]


def test_read_motion_json_frames_must_be_numbers(tmp_path):
    """Strings ("1") and booleans were read as numbers; an integer too large for a float raised
    OverflowError and deeply nested lists RecursionError, not the documented ValueError."""
    strings = [[[[str(x) for x in row] for row in EYE]]]
    bools = [[[[bool(x) for x in row] for row in EYE]]]
    for frames in (strings, bools):
        with pytest.raises(ValueError, match="numbers"):
            read_motion(_json(tmp_path / "m.json", {"frames": frames}))
    huge = json.dumps({"frames": [[EYE]]}).replace("1.0", str(10 ** 400), 1)
    with pytest.raises(ValueError, match="too large"):
        read_motion(_json(tmp_path / "m.json", raw=huge))
    with pytest.raises(ValueError, match="m.json"):
        read_motion(_json(tmp_path / "m.json", raw='{"frames": ' + "[" * 100000 + "]" * 100000 + "}"))


def test_read_motion_damaged_npz_is_a_value_error(tmp_path):
    """An empty file raised EOFError, a truncated or corrupted archive BadZipFile (or zlib.error),
    and a lone .npy array named .npz a TypeError."""
    T, names = default_motion(2)
    good = write_motion(tmp_path / "good.npz", T, names).read_bytes()
    damaged = {"empty": b"", "truncated": good[: len(good) // 2], "not-zip": b"PK\x03\x04" + bytes(100)}
    with zipfile.ZipFile(io.BytesIO(good)) as z:                  # flip a byte inside the member's data
        info = z.getinfo("transforms.npy")
    at = info.header_offset + 30 + len(info.filename) + info.compress_size // 2
    damaged["crc"] = good[:at] + bytes([good[at] ^ 0xFF]) + good[at + 1:]
    buf = io.BytesIO()
    np.save(buf, T)
    damaged["npy"] = buf.getvalue()
    for what, data in damaged.items():
        (tmp_path / f"{what}.npz").write_bytes(data)
        with pytest.raises(ValueError, match=f"{what}.npz"):
            read_motion(tmp_path / f"{what}.npz")


def test_read_motion_npz_needs_real_transforms_and_string_names(tmp_path):
    """Transforms stored as strings, booleans or complex numbers were converted (complex dropping the
    imaginary part); names stored as numbers or bytes became "3.5" and "b'a'"; a 0-d names array
    raised TypeError."""
    T = np.eye(4)[None, None]
    for bad in (T.astype(str), T.astype(bool), T.astype(complex) + 1j):
        with pytest.raises(ValueError, match="real numbers"):
            read_motion(_npz(tmp_path / "m.npz", transforms=bad))
    for names in (np.array([3.5]), np.array([b"a"]), np.array("a"), np.array([["a"]])):
        with pytest.raises(ValueError, match="names must be"):
            read_motion(_npz(tmp_path / "m.npz", transforms=T, names=names))
    with pytest.raises(ValueError, match="allow_pickle"):                   # never unpickled
        read_motion(_npz(tmp_path / "m.npz", transforms=T.astype(object)))


def test_write_motion_rejects_non_string_names_and_non_numeric_transforms(tmp_path):
    """write_motion wrote names "a" as ['a'] per character, [1] as "1", [None] as "None", and string
    or boolean transforms as numbers; now a TypeError and nothing written."""
    T = np.eye(4)[None, None]
    for names in ("a", [1], [None], 5):
        with pytest.raises(TypeError, match="names must be"):
            write_motion(tmp_path / "m.json", T, names)
    for bad in (T.astype(str), T.astype(bool), T.astype(object)):
        with pytest.raises(TypeError, match="real numbers"):
            write_motion(tmp_path / "m.npz", bad)
    assert not any(tmp_path.iterdir())
    write_motion(tmp_path / "m.npz", T, np.array(["body"]))                 # an array of str is fine
    assert read_motion(tmp_path / "m.npz")[1] == ["body"]


def test_default_motion_needs_an_int_number_of_frames():
    """default_motion(2.5) returned 2 frames of a partial turn (angles divided by 2.5); "3" raised a
    TypeError about '/', NaN and inf messages that did not name frames."""
    for frames in (2.5, "3", None, float("nan"), float("inf"), True):
        with pytest.raises(TypeError, match="frames"):
            default_motion(frames)
    with pytest.raises(ValueError, match="frames"):
        default_motion(0)
    assert default_motion(np.int64(2))[0].shape[0] == 2


# ---------------------------------------------------------------- AssetParams
def test_asset_params_flags_must_be_bools():
    """ground="false" or fill_holes="no" (truthy strings, as from a hand-edited JSON) baked with a
    ground plane / filled holes; 0, 1 and None went into the key as they were."""
    for value in ("false", "no", 0, 1, None):
        with pytest.raises(TypeError, match="ground"):
            AssetParams(ground=value)
        with pytest.raises(TypeError, match="fill_holes"):
            AssetParams(fill_holes=value)
    p = AssetParams(ground=np.bool_(True))
    assert p.ground is True and json.dumps(p.to_dict())


def test_asset_params_depth_bits_and_max_error_types():
    """depth_bits=16.0 was accepted under another key than 16, np.int64(16) made asset_key raise
    (not JSON); max_error "0.01" was accepted as a string, and Decimal, Fraction or np.float32 made
    asset_key raise."""
    for d in (16.0, np.int64(16), "16"):
        with pytest.raises(ValueError, match="depth_bits"):
            AssetParams(depth_bits=d)
    for m in ("0.01", Decimal("0.01"), [0.01], 0.01 + 0j):
        with pytest.raises(TypeError, match="max_error"):
            AssetParams(max_error=m)
    for m in (Fraction(1, 100), np.float32(0.01), np.float64(0.01)):
        p = AssetParams(max_error=m)
        assert type(p.max_error) is float and p.max_error == float(m)
        asset_key("0" * 64, p, "code")
    assert asset_key("0" * 64, AssetParams(max_error=np.float64(0.01)), "c") == \
        asset_key("0" * 64, AssetParams(max_error=0.01), "c")
    for d in ([("theta", 8)], None, "theta"):
        with pytest.raises(TypeError, match="dict"):
            AssetParams.from_dict(d)


# ---------------------------------------------------------------- baked meshes
def _mesh_ao():
    mesh = trimesh.creation.icosphere(1)
    n = len(mesh.vertices)
    rng = np.random.default_rng(3)
    ao = rng.random(n).astype(np.float32)
    bent = rng.standard_normal((n, 3))
    bent = (bent / np.linalg.norm(bent, axis=1, keepdims=True)).astype(np.float32)
    return mesh, ao, bent


def test_baked_mesh_unknown_format_is_an_error():
    """Any mesh_format but 'ply' ('obj', 'PLY', None) silently returned GLB bytes."""
    mesh, ao, bent = _mesh_ao()
    for fmt in ("obj", "PLY", None):
        with pytest.raises(ValueError, match="mesh_format"):
            baked_mesh_bytes(mesh, ao, bent, fmt)


def test_baked_mesh_ao_and_bent_must_match_the_vertices():
    """AO or bent normals of the wrong length were silently dropped from the file (trimesh skips a
    vertex attribute of another length), and a (V, 2) bent went into the GLB as it was."""
    mesh, ao, bent = _mesh_ao()
    for fmt in ("ply", "glb"):
        for a, b in ((ao[:-1], bent), (np.append(ao, 0.5), bent), (ao, bent[:-1]), (ao, bent[:, :2]),
                     (ao[:, None], bent)):
            with pytest.raises(ValueError, match="shape"):
                baked_mesh_bytes(mesh, a, b, fmt)


def test_baked_mesh_rejects_nan_or_out_of_range_ao_and_empty_meshes():
    """NaN AO was cast to an undefined grey (a RuntimeWarning) and stored as NaN, 1.5 stored beside a
    clipped colour; a mesh without faces gave a GLB with no geometry at all (vertices and AO lost),
    and vertices beyond float32 were written as inf."""
    mesh, ao, bent = _mesh_ao()
    for fmt in ("ply", "glb"):
        for v in (np.nan, np.inf, 1.5, -0.1):
            a = ao.copy()
            a[5] = v
            with pytest.raises(ValueError, match=r"ao must lie in \[0, 1\]"):
                baked_mesh_bytes(mesh, a, bent, fmt)
        b = bent.copy()
        b[2, 1] = np.nan
        with pytest.raises(ValueError, match="bent"):
            baked_mesh_bytes(mesh, ao, b, fmt)
        no_faces = trimesh.Trimesh(mesh.vertices, np.zeros((0, 3), np.int64), process=False)
        with pytest.raises(ValueError, match="no triangles"):
            baked_mesh_bytes(no_faces, ao, bent, fmt)
        huge = trimesh.Trimesh(mesh.vertices * 1e39, mesh.faces, process=False)
        with pytest.raises(ValueError, match="float32"):
            baked_mesh_bytes(huge, ao, bent, fmt)


# ---------------------------------------------------------------- done records and the CSM choice
def test_done_treats_a_deeply_nested_record_as_not_done(tmp_path):
    """A corrupt record of deeply nested brackets raised RecursionError out of done(), which
    bake_assets calls before any task: one damaged record stopped the whole job."""
    rec = store(tmp_path, "records/a.json", {"status": "baked", "key": "k"}, {"csm/a.csm": b"abc"})
    assert done(tmp_path, "records/a.json", "k") == rec
    (tmp_path / "records" / "a.json").write_text("[" * 100000 + "]" * 100000)
    assert done(tmp_path, "records/a.json", "k") is None
    text = json.dumps({"status": "baked", "key": "k"})[:-1] + ', "outputs": ' + "[" * 100000 + "]" * 100000 + "}"
    (tmp_path / "records" / "a.json").write_text(text)
    assert done(tmp_path, "records/a.json", "k") is None


def test_choose_csm_without_max_error_names_it():
    """choose_csm(mesh, AssetParams()) raised "float() argument must be ... not 'NoneType'"."""
    with pytest.raises(ValueError, match="max_error"):
        choose_csm(trimesh.creation.icosphere(1), AssetParams())
