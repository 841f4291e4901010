"""Example scripts and scene drawing, checked against what they claim to show.

Defects fixed: ``depth_maps.py`` with a zigzag set of 2x1 maps crashed inside
pyvista (a plotter column slice with no column); ``csm_heatmap.py`` labelled its
colour bar in quarters of the range with whole numbers (a range 0..1 read
0, 0, 0, 1, 1); ``moving_bodies.py`` and ``lit_scene.py`` named the frames of
``--screenshot out.jpg`` ``out.jpg_0000.png``; :func:`viz.scene_to_plotter` drew
NaN values in pyvista's dark grey (169 of 255), which reads as an AO of 0.66,
and per-vertex columns (V, 1) as their magnitude; :func:`viz.update_scalars`
drew strings and None in the lowest colour; :func:`viz.make_plotter` refused to
work without a display when pyvista.OFF_SCREEN asked for off-screen plotters.
The scripts run in this process, off screen, with tiny maps; ``viz.finish``
closes the plotter without rendering where the picture is not checked.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_bad_input_bench import example_module as _example
import trimesh

import pyshadow
from pyshadow import viz

pytest.importorskip("pyvista")

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"




@pytest.fixture
def no_render(monkeypatch):
    """``viz.finish`` closes the plotter and writes nothing (the picture is not checked)."""
    def finish(plotter, screenshot=None, **kw):
        plotter.close()
        return screenshot
    monkeypatch.setattr(viz, "finish", finish)


@pytest.fixture
def box_file(tmp_path):
    path = tmp_path / "box.obj"
    trimesh.creation.box((1.0, 1.0, 1.0)).export(path)
    return str(path)


def test_depth_maps_with_a_2x1_zigzag_set_shows_both_maps(tmp_path, no_render, capsys, box_file):
    """Was: TypeError from pyvista's Renderers (np.min of an empty column group); the one map left
    after the first row was shown (if at all) instead of the set's two."""
    argv = [box_file, "--theta", "2", "--phi", "1", "--resolution", "8", "--level", "1",
            "--window", "200", "200", "--screenshot", str(tmp_path / "d.png")]
    assert _example("depth_maps").main(argv) == 0
    lines = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("map ")]
    assert [int(ln.split()[1]) for ln in lines] == [0, 1]


def test_depth_maps_with_one_map_is_a_usage_error(tmp_path, no_render, capsys, box_file):
    """Was: the same TypeError traceback (exit status 1) for zigzag 1x1, which has a single map."""
    argv = [box_file, "--theta", "1", "--phi", "1", "--resolution", "8", "--level", "1",
            "--window", "200", "200", "--screenshot", str(tmp_path / "d.png")]
    with pytest.raises(SystemExit) as exc:
        _example("depth_maps").main(argv)
    assert exc.value.code == 2
    assert "has 1 map" in capsys.readouterr().err


def _labels_exact(clim, n_labels, fmt):
    lo, hi = clim
    values = np.linspace(lo, hi, n_labels)
    return max(abs(float(fmt % v) - v) for v in values) <= 1e-9 * max(1.0, hi)


def test_csm_heatmap_colour_bar_labels_are_the_counts_at_their_places(tmp_path, no_render, monkeypatch,
                                                                       box_file):
    """Was: a box seen by 4 maps (1 segment per texel) got the range 0..1 in 5 labels printed
    '%.0f': 0, 0, 0, 1, 1 (0.25 labelled 0, 0.75 labelled 1)."""
    seen = {}
    bar = viz.colour_bar

    def spy(plotter, title, **kw):
        seen.update(kw)
        return bar(plotter, title, **kw)
    monkeypatch.setattr(viz, "colour_bar", spy)
    argv = [box_file, "--theta", "1", "--phi", "4", "--resolution", "8",
            "--window", "200", "200", "--screenshot", str(tmp_path / "h.png")]
    assert _example("csm_heatmap").main(argv) == 0
    assert seen["clim"][1] >= 1.0
    assert _labels_exact(seen["clim"], seen.get("n_labels", 5), seen["fmt"])


@pytest.mark.parametrize("most", [1, 2, 3, 7, 9, 11, 54, 371, 724, 12345])
def test_csm_heatmap_count_range_whole_labels_reaching_the_maximum(most):
    """Was: 7 -> 0..7 in quarters (labels 0, 2, 4, 5, 7 at 0, 1.75, 3.5, 5.25, 7); 54 -> 0..55
    (14 at 13.75, 41 at 41.25). Now whole labels, the top at most 2.5x the maximum."""
    top, n_labels = _example("csm_heatmap").count_range(float(most))
    assert most <= top <= 2.5 * most and 2 <= n_labels <= 6
    assert _labels_exact((0.0, top), n_labels, "%.0f")


