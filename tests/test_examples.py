"""The example scripts, run as subprocesses at tiny size, and the pyvista glue they share.

Every script in examples/ is run off screen (``--screenshot``) with a few
maps, 32^2 texels, few samples and a 400x300 window, and its PNG is checked
for content (see :func:`image_stats`). pyvista renders only in those
subprocesses; this process imports it for the PolyData checks alone.
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import viz
from pyshadow.io import linear_to_srgb

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "examples"
TINY_MAPS = ["--theta", "8", "--phi", "16", "--resolution", "32"]
WINDOW = ["--window", "400", "300"]
SCRIPTS = ["ao_mesh.py", "depth_maps.py", "csm_heatmap.py", "moving_bodies.py", "ao_image.py",
           "lit_scene.py"]

# Content thresholds for a screenshot (8-bit sRGB, background viz.BACKGROUND).
# A window holding nothing but a title and a full-width colour bar -- what a
# script draws when its data panels come out empty -- has 4 % non-background
# pixels (test_image_checks_reject_empty_and_flat_windows); the tiny
# screenshots of the scripts have 24-70 %. Each data panel must be at least
# 5 % covered (the tiny ones: 11-57 %).
MIN_SHARE, MAX_SHARE = 0.10, 0.90
MIN_PANEL_SHARE = 0.05
# Standard deviation of the grey level over the non-background pixels of the
# data panels (titles and colour bars excluded): one flat colour -- an
# unshaded fill, or every value clipped to one end of the colour range --
# gives 0.012 (anti-aliased edges only); the scripts' AO, depth and heat maps
# give 0.14-0.21. The floor, 0.04, is about 10 grey levels.
MIN_CONTENT_STD = 0.04


def run_script(name, *args, timeout=300):
    cmd = [sys.executable, str(EXAMPLES / name), *map(str, args)]
    return subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=timeout)


def run_ok(name, *args):
    res = run_script(name, *args)
    assert res.returncode == 0, f"{name} failed ({res.returncode}):\n{res.stdout}\n{res.stderr}"
    return res.stdout


def background_rgb() -> np.ndarray:
    h = viz.BACKGROUND.lstrip("#")
    return np.array([int(h[i:i + 2], 16) for i in (0, 2, 4)], dtype=np.float64)


def read_png(path) -> np.ndarray:
    """A PNG as 8-bit sRGB values (H, W, 3) float64, through pyshadow.read_image."""
    img = pyshadow.read_image(path)
    assert img.ndim == 3 and img.shape[2] in (3, 4), img.shape
    return np.round(linear_to_srgb(img[..., :3]) * 255.0)


def image_stats(rgb: np.ndarray) -> dict:
    """Share of pixels that differ from the background and grey-level spread among them."""
    rgb = rgb.reshape(-1, 3)
    differ = np.abs(rgb - background_rgb()).max(axis=-1) > 3
    grey = rgb.mean(axis=-1) / 255.0
    return {"share": float(differ.mean()),
            "content_std": float(grey[differ].std()) if differ.any() else 0.0}


def panel_pixels(rgb, box):
    r0, r1, c0, c1 = box
    H, W = rgb.shape[:2]
    return rgb[int(r0 * H):int(r1 * H), int(c0 * W):int(c1 * W)].reshape(-1, 3)


def assert_content(path, panels):
    """Check a screenshot; ``panels`` are (row0, row1, col0, col1) fractions holding data."""
    rgb = read_png(path)
    s = image_stats(rgb)
    assert MIN_SHARE <= s["share"] <= MAX_SHARE, f"{path}: {s}"
    for box in panels:
        share = image_stats(panel_pixels(rgb, box))["share"]
        assert share >= MIN_PANEL_SHARE, f"{path}: panel {box} is empty ({share:.3f})"
    inside = image_stats(np.concatenate([panel_pixels(rgb, b) for b in panels]))
    assert inside["content_std"] >= MIN_CONTENT_STD, f"{path}: flat panels {inside}"
    return s


def number(pattern, text):
    m = re.search(pattern, text)
    assert m, f"{pattern!r} not in output:\n{text}"
    return float(m.group(1))


# ---------------------------------------------------------------------------
# the scripts
# ---------------------------------------------------------------------------
@pytest.mark.slow
def test_ao_mesh_screenshot(tmp_path):
    png = tmp_path / "ao_mesh.png"
    out = run_ok("ao_mesh.py", *TINY_MAPS, "--samples", "16", "--ground-divisions", "16",
                 *WINDOW, "--screenshot", png)
    # pyshadow and Embree trace the same directions: they agree up to the CSM's discretisation
    assert number(r"mean \|diff\| ([0-9.]+)", out) < 0.05
    top = 1.0 / 1.13                                  # three 3-D panels above the colour bars
    assert_content(png, [(0.1, top, k / 3, (k + 1) / 3) for k in range(3)])


@pytest.mark.slow
def test_depth_maps_screenshot(tmp_path):
    png = tmp_path / "depth_maps.png"
    out = run_ok("depth_maps.py", "--maps", "2", "--resolution", "32", "--theta", "8", "--phi", "16",
                 "--level", "2", *WINDOW, "--screenshot", png)
    covers = [float(v) for v in re.findall(r"layer 1 covers ([0-9.]+)%", out)]
    assert len(covers) == 2 and all(5.0 < c < 90.0 for c in covers), out
    w = np.cumsum([0.0, 1.0, 1.0, 0.2, 1.6, 0.2]) / 4.0   # row weights of the script's layout
    panels = [(w[r], w[r + 1], c / 2, (c + 1) / 2) for r in (0, 1) for c in (0, 1)]   # depth
    panels += [(w[3], w[4], 0.0, 0.5), (w[3], w[4], 0.5, 1.0)]                        # spheres
    assert_content(png, panels)


@pytest.mark.slow
def test_csm_heatmap_screenshot(tmp_path):
    png = tmp_path / "csm_heatmap.png"
    out = run_ok("csm_heatmap.py", *TINY_MAPS, *WINDOW, "--screenshot", png)
    assert number(r"ratio ([0-9.]+):1", out) > 1.0
    silhouette = number(r"silhouette: \d+ texels \((\d+)%\)", out)
    assert 20 < silhouette < 100
    assert_content(png, [(0.1, 0.85, 0.1, 0.9)])


@pytest.mark.slow
def test_moving_bodies_frames(tmp_path):
    png = tmp_path / "moving.png"
    out = run_ok("moving_bodies.py", *TINY_MAPS, "--samples", "8", "--ground-divisions", "16",
                 "--frames", "3", "--save-frames", *WINDOW, "--screenshot", png)
    assert number(r"AO frames per second: ([0-9.]+)", out) > 0.0
    frames = [tmp_path / f"moving_{k:04d}.png" for k in range(3)]
    assert all(f.is_file() for f in frames)
    assert_content(png, [(0.1, 0.9, 0.0, 1.0)])
    first, last = read_png(frames[0]), read_png(frames[-1])
    # the bodies moved between the frames, and out.png is the last frame
    assert np.abs(first - last).mean() > 1.0
    assert np.array_equal(read_png(png), last)


INTERACTIVE_HARNESS = """
import sys
sys.dont_write_bytecode = True           # no __pycache__ inside examples/
sys.path.insert(0, sys.argv[2])
import numpy as np
import moving_bodies
from pyshadow import viz

