"""pyshadow-bench (helper bench2): an output the disk cannot take, the by-surface rows of a filtered run,
and an environment map with no sun in it. In-process and by hand: no full benchmark run."""
from __future__ import annotations

import errno
import os
import re

import numpy as np
import pytest

TINY = ["--maps", "8x16", "--resolution", "32", "--size", "64x48", "--samples", "8",
        "--reference-samples", "64", "--repeats", "1"]


@pytest.fixture
def bench_main(monkeypatch, tmp_path):
    """``run(replace, *options)``: pyshadow-bench's main in-process (tiny, --quiet, no cache) with the
    names of ``replace`` (a dict) replaced on pyshadow.bench.cli; returns (status, out folder)."""
    from pyshadow.bench import cli
    from pyshadow.bench.common import _PROGRESS

    monkeypatch.setitem(_PROGRESS, "on", _PROGRESS["on"])          # main sets it
    out = tmp_path / "out"

    def run(replace, *extra):
        for name, fake in replace.items():
            monkeypatch.setattr(cli, name, fake)
        return cli.main([*TINY, *extra, "--out", str(out), "--no-cache", "--quiet"]), out
    return run


def _disk_full(path):
    # what pyshadow.io's room check and a write on a full file system raise: the errno, the file's name
    return OSError(errno.ENOSPC, "No space left on device", str(path))


def _one_line(capsys, name):
    o, e = capsys.readouterr()
    assert o == ""
    assert e.count("\n") == 1 and "Traceback" not in e
    assert e.startswith("pyshadow-bench: error: ") and "No space left on device" in e and name in e


def test_a_full_disk_ends_the_single_benchmark_with_one_line(bench_main, capsys):
    """Was: an output the disk could not take after the run's work (a 20 KiB tmpfs as --out: ao.png needed
    up to 68,686 bytes) ended pyshadow-bench in a 20-line traceback (OSError out of main). Now one line
    naming the file and the reason, status 1, nothing on stdout and no record."""
    def fake(args, *a, **k):
        raise _disk_full(os.path.join(args.out, "ao.png"))

    status, out = bench_main({"run_main": fake})
    assert status == 1
    _one_line(capsys, "ao.png")
    assert sorted(os.listdir(out)) == []                            # no probe, no record


def test_a_full_disk_ends_the_sweep_with_one_line(bench_main, capsys):
    """Was: the same traceback when pareto.png, the sweep's first output, could not be written."""
    def plot(sw, path, max_error=None):
        raise _disk_full(path)

    status, out = bench_main({"run_sweep": lambda *a, **k: {"rows": []}, "pareto_plot": plot},
                             "--sweep", "--sweep-grid", "tiny")
    assert status == 1
    _one_line(capsys, "pareto.png")
    assert sorted(os.listdir(out)) == []


def test_a_full_disk_ends_max_error_with_one_line(bench_main, capsys):
    """Was: the same traceback when max_error.json could not be written."""
    def write(path, data):
        raise _disk_full(path)

    status, out = bench_main({"run_max_error": lambda *a, **k: {}, "write_bytes_atomic": write},
                             "--max-error", "0.1")
    assert status == 1
    _one_line(capsys, "max_error.json")
    assert sorted(os.listdir(out)) == []


def _f(value, unit="1"):
    return {"value": value, "unit": unit, "label": "test"}


