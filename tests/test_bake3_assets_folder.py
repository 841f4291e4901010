"""An asset bake into a folder that holds another bake's assets (pyshadow.bake.library), found by the third
audit of the bake. Tiny bakes (2x2 maps of 8 texels, one sample, serial)."""
import trimesh

from pyshadow.bake import AssetParams, bake_assets


def test_a_bake_of_other_parameters_says_it_bakes_over_the_folders_assets(tmp_path):
    """Was: two assets at 1 sample, then at 2 samples into the same folder: the second run logged only
    '2 assets: 2 to bake, 0 done or unreadable' and replaced the first's assets without a word; stopped part
    way it left a folder of both bakes' assets. Now it names the parameters that differ and how many
    assets it bakes over; a changed source alone (same parameters) is no other bake."""
    src = tmp_path / "src"
    src.mkdir()
    trimesh.creation.box((1.0, 1.0, 1.0)).export(src / "box.obj")
    trimesh.creation.icosphere(1).export(src / "ball.obj")
    p1 = AssetParams(theta=2, phi=2, resolution=8, samples=1)
    bake_assets(src, tmp_path / "out", p1, executor="serial", progress=False)
    notes = []
    p2 = AssetParams(theta=2, phi=2, resolution=8, samples=2)
    m = bake_assets(src, tmp_path / "out", p2, executor="serial", progress=False, log=notes.append)
    assert m["summary"]["baked"] == 2
    other = [n for n in notes if "baked with other parameters" in n]
    assert len(other) == 1 and "holds 2 assets" in other[0] and "samples 1 there, 2 here" in other[0], notes
    trimesh.creation.box((1.0, 2.0, 1.0)).export(src / "box.obj")
    notes.clear()
    m = bake_assets(src, tmp_path / "out", p2, executor="serial", progress=False, log=notes.append)
    assert m["summary"]["baked"] == 1 and not [n for n in notes if "other parameters" in n], notes
