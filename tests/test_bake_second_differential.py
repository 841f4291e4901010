"""Second differential audit of the bake (pyshadow.bake): two bakes into one output folder against one bake
alone. Each test says in its docstring what happened before. The bakes are tiny (4x8 maps of 16 texels,
images of a few pixels); a second bake is started at a chosen point of the first (while the first writes
an output) by hooking the fsync of the atomic writes, so the interleaving is the same on every run."""
import os
import sys
import time

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.bake import AssetParams, bake_assets
from pyshadow.bake.assets import csm_file_bytes
from pyshadow.bake.frames import bake_frames
from pyshadow.bake.runner import _TEMPORARY, sweep_temporaries

PARAMS = AssetParams(theta=4, phi=8, resolution=16, samples=8, ground=True)
BOX = trimesh.creation.box((1.0, 1.0, 1.0))
BOX.apply_translation((0.0, 0.5, 0.0))


def _csm(name, mesh):
    return pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(4, 8), resolution=16, progress=False)


def _temporaries(out):
    return [p for p in out.rglob(".*") if _TEMPORARY.match(p.name)]


def _second_bake_during_first_write(monkeypatch, out, second):
    """Run ``second()`` once, inside the fsync of the first atomic write under ``out`` (its temporary file
    written, not yet renamed): another bake into the same folder starting at that moment."""
    real = os.fsync
    ran = []

    def fsync(fd):
        if not ran and _temporaries(out):
            ran.append(True)
            second()
        return real(fd)

    monkeypatch.setattr(os, "fsync", fsync)
    return ran


def _ao(path):
    return trimesh.load(path, process=False).metadata["_ply_raw"]["vertex"]["data"]["ao"]


def test_two_asset_bakes_into_one_library_keep_each_others_writes(tmp_path, monkeypatch):
    """A second ``bake_assets`` into the same folder, started while the first was writing an output,
    removed the first's temporary file (its start-of-run sweep of a killed run's leftovers), and the first
    bake's asset failed: "writing its outputs: FileNotFoundError" (measured with real processes: a sweep
    loop beside a 12-asset bake failed 2 of 12 assets). Now both bakes finish, and each asset's CSM and
    per-vertex AO equal those computed directly."""
    out = tmp_path / "out"
    for name, mesh in (("a", BOX), ("b", trimesh.creation.icosphere(1, 0.5))):
        (tmp_path / name).mkdir()
        mesh.export(tmp_path / name / f"{name}.ply")
    second = []
    ran = _second_bake_during_first_write(monkeypatch, out, lambda: second.append(
        bake_assets(tmp_path / "b", out, PARAMS, executor="serial", progress=False)))
    first = bake_assets(tmp_path / "a", out, PARAMS, executor="serial", progress=False)
    assert ran == [True] and len(second) == 1
    assert first["summary"] == {"baked": 1, "skipped": 0, "failed": 0, "interrupted": 0}, first["assets"]
    assert second[0]["summary"] == {"baked": 1, "skipped": 0, "failed": 0, "interrupted": 0}
    for name in ("a", "b"):
        mesh = pyshadow.load_mesh(tmp_path / name / f"{name}.ply")
        csm = _csm(name, mesh)
        assert (out / "csm" / f"{name}.csm").read_bytes() == csm_file_bytes(csm)
        scene = pyshadow.Scene(ground=float(mesh.vertices[:, 1].min()))
        scene.add(csm, np.eye(4), mesh=mesh)
        np.testing.assert_array_equal(_ao(out / "meshes" / f"{name}.ply"),
                                      scene.vertex_ao(0, sampling=pyshadow.Sampling(8)))
    assert _temporaries(out) == []
    again = bake_assets([tmp_path / "a", tmp_path / "b"], out, PARAMS, executor="serial", progress=False)
    assert again["summary"] == {"baked": 0, "skipped": 2, "failed": 0, "interrupted": 0}


