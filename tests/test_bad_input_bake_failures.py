"""Failures during a batch bake (pyshadow.bake.library, runner, cli): a worker that dies, an output
that cannot be written, a source that is no regular file. Each test is a defect found in an audit:
the wrong behaviour it had is in its docstring."""
import json
import os
from pathlib import Path

import pytest

import pyshadow
import pyshadow.bake.library as library
from pyshadow.bake import AssetParams, bake_assets
from pyshadow.bake.assets import bake_asset

PARAMS = AssetParams(theta=16, phi=32, resolution=64, samples=16)
SMALL = ("cow.obj", "spot.obj", "torus.STL")


def _sources(folder: Path, names=SMALL) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for name in names:
        pyshadow.data.mesh_file(name, folder)
    return folder


def _temporaries(out: Path) -> list:
    return [p for p in out.rglob("*") if ".tmp" in p.name]


def die_on_cow(name, *args):
    """A task function whose worker process dies (as in a segfault) on the asset 'cow'."""
    if name == "cow":
        os._exit(3)
    return bake_asset(name, *args)


def test_a_dying_worker_fails_only_its_own_asset(tmp_path, monkeypatch):
    """A worker process that died (os._exit, a segfault) broke the whole process pool: every other
    asset in flight was recorded 'failed' with BrokenProcessPool, and a task submitted after the
    break raised BrokenProcessPool out of bake_assets, the rest left 'interrupted'."""
    src = _sources(tmp_path / "src")
    monkeypatch.setattr(library, "bake_asset", die_on_cow)
    m = bake_assets(src, tmp_path / "out", PARAMS, executor="process", workers=2, progress=False)
    acts = {e["name"]: (e["action"], e.get("error")) for e in m["assets"]}
    assert acts["cow"][0] == "failed" and "worker process died" in acts["cow"][1], acts
    assert {n: a for n, (a, _) in acts.items() if n != "cow"} == {"spot": "baked", "torus": "baked"}, acts
    assert _temporaries(tmp_path / "out") == []


def test_an_output_that_cannot_be_written_fails_that_asset_only(tmp_path, monkeypatch):
    """An OSError writing one asset's outputs (the folder unwritable half way, a disk full) left
    bake_assets at once: that asset was recorded 'interrupted before it finished', the assets after it
    were not baked, and a record could be missing for an asset whose outputs were written."""
    src = _sources(tmp_path / "src")
    real = library.store

    def store(out, record, rec, files):
        if rec["name"] == "spot":
            raise PermissionError(13, "Permission denied", str(out / "meshes/spot.ply"))
        return real(out, record, rec, files)

    monkeypatch.setattr(library, "store", store)
    m = bake_assets(src, tmp_path / "out", PARAMS, executor="serial", progress=False)
    acts = {e["name"]: (e["action"], e.get("error") or "") for e in m["assets"]}
    assert acts["spot"][0] == "failed" and "Permission denied" in acts["spot"][1], acts
    assert acts["cow"][0] == acts["torus"][0] == "baked", acts
    assert json.loads((tmp_path / "out/manifest.json").read_text())["summary"]["failed"] == 1
    monkeypatch.setattr(library, "store", real)        # writable again: the rerun bakes only spot
    m2 = bake_assets(src, tmp_path / "out", PARAMS, executor="serial", progress=False)
    assert m2["summary"] == {"baked": 1, "skipped": 2, "failed": 0, "interrupted": 0}


def test_an_output_path_that_is_a_folder_is_found_before_the_bake(tmp_path):
    """A folder where manifest.json goes was found only after every asset was baked: the run ended in
    a FileExistsError traceback and no manifest; a file where a subfolder goes (records) gave a bare
    mkdir FileExistsError, a traceback from the command line."""
    from pyshadow.bake.cli import main

    src = _sources(tmp_path / "src", ("cow.obj",))
    (tmp_path / "o1/manifest.json").mkdir(parents=True)
    with pytest.raises(FileExistsError, match="manifest"):
        bake_assets(src, tmp_path / "o1", PARAMS, executor="serial", progress=False)
    assert not (tmp_path / "o1/csm/cow.csm").exists()          # nothing baked in vain
    (tmp_path / "o2").mkdir()
    (tmp_path / "o2/records").write_text("x")
    assert main(["assets", str(src), "-o", str(tmp_path / "o2"), "--executor", "serial", "--quiet"]) == 1


def test_cli_reports_an_os_error_without_a_traceback(tmp_path, monkeypatch, capsys):
    """An OSError during the bake (an unreadable source folder, an unwritable manifest) came out of
    pyshadow-bake as a traceback."""
    from pyshadow.bake.cli import main

    src = _sources(tmp_path / "src", ("cow.obj",))

    def fail(*a, **k):
        raise PermissionError(13, "Permission denied", str(src))

    monkeypatch.setattr(library, "bake_assets", fail)
    assert main(["assets", str(src), "-o", str(tmp_path / "o"), "--quiet"]) == 1
    assert "Permission denied" in capsys.readouterr().err


def test_a_fifo_source_is_an_error_not_a_hang(tmp_path):
    """A named source that exists but is no regular file (a FIFO) was taken as a mesh, and hashing it
    blocked forever; in a folder it was passed over without being listed in 'ignored'."""
    from pyshadow.bake import find_assets

    fifo = tmp_path / "pipe.obj"
    os.mkfifo(fifo)
    with pytest.raises(ValueError, match="not a mesh file"):
        find_assets(fifo)
    assert find_assets(tmp_path) == ([], [str(fifo)])


def test_broken_and_looping_links_in_a_folder_are_listed_as_ignored(tmp_path):
    """A dangling link or a link to itself in a source folder vanished silently: neither an asset nor
    in the manifest's 'ignored' list."""
    from pyshadow.bake import find_assets

    src = _sources(tmp_path / "src", ("cow.obj",))
    os.symlink("gone.obj", src / "dangling.obj")
    os.symlink("loop.obj", src / "loop.obj")
    assets, ignored = find_assets(src)
    assert [n for n, _ in assets] == ["cow"]
    assert sorted(ignored) == [str(src / "dangling.obj"), str(src / "loop.obj")]


def test_one_file_named_twice_is_one_asset_and_clashes_name_the_files(tmp_path):
    """A folder named twice in two spellings (src and src/../src) was 'assets with the same name:
    [cow_obj, cow_obj]'; and a real clash (two folders with a cow.obj) listed every name but not the
    files that clash."""
    from pyshadow.bake import find_assets

    src = _sources(tmp_path / "src", ("cow.obj", "spot.obj"))
    assets, _ = find_assets([src, tmp_path / "src/../src"])
    assert [n for n, _ in assets] == ["cow", "spot"]
    other = _sources(tmp_path / "other", ("cow.obj",))
    with pytest.raises(ValueError, match="cow_obj") as e:
        find_assets([src, other])
    assert str(other / "cow.obj") in str(e.value) and "spot" not in str(e.value)


@pytest.mark.parametrize("arg", ["workers", "threads"])
@pytest.mark.parametrize("value", [2.5, "abc", float("nan"), "3"])
def test_workers_and_threads_must_be_ints(arg, value):
    """workers=2.5 was cut to 2 workers without a word, and 'abc' or nan raised int()'s message
    ('invalid literal for int()', 'cannot convert float NaN') naming neither argument."""
    from pyshadow.bake.runner import open_executor

    with pytest.raises(ValueError, match=f"{arg} must be a positive int"):
        open_executor("serial", **{arg: value})
