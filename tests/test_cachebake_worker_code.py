"""pyshadow.bake.bake_assets with a worker that runs other pyshadow code than the driver."""
from __future__ import annotations

import trimesh

import pyshadow.bake.library as library
from pyshadow.bake import AssetParams, bake_assets

PARAMS = AssetParams(theta=2, phi=4, resolution=8, samples=4)


def test_outputs_of_other_code_are_not_kept_under_this_codes_key(tmp_path, monkeypatch):
    """Was: the driver (here: new code, its digest replaced) stored what a worker of other code baked under
    the driver's key: 1 of 1 asset 'baked', and every rerun 'skipped' it, keeping the other code's outputs
    as this code's for good."""
    src = tmp_path / "src"
    src.mkdir()
    (src / "box.obj").write_bytes(trimesh.creation.box().export(file_type="obj").encode())
    real = library.code_digest()
    monkeypatch.setattr(library, "code_digest", lambda: "f" * 64)     # the driver's code; the worker's is real
    m = bake_assets(src, tmp_path / "out", PARAMS, executor="serial", progress=False)
    assert m["summary"] == {"baked": 0, "skipped": 0, "failed": 1, "interrupted": 0}
    (entry,) = m["assets"]
    assert "other pyshadow code" in entry["error"] and real[:12] in entry["error"]
    assert not (tmp_path / "out" / "records" / "box.json").exists()
    monkeypatch.setattr(library, "code_digest", lambda: real)         # the same code on both sides
    m = bake_assets(src, tmp_path / "out", PARAMS, executor="serial", progress=False)
    assert m["summary"]["baked"] == 1 and "code" not in m["assets"][0]
    m = bake_assets(src, tmp_path / "out", PARAMS, executor="serial", progress=False)
    assert m["summary"]["skipped"] == 1
