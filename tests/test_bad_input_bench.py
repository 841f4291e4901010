"""Bad command-line input and file-system conditions of ``pyshadow-bench`` and of the example scripts.

Each test states in its docstring what happened before the fix. The bench
runs in process (``pyshadow.bench.cli.main``) at the smallest settings,
without the cache; the examples' ``main(argv)`` are called in process too
and stop at argument checks, before anything is rendered.
"""
from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import pytest

from pyshadow.bench.cli import main

REPO = Path(__file__).resolve().parents[1]
TINY = ["--maps", "4x8", "--resolution", "16", "--size", "32x24", "--samples", "4",
        "--reference-samples", "16", "--repeats", "1", "--threads", "1", "--no-cache", "--quiet"]
SCRIPTS = ["ao_image.py", "ao_mesh.py", "csm_heatmap.py", "depth_maps.py", "lit_scene.py",
           "moving_bodies.py"]
#: the smallest settings each script takes (so that a run that gets past its checks is short)
SMALL = {
    "ao_image.py": ["--theta", "4", "--phi", "8", "--resolution", "16", "--width", "32", "--height", "24",
                    "--samples", "4"],
    "ao_mesh.py": ["--theta", "4", "--phi", "8", "--resolution", "16", "--samples", "4",
                   "--ground-divisions", "4"],
    "csm_heatmap.py": ["--theta", "4", "--phi", "8", "--resolution", "16"],
    "depth_maps.py": ["--theta", "4", "--phi", "8", "--resolution", "16"],
    "lit_scene.py": ["--theta", "4", "--phi", "8", "--resolution", "16", "--width", "32", "--height", "24",
                     "--samples", "4", "--frames", "2"],
    "moving_bodies.py": ["--theta", "4", "--phi", "8", "--resolution", "16", "--samples", "4",
                         "--ground-divisions", "4", "--frames", "2"],
}


def usage_error(argv, capsys) -> str:
    """Run the bench with ``argv``; assert an argparse error (exit 2, nothing on stdout); its stderr."""
    with pytest.raises(SystemExit) as e:
        main(argv)
    err = capsys.readouterr()
    assert e.value.code == 2, err.err[-2000:]
    assert err.out == ""
    assert "pyshadow-bench: error:" in err.err
    return err.err


def earlier(out: Path) -> bytes:
    """An earlier run's results.json in ``out``; returns its bytes."""
    out.mkdir(parents=True, exist_ok=True)
    data = b'{"earlier": true}\n'
    (out / "results.json").write_bytes(data)
    return data


def triangle(tmp_path) -> Path:
    p = tmp_path / "tri.obj"
    p.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    return p


# ---------------------------------------------------------------------------
# pyshadow-bench
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("extra, name", [
    ([], "results.json"),
    ([], "ao.png"),
    (["--sky", "overcast"], "lit.png"),
    (["--max-error", "0.1"], "max_error.json"),
    (["--sweep", "--sweep-grid", "tiny"], "sweep.json"),
])
def test_output_name_taken_by_a_folder(tmp_path, capsys, extra, name):
    """Before: a folder in --out named like an output (results.json/, ao.png/, ...) let the whole run go
    on and ended it with an IsADirectoryError traceback when that output was written (for results.json
    after removing nothing and writing every image; for sweep.json after the whole sweep)."""
    out = tmp_path / "out"
    (out / name).mkdir(parents=True)
    err = usage_error([*TINY, *extra, "--out", str(out)], capsys)
    assert name in err and "not a regular file" in err
    assert sorted(p.name for p in out.iterdir()) == [name]       # nothing written


