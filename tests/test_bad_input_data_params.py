"""Bad input to the bundled data (pyshadow.data) and to the bake's parameters (pyshadow.bake.AssetParams).

Each test is a defect found in an audit: the wrong behaviour it had is in its docstring ("Was: ...").
"""
from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest

from pyshadow import Sampling, _compat, data
from pyshadow.bake import AssetParams, asset_key
from pyshadow.bake.records import done, store
from pyshadow.raster import MAX_RESOLUTION
from pyshadow.views import MAX_GRID, MAX_MAPS


# ---------------------------------------------------------------- AssetParams
def test_asset_params_mesh_format_must_be_a_string():
    """Was: AssetParams(mesh_format=np.array("ply")) was accepted (the membership test compares equal), and
    asset_key then raised "Object of type ndarray is not JSON serializable"; np.array(["ply", "glb"]) raised
    NumPy's "truth value of an array ... is ambiguous"."""
    for bad in (np.array("ply"), np.array(["ply", "glb"]), ["ply"], b"ply", 1):
        with pytest.raises(ValueError, match=r"AssetParams.mesh_format must be one of \('ply', 'glb'\), got"):
            AssetParams(mesh_format=bad)
    p = AssetParams(mesh_format=np.str_("glb"))            # a str subclass: JSON-ready
    assert p.mesh_format == "glb"
    assert asset_key("0" * 64, p, "c") == asset_key("0" * 64, AssetParams(mesh_format="glb"), "c")


@pytest.mark.parametrize("kw, message", [
    (dict(resolution=MAX_RESOLUTION + 1), f"AssetParams.resolution must be at most {MAX_RESOLUTION} "
                                          r"\(the CSM builder's limit\), got 4097"),
    (dict(theta=2048, phi=2048), r"theta \* phi at most 2097152 .*got 2048x2048"),
    (dict(theta=MAX_GRID + 1, phi=2), "theta and phi must be at most 65536 .*got 65537x2"),
    (dict(theta=2, phi=MAX_GRID + 1), "got 2x65537"),
])
def test_asset_params_beyond_the_csm_limits_are_refused_up_front(kw, message):
    """Was: AssetParams(resolution=5000), (theta=2048, phi=2048) or (theta=70000) were accepted (the command
    line takes --maps up to 4096x4096), and bake_assets then loaded every asset and failed each one with
    "resolution must be in 1..4096" or "ViewSet.zigzag: theta * phi must be at most 2097152"."""
    with pytest.raises(ValueError, match=message):
        AssetParams(**kw)


def test_asset_params_at_the_csm_limits_are_accepted():
    """The largest accepted values are the CSM builder's own (checked by the constructor, not built)."""
    assert AssetParams(resolution=MAX_RESOLUTION).resolution == 4096
    assert (AssetParams(theta=1024, phi=2048).theta, AssetParams(theta=1024, phi=2048).phi) == (1024, 2048)
    assert 1024 * 2048 == MAX_MAPS
    p = AssetParams(theta=MAX_GRID, phi=32)                 # 65536 * 32 == 2**21
    assert (p.theta, p.phi) == (65536, 32)


def test_asset_params_from_dict_names_keys_that_are_not_strings():
    """Was: AssetParams.from_dict({1: 2}) raised "sequence item 0: expected str instance, int found" and
    {1: 2, "a": 3} "'<' not supported between instances of 'str' and 'int'", naming no key."""
    with pytest.raises(ValueError) as e:
        AssetParams.from_dict({1: 2, "a": 3, "theta": 8})
    assert str(e.value) == "unknown bake parameters: 'a', 1"
    with pytest.raises(ValueError) as e:
        AssetParams.from_dict({None: 2})
    assert str(e.value) == "unknown bake parameters: None"
    d = AssetParams(theta=8, phi=16).to_dict()
    assert AssetParams.from_dict(json.loads(json.dumps(d))) == AssetParams(theta=8, phi=16)


