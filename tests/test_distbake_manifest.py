"""A bake killed outright (SIGKILL: no manifest written) leaves no manifest of an earlier run describing the
outputs it replaced; a rerun of a shorter motion says that the folder still holds a longer one's frames."""
import json

import pytest

import pyshadow
from pyshadow.bake import AssetParams, bake_assets
from pyshadow.bake import frames as frames_mod
from pyshadow.bake import library
from pyshadow.bake.frames import bake_frames
from pyshadow.bake.motion import default_motion


class _Killed(BaseException):
    """The process dying: nothing after it runs (the manifest is not written)."""


def _die_after(monkeypatch, module, n):
    """``module``'s store() dies after ``n`` outputs, and so does its manifest write."""
    store, write = module.store, module.write_bytes_atomic
    count = []

    def dying_store(*a, **k):
        if len(count) == n:
            raise _Killed
        count.append(1)
        return store(*a, **k)

    def dying_write(path, data):
        if path.name == "manifest.json":
            raise _Killed
        return write(path, data)

    monkeypatch.setattr(module, "store", dying_store)
    monkeypatch.setattr(module, "write_bytes_atomic", dying_write)


def _scene(frames):
    T, _ = default_motion(frames)
    parts = [(n, m, c) for n, m, _, c in pyshadow.data.default_parts()]
    cam = pyshadow.Camera([2.4, 2.1, 4.8], [0.8, 0.5, 0.0], width=16, height=12)
    csms = {}

    def csm_for(name, mesh):
        return csms.setdefault(name, pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(4, 8),
                                                                       resolution=16, progress=False))

    return parts, cam, T, csm_for


def test_shorter_rerun_notes_the_earlier_runs_frames_past_its_end(tmp_path):
    """Was: 6 frames at 3 samples, then 4 frames (another motion) at 2 samples into the same folder: png/ held
    frames 0-5, the last two of the first run, and nothing said so (read as one sequence: a mix of the two)."""
    parts, cam, T6, csm_for = _scene(6)
    bake_frames(tmp_path, parts, cam, T6, samples=3, csm_for=csm_for, executor="serial", progress=False)
    notes = []
    T4 = default_motion(4)[0]
    m = bake_frames(tmp_path, parts, cam, T4, samples=2, csm_for=csm_for, executor="serial", progress=False,
                    log=notes.append)
    assert m["summary"]["rendered"] == 4 and len(m["frames"]) == 4
    assert len(list((tmp_path / "png").glob("frame_*.png"))) == 6          # kept: they are not this run's to delete
    past = [n for n in notes if "earlier run past this motion's 4" in n]
    assert len(past) == 1 and "2 frames" in past[0] and "frame 4 to 5" in past[0], notes
    again = []
    bake_frames(tmp_path, parts, cam, T6, samples=3, csm_for=csm_for, executor="serial", progress=False,
                log=again.append)
    assert not [n for n in again if "past this motion" in n]


def test_frames_killed_rerun_leaves_no_stale_manifest(tmp_path, monkeypatch):
    """Was: a rerun with 4 samples killed after 2 frames left the 2-sample run's manifest.json, which
    listed frames 0 and 1 as rendered with 2 samples (and their old sha256) while their files were the new
    run's."""
    parts, cam, T, csm_for = _scene(4)
    first = bake_frames(tmp_path, parts, cam, T, samples=2, csm_for=csm_for, executor="serial", progress=False)
    assert first["summary"]["rendered"] == 4
    _die_after(monkeypatch, frames_mod, 2)
    with pytest.raises(_Killed):
        bake_frames(tmp_path, parts, cam, T, samples=4, csm_for=csm_for, executor="serial", progress=False)
    assert (tmp_path / "records" / "frame_0001.json").is_file()
    new = json.loads((tmp_path / "records" / "frame_0001.json").read_text())["outputs"]
    assert new != first["frames"][1]["outputs"]         # frame 1 was replaced by the killed run
    assert not (tmp_path / "manifest.json").exists()    # not the first run's, describing the old frame 1


def test_assets_killed_rerun_leaves_no_stale_manifest(tmp_path, monkeypatch):
    """Was: a rerun with other parameters killed after 1 asset left the earlier run's manifest.json,
    listing that asset's replaced outputs (sha256 of the old files) as baked."""
    src = tmp_path / "src"
    src.mkdir()
    for name in list(pyshadow.data.MESHES)[:2]:
        pyshadow.data.mesh_file(name, src)
    out = tmp_path / "out"
    first = bake_assets(src, out, AssetParams(theta=4, phi=8, resolution=16, samples=2), executor="serial",
                        progress=False)
    assert first["summary"]["baked"] == 2
    _die_after(monkeypatch, library, 1)
    with pytest.raises(_Killed):
        bake_assets(src, out, AssetParams(theta=4, phi=8, resolution=16, samples=4), executor="serial",
                    progress=False)
    assert not (out / "manifest.json").exists()
