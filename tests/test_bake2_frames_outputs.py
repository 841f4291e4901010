"""Frame bakes whose outputs cannot all be written (pyshadow.bake.frames), found by the second audit of
the bake. The bakes are tiny (2x2 maps of 8 texels, 8x6 images, one sample, serial)."""
import json

import numpy as np
import trimesh

import pyshadow
from pyshadow.bake.frames import bake_frames

BOX = trimesh.creation.box((1.0, 1.0, 1.0))


def _csm(name, mesh):
    return pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(2, 2), resolution=8, progress=False)


def _bake(out, frames=5):
    T = np.repeat(np.eye(4)[None, None], frames, axis=0)
    T[:, 0, 0, 3] = np.linspace(0.0, 0.4, frames)
    cam = pyshadow.Camera([3.0, 3.0, 3.0], [0.0, 0.0, 0.0], width=8, height=6)
    return bake_frames(out, [("box", BOX, True)], cam, T, samples=1, csm_for=_csm, chunk=2, executor="serial",
                       progress=False)


def test_a_frame_whose_output_cannot_be_written_fails_alone(tmp_path):
    """Was: a folder where frame 2's PNG goes (or any OSError writing a frame: a disk full, a folder
    made unwritable) ended bake_frames at once with FileExistsError; frames 2, 3 and 4 of 5 were left
    unrendered and the manifest called them 'interrupted before it finished' (summary rendered 2,
    interrupted 3), hiding the error. Now frame 2 alone fails, naming the write and the file, and a
    rerun once the path is free renders only frame 2."""
    out = tmp_path / "out"
    (out / "png/frame_0002.png").mkdir(parents=True)
    m = _bake(out)
    assert m["summary"] == {"rendered": 4, "skipped": 0, "failed": 1, "interrupted": 0}, m["summary"]
    bad = m["frames"][2]
    assert bad["frame"] == 2 and bad["action"] == "failed"
    assert bad["error"].startswith("writing its outputs:") and "frame_0002.png" in bad["error"], bad
    assert json.loads((out / "manifest.json").read_text())["summary"] == m["summary"]
    assert not (out / "records/frame_0002.json").exists()
    (out / "png/frame_0002.png").rmdir()
    m2 = _bake(out)
    assert m2["summary"] == {"rendered": 1, "skipped": 4, "failed": 0, "interrupted": 0}, m2["summary"]
    assert [e["action"] for e in m2["frames"]] == ["skipped", "skipped", "rendered", "skipped", "skipped"]


def test_a_frame_that_kills_its_worker_fails_alone_not_with_its_chunk(tmp_path, monkeypatch):
    """Was: a task that failed whole (its worker process died on one frame: a crash in native code, out
    of memory) failed every frame of its chunk: with chunk=4, frames 0-3 of 8 'failed' with
    WorkerDied for frame 2's death (rendered 4, failed 4). Now the chunk's frames are tried again one
    by one and only frame 2 fails (rendered 7, failed 1), its error naming the cause."""
    from pyshadow.bake import frames as frames_mod
    from pyshadow.bake.runner import WorkerDied

    real = frames_mod.render_chunk

    def render_chunk(frames, transforms, payload):
        if 2 in frames:
            raise WorkerDied("its worker process died while running it")
        return real(frames, transforms, payload)

    monkeypatch.setattr(frames_mod, "render_chunk", render_chunk)
    T = np.repeat(np.eye(4)[None, None], 8, axis=0)
    T[:, 0, 0, 3] = np.linspace(0.0, 0.4, 8)
    cam = pyshadow.Camera([3.0, 3.0, 3.0], [0.0, 0.0, 0.0], width=8, height=6)
    m = bake_frames(tmp_path / "out", [("box", BOX, True)], cam, T, samples=1, csm_for=_csm, chunk=4,
                    executor="serial", progress=False)
    assert m["summary"] == {"rendered": 7, "skipped": 0, "failed": 1, "interrupted": 0}, m["summary"]
    assert m["frames"][2]["action"] == "failed" and m["frames"][2]["error"].startswith("WorkerDied: ")
    assert sorted((tmp_path / "out/records").iterdir()) == [tmp_path / f"out/records/frame_{f:04d}.json"
                                                             for f in (0, 1, 3, 4, 5, 6, 7)]
