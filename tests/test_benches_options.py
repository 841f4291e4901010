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
    ("anchor_groups", ["--rounds", "0"], "--rounds"),
    ("anchor_groups", ["--radius", "0"], "--radius"),
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
    ("texel_blocks", ["--resolution", "63"], "--resolution"),
    ("texel_blocks", ["--maps", "4"], "--maps"),
    ("texel_blocks", ["--meshes", "no-such-mesh"], "--meshes"),
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


@pytest.fixture
def within(request):
    """A bad option must stop the script before its work: SIGALRM after 25 s raises (the tests run in the
    main thread), so a script that goes on with the option fails here instead of running for minutes."""
    import signal

    def stop(signum, frame):
        raise TimeoutError("the script went on with the bad option (no usage error within 25 s)")

    old = signal.signal(signal.SIGALRM, stop)
    signal.alarm(25)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)


@pytest.mark.parametrize("module, argv, option", [
    ("analytic_ao", ["--copies", "0"], "--copies"),
    ("analytic_ao", ["--probe-resolution", "8"], "--probe-resolution"),
    ("analytic_ao", ["--timing", "--samples", "5"], "--timing"),
    ("coherence", ["--random", "0"], "--random"),
    ("coherence", ["--backends", "foo"], "--backends"),
    ("coherence", ["--workloads", "", "--sweep", "x"], "--sweep"),
    ("coherence", ["--workloads", "ao", "--random", "5", "--size", "8x8"], "--random"),
    ("compression", ["--mesh", "{tmp}/none.obj", "--quick"], "--mesh"),
    ("compression", ["--resolution", "0", "--quick"], "--resolution"),
    ("cubemap", ["--distance", "-1"], "--distance"),
    ("cubemap", ["--resolutions", "8"], "--resolutions"),
    ("cubemap", ["--out", "{tmp}/no/result.json"], "--out"),
    ("direct_light", ["--width", "0"], "--width"),
    ("error_model", ["--meshes", "nosuch", "--meshes-only"], "--meshes"),
    ("error_model", ["--quick", "--meshes", "fandisk", "--targets", "0.02", "--meshes-only"], "--quick"),
    ("error_model", ["--shapes", "nosuch"], "--shapes"),
    ("error_model", ["--shapes", "comb", "--meshes", "fandisk"], "--shapes"),
    ("error_model", ["--lookup", "vote", "--targets", "0.02"], "--lookup"),
    ("error_model", ["--files", "{tmp}/none.obj"], "--files"),
    ("error_model", ["--files", "{tmp}/a_file", "--shapes", "comb"], "--files"),
    ("exposure", ["--meshes", "nosuch.obj"], "--meshes"),
    ("extremes", ["--resolution", "0", "--rows", "grazing"], "--resolution"),
    ("fig65", ["--backend", "foo"], "--backend"),
    ("fig65", ["--out", "{tmp}/a_file/fig65", "--width", "8", "--height", "6", "--samples", "1"], "--out"),
    ("filtering", ["--width", "0"], "--width"),
    ("filters", ["--width", "0"], "--width"),
    ("free_space", ["--meshes", "nosuch.obj"], "--meshes"),
    ("identity", ["--compare", "{tmp}/none.npz"], "--compare"),
    ("identity", ["--compare", "{tmp}/a_file"], "--compare"),
    ("identity", ["--save", "{tmp}/no/x.npz", "--quick", "--mesh", "torus"], "--save"),
    ("identity", ["--save", "{tmp}/x.npz", "--mesh", "nosuch"], "--mesh"),
    ("lighting_modes", ["--sun-samples", "0", "--identical-only"], "--sun-samples"),
    ("lighting_modes", ["--identical-only", "--repeats", "5"], "--repeats"),
    ("methods", ["--frames", "0", "--skip-tables", "--skip-pareto"], "--frames"),
    ("methods", ["--threads", "0"], "--threads"),
    ("methods", ["--skip-pareto", "--pareto-samples", "9"], "--pareto-samples"),
    ("penumbra", ["--alphas", "-1"], "--alphas"),
    ("penumbra", ["--plot", "{tmp}/a_file/p.png"], "--plot"),
    ("pole_window", ["--directions", "0"], "--directions"),
    ("raster", ["--layers", "0"], "--layers"),
    ("raster", ["--mesh", "{tmp}/none.obj"], "--mesh"),
    ("shadow_map", ["--frames", "0"], "--frames"),
    ("side_by_side", ["--old", "{tmp}/none", "--new", "{tmp}", "--key", "x", "--", "true"], "--old"),
    ("side_by_side", ["--old", "{tmp}", "--new", "{tmp}", "--rounds", "0", "--key", "x", "--", "true"], "--rounds"),
    ("sun_shadows", ["--resolution", "0"], "--resolution"),
    ("surface_rule", ["--meshes", "nosuch.obj"], "--meshes"),
    ("visibility", ["--threads", "0", "--points", "10", "--theta", "4", "--phi", "8", "--resolution", "16"],
     "--threads"),
    ("visibility", ["--mesh", "{tmp}/none.obj"], "--mesh"),
    ("zigzag_rows", ["--resolution", "0"], "--resolution"),
])
def test_bad_option_stops_before_the_work(module, argv, option, tmp_path, within, monkeypatch, capsys):
    """Was (benchscripts, each run by hand): a traceback after part of the work (a count of 0 or a resolution
    out of range: ValueError from the library; a missing mesh: FileNotFoundError; cubemap/identity/fig65/penumbra
    output paths: the error after the whole run), or the option accepted and ignored (analytic_ao --timing
    --samples, lighting_modes --identical-only --repeats, methods --skip-pareto --pareto-samples, coherence
    --random without the random workload), or the run going on with it (pole_window --directions 0, shadow_map
    --frames 0: StatisticsError at the end); identity --compare of a missing file ran the whole record first."""
    (tmp_path / "a_file").write_text("not a folder, not a .npz")
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    with pytest.raises(SystemExit) as e:
        _main(module, argv, monkeypatch)
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert option in err and "Traceback" not in err
