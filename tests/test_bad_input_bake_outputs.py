"""Bad input to the bake's outputs (pyshadow.bake.frames and library): transforms, render options and part
names of bake_frames, and done records that do not list the outputs they vouch for. Each test is a defect
found in an audit: the wrong behaviour it had is in its docstring. The bakes are tiny (2x2 maps of 8
texels, 8x6 images, one sample)."""
import hashlib
import json

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.bake import AssetParams, bake_assets
from pyshadow.bake.assets import csm_file_bytes
from pyshadow.bake.frames import bake_frames

BOX = trimesh.creation.box((1.0, 1.0, 1.0))
ONE = np.eye(4)[None, None]                     # one frame of one body


def _csm(name, mesh):
    return pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(2, 2), resolution=8, progress=False)


def _never(name, mesh):
    raise AssertionError("a CSM was built for input that is refused")


def _bake(out, T=ONE, parts=None, csm_for=_csm, **kw):
    kw.setdefault("samples", 1)
    cam = pyshadow.Camera([3.0, 3.0, 3.0], [0.0, 0.0, 0.0], width=8, height=6)
    return bake_frames(out, parts or [("box", BOX, True)], cam, T, csm_for=csm_for, executor="serial",
                       progress=False, **kw)


def test_frames_transforms_are_checked_before_any_csm_is_built(tmp_path):
    """No frames gave an empty, successful manifest (the CSMs built for nothing); a NaN or sheared
    transform had every CSM built and then each frame 'failed' ("transform has non-finite entries",
    naming no frame); transforms given as strings ("1", "0") were read as numbers and rendered."""
    sheared = ONE.copy()
    sheared[0, 0, 0, 1] = 1.0
    nan = ONE.copy()
    nan[0, 0, 1, 3] = np.nan
    two = np.repeat(ONE, 2, axis=0)
    two[1, 0, 2, 3] = np.inf
    for T, match in ((np.zeros((0, 1, 4, 4)), "at least one frame"), (nan, "frame 0, body 0 has non-finite"),
                     (sheared, "frame 0, body 0 is not rigid"), (two, "frame 1, body 0 has non-finite")):
        with pytest.raises(ValueError, match=match):
            _bake(tmp_path / "out", T, csm_for=_never)
    with pytest.raises(TypeError, match="real numbers"):
        _bake(tmp_path / "out", ONE.astype(str), csm_for=_never)
    assert not (tmp_path / "out").exists()


def test_frames_chunk_and_render_options_are_checked_before_any_csm_is_built(tmp_path):
    """chunk=2.5 passed the check and then raised "slice indices must be integers", chunk="3" "unsupported
    operand type(s) for +", chunk=nan "cannot convert float NaN"; samples=2.5 rendered 2 samples and "3"
    or True were taken as 3 and 1; samples=0, an unknown lookup or denoise had the CSMs built and every
    frame then 'failed'."""
    for chunk in (2.5, "3", float("nan"), 0, True):
        with pytest.raises(ValueError, match="chunk must be a positive int"):
            _bake(tmp_path / "out", chunk=chunk, csm_for=_never)
    for samples in (2.5, "3", True):
        with pytest.raises(TypeError, match="samples must be an int"):
            _bake(tmp_path / "out", samples=samples, csm_for=_never)
    with pytest.raises(ValueError, match="samples must be in"):
        _bake(tmp_path / "out", samples=0, csm_for=_never)
    with pytest.raises(ValueError, match="lookup must be"):
        _bake(tmp_path / "out", lookup="bogus", csm_for=_never)
    with pytest.raises(ValueError, match="denoise must be"):
        _bake(tmp_path / "out", denoise="gauss", csm_for=_never)
    assert not (tmp_path / "out").exists()
    m = _bake(tmp_path / "ok", np.repeat(ONE, 3, axis=0), chunk=np.int64(2), samples=np.int64(1))
    assert m["summary"] == {"rendered": 3, "skipped": 0, "failed": 0, "interrupted": 0}


