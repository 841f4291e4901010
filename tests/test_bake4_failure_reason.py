"""pyshadow-bake frames prints why a frame failed (before: only its count, the reason in the manifest alone)."""
from pyshadow.bake import frames as frames_mod
from pyshadow.bake.cli import main


def test_a_failed_frame_prints_its_error_even_quiet(tmp_path, monkeypatch, capsys):
    real = frames_mod.render_chunk

    def render_chunk(frames, transforms, payload):
        if 1 in frames:
            raise ValueError("render: the camera sits inside body 'torus'")
        return real(frames, transforms, payload)

    monkeypatch.setattr(frames_mod, "render_chunk", render_chunk)
    code = main(["frames", "-o", str(tmp_path / "out"), "--frames", "3", "--size", "8x6", "--samples", "1",
                 "--maps", "2x2", "--resolution", "8", "--no-cache", "--chunk", "1", "--executor", "serial",
                 "--quiet"])
    out = capsys.readouterr().out
    assert code == 1
    assert "1 failed" in out
    assert "frame 1 failed: ValueError: render: the camera sits inside body 'torus' (1 with an error; each one's in " \
        in out and str(tmp_path / "out" / "manifest.json") in out
