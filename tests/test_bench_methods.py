"""pyshadow-bench --method (pyshadow/bench/methods.py): the methods entry of results.json at tiny
settings, its figures recomputed here from the arrays they come from, and the option errors."""
from __future__ import annotations

import json

import numpy as np
import pytest

from test_bench import TINY, bench

PROBE_R = 32


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A tiny run of every method (repeated and comma-separated --method): (results, stderr)."""
    out = tmp_path_factory.mktemp("methods")
    cache = tmp_path_factory.mktemp("methods-cache")
    p = bench(*TINY, "--method", "csm,ssao", "--method", "cubemap,embree", "--method", "cubemap-horizon,vtk-ssao",
              "--probe-resolution", PROBE_R,
              "--out", out, "--json", cache=cache)
    return json.loads(p.stdout), p.stderr


@pytest.fixture(scope="module")
def tiny_scene():
    """The benchmark's scene, camera and covered pixels at TINY settings, rebuilt here."""
    import pyshadow
    from pyshadow.bench.measure import GBuffer
    from pyshadow.data import default_scene

    scene, cam = default_scene(views=pyshadow.ViewSet.zigzag(8, 16), resolution=32, depth_bits=16,
                               width=64, height=48)
    out = scene.render(cam, sampling=pyshadow.Sampling(8))
    return scene, cam, GBuffer.from_render(out, cam)


def _rows(r):
    return {(row["method"], row["definition"]): row for row in r["methods"]["rows"]}


def _val(f):
    return f["value"]


def _limited_ao(scene, gb, samples, D):
    """Distance-limited Embree AO by pyshadow.embree.visible, one call per pixel run (float32 mean)."""
    import pyshadow
    from pyshadow import embree

    smp = pyshadow.Sampling(samples, "hammersley", 256, 0)
    d = pyshadow.sample_directions(gb.normals, sampling=smp, indices=gb.sel).reshape(-1, 3)
    vis = embree.visible(scene, np.repeat(gb.points, samples, axis=0), d.astype(np.float32), max_distance=D)
    return vis.reshape(gb.n, samples).mean(axis=1).astype(np.float32), vis


def test_rows_and_table(run):
    r, err = run
    assert set(_rows(r)) == {("csm", "unlimited"), ("csm", "limited"), ("cubemap", "limited"),
                             ("cubemap-horizon", "limited"), ("ssao", "limited"), ("vtk-ssao", "limited"),
                             ("embree", "unlimited"), ("embree", "limited")}
    assert [row["method"] for row in r["methods"]["rows"]] == ["csm", "csm", "cubemap", "cubemap-horizon", "ssao",
                                                               "vtk-ssao", "embree", "embree"]
    assert "| cubemap | limited | 8 spp, R 32 |" in err           # the table went to stderr with --json
    share = _val(_rows(r)["csm", "limited"]["embree_share"])    # rays the CSM hands to Embree within D
    assert 0 < share < 1 and "embree_share" not in _rows(r)["csm", "unlimited"]
    for row in r["methods"]["rows"]:       # pyvista's pass renders its own frame: no G-buffer raster added
        raster = 0.0 if row["method"] == "vtk-ssao" else _val(r["methods"]["gbuffer_time"])
        assert _val(row["frame_time"]) == pytest.approx(_val(row["ao_time"]) + raster)
        assert sum(_val(s["pixels"]) for s in row["surfaces"]) == _val(r["figures"]["covered_pixels"])


def test_agreement_figures(run):
    """Embree agrees with itself on every ray; the CSM row is the benchmark's own per-ray pass."""
    r, _ = run
    rows = _rows(r)
    for d in ("unlimited", "limited"):
        assert _val(rows["embree", d]["visibility_agreement"]) == 1.0
        assert _val(rows["embree", d]["false_visible"]) == 0.0
    assert _val(rows["csm", "unlimited"]["visibility_agreement"]) == _val(r["figures"]["visibility_agreement"])
    assert rows["ssao", "limited"]["visibility_agreement"].startswith("n/a")
    by = {s["surface"]: s for s in rows["csm", "unlimited"]["surfaces"]}
    for s in r["surfaces"]:
        assert _val(by[s["surface"]]["visibility_agreement"]) == _val(s["visibility_agreement"])
    # the unlimited CSM row's RMSE vs the unlimited reference is the benchmark's own figure
    assert _val(rows["csm", "unlimited"]["ao_rmse_unlimited"]) == pytest.approx(
        _val(r["figures"]["ao_rmse_converged"]), rel=1e-12)
    cm = rows["cubemap", "limited"]
    a = _val(cm["visibility_agreement"])
    assert a == pytest.approx(1 - _val(cm["false_visible"]) - _val(cm["false_occluded"]), abs=1e-12)


