"""pyshadow-bake frames --camera FILE: the frames' camera from a JSON file (a manifest's "camera" entry)."""
import json
import re

import numpy as np
import pytest
import trimesh

import pyshadow.bake.frames as frames_module
from pyshadow import Camera
from pyshadow.bake import write_motion
from pyshadow.bake.cli import main


@pytest.fixture
def seen(monkeypatch):
    """bake_frames replaced by one that records its camera and renders nothing."""
    got = []

    def fake(out, parts, camera, T, **kw):
        got.append(camera)
        return {"summary": {"rendered": 0, "skipped": 0, "failed": 0, "interrupted": 0}, "frames": [],
                "executor": {"kind": "serial", "workers": 1}, "frames_per_minute": None, "seconds": 0.0,
                "prepare_seconds": 0.0}

    monkeypatch.setattr(frames_module, "bake_frames", fake)
    return got


def _run(tmp_path, *argv):
    return main(["frames", "-o", str(tmp_path / "out"), "--frames", "2", "--executor", "serial", "--no-cache",
                 "--quiet", *argv])


def test_the_camera_file_sets_the_frames_camera(tmp_path, seen):
    """Was: no way to choose the frames' camera from the command line (the bundled scene's fixed camera, or
    auto_camera's view of the --mesh bodies); "--camera" was an unknown argument (exit status 2)."""
    p = tmp_path / "cam.json"
    p.write_text(json.dumps({"eye": [1.0, 4.0, 6.0], "target": [0.5, 0.0, -0.5], "fov_y": 30.0}))
    assert _run(tmp_path, "--camera", str(p), "--size", "32x24") == 0
    cam = seen[-1]
    assert cam.eye.tolist() == [1.0, 4.0, 6.0] and cam.target.tolist() == [0.5, 0.0, -0.5]
    assert (cam.fov_y, cam.width, cam.height) == (30.0, 32, 24)
    p.write_text(json.dumps({"eye": [1.0, 4.0, 6.0], "target": [0.0, 0.0, 0.0], "up": [0, 0, 1], "width": 20,
                             "height": 10}))
    assert _run(tmp_path, "--camera", str(p)) == 0        # the file's size
    cam = seen[-1]
    assert (cam.fov_y, cam.width, cam.height) == (45.0, 20, 10)
    assert cam.up.tolist() == Camera([1.0, 4.0, 6.0], [0.0, 0.0, 0.0], up=[0, 0, 1]).up.tolist()
    assert _run(tmp_path) == 0                              # without it: the bundled scene's camera, as before
    assert seen[-1].eye.tolist() == [2.4, 2.1, 4.8] and (seen[-1].width, seen[-1].height) == (640, 480)


@pytest.mark.parametrize("content, message", [
    ("[1, 2, 3]", "expected a JSON object with eye and target"),
    ('{"eye": [0, 1, 5]}', "expected a JSON object with eye and target"),
    ('{"eye": [0, 1, 5], "target": [0, 0, 0], "fov": 30}', r"got \['eye', 'fov', 'target'\]"),
    ("{eye: 1}", "not a JSON file"),
    ('{"eye": [0, 1, 5], "target": [0, 1, 5]}', "eye and target coincide"),
    ('{"eye": [0, 1, 5], "target": [0, 0, 0], "fov_y": 200}', "fov"),
    ('{"eye": [0, 1, 5], "target": [0, 0, 0], "width": 64, "height": 48}', "is 64x48 pixels and --size 32x24"),
])
def test_a_bad_camera_file_is_a_usage_error_naming_it(tmp_path, seen, capsys, content, message):
    p = tmp_path / "cam.json"
    p.write_text(content)
    with pytest.raises(SystemExit) as e:
        _run(tmp_path, "--camera", str(p), "--size", "32x24")
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert f"--camera {p}" in err and re.search(message, err), err
    assert not seen


def test_a_manifests_camera_renders_the_same_frames(tmp_path):
    """The frames manifest's "camera" entry, given back as --camera, renders the same images."""
    box = tmp_path / "box.obj"
    trimesh.creation.box((1.0, 1.0, 1.0)).export(box)
    motion = tmp_path / "m.json"
    T = np.eye(4)
    T[1, 3] = 0.5
    write_motion(motion, T[None, None], ["box"])
    common = ["--mesh", str(box), "--motion", str(motion), "--size", "12x9", "--samples", "2", "--maps", "2x4",
              "--resolution", "16", "--executor", "serial", "--no-cache", "--quiet"]
    assert main(["frames", "-o", str(tmp_path / "a"), *common]) == 0
    cam = json.loads((tmp_path / "a" / "manifest.json").read_text())["camera"]
    (tmp_path / "cam.json").write_text(json.dumps(cam))
    assert main(["frames", "-o", str(tmp_path / "b"), *common, "--camera", str(tmp_path / "cam.json")]) == 0
    again = json.loads((tmp_path / "b" / "manifest.json").read_text())["camera"]
    assert again.keys() == cam.keys()       # up: the camera's orthogonal up, made again (within an ulp)
    np.testing.assert_allclose([again[k] for k in ("eye", "target", "up")], [cam[k] for k in ("eye", "target", "up")],
                               rtol=0, atol=1e-15)
    a = (tmp_path / "a" / "exr" / "frame_0000.exr").read_bytes()
    assert a == (tmp_path / "b" / "exr" / "frame_0000.exr").read_bytes()
