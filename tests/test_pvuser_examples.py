"""Example options that were accepted and ignored: now usage errors.

``moving_bodies.py --frames N`` without ``--screenshot`` opened the interactive window and ran no
frames; ``csm_heatmap.py --hilbert L --theta T --phi P`` built the Hilbert set and dropped T and P.
"""
from pathlib import Path

import pytest
from test_bad_input_bench import example_module as _example

from pyshadow import viz

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"




@pytest.fixture
def no_render(monkeypatch):
    """No window and no file: ``viz.finish`` closes the plotter; ``make_plotter`` is off screen."""
    make = viz.plotter.make_plotter

    def offscreen(*args, **kwargs):
        kwargs["off_screen"] = True
        return make(*args, **kwargs)

    def finish(plotter, screenshot=None, **kw):
        plotter.close()
        return screenshot
    monkeypatch.setattr(viz, "finish", finish)
    monkeypatch.setattr(viz.plotter, "make_plotter", offscreen)


SMALL_MOVING = ["--theta", "4", "--phi", "8", "--resolution", "16", "--samples", "4", "--ground-divisions", "4"]


def test_moving_bodies_frames_without_screenshot_is_a_usage_error(no_render, capsys):
    with pytest.raises(SystemExit) as e:
        _example("moving_bodies").main([*SMALL_MOVING, "--frames", "3"])
    assert e.value.code == 2
    assert "--frames needs --screenshot" in capsys.readouterr().err


def test_moving_bodies_frames_zero_without_screenshot_is_still_the_window(no_render, monkeypatch):
    """The default (--frames 0) keeps the interactive path: nothing refused before the window."""
    shown = []
    monkeypatch.setattr(viz, "finish", lambda plotter, screenshot=None, **kw: shown.append(screenshot)
                        or plotter.close())
    assert _example("moving_bodies").main([*SMALL_MOVING, "--window", "200", "150"]) == 0
    assert shown == [None]


@pytest.mark.parametrize("extra", [["--theta", "4"], ["--phi", "8"], ["--theta", "4", "--phi", "8"]])
def test_csm_heatmap_zigzag_options_with_hilbert_are_a_usage_error(tmp_path, no_render, capsys, extra):
    with pytest.raises(SystemExit) as e:
        _example("csm_heatmap").main(["--hilbert", "1", "--resolution", "8", *extra, "--window", "200", "200",
                                      "--screenshot", str(tmp_path / "h.png")])
    assert e.value.code == 2
    assert "give them or --hilbert" in capsys.readouterr().err


@pytest.mark.parametrize("argv, layout", [(["--hilbert", "1"], "hilbert level 1"),
                                          (["--theta", "4", "--phi", "8"], "zigzag 4x8"),
                                          (["--theta", "4"], "zigzag 4x64")])
def test_csm_heatmap_layouts_still_run(tmp_path, no_render, capsys, argv, layout):
    assert _example("csm_heatmap").main([*argv, "--resolution", "8", "--window", "200", "200",
                                         "--screenshot", str(tmp_path / "h.png")]) == 0
    assert f"({layout})" in capsys.readouterr().out