def test_two_frame_bakes_into_one_folder_keep_each_others_writes(tmp_path, monkeypatch):
    """The same scene's frames baked twice at once into one folder (a script that started the job twice):
    the second run's sweep removed the first's temporary CSM file as it was written, and the first
    ``bake_frames`` raised FileNotFoundError ("No such file or directory: .../csm/box.csm"). Now both
    finish (the first finding the frames the second rendered done) and every frame equals Scene.render of
    the same transforms."""
    out = tmp_path / "out"
    parts = [("box", BOX, True)]
    cam = pyshadow.Camera([3.0, 2.0, 4.0], [0.0, 0.5, 0.0], width=6, height=5)
    T = np.tile(np.eye(4), (2, 1, 1, 1))
    T[1, 0, :3, :3] = [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]]     # a half turn, exactly
    T[1, 0, 0, 3] = 0.25
    kw = dict(samples=2, csm_for=_csm, executor="serial", progress=False)
    second = []
    ran = _second_bake_during_first_write(monkeypatch, out, lambda: second.append(
        bake_frames(out, parts, cam, T, **kw)))
    first = bake_frames(out, parts, cam, T, **kw)
    assert ran == [True] and len(second) == 1
    assert second[0]["summary"] == {"rendered": 2, "skipped": 0, "failed": 0, "interrupted": 0}
    # the first found the second's frames done once its CSM was written
    assert first["summary"] == {"rendered": 0, "skipped": 2, "failed": 0, "interrupted": 0}, first["frames"]
    scene = pyshadow.Scene(ground=0.0)
    scene.add(_csm("box", BOX), np.eye(4), mesh=BOX)
    for f in range(2):
        scene.set_transform(0, T[f, 0])
        np.testing.assert_array_equal(pyshadow.read_image(out / "exr" / f"frame_{f:04d}.exr"),
                                      scene.render(cam, sampling=pyshadow.Sampling(2)).ao)
    assert _temporaries(out) == []


def test_sweep_keeps_young_temporaries_when_asked(tmp_path):
    """Part of the fix above: with ``min_age`` a temporary file modified within that many seconds (another
    bake's write in progress) is kept and an older one (a killed run's) removed; without it every one
    goes, as before. Before, there was no ``min_age``: every temporary went."""
    from pyshadow.bake.runner import STALE_SECONDS

    young, old = tmp_path / ".a.0123456789ab.tmp.csm", tmp_path / "sub" / ".f.abcdefabcdef.tmp.png"
    old.parent.mkdir()
    for p in (young, old):
        p.write_bytes(b"x")
    stale = time.time() - STALE_SECONDS - 60.0
    os.utime(old, (stale, stale))
    assert STALE_SECONDS == 3600.0
    assert sweep_temporaries(tmp_path, STALE_SECONDS) == [old]
    assert young.exists() and not old.exists()
    assert sweep_temporaries(tmp_path) == [young]


def test_a_skipped_assets_source_is_the_file_this_run_read(tmp_path):
    """The library's sources moved (same files, same content): a rerun from the new folder skipped every
    asset, as it should, but its manifest gave each one the ``source`` of the run that baked it, a path
    that no longer existed, not the file this run hashed. Now the manifest (returned and written) names
    this run's file, and the asset's record keeps the path it was baked from."""
    import json
    import shutil

    (tmp_path / "old").mkdir()
    BOX.export(tmp_path / "old" / "box.ply")
    out = tmp_path / "out"
    bake_assets(tmp_path / "old", out, PARAMS, executor="serial", progress=False)
    shutil.move(tmp_path / "old", tmp_path / "new")
    m = bake_assets(tmp_path / "new", out, PARAMS, executor="serial", progress=False)
    assert m["summary"] == {"baked": 0, "skipped": 1, "failed": 0, "interrupted": 0}
    written = json.loads((out / "manifest.json").read_text())
    for entry in (m["assets"][0], written["assets"][0]):
        assert entry["source"] == str(tmp_path / "new" / "box.ply")
    assert json.loads((out / "records" / "box.json").read_text())["source"] == str(tmp_path / "old" / "box.ply")


