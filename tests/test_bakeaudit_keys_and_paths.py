"""Audit of the bake (pyshadow.bake): a rerun that redid finished frames for a ground plane given as an int,
and motion paths that, unlike the bake's other paths, did not expand ``~``. Tiny bakes (4x8 maps of 16
texels, images of a few pixels)."""
import json

import numpy as np
import trimesh

import pyshadow
from pyshadow.bake.cli import main
from pyshadow.bake.frames import bake_frames, scene_payload
from pyshadow.bake.motion import read_motion, write_motion

BOX = trimesh.creation.box((1.0, 1.0, 1.0))
BOX.apply_translation((0.0, 0.5, 0.0))
CAM = pyshadow.Camera([3.0, 2.0, 4.0], [0.0, 0.5, 0.0], width=8, height=6)


def _csm(name, mesh):
    return pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(4, 8), resolution=16, progress=False)


def _motion(frames=3):
    T = np.tile(np.eye(4), (frames, 1, 1, 1))
    T[:, 0, 0, 3] = 0.25 * np.arange(frames)
    return T


def test_a_ground_given_as_an_int_or_minus_zero_is_the_same_scene():
    """Was: ``bake_frames(..., ground=0)`` and a rerun with the default ``ground=0.0`` (or ``-0.0``) had three
    different scene keys (the key hashed JSON "0", "0.0", "-0.0"), so each rerun rendered all 3 of 3 finished
    frames again, to the same pixels; ``ground=1`` and ``1.0`` likewise; ``scene_payload(..., ground=np.float32(0))``
    raised TypeError "Object of type float32 is not JSON serializable". Now one key, and the rerun skips."""
    render = {"samples": 2, "lookup": "nearest", "denoise": None}
    parts = [("box", BOX, True)]
    keys = {g: scene_payload(parts, CAM, ground=g, render=render, csm_for=_csm)["key"]
            for g in (0, 0.0, -0.0, np.float32(0.0), np.int64(0))}
    assert len(set(keys.values())) == 1, keys
    one = {scene_payload(parts, CAM, ground=g, render=render, csm_for=_csm)["key"] for g in (1, 1.0, np.int32(1))}
    assert len(one) == 1 and one.isdisjoint(keys.values())


def test_a_rerun_with_an_equal_ground_of_another_type_skips_every_frame(tmp_path):
    """Was: a bake of 3 frames with ``ground=0``, rerun with ``ground=0.0``, rendered 3 of 3 frames again
    (summary ``rendered: 3, skipped: 0``). Now 0 rendered, 3 skipped, and the frames equal Scene.render of a
    ground at 0.0, bit for bit."""
    T = _motion()
    kw = dict(samples=2, csm_for=_csm, executor="serial", progress=False)
    first = bake_frames(tmp_path, [("box", BOX, True)], CAM, T, ground=0, **kw)
    assert first["summary"]["rendered"] == 3 and first["ground"] == 0.0
    for g in (0.0, -0.0, np.float64(0.0)):
        again = bake_frames(tmp_path, [("box", BOX, True)], CAM, T, ground=g, **kw)
        assert again["summary"] == {"rendered": 0, "skipped": 3, "failed": 0, "interrupted": 0}, (g, again["summary"])
    scene = pyshadow.Scene(ground=0.0)
    scene.add(_csm("box", BOX), np.eye(4), mesh=BOX)
    for f in range(3):
        scene.set_transform(0, T[f, 0])
        np.testing.assert_array_equal(pyshadow.read_image(tmp_path / "exr" / f"frame_{f:04d}.exr"),
                                      scene.render(CAM, sampling=pyshadow.Sampling(2)).ao)


def test_motion_paths_expand_the_home_folder(tmp_path, monkeypatch):
    """Was: ``read_motion("~/m.npz")`` raised ValueError "not a motion NPZ ... No such file or directory:
    '~/m.npz'" and ``write_motion("~/m.json", ...)`` FileNotFoundError "no folder '~'", while ``-o`` and
    ``--mesh`` expand ``~``: ``pyshadow-bake frames --motion=~/m.npz`` (no shell expansion after ``=``)
    stopped with a usage error. Now ``~`` is the home folder."""
    scene = pyshadow.Scene(ground=0.0)        # the kernels built first, under the real home (PoCL's cache)
    scene.add(_csm("box", BOX), np.eye(4), mesh=BOX)
    scene.render(CAM, sampling=pyshadow.Sampling(2))
    monkeypatch.setenv("HOME", str(tmp_path))
    T = _motion(2)
    for ext in ("npz", "json"):
        written = write_motion(f"~/m.{ext}", T, ["box"])
        assert written == tmp_path / f"m.{ext}" and written.is_file()
        got, names = read_motion(f"~/m.{ext}")
        np.testing.assert_array_equal(got, T)
        assert names == ["box"]
    (tmp_path / "box.obj").write_bytes(BOX.export(file_type="obj").encode())
    rc = main(["frames", "-o", "~/out", "--mesh=~/box.obj", "--motion=~/m.npz", "--size", "8x6", "--samples", "2",
               "--maps", "4x8", "--resolution", "16", "--no-cache", "--executor", "serial", "--quiet"])
    assert rc == 0
    m = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert m["summary"] == {"rendered": 2, "skipped": 0, "failed": 0, "interrupted": 0}