def test_moving_bodies_frames_of_a_jpeg_screenshot(tmp_path, no_render, box_file):
    """Was: --screenshot out.jpg --save-frames wrote out.jpg_0000.png, out.jpg_0001.png (the stem was
    cut only after '.png'); now out_0000.png, as the help says (OUT_0000.png)."""
    argv = [box_file, box_file, "--theta", "2", "--phi", "2", "--resolution", "8", "--samples", "1",
            "--ground-divisions", "1", "--frames", "2", "--window", "64", "64",
            "--screenshot", str(tmp_path / "out.jpg"), "--save-frames"]
    assert _example("moving_bodies").main(argv) == 0
    assert sorted(p.name for p in tmp_path.iterdir() if p.suffix == ".png") == ["out_0000.png",
                                                                                  "out_0001.png"]


def test_scene_to_plotter_draws_nan_apart_from_every_grey():
    """Was: NaN vertices drawn (169, 169, 169), the gray map's colour of AO 0.663; now magenta,
    no grey, while 0.25 stays grey 64 and +inf the end colour (white)."""
    scene = pyshadow.Scene(ground=None, views=pyshadow.ViewSet.zigzag(2, 4), resolution=8)
    grid = viz.ground_grid((0.0, 0.0), 2.0, 2)
    gid = scene.add(grid, casts=False)
    V = len(grid.vertices)
    got = {}
    for value in (np.nan, 0.25, np.inf):
        p = viz.make_plotter(window_size=(64, 64), off_screen=True)
        try:
            viz.scene_to_plotter(scene, p, {gid: np.full(V, value, np.float32)}, ground=False,
                                 lighting=False)
            viz.look_at_bodies(p, (0.0, 0.0, 0.0), 0.5, direction=(0.0, 1.0, 0.0))
            p.render()
            got[value] = p.screenshot(return_img=True)[32, 32, :3].astype(int)
        finally:
            p.close()
    nan = got[np.nan]
    assert nan.max() - nan.min() > 100, nan          # far from any grey
    assert np.abs(got[0.25] - 64).max() <= 1
    assert got[np.inf].min() >= 254


def test_lit_scene_frames_of_a_jpeg_screenshot(tmp_path, no_render):
    """Was: --screenshot out.jpg --save-frames wrote out.jpg_0000.png and out.jpg_0001.png."""
    argv = ["--theta", "2", "--phi", "2", "--resolution", "8", "--samples", "1", "--width", "16",
            "--height", "12", "--frames", "2", "--window", "64", "64",
            "--screenshot", str(tmp_path / "out.jpg"), "--save-frames"]
    assert _example("lit_scene").main(argv) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out_0000.png", "out_0001.png"]


@pytest.mark.parametrize("values", [["0.5"] * 9, [None] * 9, [0.5 + 1j] * 9])
def test_update_scalars_refuses_values_that_are_not_real_numbers(values):
    """Was: strings '0.5' and None drawn black (the colour of AO 0) without a word, complex values
    as their real part (a ComplexWarning from pyvista at render time)."""
    poly = viz.mesh_to_polydata(viz.ground_grid((0.0, 0.0), 2.0, 2))
    with pytest.raises(TypeError, match="real numbers"):
        viz.update_scalars(poly, values)


@pytest.mark.parametrize("shape", [(9, 1), (9, 2), (9, 3)])
def test_scene_to_plotter_refuses_per_vertex_columns(shape):
    """Was: AO values of shape (V, 1) drawn as their magnitude (a difference of -0.1 as +0.1;
    0.5 in two columns as 0.71, grey 181 instead of 128)."""
    scene = pyshadow.Scene(ground=None, views=pyshadow.ViewSet.zigzag(2, 4), resolution=8)
    gid = scene.add(viz.ground_grid((0.0, 0.0), 2.0, 2), casts=False)
    p = viz.make_plotter(window_size=(64, 64), off_screen=True)
    try:
        with pytest.raises(ValueError, match=r"must have shape \(9,\)"):
            viz.scene_to_plotter(scene, p, {gid: np.full(shape, -0.1)})
        assert len(p.renderer.actors) == 0
    finally:
        p.close()


def test_make_plotter_follows_pyvista_off_screen_without_a_display(monkeypatch, tmp_path):
    """Was: with pyvista.OFF_SCREEN = True (pyvista's own switch, PYVISTA_OFF_SCREEN=true) and no
    display, make_plotter() raised RuntimeError 'no display: pass --screenshot' -- a script option
    -- instead of making the off-screen plotter pyvista's setting asks for."""
    import pyvista as pv

    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(pv, "OFF_SCREEN", True)
    p = viz.make_plotter(window_size=(32, 32))
    assert p.off_screen
    viz.image_panel(p, np.full((2, 2), 0.25), clim=(0.0, 1.0))
    assert viz.finish(p, tmp_path / "o.png") == str(tmp_path / "o.png")
    assert (tmp_path / "o.png").stat().st_size > 0