def test_output_name_is_a_broken_link(tmp_path, capsys):
    """Before: ao.png in --out a symbolic link into a folder that does not exist let the whole run go on
    and ended it with a FileNotFoundError traceback when the first image was written."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "ao.png").symlink_to(tmp_path / "gone" / "ao.png")
    err = usage_error([*TINY, "--out", str(out)], capsys)
    assert "ao.png is a symbolic link" in err
    assert sorted(p.name for p in out.iterdir()) == ["ao.png"]


def test_light_facing_no_pixel_is_a_usage_error_before_any_output(tmp_path, capsys):
    """Before: a --light no covered pixel faces (a sun low behind the user's mesh) ran the whole benchmark,
    removed the earlier results.json, wrote the new images and then ended in a RuntimeError traceback."""
    out = tmp_path / "out"
    old = earlier(out)
    err = usage_error([*TINY, "--mesh", str(triangle(tmp_path)), "--light", "sun:0,1", "--out", str(out)],
                      capsys)
    assert "--light sun:0,1: no covered pixel faces the light" in err
    assert (out / "results.json").read_bytes() == old
    assert sorted(p.name for p in out.iterdir()) == ["results.json"]


def test_light_inside_a_caster_is_a_usage_error_before_any_output(tmp_path, capsys):
    """Before: a --light point inside a caster's bounding sphere was found only after the whole run:
    the earlier results.json was already removed and the new images written; exit status 1."""
    out = tmp_path / "out"
    old = earlier(out)
    err = usage_error([*TINY, "--light", "point:0,0.3,0", "--out", str(out)], capsys)
    assert "--light point:0,0.3,0: the light lies inside caster" in err
    assert (out / "results.json").read_bytes() == old
    assert sorted(p.name for p in out.iterdir()) == ["results.json"]


def test_far_point_light_is_a_usage_error(tmp_path, capsys):
    """Before: --light point:1e308,1e308,1e308 (finite, accepted) ran the benchmark, printed numpy overflow
    warnings and ended in a RuntimeError traceback ("no covered pixel faces the light")."""
    err = usage_error([*TINY, "--light", "point:1e308,1e308,1e308", "--out", str(tmp_path / "o")], capsys)
    assert "no covered pixel faces the light" in err and "overflow" not in err
    assert not (tmp_path / "o" / "ao.png").exists()


def test_ao_distance_beyond_float32_is_refused_by_the_parser(tmp_path, capsys):
    """Before: --ao-distance 1e300 (finite, > 0: accepted) ran the benchmark and ended in a ValueError
    traceback from the SSAO kernel ("radius must be at most 3.4e+38")."""
    err = usage_error([*TINY, "--method", "ssao", "--ao-distance", "1e300", "--out", str(tmp_path / "o")],
                      capsys)
    assert "argument --ao-distance" in err and "3.4e+38" in err
    assert not (tmp_path / "o").exists()


def test_ao_distance_float32_max_still_accepted():
    from pyshadow._validate import FLOAT32_MAX
    from pyshadow.bench.cli import build_parser

    args = build_parser().parse_args(["--method", "ssao", "--ao-distance", repr(FLOAT32_MAX)])
    assert args.ao_distance == FLOAT32_MAX


@pytest.mark.parametrize("option", ["--out", "--cache-dir"])
def test_empty_folder_path_is_refused(tmp_path, capsys, monkeypatch, option):
    """Before: --out "" ran the benchmark and wrote results.json and six images into the current
    folder; --cache-dir "" silently used the default cache ($PYSHADOW_CACHE or the user cache)."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("PYSHADOW_CACHE", str(tmp_path / "cache"))     # the default cache, kept in tmp_path
    argv = [*TINY, "--out", str(tmp_path / "o")]
    if option == "--out":
        argv = [a for a in argv if a != "--no-cache"]          # the error must come from --out alone
        argv[argv.index("--out") + 1] = ""
    else:
        argv = [a for a in argv if a != "--no-cache"] + ["--cache-dir", ""]
    err = usage_error(argv, capsys)
    assert f"argument {option}" in err
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------------
# the example scripts
# ---------------------------------------------------------------------------
def example_module(name: str, fresh: bool = True):
    """``examples/<name>.py`` as a module registered in ``sys.modules`` (dataclasses look it up there), no
    ``__pycache__`` written into examples/; ``fresh=False`` reuses one loaded before."""
    key = "_example_" + name.removesuffix(".py")
    if fresh or key not in sys.modules:
        spec = importlib.util.spec_from_file_location(key, REPO / "examples" / (key[9:] + ".py"))
        sys.modules[key] = mod = importlib.util.module_from_spec(spec)
        keep, sys.dont_write_bytecode = sys.dont_write_bytecode, True
        try:
            spec.loader.exec_module(mod)
        finally:
            sys.dont_write_bytecode = keep
    return sys.modules[key]


def example_main(name):
    """The ``main`` of ``examples/name``, the script loaded as a module once (:func:`example_module`)."""
    return example_module(name, fresh=False).main


def example_error(name, argv, capsys) -> str:
    with pytest.raises(SystemExit) as e:
        example_main(name)([*SMALL[name], *argv])
    err = capsys.readouterr().err
    assert e.value.code == 2, err[-2000:]
    assert "error: " in err
    return err


@pytest.mark.parametrize("name", SCRIPTS)
@pytest.mark.parametrize("window", [["0", "0"], ["-5", "300"], ["400", "99999999"]])
def test_example_window_out_of_range(tmp_path, capsys, name, window):
    """Before: --window 0 0 (or a negative side) computed everything and then ended in a ValueError
    traceback from viz.make_plotter; a huge side was handed to VTK."""
    err = example_error(name, ["--window", *window, "--screenshot", str(tmp_path / "x.png")], capsys)
    assert "argument --window" in err
    assert not (tmp_path / "x.png").exists()


@pytest.mark.parametrize("name", SCRIPTS)
def test_example_screenshot_folder_missing(tmp_path, capsys, name):
    """Before: --screenshot into a folder that does not exist computed everything, opened the off-screen
    plotter and ended in a FileNotFoundError traceback."""
    err = example_error(name, ["--screenshot", str(tmp_path / "no" / "x.png")], capsys)
    assert "argument --screenshot" in err and "does not exist" in err


@pytest.mark.parametrize("name", SCRIPTS)
def test_example_screenshot_is_a_folder(tmp_path, capsys, name):
    """Before: --screenshot naming an existing folder rendered, printed "wrote DIR" and exited 0 with
    no image written anywhere."""
    err = example_error(name, ["--screenshot", str(tmp_path)], capsys)
    assert "argument --screenshot" in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name", SCRIPTS)
def test_example_screenshot_of_an_unknown_image_type(tmp_path, capsys, name):
    """Before: --screenshot out.txt computed everything, opened the off-screen plotter and ended in a
    ValueError traceback from pyvista ("Must be one of the following: ['.png', ...]")."""
    err = example_error(name, ["--screenshot", str(tmp_path / "out.txt")], capsys)
    assert "argument --screenshot" in err and ".png" in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(sys.platform != "linux", reason="the display check is Linux's")
@pytest.mark.parametrize("name", SCRIPTS)
def test_example_without_display_or_screenshot(capsys, monkeypatch, name):
    """Before: with no display and no --screenshot a script computed everything and then ended in a
    RuntimeError traceback from viz.make_plotter (whose message says to pass --screenshot)."""
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    err = example_error(name, ["--window", "64", "64"], capsys)
    assert "no display" in err and "--screenshot" in err


@pytest.mark.parametrize("name, argv, message", [
    ("ao_mesh.py", ["--ground-divisions", "0"], "divisions must be in"),
    ("ao_mesh.py", ["--resolution", "0"], "resolution must be in"),
    ("ao_mesh.py", ["--theta", "0"], "theta must be in"),
    ("depth_maps.py", ["--resolution", "0"], "resolution must be in"),
])
def test_example_bad_sizes_are_usage_errors(tmp_path, capsys, name, argv, message):
    """Before: ao_mesh.py --ground-divisions 0 / --resolution 0 / --theta 0 and depth_maps.py
    --resolution 0 ended in a ValueError traceback (the scene or depth maps were built outside the
    scripts' argument-error handling)."""
    err = example_error(name, [*argv, "--screenshot", str(tmp_path / "x.png")], capsys)
    assert message in err
    assert not (tmp_path / "x.png").exists()


def test_results_json_is_strict_json_for_a_valid_light_run(tmp_path, capsys):
    """A valid --light run still measures, writes shadow.png and a strict-JSON results.json."""
    out = tmp_path / "out"
    assert main([*TINY, "--light", "sun:40,35", "--out", str(out), "--json"]) == 0
    text = capsys.readouterr().out

    def refuse(token):
        raise ValueError(token)

    rec = json.loads(text, parse_constant=refuse)
    assert rec["light"]["spec"] == "sun:40,35" and (out / "shadow.png").is_file()
    assert json.loads((out / "results.json").read_text(), parse_constant=refuse) == rec
