"""pyshadow-bench (pyshadow/bench/): the CLI run as a subprocess at tiny settings,
its use of the cache, outputs and errors, and the helpers it measures with.

The cache itself is tested in test_cache.py, the threaded Embree tracer in test_embree.py."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from conftest import mesh_path

TINY = ["--maps", "8x16", "--resolution", "32", "--size", "64x48", "--samples", "8",
        "--reference-samples", "64", "--repeats", "1"]


def bench(*args, cache=None, env_cache=None, check=True):
    """Run ``python -m pyshadow.bench`` and return the CompletedProcess."""
    env = dict(os.environ)
    env.pop("PYSHADOW_CACHE", None)
    if env_cache is not None:
        env["PYSHADOW_CACHE"] = str(env_cache)
    cmd = [sys.executable, "-m", "pyshadow.bench", *map(str, args)]
    if cache is not None:
        cmd += ["--cache-dir", str(cache)]
    p = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)
    if check and p.returncode != 0:
        raise AssertionError(f"{cmd} failed ({p.returncode}):\n{p.stderr[-3000:]}")
    return p


@pytest.fixture(scope="module")
def cache_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("cache")


@pytest.fixture(scope="module")
def first(tmp_path_factory, cache_dir):
    """A cold run with --json: (parsed stdout, output dir, process)."""
    out = tmp_path_factory.mktemp("out1")
    p = bench(*TINY, "--out", out, "--json", cache=cache_dir)
    return json.loads(p.stdout), out, p


@pytest.fixture(scope="module")
def second(tmp_path_factory, cache_dir, first):
    """The same run again, the cache given through $PYSHADOW_CACHE."""
    out = tmp_path_factory.mktemp("out2")
    files = sorted(cache_dir.rglob("*.csm"))
    before = {f: f.stat().st_mtime_ns for f in files}
    p = bench(*TINY, "--out", out, "--json", env_cache=cache_dir)
    return json.loads(p.stdout), out, p, before


# ---------------------------------------------------------------------------
# the single benchmark
# ---------------------------------------------------------------------------
def test_bench_json_stdout_is_results_json(first):
    result, out, p = first
    assert json.loads((out / "results.json").read_text()) == result
    assert p.stdout.lstrip().startswith("{") and p.stdout.rstrip().endswith("}")
    assert "visibility agreement" in p.stderr          # the table went to stderr
    assert result["schema"] == "pyshadow-bench/1"
    assert result["mode"] == "custom"
    assert result["config"]["width"] == 64 and result["config"]["height"] == 48
    assert result["config"]["samples"] == 8 and result["config"]["maps"] == "8x16"


def test_bench_filtered_lookup_run(first, cache_dir, tmp_path):
    """--filtered-lookup: the same CSMs (from the cache) asked by filtered lookups
    in render, AO and the per-ray comparison; more rays agree with Embree (the
    tiny sweep's filtered_lookup row measures +0.24 points on these rays)."""
    base, _, _ = first
    p = bench(*TINY, "--filtered-lookup", "--out", tmp_path, "--json", cache=cache_dir)
    r = json.loads(p.stdout)
    assert r["mode"] == "custom" and r["config"]["filtered_lookup"] is True
    assert base["config"]["filtered_lookup"] is False
    assert r["csm"]["source"] == "cached"
    assert r["checks"]["ao_equals_render"]
    f, f0 = ({k: v["value"] for k, v in x["figures"].items()} for x in (r, base))
    assert f["csm_bytes"] == f0["csm_bytes"]
    assert f["visibility_agreement"] > f0["visibility_agreement"]
    assert "filtered lookups" in p.stderr


def test_bench_every_figure_has_value_and_unit(first):
    result, _, _ = first
    expected = {"csm_build_time", "csm_time", "csm_size", "csm_bytes", "csm_ratio", "covered_pixels",
                "frame_time", "ao_time", "ao_throughput", "embree_time", "embree_throughput",
                "embree_ray_rate", "speedup", "visibility_agreement", "ao_rmse_identical",
                "ao_mae_identical", "ao_rmse_converged", "ao_mae_converged", "reference_noise_rmse",
                "converged_time", "total_time"}
    figs = result["figures"]
    assert expected <= set(figs)
    for name, f in figs.items():
        assert set(f) == {"value", "unit", "label"}, name
        assert isinstance(f["unit"], str) and f["unit"], name
    assert figs["frame_time"]["unit"] == "s" and figs["ao_throughput"]["unit"] == "Msamples/s"
    assert figs["embree_ray_rate"]["unit"] == "Mrays/s"


def test_bench_figures_plausible(first):
    result, _, _ = first
    f = {k: v["value"] for k, v in result["figures"].items()}
    assert 0.9 < f["visibility_agreement"] <= 1.0
    assert f["false_visible"] + f["false_occluded"] == pytest.approx(1.0 - f["visibility_agreement"])
    for k in ("ao_rmse_identical", "ao_mae_identical", "ao_rmse_converged", "ao_mae_converged"):
        assert 0.0 <= f[k] < 0.25, k
        assert f[k.replace("mae", "rmse")] >= f[k.replace("rmse", "mae")] - 1e-12
    assert f["csm_ratio"] > 1.0
    assert f["csm_bytes"] == sum(c["bytes"]["value"] for c in result["csm"]["casters"])
    assert f["covered_pixels"] == 64 * 48                  # the default camera sees no sky
    assert f["ao_samples"] == 8 * f["covered_pixels"]
    assert 0 < f["embree_rays"] <= f["ao_samples"]
    assert f["frame_time"] > 0 and f["ao_time"] > 0 and f["embree_time"] > 0
    assert f["speedup"] == pytest.approx(f["ao_throughput"] / f["embree_throughput"], rel=1e-6)
    assert f["primary_agreement"] > 0.95
    assert result["csm"]["source"] == "built"
    assert [c["name"] for c in result["csm"]["casters"]] == ["bunny", "torus"]
    # per surface: the pixels and rays add up to the whole
    surf = result["surfaces"]
    assert {"ground", "bunny", "torus", "back_wall"} <= {x["surface"] for x in surf}
    px = [x["pixels"]["value"] for x in surf]
    assert sum(px) == f["covered_pixels"]
    agree = sum(x["visibility_agreement"]["value"] * n for x, n in zip(surf, px)) / sum(px)
    assert agree == pytest.approx(f["visibility_agreement"], abs=1e-9)
    for x in surf:
        assert -0.25 < x["ao_bias_identical"]["value"] < 0.25
        assert x["ao_rmse_identical"]["value"] >= abs(x["ao_bias_identical"]["value"]) - 1e-9
    # the AO kernel and per-ray visibility agree (at most one ray of a pixel apart)
    assert result["checks"]["ao_equals_render"]
    assert result["checks"]["ao_vs_visible_max_abs"] <= 1.0 / 8 + 1e-6


def test_bench_images_written_and_not_blank(first):
    import pyshadow

    result, out, _ = first
    for name in ("ao.png", "reference.png", "difference.png", "ao.exr", "reference.exr",
                 "converged.exr"):
        assert (out / name).is_file(), name
        assert result["files"][name] == str(out / name)
    ao = pyshadow.read_image(out / "ao.png")
    ref = pyshadow.read_image(out / "reference.png")
    diff = pyshadow.read_image(out / "difference.png")
    exr = pyshadow.read_image(out / "ao.exr")
    assert ao.shape == ref.shape == exr.shape == (48, 64)
    assert diff.shape == (48, 64, 3)
    for img in (ao, ref, diff, exr):
        assert float(np.var(img)) > 1e-4
    assert exr.dtype == np.float32 and 0.0 <= exr.min() and exr.max() <= 1.0
    # the PNG is the EXR, sRGB-encoded to 8 bits
    assert np.abs(ao - exr).max() < 0.02
    # zero difference maps to RdBu's centre (near white): most pixels agree
    centre = np.all(diff > 0.8, axis=-1).mean()
    assert centre > 0.5


def test_bench_cache_reused(first, second):
    r1, _, _ = first
    r2, _, p2, before = second
    assert r2["csm"]["source"] == "cached"
    assert all(c["source"] == "cached" for c in r2["csm"]["casters"])
    assert "building the CSM" not in p2.stderr
    assert r2["converged_source"] == "cached"
    assert r2["figures"]["converged_time"]["value"] is None
    # the cache files were read, not rewritten; the original build time is kept
    assert before and all(f.stat().st_mtime_ns == t for f, t in before.items())
    assert r2["figures"]["csm_build_time"]["value"] == pytest.approx(
        r1["figures"]["csm_build_time"]["value"])
    # the measurement itself does not depend on where the CSMs came from
    for k in ("visibility_agreement", "ao_rmse_identical", "ao_rmse_converged", "csm_bytes"):
        assert r2["figures"][k]["value"] == pytest.approx(r1["figures"][k]["value"], rel=1e-9), k


def test_bench_corrupt_cache_file_rebuilt(tmp_path, first, cache_dir):
    import pyshadow

    cache = tmp_path / "cache"
    import shutil

    shutil.copytree(cache_dir, cache)
    files = sorted(cache.rglob("*.csm"))
    assert len(files) == 2
    victim = files[0]
    data = bytearray(victim.read_bytes())
    data[len(data) // 2] ^= 0xFF
    victim.write_bytes(bytes(data))
    with pytest.raises(pyshadow.CSMFormatError):
        pyshadow.CoherentShadowMap.load(victim)
    p = bench(*TINY, "--out", tmp_path / "out", "--json", cache=cache)
    r = json.loads(p.stdout)
    sources = sorted(c["source"] for c in r["csm"]["casters"])
    assert sources == ["cached", "rebuilt"]
    assert r["csm"]["source"] == "partly cached"
    assert "rebuilding" in p.stderr and victim.name in p.stderr
    pyshadow.CoherentShadowMap.load(victim)            # a good file again
    assert r["figures"]["visibility_agreement"]["value"] == pytest.approx(
        first[0]["figures"]["visibility_agreement"]["value"], rel=1e-9)


def test_bench_impossible_cached_reference_recomputed(tmp_path, first, cache_dir):
    """A reference/*.npz with a valid checksum but NaN (or AO > 1) is a miss: traced again, rewritten."""
    import shutil

    from pyshadow.cache import CSMCache

    cache = tmp_path / "cache"
    shutil.copytree(cache_dir, cache)
    (victim,) = sorted((cache / "reference").glob("*.npz"))      # the converged reference
    good = CSMCache(cache).array(victim.stem)
    for bad in (np.full_like(good, np.nan), good + 1.5):
        CSMCache(cache).put_array(victim.stem, bad)            # checksummed like a good file
        p = bench(*TINY, "--out", tmp_path / "out", "--json", cache=cache)
        r = json.loads(p.stdout)
        assert r["converged_source"] == "computed"
        assert f"cache: reference/{victim.name} is not a possible AO of {good.size} pixels (" in p.stderr
        assert np.array_equal(CSMCache(cache).array(victim.stem), good)    # rewritten, as first computed
        for k in ("ao_rmse_converged", "ao_mae_converged", "reference_noise_rmse"):
            assert r["figures"][k]["value"] == pytest.approx(first[0]["figures"][k]["value"], rel=1e-9), k


def test_format_table_prints_missing_figures_as_na(first):
    from pyshadow.bench import format_table

    r = json.loads(json.dumps(first[0]))
    rmse_i = r["figures"]["ao_rmse_identical"]["value"]
    for k in ("ao_rmse_converged", "ao_mae_converged"):         # what a NaN reference made of them
        r["figures"][k]["value"] = None
    table = format_table(r)
    assert "RMSE n/a  MAE n/a  (Embree 8 spp itself: RMSE " in table
    assert f"RMSE {rmse_i:.4f}  MAE " in table
    for fig in [r["figures"]] + r["surfaces"]:                 # every figure missing
        for v in fig.values():
            if isinstance(v, dict):
                v["value"] = None
    table = format_table(r)
    assert "RMSE n/a  MAE n/a  (Embree 8 spp itself: RMSE n/a)" in table
    assert "n/a px  agreement n/a %  bias n/a  RMSE n/a (same dirs) n/a (converged)" in table


def test_bench_table_on_stdout_without_json(tmp_path, cache_dir, first):
    p = bench(*TINY, "--out", tmp_path, "--quiet", cache=cache_dir)
    assert "visibility agreement" in p.stdout and "CSM build" in p.stdout
    assert "cached" in p.stdout
    assert p.stderr.strip() == ""                   # --quiet
    assert (tmp_path / "results.json").is_file()


def test_bench_user_meshes(tmp_path, cache_dir):
    paths = [mesh_path("spot.obj"), mesh_path("teapot.obj")]
    p = bench(*TINY, "--mesh", paths[0], "--mesh", paths[1], "--out", tmp_path, "--json",
              cache=cache_dir)
    r = json.loads(p.stdout)
    assert "spot" in r["scene"] and "teapot" in r["scene"]
    assert [c["name"] for c in r["csm"]["casters"]] == ["spot", "teapot"]
    f = {k: v["value"] for k, v in r["figures"].items()}
    assert 0.9 < f["visibility_agreement"] <= 1.0
    assert 0 < f["covered_pixels"] <= 64 * 48


# ---------------------------------------------------------------------------
# --sky: the scene lit, pyshadow's "bent" mode against Embree's
# ---------------------------------------------------------------------------
@pytest.fixture(scope="module")
def lit(tmp_path_factory, cache_dir, first):
    """The tiny run with --sky overcast, on the CSMs of ``first``: (parsed stdout, output dir, process)."""
    out = tmp_path_factory.mktemp("lit")
    p = bench(*TINY, "--sky", "overcast", "--out", out, "--json", cache=cache_dir)
    return json.loads(p.stdout), out, p


def test_bench_without_sky_has_no_lighting(first):
    result, out, _ = first
    assert "lighting" not in result
    assert not (out / "radiance.exr").exists() and not (out / "lit.png").exists()
    assert "radiance.exr" not in result["files"] and "lit.png" not in result["files"]


def test_bench_sky_overcast_writes_radiance_and_lit_png(lit, first):
    import pyshadow
    from pyshadow.io import linear_to_srgb
    from pyshadow.lighting import tonemap

    r, out, p = lit
    assert json.loads((out / "results.json").read_text()) == r
    for name in ("radiance.exr", "lit.png", "ao.png", "results.json"):
        assert (out / name).is_file() and r["files"][name] == str(out / name), name
    rad = pyshadow.read_image(out / "radiance.exr")
    assert rad.shape == (48, 64, 3) and rad.dtype == np.float32
    assert np.isfinite(rad).all() and rad.min() >= 0.0 and float(np.var(rad)) > 0.0
    # grey sky, grey albedos: grey radiance
    np.testing.assert_allclose(rad[..., 0], rad[..., 2], rtol=1e-5)
    # lit.png is the EXR tone-mapped (sRGB curve) at the recorded exposure
    lit = r["lighting"]
    exposure = lit["exposure"]["value"]
    png = np.round(linear_to_srgb(pyshadow.read_image(out / "lit.png")) * 255.0)
    assert png.shape == (48, 64, 3)
    assert np.abs(png - tonemap(rad, exposure)).max() <= 1
    assert float(np.var(png / 255.0)) > 1e-4
    # the automatic exposure maps the 99th luminance percentile to 0.8
    lum = rad.reshape(-1, 3).astype(np.float64) @ [0.2126, 0.7152, 0.0722]
    assert exposure * np.percentile(lum, 99.0) == pytest.approx(0.8, rel=1e-5)
    assert lit["sky"] == "overcast" and lit["sun"] is None and lit["backend"] == "csm"
    # the AO measurement is the same as without --sky
    for k in ("visibility_agreement", "ao_rmse_identical", "csm_bytes"):
        assert r["figures"][k]["value"] == first[0]["figures"][k]["value"], k
    assert "bent vs Embree bent" in p.stderr


def test_bench_sky_overcast_radiance_error(lit):
    """The "bent" radiance against Embree's on the same directions. Under the overcast sky (no sun)
    radiance is AO x E_sky(bent normal) x albedo / pi, so its relative error is the AO's relative
    error reweighted by E_sky: measured 0.0821 against the AO's 0.0790 at these tiny settings
    (8x16 maps of 32^2 texels, 97.5 % of the rays agree with Embree; at --quick, 0.035 under the
    clear sky). The bounds leave about 1.5x room for other OpenCL devices."""
    f = {k: v["value"] for k, v in lit[0]["lighting"]["modes"]["bent"].items()}
    rel, rel_ao = f["radiance_rmse_relative"], f["ao_rmse_relative"]
    assert rel is not None and np.isfinite(rel) and 0.0 < rel < 0.12
    assert rel <= 1.25 * rel_ao
    assert abs(f["luminance_bias"]) < 0.03
    assert f["lit_frame_time"] > 0 and f["ao_frame_time"] > 0 and f["embree_lit_frame_time"] > 0
    for v in lit[0]["lighting"]["modes"]["bent"].values():
        assert set(v) == {"value", "unit", "label"}


def test_bench_sky_smooth_normals(lit, cache_dir, tmp_path):
    """--normals smooth: the lit frames take interpolated vertex normals on both backends alike, so the
    "bent" error against Embree stays within the flat run's bound (< 0.12, test above), while the torus's
    and the bunny's pixels change (no facet bands) and results.json says which normals were used."""
    import pyshadow

    p = bench(*TINY, "--sky", "overcast", "--normals", "smooth", "--out", tmp_path, "--json", cache=cache_dir)
    r = json.loads(p.stdout)
    assert r["lighting"]["normals"] == "smooth" and lit[0]["lighting"]["normals"] == "flat"
    f = {k: v["value"] for k, v in r["lighting"]["modes"]["bent"].items()}
    assert 0.0 < f["radiance_rmse_relative"] < 0.12
    smooth, flat = (pyshadow.read_image(d / "radiance.exr") for d in (tmp_path, lit[1]))
    assert np.abs(smooth - flat).max() > 0.01 * float(flat.max())


def test_bench_sky_measures_every_mode(lit):
    """--sky measures "transfer" and "sampled" beside "bent", each against Embree in the same mode on the
    same directions. With no sun all three are the sky weighted by the same rays' visibility, so each
    error is the AO's reweighted, like bent's: measure, then bound as bent (< 0.12, <= 1.5x the AO's:
    transfer and sampled weight single rays more unevenly than the bent normal does). Measured at these
    tiny settings: transfer 0.068, sampled 0.071, against the AO's 0.079."""
    modes = lit[0]["lighting"]["modes"]
    assert list(modes) == ["bent", "transfer", "sampled"]
    for m in ("transfer", "sampled"):
        f = {k: v["value"] for k, v in modes[m].items()}
        assert np.isfinite(f["radiance_rmse_relative"]) and 0.0 < f["radiance_rmse_relative"] < 0.12, m
        assert f["radiance_rmse_relative"] <= 1.5 * f["ao_rmse_relative"], m
        assert f["lit_throughput"] > 0 and f["embree_lit_frame_time"] > 0


@pytest.mark.parametrize("kind", ["missing", "garbage"])
def test_bench_sky_unreadable_file(tmp_path, kind):
    sky = tmp_path / "sky.hdr"
    if kind == "garbage":
        sky.write_text("this is not an HDR image\n")
    p = bench(*TINY, "--sky", sky, "--out", tmp_path / "o", check=False)
    assert p.returncode == 2
    assert "--sky" in p.stderr and "sky.hdr" in p.stderr and "environment map" in p.stderr
    assert "rendering" not in p.stderr and "building the CSM" not in p.stderr     # nothing ran
    assert not (tmp_path / "o").exists()
    assert p.stdout == ""


# ---------------------------------------------------------------------------
# the sweep
# ---------------------------------------------------------------------------
def test_bench_sweep_tiny_and_max_error(tmp_path, cache_dir):
    import pyshadow

    p = bench(*TINY, "--sweep", "--sweep-grid", "tiny", "--max-error", "0.2", "--out", tmp_path,
              "--json", cache=cache_dir)
    sw = json.loads(p.stdout)
    assert json.loads((tmp_path / "sweep.json").read_text()) == sw
    assert sw["schema"] == "pyshadow-bench-sweep/1" and sw["grid"] == "tiny"
    labels = [r["label"] for r in sw["rows"]]
    assert len(labels) == len(set(labels)) == 6
    assert {r["varies"] for r in sw["rows"]} == {"base", "samples", "filter", "maps", "depth_bits",
                                                "filtered_lookup"}
    for r in sw["rows"]:
        f = {k: v["value"] for k, v in r["figures"].items()}
        assert all(set(v) == {"value", "unit", "label"} for v in r["figures"].values())
        assert 0.85 < f["visibility_agreement"] <= 1.0
        assert f["ao_rmse_converged"] >= 0 and f["frame_time"] > 0 and f["csm_bytes"] > 0
        assert f["build_time"] is not None and f["build_time"] > 0
    rows = {r["label"]: r for r in sw["rows"]}
    # fewer samples are noisier; the filter lowers the error against the converged reference
    base = rows["8x16 r32 16b s8"]["figures"]
    assert (rows["8x16 r32 16b s4"]["figures"]["ao_rmse_converged"]["value"]
            > base["ao_rmse_converged"]["value"])
    assert (rows["8x16 r32 16b s8 bilateral"]["figures"]["ao_rmse_converged"]["value"]
            < base["ao_rmse_converged"]["value"])
    # the filter does not change per-ray visibility; 32-bit depth does not change the sample set
    assert (rows["8x16 r32 16b s8 bilateral"]["figures"]["visibility_agreement"]["value"]
            == base["visibility_agreement"]["value"])
    assert rows["8x16 r32 32b s8"]["figures"]["csm_bytes"]["value"] > base["csm_bytes"]["value"]
    # filtered lookups agree with Embree on more of the same rays (measured +0.24 points of
    # 24576 rays, about 3 standard errors of the paired difference) on the same CSMs
    filt = rows["8x16 r32 16b s8 filtered-lookup"]
    assert filt["config"]["filtered_lookup"] and filt["figures"]["csm_bytes"] == base["csm_bytes"]
    assert filt["figures"]["visibility_agreement"]["value"] > base["visibility_agreement"]["value"]
    # Pareto flags: exactly the non-dominated rows
    pts = [(r["figures"]["frame_time"]["value"], r["figures"]["ao_rmse_converged"]["value"])
           for r in sw["rows"]]
    for r, (t, e) in zip(sw["rows"], pts):
        dominated = any(t2 <= t and e2 <= e and (t2 < t or e2 < e) for t2, e2 in pts)
        assert r["pareto"] == (not dominated), r["label"]
    assert sw["pareto"] == sorted((r["label"] for r in sw["rows"] if r["pareto"]),
                                  key=lambda l: rows[l]["figures"]["frame_time"]["value"])
    # --max-error: the fastest row that meets it
    ok = [r for r in sw["rows"] if r["figures"]["ao_rmse_converged"]["value"] <= 0.2]
    best = min(ok, key=lambda r: r["figures"]["frame_time"]["value"])
    assert sw["max_error"]["label"] == best["label"]
    from pyshadow.bench.sweep import _answer               # the same rule at other thresholds
    assert _answer(sw, 1e-9)["label"] is None
    strictest = min(r["figures"]["ao_rmse_converged"]["value"] for r in sw["rows"])
    assert _answer(sw, strictest)["row"]["figures"]["ao_rmse_converged"]["value"] == strictest
    md = (tmp_path / "sweep.md").read_text()
    assert md.count("\n| 8x16") + md.count("\n| 4x8") == 6 and best["label"] in md
    png = pyshadow.read_image(tmp_path / "pareto.png")
    assert png.shape[0] > 200 and float(np.var(png)) > 1e-4

    # --max-error alone no longer reads this sweep.json: it fits its model and verifies
    # (tests/test_bench_answer.py); here its predictions meet the sweep's measurements of
    # the same configurations (same CSMs, seed and reference), which the model measured at
    # other seeds: predicted / measured 0.96 (s8), 0.95 (s8 bilateral), 1.01 (s4)
    before = (tmp_path / "sweep.json").read_bytes()
    q = bench(*TINY, "--max-error", "0.05", "--out", tmp_path, "--json", cache=cache_dir)
    ans = json.loads(q.stdout)
    assert ans["schema"] == "pyshadow-bench-max-error/1" and ans["converged_source"] == "cached"
    assert (tmp_path / "sweep.json").read_bytes() == before
    pred = {c["label"]: c["predicted_rmse"]["value"] for c in ans["candidates"]}
    for label in ("8x16 r32 16b s8", "8x16 r32 16b s8 bilateral", "8x16 r32 16b s4"):
        measured = rows[label]["figures"]["ao_rmse_converged"]["value"]
        assert 0.85 * measured <= pred[label] <= 1.15 * measured, (label, pred[label], measured)


# ---------------------------------------------------------------------------
# errors
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("args, message", [
    (["--size", "640"], "WIDTHxHEIGHT"),
    (["--size", "0x10"], "between 1 and 16384"),
    (["--maps", "64by128"], "AxB"),
    (["--samples", "0"], "--samples must be in 1..4096"),
    (["--resolution", "big"], "--resolution must be an integer"),
    (["--depth-bits", "24"], "invalid choice"),
    (["--max-error", "-0.1"], "positive finite number"),
    (["--sweep-grid", "tiny"], "--sweep-grid needs --sweep"),
    (["--mesh", "/nonexistent/dir/bunny.obj"], "no such file"),
    (["--exposure", "2"], "--exposure needs --sky"),
    (["--normals", "smooth"], "--normals needs --sky"),
    (["--sky", "clear", "--sweep"], "--sky is for the single benchmark"),
    (["--sky", "clear", "--max-error", "0.02"], "--sky is for the single benchmark"),
    (["--max-error", "0.02", "--filter", "bilateral"], "--max-error and --frame-budget choose the filter"),
])
def test_bench_bad_arguments(tmp_path, args, message):
    p = bench(*args, "--out", tmp_path / "o", check=False)
    assert p.returncode == 2
    assert message in p.stderr
    assert p.stdout == ""
    assert not (tmp_path / "o" / "results.json").exists()


def test_bench_bad_mesh_file(tmp_path):
    bad = tmp_path / "broken.obj"
    bad.write_text("this is not a mesh\n")
    p = bench("--mesh", bad, "--out", tmp_path / "o", check=False)
    assert p.returncode == 2 and "--mesh" in p.stderr and "broken.obj" in p.stderr


def test_bench_unwritable_out(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    p = bench("--out", blocker / "sub", check=False)        # a path under a regular file
    assert p.returncode == 2 and "cannot write there" in p.stderr
    p = bench("--out", blocker, check=False)
    assert p.returncode == 2 and "not a directory" in p.stderr


# ---------------------------------------------------------------------------
# helpers, in process
# ---------------------------------------------------------------------------
def test_bench_reexports_and_module_entry_point():
    """Names imported from pyshadow.bench before its split into modules are still there."""
    import pyshadow.bench as bench
    from pyshadow import cache, embree

    assert bench.CSMCache is cache.CSMCache and bench.default_cache_dir is cache.default_cache_dir
    assert bench.EmbreeTracer is embree.EmbreeTracer
    for name in bench.__all__:
        assert getattr(bench, name) is not None, name
    p = subprocess.run([sys.executable, "-m", "pyshadow.bench", "--help"], capture_output=True,
                       text=True, timeout=120)
    assert p.returncode == 0 and p.stdout.startswith("usage: pyshadow-bench")


def test_pareto_front_cases():
    from pyshadow.bench import pareto_front

    pts = [(1.0, 0.5), (2.0, 0.3), (2.0, 0.4), (3.0, 0.3), (0.5, 0.9), (4.0, 0.1), (5.0, None)]
    assert pareto_front(pts) == [4, 0, 1, 5]
    assert pareto_front([(1.0, 1.0), (1.0, 1.0)]) == [0, 1]         # ties dominate neither
    assert pareto_front([]) == []


def test_sweep_grids_vary_one_knob_then_combine():
    from pyshadow.bench import PRESETS, Config, sweep_configs

    p = PRESETS["default"]
    base = Config(p["maps"], p["resolution"], p["depth_bits"], p["samples"])
    rows = sweep_configs(base, "full")
    assert rows[0] == (base, "base")
    singles = [c for c, v in rows if v not in ("base", "combination")]
    for c in singles:
        diff = [k for k in ("maps", "resolution", "depth_bits", "samples", "filter", "filtered_lookup")
                if getattr(c, k) != getattr(base, k)]
        assert len(diff) == 1
    assert {v for _, v in rows} >= {"maps", "resolution", "depth_bits", "samples", "filter",
                                    "filtered_lookup", "combination"}
    assert len({c for c, _ in rows}) == len(rows)


def test_embree_pass_matches_embree_ambient_occlusion():
    """The bench's Embree pass on the G-buffer is embree.ambient_occlusion, bit for bit."""
    import pyshadow
    from pyshadow import embree
    from pyshadow.bench import GBuffer, embree_pass
    from pyshadow.embree import EmbreeTracer
    from pyshadow.data import default_scene

    scene, camera = default_scene(views=pyshadow.ViewSet.zigzag(4, 8), resolution=16, width=40,
                                  height=30)
    gb = GBuffer.from_render(scene.render(camera, sampling=pyshadow.Sampling(4)), camera)
    tracer = EmbreeTracer(scene, 2)
    try:
        got = embree_pass(tracer, gb, 12, "halton", 3, 64)
    finally:
        tracer.close()
    want = embree.ambient_occlusion(scene, gb.points, gb.normals, indices=gb.sel,
                                    sampling=pyshadow.Sampling(12, "halton", patterns=64, seed=3))
    np.testing.assert_array_equal(got["ao"], want)
    occ = got["occluded"]
    assert occ.shape == (gb.n * 12,) and 0.0 < occ.mean() < 1.0      # both outcomes present
    assert 0 < got["traced"] < gb.n * 12                            # some rays hit the ground plane
    assert np.any(want == 1.0) and np.any(want < 0.7)


def test_mesh_scene_frames_every_body():
    import pyshadow
    from pyshadow.bench import mesh_scene
    from conftest import load

    meshes = [("spot", load("spot.obj")), ("cow", load("cow.obj")), ("teapot", load("teapot.obj"))]
    scene, camera = mesh_scene(meshes, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16,
                               width=96, height=48)
    assert len(scene.instances) == 3 and scene.ground == 0.0
    ys, xs = [], []
    for i in range(3):
        pts, _ = scene.vertex_points(i)
        c, r = scene.instances[i].world_sphere()
        assert r == pytest.approx(1.0)
        assert pts[:, 1].min() == pytest.approx(0.0, abs=1e-9)       # standing on the ground
        ys.append(pts[:, 1].max())
        xs.append(c[0])
    assert xs[0] < xs[1] < xs[2]
    assert all(b - a >= 2.0 for a, b in zip(xs, xs[1:]))               # spheres do not overlap
    ids = scene.render(camera, sampling=pyshadow.Sampling(1))["object_id"]
    for i in range(3):
        assert (ids == i).sum() > 20, i                                  # every body is in view
    # no body is cut by the image border
    border = np.concatenate([ids[0], ids[-1], ids[:, 0], ids[:, -1]])
    assert not np.isin(border, [0, 1, 2]).any()


def test_bench_unwritable_cache_only_disables_caching(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    p = bench(*TINY, "--out", tmp_path / "o", "--json", env_cache=blocker / "cache")
    r = json.loads(p.stdout)
    assert "not caching" in p.stderr
    assert r["csm"]["source"] == "built"
    assert all(c["file"] is None for c in r["csm"]["casters"])
