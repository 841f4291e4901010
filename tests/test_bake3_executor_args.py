"""Executor arguments of the bakes that were dropped without a word (pyshadow.bake.runner, frames, library,
cli), found by the third audit of the bake. Tiny bakes (2x2 maps of 8 texels, 8x6 images, one sample)."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.bake import AssetParams, bake_assets
from pyshadow.bake.cli import main
from pyshadow.bake.frames import bake_frames

BOX = trimesh.creation.box((1.0, 1.0, 1.0))


def _frames(out, built, **kw):
    def csm_for(name, mesh):
        built.append(name)
        return pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(2, 2), resolution=8, progress=False)

    cam = pyshadow.Camera([3.0, 3.0, 3.0], [0.0, 0.0, 0.0], width=8, height=6)
    return bake_frames(out, [("box", BOX, True)], cam, np.eye(4)[None, None], samples=1, csm_for=csm_for,
                       progress=False, **kw)


def test_frame_rerun_with_everything_done_checks_the_executor(tmp_path):
    """Was: a frame bake's rerun with every frame done opened no executor, so executor='bogus' passed and
    the manifest said executor 'bogus'. Now ValueError before a CSM is built, as on a first run."""
    _frames(tmp_path / "out", [], executor="serial")
    built = []
    with pytest.raises(ValueError, match="executor must be one of"):
        _frames(tmp_path / "out", built, executor="bogus")
    assert built == []


@pytest.mark.parametrize("command", ["frames", "assets"])
def test_cli_serial_with_workers_is_a_usage_error(tmp_path, capsys, command):
    """Was: 'pyshadow-bake frames --executor serial --workers 4' ran serially (exit 0) and said nothing of the
    4 workers asked for. Now exit status 2, the message naming --workers 4, before the output folder is made."""
    # small, should it run: a box, or 1 frame of 8x6 at 2x2 maps of 8 texels
    trimesh.creation.box((1.0, 1.0, 1.0)).export(tmp_path / "box.obj")
    src = [str(tmp_path / "box.obj")] if command == "assets" else ["--frames", "1", "--size", "8x6", "--no-cache"]
    with pytest.raises(SystemExit) as e:
        main([command, *src, "-o", str(tmp_path / "out"), "--maps", "2x2", "--resolution", "8", "--samples", "1",
              "--executor", "serial", "--workers", "4", "--quiet"])
    assert e.value.code == 2
    assert "--workers 4: the serial executor" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_asset_rerun_with_everything_done_checks_the_executor(tmp_path):
    """Was: a rerun with every asset done opened no executor, so executor='bogus' (or a scheduler address
    with the process pool) passed: a manifest saying executor 'bogus'. Now refused as the first run refuses it,
    before the manifest of the done bake is replaced."""
    src = tmp_path / "src"
    src.mkdir()
    BOX.export(src / "box.obj")
    p = AssetParams(theta=2, phi=2, resolution=8, samples=1)
    bake_assets(src, tmp_path / "out", p, executor="serial", progress=False)
    manifest = (tmp_path / "out/manifest.json").read_bytes()
    for kw in ({"executor": "bogus"}, {"executor": "process", "scheduler": "tcp://127.0.0.1:1"}):
        with pytest.raises(ValueError, match="executor must be one of|scheduler address needs the 'dask'"):
            bake_assets(src, tmp_path / "out", p, progress=False, **kw)
    assert (tmp_path / "out/manifest.json").read_bytes() == manifest