def test_limited_rmse_recomputed(run, tiny_scene):
    """D is the casters' mean bounding radius; the Embree limited row's RMSE vs the limited
    reference equals the RMSE of the two arrays traced here by pyshadow.embree.visible."""
    r, _ = run
    scene, cam, gb = tiny_scene
    D = float(np.mean([scene.instances[i].world_sphere()[1] for i in scene.casters]))
    assert _val(r["methods"]["distance"]) == D
    ao8, _ = _limited_ao(scene, gb, 8, D)
    ref, _ = _limited_ao(scene, gb, 64, D)
    d = ao8.astype(np.float64) - ref
    rows = _rows(r)
    assert _val(rows["embree", "limited"]["ao_rmse_limited"]) == pytest.approx(np.sqrt(np.mean(d * d)), rel=1e-12)
    # the limit's effect: the two converged references differ by this RMSE
    from pyshadow import embree

    import pyshadow

    conv = embree.ambient_occlusion(scene, gb.points, gb.normals, sampling=pyshadow.Sampling(64), indices=gb.sel)
    e = ref.astype(np.float64) - conv
    assert _val(r["methods"]["limit_effect_rmse"]) == pytest.approx(np.sqrt(np.mean(e * e)), rel=1e-6)


def test_ssao_rmse_recomputed(run, tiny_scene):
    """The SSAO row is pyshadow.ssao.screen_space_ao of the camera's G-buffer with radius D."""
    from pyshadow.gbuffer import render_gbuffer
    from pyshadow.ssao import screen_space_ao

    r, _ = run
    scene, cam, gb = tiny_scene
    D = _val(r["methods"]["distance"])
    g = render_gbuffer(scene.draw_items()[0], cam)
    ao = screen_space_ao(g, cam, D, samples=8, seed=0).reshape(-1)[gb.sel]
    ref, _ = _limited_ao(scene, gb, 64, D)
    d = ao.astype(np.float64) - ref
    assert _val(_rows(r)["ssao", "limited"]["ao_rmse_limited"]) == pytest.approx(np.sqrt(np.mean(d * d)),
                                                                                 rel=1e-12)


def test_horizon_and_vtk_rows_recomputed(run, tiny_scene):
    """The horizon row is CubeMapAO(estimator='horizon') projected on the camera (uncovered pixels open);
    the vtk-ssao row is pyshadow.viz.ssao_pass.vtk_ssao with radius D and kernel size = samples (VTK's
    pass is deterministic: two renders give the same image). Neither answers rays."""
    from pyshadow.cubemap import CubeMapAO
    from pyshadow.gbuffer import render_gbuffer
    from pyshadow.viz.ssao_pass import vtk_ssao

    r, _ = run
    scene, cam, gb = tiny_scene
    D = _val(r["methods"]["distance"])
    ref, _ = _limited_ao(scene, gb, 64, D)
    rows = _rows(r)
    maps = CubeMapAO(scene, D, resolution=PROBE_R, estimator="horizon")
    maps.place(cam)
    g = render_gbuffer(scene.draw_items()[0], cam)
    pr = maps.project(cam, gbuffer=g, fallback=1.0, on_empty="fallback")
    for name, ao in (("cubemap-horizon", pr.ao.reshape(-1)[gb.sel]),
                     ("vtk-ssao", vtk_ssao(scene, cam, D, kernel_size=8).ao.reshape(-1)[gb.sel])):
        d = np.asarray(ao, np.float32).astype(np.float64) - ref
        assert _val(rows[name, "limited"]["ao_rmse_limited"]) == pytest.approx(np.sqrt(np.mean(d * d)),
                                                                                rel=1e-9), name
        assert rows[name, "limited"]["visibility_agreement"].startswith("n/a")
    assert _val(rows["cubemap-horizon", "limited"]["coverage"]) == pytest.approx(pr.coverage)
    assert _val(rows["vtk-ssao", "limited"]["memory"]) == 0


