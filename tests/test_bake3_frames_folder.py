"""What a frame bake leaves in a folder that held another bake's frames, and the names of a long motion's
frames (pyshadow.bake.frames), found by the third audit of the bake. Tiny bakes (2x2 maps of 8 texels, 8x6
images, one sample, serial)."""
import json

import numpy as np
import trimesh

import pyshadow
from pyshadow.bake import frames as fr
from pyshadow.bake.params import code_digest

BOX = trimesh.creation.box((1.0, 1.0, 1.0))


def _csm(name, mesh):
    return pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(2, 2), resolution=8, progress=False)


def _T(frames):
    T = np.repeat(np.eye(4)[None, None], frames, axis=0)
    T[:, 0, 0, 3] = np.linspace(0.0, 0.4, frames)
    return T


def _bake(out, frames=4, samples=1, width=8, log=None, **kw):
    cam = pyshadow.Camera([3.0, 3.0, 3.0], [0.0, 0.0, 0.0], width=width, height=6)
    return fr.bake_frames(out, [("box", BOX, True)], cam, _T(frames), samples=samples, csm_for=_csm, chunk=2,
                          executor="serial", progress=False, log=log, **kw)


def test_a_bake_of_other_parameters_says_it_renders_over_the_folders_frames(tmp_path):
    """Was: 4 frames at 1 sample, then the same motion at 4 samples into the same folder: the second run logged
    only '4 frames: 4 to render' and replaced the first's finished frames without a word; stopped part way it
    left a folder of both bakes' frames under one sequence of names. Now each run names what differs and how
    many finished frames of the other bake it renders over (its records keep the bake's parameters)."""
    _bake(tmp_path, samples=1)
    notes = []
    m = _bake(tmp_path, samples=4, log=notes.append)
    assert m["summary"]["rendered"] == 4
    other = [n for n in notes if "finished frames of another bake" in n]
    assert len(other) == 1 and "holds 4 finished frames" in other[0] and "samples 1 there, 4 here" in other[0], notes
    notes.clear()
    _bake(tmp_path, samples=4, width=16, log=notes.append)
    assert any("width 8 there, 16 here" in n for n in notes), notes
    notes.clear()
    m = _bake(tmp_path, samples=4, width=16, log=notes.append)     # its own frames: nothing to say
    assert m["summary"]["skipped"] == 4 and not [n for n in notes if "another bake" in n], notes
    # the manifest's frame entries stay as they were: the parameters are in it once, at its top
    assert "bake" not in m["frames"][0] and m["render"]["samples"] == 4
    assert json.loads((tmp_path / "records/frame_0000.json").read_text())["bake"]["render"]["samples"] == 4


def test_more_than_10000_frames_are_named_to_sort_in_frame_order(tmp_path, monkeypatch):
    """Was: frame_0000 ... frame_9999, then frame_10000: by name (a glob, ls, an image-sequence reader that
    sorts) frame 10000 came between frames 1000 and 1001, 9,000 frames out of place in a 10,001-frame
    motion. Now every name of a motion has its last frame's digits (5 here); 4 as before up to 10,000 frames.
    The renders and writes are stubbed (the names alone are checked)."""
    code = code_digest()

    def render_chunk(frames, transforms, payload):     # names its files as the real one does
        return [{"frame": f, "files": {f"{k}/frame_{f:04d}.{k}": b"" for k in ("exr", "png")}, "seconds": 0.0,
                 "ao_mean": 1.0, "worker": "w", "code": code} for f in frames]

    stored = {}

    def store(out, record, rec, files):
        stored[rec["frame"]] = (record, sorted(files))
        return dict(rec, outputs={rel: {"sha256": "", "bytes": 0} for rel in files})

    monkeypatch.setattr(fr, "render_chunk", render_chunk)
    monkeypatch.setattr(fr, "store", store)
    F = 10_001
    cam = pyshadow.Camera([3.0, 3.0, 3.0], [0.0, 0.0, 0.0], width=8, height=6)
    m = fr.bake_frames(tmp_path, [("box", BOX, True)], cam, np.repeat(np.eye(4)[None, None], F, axis=0),
                       samples=1, csm_for=_csm, chunk=5000, executor="serial", progress=False)
    assert m["summary"]["rendered"] == F
    pngs = [stored[f][1][1] for f in range(F)]
    assert sorted(pngs) == pngs, [p for i, p in enumerate(sorted(pngs)) if p != pngs[i]][:3]
    assert pngs[0] == "png/frame_00000.png" and pngs[-1] == "png/frame_10000.png"
    assert stored[7][0] == "records/frame_00007.json" and stored[7][1] == ["exr/frame_00007.exr",
                                                                           "png/frame_00007.png"]
    assert fr._frame_stem(9999, 10_000) == "frame_9999"      # up to 10,000 frames: named as before


def test_frames_of_a_run_named_with_other_digits_are_noted(tmp_path):
    """Was: a folder holding the records of a 10,001-frame motion (frame_00000 ...) and then baked with 3
    frames (frame_0000 ...) held two sequences of names and nothing said so. Now a note names the others."""
    (tmp_path / "records").mkdir()
    (tmp_path / "records/frame_00001.json").write_text("{}")
    notes = []
    m = _bake(tmp_path, frames=3, log=notes.append)
    assert m["summary"]["rendered"] == 3
    other = [n for n in notes if "named with 5 digits" in n]
    assert len(other) == 1 and "frame_00001" in other[0] and "frame_0000 ..." in other[0], notes
