"""pyshadow-bake's options: an option that does nothing where it is given is refused, not ignored."""
from __future__ import annotations

import pytest

from pyshadow.bake import cli, frames
from pyshadow.bake.motion import default_motion, write_motion


def test_frames_with_a_motion_file_is_refused(tmp_path, monkeypatch, capsys):
    """Was: ``pyshadow-bake frames --motion m.npz --frames 2`` rendered every frame of the file (here 5; a
    quick preview of a 600-frame motion rendered all 600): --frames was read only for the bundled scene's
    default motion and ignored without a word. Now a usage error (status 2) before anything is built."""
    motion = tmp_path / "m.npz"
    write_motion(motion, *default_motion(5))
    def fake(out, parts, camera, T, **kw):
        raise AssertionError(f"--frames 2 ignored: {len(T)} frames to render")
    monkeypatch.setattr(frames, "bake_frames", fake)
    with pytest.raises(SystemExit) as exc:
        cli.main(["frames", "-o", str(tmp_path / "out"), "--motion", str(motion), "--frames", "2", "--no-cache",
                  "--quiet", "--executor", "serial"])
    assert exc.value.code == 2
    assert "--frames 2" in capsys.readouterr().err


def test_frames_default_length_is_still_60(tmp_path, monkeypatch):
    """The bundled scene's motion without --frames: 60 frames, as before; --frames 3 gives 3."""
    seen = []

    def fake(out, parts, camera, T, **kw):
        seen.append(len(T))
        raise KeyboardInterrupt
    monkeypatch.setattr(frames, "bake_frames", fake)
    for extra in ([], ["--frames", "3"]):
        assert cli.main(["frames", "-o", str(tmp_path / "out"), "--no-cache", "--quiet", *extra]) == 130
    assert seen == [60, 3]
