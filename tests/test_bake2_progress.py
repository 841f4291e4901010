"""Progress of a bake's long check of earlier outputs (pyshadow.bake.frames and library), found by the
second audit of the bake. Tiny bakes (2x2 maps of 8 texels, 8x6 images, one sample, serial); the check
is slowed by a patched ``done`` to pass the bar's 1 s delay."""
import time

import numpy as np
import trimesh

import pyshadow
from pyshadow.bake import AssetParams, bake_assets
from pyshadow.bake import frames as frames_mod
from pyshadow.bake import library

BOX = trimesh.creation.box((1.0, 1.0, 1.0))


def _csm(name, mesh):
    return pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(2, 2), resolution=8, progress=False)


def _slow(real, seconds):
    def done(*args):
        time.sleep(seconds)
        return real(*args)
    return done


def test_a_frame_bakes_check_of_earlier_frames_shows_progress(tmp_path, monkeypatch, capsys):
    """Was: the check of every earlier frame (reading its record, hashing its EXR and PNG; 0.5 ms a
    frame here, a minute for 100,000 frames) printed nothing, however long it took, even with
    progress=True: a rerun of a long motion seemed to hang. Now a 'checking' bar shows after 1 s."""
    T = np.repeat(np.eye(4)[None, None], 3, axis=0)
    cam = pyshadow.Camera([3.0, 3.0, 3.0], [0.0, 0.0, 0.0], width=8, height=6)

    def bake(progress):
        return frames_mod.bake_frames(tmp_path / "out", [("box", BOX, True)], cam, T, samples=1, csm_for=_csm,
                                      executor="serial", progress=progress)

    bake(False)
    capsys.readouterr()
    monkeypatch.setattr(frames_mod, "done", _slow(frames_mod.done, 0.45))
    m = bake(True)
    assert m["summary"]["skipped"] == 3
    err = capsys.readouterr().err
    assert "checking" in err, err
    bake(False)                             # not with progress=False
    assert "checking" not in capsys.readouterr().err


def test_an_asset_bakes_check_of_earlier_outputs_shows_progress(tmp_path, monkeypatch, capsys):
    """Was: hashing every source and every earlier output (a default CSM is tens of MB: minutes for a
    large library) printed nothing before the bake's own bar, even with progress=True. Now a
    'checking' bar shows after 1 s."""
    src = tmp_path / "src"
    src.mkdir()
    for i in range(3):
        trimesh.creation.box((1.0, 1.0 + i, 1.0)).export(src / f"b{i}.ply")
    P = AssetParams(theta=2, phi=2, resolution=8, samples=1)
    bake_assets(src, tmp_path / "out", P, executor="serial", progress=False)
    capsys.readouterr()
    monkeypatch.setattr(library, "done", _slow(library.done, 0.45))
    m = bake_assets(src, tmp_path / "out", P, executor="serial", progress=True)
    assert m["summary"]["skipped"] == 3
    err = capsys.readouterr().err
    assert "checking" in err, err


def test_an_asset_that_cannot_be_read_for_its_task_still_counts_in_the_bar(tmp_path, monkeypatch, capsys):
    """Was: an asset whose file was gone when its task was sent (removed after the check) was reported
    'failed' but not counted by the bar, which ended at 2/3 assets. Now it ends at 3/3."""
    src = tmp_path / "src"
    src.mkdir()
    for i in range(3):
        trimesh.creation.box((1.0, 1.0 + i, 1.0)).export(src / f"b{i}.ply")
    real = library.done

    def done(out, record, key):             # called once the asset is checked: then its file goes
        if record == "records/b1.json":
            (src / "b1.ply").unlink()
        return real(out, record, key)

    monkeypatch.setattr(library, "done", done)
    m = bake_assets(src, tmp_path / "out", AssetParams(theta=2, phi=2, resolution=8, samples=1),
                    executor="serial", progress=True)
    assert m["summary"] == {"baked": 2, "skipped": 0, "failed": 1, "interrupted": 0}, m["summary"]
    err = capsys.readouterr().err
    assert "3/3" in err.strip().rsplit("\r", 1)[-1], err          # the bar's last state