def test_frames_ground_as_a_numpy_scalar(tmp_path):
    """ground=np.float32(0.5) (or np.int64) passed the check, then json.dumps raised "Object of type
    float32 is not JSON serializable", once building the scene's key and again writing the manifest:
    no manifest, a bare TypeError."""
    a = _bake(tmp_path / "a", ground=np.float32(0.5))
    b = _bake(tmp_path / "b", ground=0.5)
    assert a["ground"] == 0.5 and a["scene"] == b["scene"] and a["summary"]["rendered"] == 1
    assert json.loads((tmp_path / "a/manifest.json").read_text())["ground"] == 0.5
    png = "png/frame_0000.png"
    assert (tmp_path / "a" / png).read_bytes() == (tmp_path / "b" / png).read_bytes()
    assert _bake(tmp_path / "c", ground=np.int64(0))["ground"] == 0


def test_frames_part_names_must_be_file_names_of_one_mesh_each(tmp_path):
    """A caster named "../esc" had its CSM written outside out/csm (to out/esc.csm; "../../x" outside the
    output folder), "" to a hidden csm/.csm, "a/b" built every CSM and then raised FileNotFoundError; two
    different meshes named "a" (two --mesh files a/cow.obj and b/cow.obj) shared csm/a.csm, the second's
    CSM replacing the first's, the manifest listing one."""
    for name in ("../esc", "a/b", "", "x\0y"):
        with pytest.raises(ValueError, match="cannot be a file name"):
            _bake(tmp_path / "out", parts=[(name, BOX, True)], csm_for=_never)
    with pytest.raises(TypeError, match="name must be a str"):
        _bake(tmp_path / "out", parts=[(5, BOX, True)], csm_for=_never)
    ico = trimesh.creation.icosphere(1)
    for other in ("a", "A"):
        with pytest.raises(ValueError, match="different meshes named"):
            _bake(tmp_path / "out", np.repeat(ONE, 2, axis=1), [("a", BOX, True), (other, ico, True)],
                  csm_for=_never)
    assert not (tmp_path / "out").exists() and not (tmp_path / "esc.csm").exists()
    # one mesh placed twice under one name, or a receiver of the caster's name: one CSM file, of that mesh
    m = _bake(tmp_path / "ok", np.repeat(ONE, 3, axis=1), [("a", BOX, True), ("a", BOX.copy(), True),
                                                           ("a", ico, False)])
    assert m["csm"] == {"a": "csm/a.csm"} and m["summary"]["rendered"] == 1
    assert (tmp_path / "ok/csm/a.csm").read_bytes() == csm_file_bytes(_csm("a", BOX))


def _edit(path, **fields):
    rec = json.loads(path.read_text())
    rec.update(fields)
    path.write_text(json.dumps(rec))


def test_frames_record_that_does_not_list_the_frames_files_is_redone(tmp_path):
    """A frame's record (matching key) that listed no outputs, or only a file elsewhere (../x), was trusted:
    the rerun 'skipped' the frame though its PNG was gone."""
    out = tmp_path / "out"
    _bake(out)
    png = (out / "png/frame_0000.png").read_bytes()
    (tmp_path / "x").write_bytes(b"x")
    elsewhere = {"../x": {"sha256": hashlib.sha256(b"x").hexdigest(), "bytes": 1}}
    for outputs in ({}, elsewhere):
        (out / "png/frame_0000.png").unlink()
        _edit(out / "records/frame_0000.json", outputs=outputs)
        m = _bake(out)
        assert m["summary"] == {"rendered": 1, "skipped": 0, "failed": 0, "interrupted": 0}
        assert (out / "png/frame_0000.png").read_bytes() == png
        assert sorted(m["frames"][0]["outputs"]) == ["exr/frame_0000.exr", "png/frame_0000.png"]
    assert _bake(out)["summary"]["skipped"] == 1


PARAMS = AssetParams(theta=2, phi=2, resolution=8, samples=1)