def test_one_frame_that_cannot_render_fails_alone_whatever_the_chunk(tmp_path):
    """A frame whose render is refused (here the second body 1e9 away: the G-buffer's near plane would cut
    the near body, README "Bodies far apart") failed every frame of its task: with the default ``chunk=4``
    all 4 frames 'failed' with that frame's error, and a rerun failed them again, while with ``chunk=1``
    3 of them rendered. Now the chunk size changes nothing: frames 0, 1 and 3 equal Scene.render, frame 2
    alone fails with its own error, and a rerun renders nothing but that frame."""
    ball = trimesh.creation.icosphere(1, 0.4)
    parts = [("box", BOX, True), ("ball", ball, True)]
    cam = pyshadow.Camera([3.0, 2.0, 4.0], [0.0, 0.5, 0.0], width=8, height=6)
    T = np.tile(np.eye(4), (4, 2, 1, 1))
    T[:, 1, 0, 3] = 1.5
    T[2, 1, :3, 3] = [0.0, 0.0, -1e9]
    kw = dict(samples=2, csm_for=_csm, executor="serial", progress=False)
    scene = pyshadow.Scene(ground=0.0)
    for name, mesh, _ in parts:
        scene.add(_csm(name, mesh), np.eye(4), mesh=mesh)
    for chunk in (1, 4):
        out = tmp_path / f"chunk{chunk}"
        m = bake_frames(out, parts, cam, T, chunk=chunk, **kw)
        assert m["summary"] == {"rendered": 3, "skipped": 0, "failed": 1, "interrupted": 0}, m["frames"]
        assert [e["action"] for e in m["frames"]] == ["rendered", "rendered", "failed", "rendered"]
        assert m["frames"][2]["error"].startswith("ValueError: render_gbuffer: item 0 has a vertex in view")
        for f in (0, 1, 3):
            for i in range(2):
                scene.set_transform(i, T[f, i])
            np.testing.assert_array_equal(pyshadow.read_image(out / "exr" / f"frame_{f:04d}.exr"),
                                          scene.render(cam, sampling=pyshadow.Sampling(2)).ao)
        assert not (out / "exr" / "frame_0002.exr").exists()
        again = bake_frames(out, parts, cam, T, chunk=chunk, **kw)
        assert again["summary"] == {"rendered": 0, "skipped": 3, "failed": 1, "interrupted": 0}


@pytest.mark.skipif(sys.platform != "linux", reason="other systems refuse file names that are no UTF-8")
def test_a_body_named_after_a_file_name_that_is_no_utf8_bakes(tmp_path):
    """A body whose name comes from a file name that is no UTF-8 (``pyshadow-bake frames --mesh`` of a
    Latin-1 ``caf\\xe9.ply``: its stem is ``os.fsdecode``'s 'caf\\udce9') made bake_frames raise
    UnicodeEncodeError "surrogates not allowed" once its CSM was built (the scene's key hashed
    ``name.encode()``), and the command exit 2 with that message. Now it renders, its CSM file has that
    name, and its frame equals the same body's named 'cafe' (skipped on a rerun)."""
    name = os.fsdecode(b"caf\xe9")
    cam = pyshadow.Camera([3.0, 2.0, 4.0], [0.0, 0.5, 0.0], width=6, height=5)
    T = np.eye(4)[None, None]
    kw = dict(samples=2, csm_for=_csm, executor="serial", progress=False)
    ms = [bake_frames(tmp_path / n, [(n, BOX, True)], cam, T, **kw) for n in (name, "cafe")]
    for m in ms:
        assert m["summary"] == {"rendered": 1, "skipped": 0, "failed": 0, "interrupted": 0}, m["frames"]
    assert ms[0]["scene"] != ms[1]["scene"]
    assert ms[0]["csm"] == {name: f"csm/{name}.csm"}
    assert (tmp_path / name / "csm" / f"{name}.csm").read_bytes() == \
        (tmp_path / "cafe" / "csm" / "cafe.csm").read_bytes()
    for kind in ("exr", "png"):
        assert (tmp_path / name / kind / f"frame_0000.{kind}").read_bytes() == \
            (tmp_path / "cafe" / kind / f"frame_0000.{kind}").read_bytes()
    again = bake_frames(tmp_path / name, [(name, BOX, True)], cam, T, **kw)
    assert again["summary"] == {"rendered": 0, "skipped": 1, "failed": 0, "interrupted": 0}
