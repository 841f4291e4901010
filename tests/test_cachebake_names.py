"""pyshadow.bake.find_assets: output names of mesh files named in other scripts than ASCII Latin."""
from __future__ import annotations

import unicodedata

import trimesh

from pyshadow.bake import AssetParams, bake_assets, find_assets


def _box(path):
    path.write_bytes(trimesh.creation.box().export(file_type="obj").encode())


def test_names_in_other_scripts_do_not_clash(tmp_path):
    """Was: every non-ASCII character became '_', so 椅子.obj and 本棚.obj were both '__' (then '__obj'),
    and find_assets raised 'assets with the same name' for the whole folder (0 of 3 assets baked);
    Stühle.obj was named 'St_hle'."""
    for stem in ("椅子", "本棚", "机", "Stühle", "a b"):
        _box(tmp_path / f"{stem}.obj")
    assets, ignored = find_assets(tmp_path)
    assert sorted(n for n, _ in assets) == sorted(["椅子", "本棚", "机", "Stühle", "a_b"])
    assert ignored == []


def test_decomposed_accent_is_composed(tmp_path):
    """Was: a name spelt as macOS stores it ('cafe' and a combining accent) became 'cafe_'."""
    _box(tmp_path / (unicodedata.normalize("NFD", "café") + ".obj"))
    assert [n for n, _ in find_assets(tmp_path)[0]] == [unicodedata.normalize("NFC", "café")]


def test_a_folder_of_cjk_names_bakes_and_reruns(tmp_path):
    """Was: ValueError 'assets with the same name: ___obj (.../本棚.obj), ___obj (.../椅子.obj)' before anything
    was baked."""
    src = tmp_path / "src"
    src.mkdir()
    for stem in ("椅子", "本棚"):
        _box(src / f"{stem}.obj")
    params = AssetParams(theta=2, phi=4, resolution=8, samples=4)
    m = bake_assets(src, tmp_path / "out", params, executor="serial", progress=False)
    assert m["summary"] == {"baked": 2, "skipped": 0, "failed": 0, "interrupted": 0}, m["assets"]
    assert (tmp_path / "out" / "csm" / "椅子.csm").is_file()
    assert (tmp_path / "out" / "meshes" / "本棚.ply").is_file()
    m = bake_assets(src, tmp_path / "out", params, executor="serial", progress=False)
    assert m["summary"]["skipped"] == 2