def test_assets_record_that_does_not_list_the_assets_files_is_redone(tmp_path):
    """An asset's record (matching key) that listed no outputs, or a file outside the folder under another
    name, was trusted: the rerun 'skipped' the asset though csm/box.csm was gone, and its manifest entry
    named the asset 'other' with outputs {'../x': ...}."""
    (tmp_path / "src").mkdir()
    BOX.export(tmp_path / "src/box.obj")
    out = tmp_path / "out"
    first = bake_assets(tmp_path / "src", out, PARAMS, executor="serial", progress=False)
    csm = (out / "csm/box.csm").read_bytes()
    (tmp_path / "x").write_bytes(b"x")
    elsewhere = {"../x": {"sha256": hashlib.sha256(b"x").hexdigest(), "bytes": 1}}
    for fields in ({"outputs": {}}, {"outputs": elsewhere, "name": "other"}):
        (out / "csm/box.csm").unlink()
        _edit(out / "records/box.json", **fields)
        m = bake_assets(tmp_path / "src", out, PARAMS, executor="serial", progress=False)
        assert m["summary"] == {"baked": 1, "skipped": 0, "failed": 0, "interrupted": 0}
        assert [a["name"] for a in m["assets"]] == ["box"]
        assert m["assets"][0]["outputs"] == first["assets"][0]["outputs"]
        assert (out / "csm/box.csm").read_bytes() == csm
    assert bake_assets(tmp_path / "src", out, PARAMS, executor="serial", progress=False)["summary"]["skipped"] == 1


def test_assets_params_must_be_asset_params(tmp_path):
    """params given as a dict ({"theta": 2}) raised "'dict' object has no attribute 'to_dict'" after the
    output folders were made."""
    (tmp_path / "src").mkdir()
    BOX.export(tmp_path / "src/box.obj")
    with pytest.raises(TypeError, match="params must be an AssetParams"):
        bake_assets(tmp_path / "src", tmp_path / "out", {"theta": 2}, executor="serial", progress=False)
    assert not (tmp_path / "out").exists()


def test_a_name_shaped_like_a_temporary_file_keeps_its_outputs(tmp_path):
    """A mesh file named .a.0123456789ab.tmp.obj (given by name) became asset '.a.0123456789ab.tmp', whose
    outputs and record matched the pattern of an interrupted atomic write's leftovers: the sweep at the end
    of the run deleted all three, the manifest said 'baked' and every rerun baked it again. A part of that
    name in bake_frames lost its CSM file the same way."""
    from pyshadow.bake import find_assets

    (tmp_path / "src").mkdir()
    src = tmp_path / "src/.a.0123456789ab.tmp.obj"
    BOX.export(src)
    assert find_assets(src)[0] == [("_.a.0123456789ab.tmp", src)]
    out = tmp_path / "out"
    m = bake_assets(src, out, PARAMS, executor="serial", progress=False)
    assert m["summary"]["baked"] == 1
    for rel in (*m["assets"][0]["outputs"], "records/_.a.0123456789ab.tmp.json"):
        assert (out / rel).is_file(), rel
    assert bake_assets(src, out, PARAMS, executor="serial", progress=False)["summary"]["skipped"] == 1
    with pytest.raises(ValueError, match="temporary file"):
        _bake(tmp_path / "frames", parts=[(".a.0123456789ab.tmp", BOX, True)], csm_for=_never)


def test_assets_samples_beyond_the_kernels_limit_is_refused_first(tmp_path, capsys):
    """AssetParams(samples=5000) (pyshadow-bake assets --samples 5000, which the command line accepts up to
    65536) built every asset's CSM and then failed each one with "samples must be in 1..4096"."""
    from pyshadow.sampling import MAX_SAMPLES

    (tmp_path / "src").mkdir()
    BOX.export(tmp_path / "src/box.obj")
    with pytest.raises(ValueError, match=f"AssetParams.samples must be at most {MAX_SAMPLES}"):
        AssetParams(theta=2, phi=2, resolution=8, samples=MAX_SAMPLES + 1)
    assert AssetParams(theta=2, phi=2, resolution=8, samples=MAX_SAMPLES).samples == MAX_SAMPLES
    from pyshadow.bake.cli import main

    with pytest.raises(SystemExit) as exit_:            # the command line refuses it before any work (usage error)
        main(["assets", str(tmp_path / "src"), "--out", str(tmp_path / "out"), "--samples", str(MAX_SAMPLES + 1)])
    assert exit_.value.code == 2
    assert f"--samples must be in 1..{MAX_SAMPLES}, got {MAX_SAMPLES + 1}" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