def _record(filter_):
    """A results.json record of a 64x48 run (two surfaces) with the AO filter ``filter_``."""
    figs = dict(csm_time=0.1, csm_build_time=1.0, csm_size=0.16, csm_ratio=3.2, ao_throughput=20.0,
                frame_time=0.02, ao_time=0.001, covered_pixels=3072, timed_pixels=3072, embree_ray_rate=7.0,
                embree_throughput=9.9, speedup=2.0, visibility_agreement=0.9932, false_visible=0.0038,
                false_occluded=0.003, ao_rmse_identical=0.0298, ao_mae_identical=0.0065,
                ao_rmse_converged=0.0332, ao_mae_converged=0.0189, reference_noise_rmse=0.0639,
                converged_time=None, total_time=4.8)
    surf = [{"surface": name, "id": i, "pixels": _f(px, "px"), "visibility_agreement": _f(0.99),
             "ao_bias_identical": _f(0.0004, "AO"), "ao_rmse_identical": _f(0.034, "AO"),
             "ao_rmse_converged": _f(rc, "AO")}
            for i, (name, px, rc) in enumerate((("ground", 2066, 0.0787), ("bunny", 1006, 0.0338)))]
    return {"mode": "custom", "scene": "default scene", "csm": {"source": "cached"}, "converged_source": "cached",
            "config": {"width": 64, "height": 48, "samples": 8, "strategy": "hammersley", "maps": "8x16",
                       "resolution": 32, "depth_bits": 16, "filter": filter_, "reference_samples": 64},
            "environment": {"device": "cpu", "platform": "pocl", "device_type": "CPU", "compute_units": 2,
                            "embree_threads": 2},
            "figures": {k: _f(v) for k, v in figs.items()}, "surfaces": surf}


def test_filtered_run_says_its_surface_rows_are_unfiltered():
    """Was: with --filter bilateral the table printed "AO vs Embree 64 spp RMSE 0.0332" (the filtered image)
    above rows by surface of 0.0338 to 0.0916 "(converged)" -- every one above the whole image's, which is
    impossible for one quantity -- without saying those rows measure the AO before the filter."""
    from pyshadow.bench import format_table

    def rows(r):
        return dict(re.fullmatch(r"  (.+?)  +(\S.*)", ln).groups() for ln in format_table(r).splitlines()[2:])

    filtered = rows(_record("bilateral"))
    assert filtered["by surface"] == ("pixels, ray agreement, AO bias and RMSE (pyshadow - Embree); "
                                      "the AO before the bilateral filter")
    assert filtered["AO vs Embree 64 spp"].startswith("RMSE 0.0332")
    # the unfiltered run's heading is as before: its rows and the headline measure the same image
    assert rows(_record(None))["by surface"] == "pixels, ray agreement, AO bias and RMSE (pyshadow - Embree)"


def _sky_file(tmp_path, sun: bool):
    import pyshadow

    img = np.full((32, 64, 3), 1.0, np.float32)       # a uniform sky: nothing stands out of it
    if sun:
        img[4, 20] = 1e6                              # one texel 10^6 times brighter: a sun
    path = tmp_path / ("sun.exr" if sun else "overcast.exr")
    pyshadow.write_image(path, img)
    return str(path)


def test_a_map_without_a_sun_gives_no_sun(tmp_path):
    """Was: --sky FILE of a uniform (overcast) map recorded a sun of irradiance (0, 0, 0) at direction
    (0.049, 0.999, 0.002), the table printed "sun dir (0.049, 0.999, 0.002)", and every lit frame traced a
    shadow ray a pixel for it. Now no sun (null), the table says "no sun"; a map with a sun keeps it."""
    from pyshadow.bench.lit import format_lighting, sky_lighting

    light, rec = sky_lighting(_sky_file(tmp_path, sun=False))
    assert light.sun is None and rec["sun"] is None
    assert light.env is not None and np.allclose(light.sh[0], light.sh[0][0])   # the sky stays, grey
    rec_t = {**rec, "exposure": _f(1.0), "modes": {}}
    assert format_lighting(rec_t)[0][1].endswith("sky, no sun; exposure 1")

    light, rec = sky_lighting(_sky_file(tmp_path, sun=True))
    assert light.sun is not None and min(rec["sun"]["irradiance"]) > 1e3


def test_an_argument_error_makes_no_output_folder(tmp_path, capsys):
    """Was: ``--method vtk-ssao --size 8x8 --out DIR`` was refused (exit 2, "--size 8x8: --method vtk-ssao
    renders in a VTK window ...") after DIR had been created: an empty folder left behind, unlike every
    other argument error. Now the folder is made after the last argument check."""
    from pyshadow.bench import cli

    out = tmp_path / "new" / "out"
    with pytest.raises(SystemExit) as e:
        cli.main(["--method", "vtk-ssao", "--size", "8x8", "--out", str(out), "--no-cache", "--quiet"])
    assert e.value.code == 2
    assert "--size 8x8: --method vtk-ssao" in capsys.readouterr().err
    assert not (tmp_path / "new").exists()