def test_memory_and_precompute(run):
    r, _ = run
    rows = _rows(r)
    # one probe: 33 bytes a texel of maps (pyshadow.cubemap.CubeProbe) + 4 of float32 AO, six R x R faces
    assert _val(rows["cubemap", "limited"]["memory"]) == 37 * 6 * PROBE_R ** 2
    assert rows["cubemap", "limited"]["setting"]["probes"] == 1
    assert _val(rows["cubemap", "limited"]["precompute_time"]) > 0
    assert 0.5 < _val(rows["cubemap", "limited"]["coverage"]) <= 1.0
    assert _val(rows["csm", "unlimited"]["memory"]) == _val(r["figures"]["csm_bytes"])
    assert _val(rows["ssao", "limited"]["memory"]) == 0


@pytest.mark.parametrize("argv, message", [
    (["--method", "csm,raytrace"], "unknown method raytrace"),
    (["--method", ","], "unknown method"),
    (["--method", "csm", "--ao-distance", "0"], "must be finite and > 0"),
    (["--method", "csm", "--ao-distance", "-1.5"], "must be finite and > 0"),
    (["--method", "csm", "--ao-distance", "inf"], "must be finite and > 0"),
    (["--ao-distance", "1"], "--ao-distance needs --method"),
    (["--method", "ssao", "--max-error", "0.05"], "for the single benchmark and --sweep"),
    (["--method", "cubemap", "--probe-resolution", "8"], "--probe-resolution"),
])
def test_option_errors(argv, message, capsys, tmp_path):
    from pyshadow.bench.cli import main

    with pytest.raises(SystemExit) as e:
        main([*argv, "--out", str(tmp_path), "--no-cache"])
    assert e.value.code == 2
    assert message in capsys.readouterr().err


def test_default_has_no_methods():
    from pyshadow.bench.cli import build_parser
    from pyshadow.bench.methods import selected_methods

    a = build_parser().parse_args([])
    assert a.method is None and a.ao_distance is None
    a = build_parser().parse_args(["--method", "embree,ssao", "--method", "ssao,csm-vote"])
    assert selected_methods(a.method) == ["csm-vote", "ssao", "embree"]


def test_limited_reference_recomputes_an_impossible_cached_array(tiny_scene, tmp_path):
    """A cached distance-limited reference holding NaN (valid checksum) is traced again and replaced."""
    from pyshadow.bench.methods import limited_reference
    from pyshadow.cache import CSMCache
    from pyshadow.embree import EmbreeTracer

    scene, _, gb = tiny_scene
    cache, notes, D = CSMCache(tmp_path), [], 0.5
    fresh, _ = _limited_ao(scene, gb, 8, D)
    tracer = EmbreeTracer(scene, 1)
    try:
        def ref():
            return limited_reference(cache, tracer, scene, gb, D, 8, "hammersley", 0, 256, notes.append)

        ao, _, source = ref()
        assert source == "computed" and np.array_equal(ao, fresh)
        (path,) = (tmp_path / "reference").glob("*.npz")
        cache.put_array(path.stem, np.full(gb.n, np.nan, np.float32))    # poisoned, checksum valid
        notes.clear()
        ao, seconds, source = ref()
        assert source == "computed" and seconds is not None and np.array_equal(ao, fresh)
        assert notes[0] == (f"cache: reference/{path.name} is not a possible AO of {gb.n} pixels "
                            f"({gb.n} of {gb.n} values are not finite); recomputing it")
        assert np.array_equal(cache.array(path.stem), fresh)                 # rewritten
        assert ref()[2] == "cached"
    finally:
        tracer.close()
