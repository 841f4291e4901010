"""Bad options of the benchmark scripts stop them with argparse's message (exit status 2), before any work."""
from __future__ import annotations

import sys

import pytest

from conftest import REPO

sys.path.insert(0, str(REPO / "benchmarks"))


def _main(module, argv, monkeypatch):
    """Run ``module.main`` on ``argv`` (through ``sys.argv`` for the scripts whose main takes none)."""
    import importlib

    mod = importlib.import_module(module)
    monkeypatch.setattr(sys, "argv", [f"{module}.py", *argv])
    try:
        return mod.main(argv)
    except TypeError as e:
        if "positional argument" not in str(e):
            raise
        return mod.main()


@pytest.mark.parametrize("module, argv, option", [
    ("instances", ["--counts", "1", "--rounds", "0"], "--rounds"),
    ("scene_cost", ["--rays", "16", "--rounds", "0"], "--rounds"),
    ("contact_cost", ["--pile", "0"], "--pile"),
    ("direct_light", ["--maps", "64x"], "--maps"),
    ("pole_window", ["--maps", "4"], "--maps"),
    ("sun_disc", ["--heights", "16,x"], "--heights"),
    ("sun_horizon", ["--heights", "x"], "--heights"),
    ("error_model", ["--targets", "-1", "--meshes", "fandisk", "--meshes-only"], "--targets"),
    ("visibility", ["--repeats", "0", "--theta", "4", "--phi", "8", "--resolution", "16", "--points", "10"],
     "--repeats"),
    ("filters", ["--repeats", "0", "--width", "8", "--height", "8"], "--repeats"),
    ("raster", ["--repeats", "0", "--theta", "2", "--phi", "4", "--resolution", "8"], "--repeats"),
])
def test_bad_option_is_a_usage_error(module, argv, option, monkeypatch, capsys):
    """Was: a traceback after part of the work -- instances.py --rounds 0: KeyError 'grid' after building
    the scenes; scene_cost.py --rounds 0: StatisticsError after a warm-up round; --maps 64x / 4 and
    --heights x: ValueError from int(); error_model.py --targets -1: ValueError from the CSM build;
    direct_light.py --maps 64 ran the whole benchmark at ViewSet.zigzag(64); visibility.py, filters.py and
    raster.py --repeats 0: StatisticsError (no median for empty data) after the build and warm-up."""
    with pytest.raises(SystemExit) as e:
        _main(module, argv, monkeypatch)
    assert e.value.code == 2
    assert option in capsys.readouterr().err