make = viz.plotter.make_plotter

def offscreen(*args, **kwargs):          # the interactive window, drawn off screen
    kwargs["off_screen"] = True
    return make(*args, **kwargs)

def drive(plotter, screenshot=None, **kwargs):   # instead of show(): press keys, drag a slider
    assert screenshot is None
    before = plotter.screenshot(None, return_img=True).copy()
    iren = plotter.iren.interactor
    for key in ("Right", "Up", "Up"):
        iren.SetKeySym(key)
        iren.InvokeEvent("KeyPressEvent")
    turn = plotter.widgets.slider_widgets[1].GetRepresentation().GetValue()
    angle = plotter.widgets.slider_widgets[0]
    angle.GetRepresentation().SetValue(120.0)
    angle.InvokeEvent("InteractionEvent")
    viz.save_screenshot(plotter, sys.argv[1])
    after = plotter.screenshot(None, return_img=True)
    changed = (np.abs(after.astype(int) - before).max(axis=-1) > 3).mean()
    print(f"turn slider {turn:.1f}; changed {changed:.3f}")
    plotter.close()

viz.plotter.make_plotter, viz.finish = offscreen, drive    # the one script_plotter calls
moving_bodies.main(["--theta", "8", "--phi", "16", "--resolution", "32", "--samples", "8",
                    "--ground-divisions", "16", "--window", "400", "300"])