# ---------------------------------------------------------------- old forms (pyshadow._compat)
def test_a_sampling_passed_by_position_is_named():
    """Was: sample_directions(normals, Sampling(16)) (or scene.ambient_occlusion(p, n, Sampling(16))) warned
    that the positional samples argument is deprecated, then raised "samples must be an int, got
    Sampling(samples=16, ...)", an argument the caller never wrote."""
    from pyshadow.sampling import sample_directions

    _compat.reset()
    n = np.array([[0.0, 1.0, 0.0]])
    with pytest.raises(TypeError, match=r"^pyshadow.sample_directions: pass the Sampling by keyword, "
                                        r"sampling=Sampling\(...\) \(positional arguments after the data are the "
                                        r"deprecated samples, strategy, patterns, seed\)$"):
        sample_directions(n, Sampling(16))
    with pytest.raises(TypeError, match="pass the Sampling by keyword"):
        _compat.legacy_sampling("f", (8, Sampling(16)), ("samples", "seed"), None, {}, Sampling())
    d = sample_directions(n, sampling=Sampling(16))      # the new form, unchanged
    assert d.shape == (1, 16, 3) and np.allclose(np.linalg.norm(d, axis=2), 1.0, atol=1e-6)


# ---------------------------------------------------------------- done records
def test_done_refuses_a_record_listing_files_outside_its_folder(tmp_path):
    """Was: a record listing "../secret.txt" or an absolute path, with that file's size and SHA-256, was
    returned by done() as the proof of a finished task (the file outside the output folder read and hashed)."""
    out = tmp_path / "out"
    rec = store(out, "records/a.json", {"status": "baked", "key": "k"}, {"csm/a.csm": b"abc"})
    assert done(out, "records/a.json", "k") == rec
    (tmp_path / "secret.txt").write_bytes(b"hello")
    meta = {"sha256": hashlib.sha256(b"hello").hexdigest(), "bytes": 5}
    for rel in ("../secret.txt", "csm/../../secret.txt", str(tmp_path / "secret.txt")):
        hostile = {"status": "baked", "key": "k", "outputs": {"csm/a.csm": rec["outputs"]["csm/a.csm"], rel: meta}}
        (out / "records" / "a.json").write_text(json.dumps(hostile))
        assert done(out, "records/a.json", "k") is None, rel


# ---------------------------------------------------------------- bundled meshes and the default scene
@pytest.mark.parametrize("bad", ["no", "False", 0, 1, None, np.array([True, False])])
def test_mesh_fill_holes_must_be_a_bool(bad):
    """Was: pyshadow.data.mesh("suzanne", fill_holes="no") closed the holes (968 faces became 1010: the
    string is truthy); an array raised NumPy's "truth value ... is ambiguous", None and 0 meant False."""
    with pytest.raises(TypeError, match=r"fill_holes: expected True or False \(got "):
        data.mesh("suzanne", fill_holes=bad)


def test_mesh_fill_holes_accepts_python_and_numpy_bools():
    """The ordinary values keep their meaning: 968 faces as stored, 1010 with the holes closed."""
    assert len(data.mesh("suzanne").faces) == 968
    assert len(data.mesh("suzanne", fill_holes=np.bool_(False)).faces) == 968
    closed = data.mesh("suzanne", fill_holes=np.bool_(True))
    assert len(closed.faces) == 1010 and closed.is_watertight


def test_default_scene_csm_for_must_return_a_csm_or_none():
    """Was: a csm_for that returned the mesh (or 0) raised "mesh= is only for CSMs; pass the mesh as obj",
    about an argument the caller never passed; a csm_for that is not callable raised "'int' object is not
    callable" after the bunny was loaded."""
    with pytest.raises(TypeError, match=r"csm_for\('bunny', mesh\) must return a CoherentShadowMap or None, "
                                        r"got Trimesh"):
        data.default_scene(csm_for=lambda name, mesh: mesh)
    with pytest.raises(TypeError, match=r"csm_for\('bunny', mesh\) must return a CoherentShadowMap or None, "
                                        r"got int"):
        data.default_scene(csm_for=lambda name, mesh: 0)
    with pytest.raises(TypeError, match=r"csm_for must be a callable csm_for\(name, mesh\) or None, got 5"):
        data.default_scene(csm_for=5)
