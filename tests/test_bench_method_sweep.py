"""pyshadow-bench --sweep --method (pyshadow/bench/method_sweep.py): every method on the sweep's axes,
its points tied to the sweep's own rows, the winners recomputed, and pyvista's SSAO pass itself."""
from __future__ import annotations

import json

import numpy as np
import pytest

from test_bench import TINY, bench

METHODS = "csm,ssao,cubemap-horizon,vtk-ssao,embree"


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    out = tmp_path_factory.mktemp("method-sweep")
    cache = tmp_path_factory.mktemp("method-sweep-cache")
    p = bench(*TINY, "--sweep", "--sweep-grid", "tiny", "--method", METHODS, "--probe-resolution", "32",
              "--out", out, "--json", cache=cache)
    return json.loads(p.stdout), out


def test_points_cover_every_method_and_setting(sweep):
    sw, _ = sweep
    m = sw["methods"]
    samples = sorted({r["config"]["samples"] for r in sw["rows"]})
    assert samples == [4, 8] and m["probe_resolutions"] == [16, 32, 64]
    got = {(p["label"], p["setting"]) for p in m["points"]}
    want = {(lab, str(s)) for lab in ("csm", "csm D", "ssao", "vtk-ssao", "embree", "embree D") for s in samples}
    want |= {("cubemap-horizon", f"R{r}") for r in (16, 32, 64)}
    assert got == want and len(m["points"]) == len(want)


def test_csm_points_are_the_sweeps_rows(sweep):
    """The csm method at a sweep row's samples and base CSMs gives that row's AO: the same RMSE, to the bit."""
    sw, _ = sweep
    rows = {r["label"]: r for r in sw["rows"]}
    pts = {(p["label"], p["samples"]): p for p in sweep[0]["methods"]["points"]}
    for label, s in (("8x16 r32 16b s8", 8), ("8x16 r32 16b s4", 4)):
        assert pts["csm", s]["rmse_unlimited"] == rows[label]["figures"]["ao_rmse_converged"]["value"]
    # the limited reference differs from the unlimited one: the limited rows are closer to it
    for s in (4, 8):
        assert pts["csm D", s]["rmse_limited"] < pts["csm", s]["rmse_limited"]
        assert pts["embree D", s]["rmse_limited"] < pts["embree", s]["rmse_limited"]


def _fastest(pts, key, target):
    ok = [p for p in pts if p[key] is not None and p[key] <= target]
    return min(ok, key=lambda p: p["frame_time"]) if ok else None


def test_winners_recomputed(sweep):
    """Limited: the fastest method point within each target. Unlimited: the same over the method points
    and the sweep's CSM rows together."""
    sw, _ = sweep
    m = sw["methods"]
    csm_rows = [{"label": f"csm {r['label']}", "frame_time": r["figures"]["frame_time"]["value"],
                 "rmse_unlimited": r["figures"]["ao_rmse_converged"]["value"]} for r in sw["rows"]]
    for key, pool in (("rmse_limited", m["points"]), ("rmse_unlimited", m["points"] + csm_rows)):
        w = m[f"winners_{key[5:]}"]
        assert [x["target"] for x in w] == [0.01, 0.02, 0.03, 0.05, 0.1, 0.2]
        for x in w:
            best = _fastest(pool, key, x["target"])
            if best is None:
                assert x["winner"] is None
            else:
                assert (x["winner"]["label"], x["winner"]["frame_time"]) == (best["label"], best["frame_time"])
    assert any(x["winner"] for x in m["winners_limited"])


def test_markdown_and_two_panel_plot(sweep):
    import pyshadow

    sw, out = sweep
    md = (out / "sweep.md").read_text()
    assert "## Methods" in md and "| cubemap-horizon | R64 |" in md and "| vtk-ssao | 8 |" in md
    assert "(limited reference)" in md and "(unlimited reference)" in md
    png = pyshadow.read_image(out / "pareto.png")
    assert png.shape[1] > 2 * png.shape[0] and float(np.var(png)) > 1e-4     # two panels side by side


def test_sweep_probe_resolutions_clip_to_the_valid_range():
    from pyshadow.bench.method_sweep import sweep_probe_resolutions

    assert sweep_probe_resolutions(128) == [64, 128, 256]
    assert sweep_probe_resolutions(16) == [16, 32]
    assert sweep_probe_resolutions(2048) == [1024, 2048]


# ---------------------------------------------------------------------------
# pyvista's SSAO pass as an AO image
# ---------------------------------------------------------------------------
def _wall_scene():
    """Ground at y = 0 and a 4 x 2 x 0.5 box wall whose front face is the plane z = 0."""
    import trimesh

    import pyshadow

    wall = trimesh.creation.box((4.0, 2.0, 0.5))
    scene = pyshadow.Scene(ground=0.0)
    T = np.eye(4)
    T[:3, 3] = (0.0, 1.0, -0.25)
    scene.add(wall, T, casts=False)
    cam = pyshadow.Camera([0.0, 1.6, 3.0], [0.0, 0.3, 0.0], fov_y=50.0, width=96, height=72)
    return scene, cam


def test_vtk_ssao_darkens_towards_the_wall_and_self_occludes_planes():
    """In front of a wall the pass's AO rises with the distance from the wall's foot (the closed form
    rises from 0.5 at the foot to 1 at D). VTK's default-like bias (0.02 D) self-occludes an open plane:
    the floor farther than 1.5 D reads about 0.92 (measured); a bias of 0.2 D lifts it to 1 within one
    8-bit step, so ``bias`` reaches the pass."""
    from pyshadow.render import surface_points
    from pyshadow.viz.ssao_pass import vtk_ssao

    scene, cam = _wall_scene()
    D = 0.5
    sp = surface_points(scene, cam)
    pos = np.asarray(sp.gbuffer["position"], np.float64).reshape(-1, 3)
    floor = (np.asarray(sp.object_id).reshape(-1) == -2) & (np.abs(pos[:, 0]) < 1.5)
    bins = [(0.0, 0.05), (0.05, 0.25), (0.25, 0.5), (0.75, 1.5), (1.5, 9.0)]
    masks = [floor & (pos[:, 2] >= lo * D) & (pos[:, 2] < hi * D) for lo, hi in bins]
    assert min(m.sum() for m in masks) > 50
    r = vtk_ssao(scene, cam, D, kernel_size=64)
    assert r.ao.shape == (72, 96) and r.render_s > 0
    med = [float(np.median(r.ao.reshape(-1)[m])) for m in masks]
    assert all(a < b for a, b in zip(med, med[1:])), med          # measured 0.54 .. 0.92
    assert med[0] < 0.65 and 0.85 < med[-1] < 1 - 2 / 255, med
    lifted = vtk_ssao(scene, cam, D, kernel_size=64, bias=0.2 * D).ao.reshape(-1)
    assert np.median(lifted[masks[-1]]) >= 1 - 1 / 255


@pytest.mark.parametrize("kw, message", [({"radius": 0.0}, "radius"), ({"radius": np.inf}, "radius"),
                                         ({"radius": 1.0, "kernel_size": 0}, "kernel_size")])
def test_vtk_ssao_bad_input(kw, message):
    from pyshadow.viz.ssao_pass import vtk_ssao

    scene, cam = _wall_scene()
    with pytest.raises(ValueError, match=message):
        vtk_ssao(scene, cam, **kw)