"""


@pytest.mark.slow
def test_moving_bodies_interactive_controls(tmp_path):
    """The interactive path: arrow keys and the sliders move the first body and redraw its AO."""
    png = tmp_path / "interactive.png"
    res = subprocess.run([sys.executable, "-c", INTERACTIVE_HARNESS, str(png), str(EXAMPLES)],
                         cwd=REPO, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stdout + res.stderr
    assert number(r"turn slider ([-0-9.]+)", res.stdout) == 20.0     # two Up presses, synced
    assert number(r"changed ([0-9.]+)", res.stdout) > 0.01
    assert_content(png, [(0.1, 0.75, 0.0, 1.0)])


@pytest.mark.slow
def test_ao_image_screenshot(tmp_path):
    png = tmp_path / "ao_image.png"
    out = run_ok("ao_image.py", "--width", "80", "--height", "60", "--samples", "8", *TINY_MAPS,
                 *WINDOW, "--screenshot", png)
    assert number(r"raw ([0-9.]+)", out) < 0.06
    top = 2.0 / 2.14
    assert_content(png, [(0.08, top / 2, 0.0, 0.5), (0.08, top / 2, 0.5, 1.0),
                         (top / 2 + 0.08, top, 0.0, 0.5), (top / 2 + 0.08, top, 0.5, 1.0)])


@pytest.mark.slow
def test_lit_scene_frames(tmp_path):
    png = tmp_path / "lit.png"
    out = run_ok("lit_scene.py", "--width", "80", "--height", "60", "--samples", "8", *TINY_MAPS,
                 "--frames", "3", "--save-frames", *WINDOW, "--screenshot", png)
    assert number(r"lit frames per second: ([0-9.]+)", out) > 0.0
    assert number(r"sun at ([0-9.]+) deg elevation", out) > 10.0
    frames = [tmp_path / f"lit_{k:04d}.png" for k in range(3)]
    assert all(f.is_file() for f in frames)
    first, last = read_png(frames[0]), read_png(frames[-1])
    assert first.shape == (60, 80, 3)
    assert float(first.std()) > 10.0                      # lit and shadowed surfaces, not one grey
    assert np.abs(first - last).mean() > 1.0              # the bunny moved between the frames
    assert_content(png, [(0.1, 0.95, 0.0, 0.5), (0.1, 0.95, 0.5, 1.0)])


@pytest.mark.parametrize("name", ["ao_mesh.py", "depth_maps.py", "csm_heatmap.py",
                                  "moving_bodies.py"])
def test_examples_missing_mesh_is_a_usage_error(tmp_path, name):
    missing = tmp_path / "no_such_mesh.obj"
    res = run_script(name, missing, "--screenshot", tmp_path / "x.png", timeout=120)
    assert res.returncode == 2, res.stderr
    assert "mesh file not found" in res.stderr and str(missing) in res.stderr
    assert not (tmp_path / "x.png").exists()


def test_examples_have_title_argparse_and_main_guard():
    for name in SCRIPTS:
        text = (EXAMPLES / name).read_text()
        assert text.startswith("# "), name
        assert "argparse" in text and "--screenshot" in text, name
        assert "def main(argv=None)" in text and 'if __name__ == "__main__":' in text, name


def test_image_checks_reject_empty_and_flat_windows(tmp_path):
    """What a script draws when its data come out empty, or all one value, fails the checks."""
    code = ("import sys, numpy as np, trimesh; from pyshadow import viz\n"
            "for path, flat in ((sys.argv[1], False), (sys.argv[2], True)):\n"
            "    p = viz.make_plotter((2, 1), (400, 300), off_screen=True, row_weights=[1, 0.1])\n"
            "    p.subplot(0, 0); viz.add_title(p, 'frame 3/3: AO of 38271 vertices, 8 samples')\n"
            "    if flat:\n"
            "        m = viz.mesh_to_polydata(trimesh.creation.icosphere(), scalars=np.ones(642))\n"
            "        p.add_mesh(m, scalars='ao', cmap='gray', clim=(0, 1), lighting=False,\n"
            "                   show_scalar_bar=False)\n"
            "    p.subplot(1, 0); viz.colour_bar(p, 'ambient occlusion (1 = open)')\n"
            "    viz.finish(p, path)\n")
    empty, flat = tmp_path / "empty.png", tmp_path / "flat.png"
    res = subprocess.run([sys.executable, "-c", code, str(empty), str(flat)], cwd=REPO,
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    s = image_stats(read_png(empty))
    assert 0.0 < s["share"] < MIN_SHARE, s
    rgb = read_png(flat)
    assert image_stats(rgb)["share"] >= MIN_SHARE                 # passes the coverage test ...
    inside = image_stats(panel_pixels(rgb, (0.1, 0.85, 0.0, 1.0)))
    assert inside["share"] >= MIN_PANEL_SHARE
    assert inside["content_std"] < MIN_CONTENT_STD, inside        # ... but not the spread test


# ---------------------------------------------------------------------------
# pyshadow.viz
# ---------------------------------------------------------------------------
def test_viz_imports_without_pyvista():
    code = ("import sys\n"
            "sys.modules['pyvista'] = None\n"          # import pyvista now raises ImportError
            "import pyshadow, pyshadow.viz as viz\n"
            "assert 'vtk' not in sys.modules and 'vtkmodules' not in sys.modules\n"
            "h = viz.ground_grid(divisions=2)\n"
            "try:\n"
            "    viz.make_plotter(off_screen=True)\n"
            "except ImportError as exc:\n"
            "    print('ImportError:', exc)\n")
    res = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 0, res.stderr
    assert "ImportError: pyshadow.viz needs pyvista" in res.stdout


def test_segment_heatmap_masks_exactly_the_never_hit_texels():
    mesh = trimesh.creation.box((1.0, 0.4, 0.7))
    views = pyshadow.ViewSet.zigzag(4, 8)
    csm = pyshadow.CoherentShadowMap.build(mesh, views, resolution=16, progress=False)
    heat = viz.segment_heatmap(csm)
    depth = pyshadow.render_depth(mesh, views, resolution=16, layers=1)
    never_hit = ~np.isfinite(depth[:, 0]).any(axis=0)
    assert never_hit.any() and (~never_hit).any()          # both kinds of texel occur
    assert np.array_equal(np.isnan(heat), never_hit)
    assert np.array_equal(heat[~never_hit], csm.texel_segment_counts()[~never_hit])
    assert heat[~never_hit].max() > 1


def test_segment_heatmap_rejects_other_objects():
    with pytest.raises(TypeError, match="CoherentShadowMap"):
        viz.segment_heatmap(np.ones((4, 4)))


def test_view_set_points_follow_the_order():
    views = pyshadow.ViewSet.hilbert(2)
    pts = viz.view_set_points(views, radius=2.0)
    D = len(views)
    assert pts.n_points == D
    np.testing.assert_allclose(np.linalg.norm(pts.points, axis=1), 2.0, rtol=1e-6)
    np.testing.assert_allclose(pts.points, 2.0 * views.directions, rtol=1e-6)
    order = np.asarray(pts.point_data["order"])
    assert order[0] == 0.0 and order[-1] == 1.0 and (np.diff(order) > 0).all()
    assert list(pts.lines) == [D, *range(D)]               # one polyline in map order


def test_mesh_to_polydata_transform_and_scalars():
    mesh = trimesh.creation.icosphere(subdivisions=1)
    T = trimesh.transformations.rotation_matrix(0.7, [0, 0, 1])
    T[:3, :3] *= 2.0
    T[:3, 3] = [1.0, 2.0, 3.0]
    ao = np.linspace(0.0, 1.0, len(mesh.vertices))
    poly = viz.mesh_to_polydata(mesh, T, ao)
    np.testing.assert_allclose(poly.points, mesh.vertices @ T[:3, :3].T + T[:3, 3], atol=1e-6)
    np.testing.assert_allclose(poly.point_data["ao"], ao)
    n = np.asarray(poly.point_data["Normals"])
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-5)
    assert poly.n_cells == len(mesh.faces)
    with pytest.raises(ValueError, match="values"):
        viz.update_scalars(poly, ao[:-1])
    with pytest.raises(TypeError, match="trimesh"):
        viz.mesh_to_polydata(poly)


def test_stand_on_ground_and_ground_grid():
    mesh = trimesh.creation.box((2.0, 1.0, 1.0))
    T = viz.stand_on_ground(mesh, radius=0.5, position=(3.0, -1.0), rotation=np.eye(3))
    w = mesh.vertices @ T[:3, :3].T + T[:3, 3]
    assert abs(w[:, 1].min()) < 1e-12
    np.testing.assert_allclose(w[:, [0, 2]].mean(axis=0), [3.0, -1.0], atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(w - w.mean(axis=0), axis=1).max(), 0.5, rtol=1e-6)
    grid = viz.ground_grid((1.0, 2.0), 4.0, 8, height=0.5)
    assert len(grid.vertices) == 81 and len(grid.faces) == 128
    assert np.allclose(grid.face_normals, [0.0, 1.0, 0.0])
    assert np.allclose(grid.vertices[:, 1], 0.5)
    with pytest.raises(ValueError, match="divisions"):
        viz.ground_grid(divisions=0)


def test_configure_offscreen_keeps_a_users_choice(monkeypatch):
    monkeypatch.setenv("VTK_DEFAULT_OPENGL_WINDOW", "vtkOSOpenGLRenderWindow")
    assert viz.configure_offscreen() == "vtkOSOpenGLRenderWindow"
    monkeypatch.delenv("VTK_DEFAULT_OPENGL_WINDOW")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(viz.ctypes.util, "find_library", lambda name: None)
    if sys.platform == "linux":
        with pytest.raises(RuntimeError, match="libegl1"):
            viz.configure_offscreen()
        assert "VTK_DEFAULT_OPENGL_WINDOW" not in os.environ
