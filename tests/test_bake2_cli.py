"""Options of the frame bake that were dropped silently (pyshadow.bake.cli and frames), found by the
second audit of the bake."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.bake.cli import main
from pyshadow.bake.frames import bake_frames


@pytest.mark.parametrize("argv, message", [
    (["--no-ground", "--ground", "0.5"], "argument --ground: not allowed with argument --no-ground"),
    (["--ground", "0", "--no-ground"], "argument --no-ground: not allowed with argument --ground"),
    (["--no-cache", "--cache-dir", "c"], "argument --cache-dir: not allowed with argument --no-cache"),
])
def test_frames_options_that_contradict_each_other_are_usage_errors(tmp_path, capsys, argv, message):
    """Was: 'frames --no-ground --ground 0.5' rendered every frame without a ground (the 0.5 dropped
    silently), '--no-cache --cache-dir c' built every CSM without caching it: exit 0 either way. Now
    argparse refuses them (exit status 2) before anything is written."""
    with pytest.raises(SystemExit) as e:
        main(["frames", "-o", str(tmp_path / "out"), *argv])
    assert e.value.code == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_frames_default_csms_are_built_with_the_bakes_progress(tmp_path, monkeypatch):
    """Was: bake_frames' default CSMs (64x128 maps per caster: seconds to minutes each) were built
    with progress=False whatever the bake's progress: a long silent start. Now they follow it."""
    real = pyshadow.CoherentShadowMap.build
    seen = []

    def build(mesh, views, **kw):
        seen.append((len(views), kw.get("progress")))
        return real(mesh, pyshadow.ViewSet.zigzag(2, 2), resolution=8, progress=False)

    monkeypatch.setattr(pyshadow.CoherentShadowMap, "build", staticmethod(build))
    cam = pyshadow.Camera([3.0, 3.0, 3.0], [0.0, 0.0, 0.0], width=8, height=6)
    for i, progress in enumerate((True, False)):
        bake_frames(tmp_path / f"o{i}", [("box", trimesh.creation.box((1.0, 1.0, 1.0)), True)], cam,
                    np.eye(4)[None, None], samples=1, executor="serial", progress=progress)
    assert seen == [(64 * 128, True), (64 * 128, False)]
