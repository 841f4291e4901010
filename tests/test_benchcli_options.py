"""pyshadow-bench's options: the mode a run reports, options that the run would ignore."""
import pytest

from pyshadow.bench import cli


class _Stop(Exception):
    """Raised in place of the single benchmark: carries the parsed arguments."""


@pytest.fixture
def no_run(monkeypatch):
    """The single benchmark replaced: a run that gets past its arguments raises :class:`_Stop`."""
    def fake_run(args, *rest, **kw):
        raise _Stop(args)

    monkeypatch.setattr(cli, "run_main", fake_run)


@pytest.fixture
def parsed(no_run, tmp_path):
    """``parsed(*argv)``: the arguments the single benchmark would get (no work is done)."""

    def parse(*argv):
        with pytest.raises(_Stop) as e:
            cli.main([*argv, "--quiet", "--no-cache", *([] if "--out" in argv else ["--out", str(tmp_path / "out")])])
        return e.value.args[0]
    return parse


@pytest.mark.parametrize("argv", [["--strategy", "random"], ["--seed", "7"], ["--patterns", "64"],
                                  ["--quick", "--strategy", "halton"]])
def test_sampling_options_make_the_run_custom(parsed, argv):
    """Was: --strategy random, --seed 7 or --patterns 64 reported mode 'default' (or 'quick'), the mode of the
    published figures, though they move every AO figure (a tiny run's back wall: converged RMSE 0.063 with
    Hammersley, 0.290 with --strategy random)."""
    assert parsed(*argv).mode == "custom"


@pytest.mark.parametrize("argv, mode", [
    (["--quick", "--samples", "36", "--size", "320x240", "--maps", "32x64", "--repeats", "3"], "quick"),
    (["--samples", "36", "--reference-samples", "1024", "--depth-bits", "16", "--strategy", "hammersley"], "default"),
    (["--quick", "--samples", "37"], "custom"), (["--size", "320x240"], "custom"), (["--quick"], "quick"),
    ([], "default")])
def test_a_setting_given_equal_to_the_preset_keeps_the_preset_mode(parsed, argv, mode):
    """Was: any setting given, even the preset's own value (--quick --samples 36), reported mode 'custom'
    (benchmarks/README: a run whose settings *differ* from its preset is 'custom')."""
    assert parsed(*argv).mode == mode


def test_probe_resolution_without_a_probe_method_is_refused(no_run, capsys, tmp_path):
    """Was: --probe-resolution 32 without --method cubemap or cubemap-horizon was accepted and ignored (the run
    used no probe; with --method csm neither)."""
    for argv in (["--probe-resolution", "32"], ["--method", "csm,ssao", "--probe-resolution", "32"]):
        with pytest.raises(SystemExit) as e:
            cli.main([*argv, "--quiet", "--no-cache", "--out", str(tmp_path / "out")])
        assert e.value.code == 2
        assert "--probe-resolution needs --method cubemap or cubemap-horizon" in capsys.readouterr().err


@pytest.mark.parametrize("argv, want", [(["--method", "cubemap"], 128),
                                        (["--method", "csm", "--method", "cubemap-horizon",
                                          "--probe-resolution", "32"], 32)])
def test_probe_resolution_with_a_probe_method(parsed, argv, want):
    """The probe methods take --probe-resolution, 128 without it."""
    assert parsed(*argv).probe_resolution == want


def test_a_relative_out_is_recorded_from_the_root(parsed, monkeypatch, tmp_path):
    """Was: --out rel recorded its files as 'rel/ao.png', 'rel/results.json' (results.json "files"), paths that
    name nothing once read from another folder; the CSM files beside them were recorded absolute."""
    monkeypatch.chdir(tmp_path)
    args = parsed("--out", "rel")
    assert args.out == str(tmp_path / "rel")


def test_a_relative_sky_file_is_recorded_from_the_root(monkeypatch, tmp_path):
    """Was: --sky sky.exr recorded "file": "sky.exr" in the lighting entry (the folder it was read from lost)."""
    import numpy as np

    import pyshadow
    from pyshadow.bench.lit import sky_lighting

    monkeypatch.chdir(tmp_path)
    sky = np.ones((8, 16, 3), np.float32)
    sky[2, 5] = 50.0
    pyshadow.write_image("sky.exr", sky)
    assert sky_lighting("sky.exr")[1]["file"] == str(tmp_path / "sky.exr")


@pytest.mark.parametrize("option", ["--out", "--mesh"])
def test_a_name_too_long_for_the_file_system_is_a_usage_error(option, no_run, capsys, tmp_path):
    """Was: --out or --mesh with a 300-character file name ended in a traceback (OSError: [Errno 36] File name
    too long, from the folder's or the file's look-up), not a usage error (exit 2)."""
    name = str(tmp_path / ("n" * 300))
    argv = [option, name] + (["--out", str(tmp_path / "out")] if option != "--out" else [])
    with pytest.raises(SystemExit) as e:
        cli.main([*argv, "--quiet", "--no-cache"])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert f"error: {option} " in err and "Traceback" not in err


def test_cache_dir_with_no_cache_is_refused(no_run, capsys, tmp_path):
    """Was: --no-cache --cache-dir DIR was accepted and DIR ignored (nothing read or written there)."""
    with pytest.raises(SystemExit) as e:
        cli.main(["--no-cache", "--cache-dir", str(tmp_path / "c"), "--quiet", "--out", str(tmp_path / "out")])
    assert e.value.code == 2
    assert "--cache-dir: --no-cache neither reads nor writes a cache" in capsys.readouterr().err


def test_a_cache_dir_that_is_a_file_is_refused(no_run, capsys, tmp_path):
    """Was: --cache-dir FILE warned "cannot be created or used ...; not caching" and ran the whole benchmark
    without the cache it was asked to use."""
    (tmp_path / "c").write_text("")
    with pytest.raises(SystemExit) as e:
        cli.main(["--cache-dir", str(tmp_path / "c"), "--quiet", "--out", str(tmp_path / "out")])
    assert e.value.code == 2
    assert f"--cache-dir {tmp_path / 'c'}: exists and is not a directory" in capsys.readouterr().err
