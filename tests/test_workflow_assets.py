"""pyshadow-bake assets: what a rerun trusts after the sources changed while a bake ran."""
from __future__ import annotations

import json

import numpy as np
import trimesh

from pyshadow.bake import AssetParams, bake_assets
from pyshadow.bake.params import asset_key, code_digest

PARAMS = AssetParams(theta=2, phi=4, resolution=8, samples=4)


def _tetra(scale: float) -> bytes:
    m = trimesh.Trimesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float) * scale,
                        [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], process=False)
    return m.export(file_type="obj").encode()


def test_a_source_changed_during_the_bake_is_keyed_by_the_bytes_baked(tmp_path):
    """Was: the key was the scan's (the file as it was when the bake started) and the outputs those of the
    file read later: an asset saved anew while a long bake ran was stored under its old content's key, and a
    rerun with the old content back skipped it, keeping the other content's CSM and mesh (here 2x the size:
    the baked vertices 2.0 where the source's are 1.0)."""
    src, out = tmp_path / "src", tmp_path / "out"
    src.mkdir()
    a, b = _tetra(1.0), _tetra(2.0)
    (src / "t.obj").write_bytes(a)

    def edit_after_the_scan(msg):       # the scan is done when the bake logs its plan; no file is read yet
        if "to bake" in msg:
            (src / "t.obj").write_bytes(b)

    m = bake_assets(src, out, PARAMS, executor="serial", progress=False, log=edit_after_the_scan)
    [e] = m["assets"]
    assert e["action"] == "baked"
    rec = json.loads((out / "records" / "t.json").read_text())
    assert rec["key"] == asset_key(rec["source_sha256"], PARAMS, code_digest()), "the key is not the baked bytes'"
    (src / "t.obj").write_bytes(a)      # the edit undone
    m2 = bake_assets(src, out, PARAMS, executor="serial", progress=False)
    assert [x["action"] for x in m2["assets"]] == ["baked"]
    baked = trimesh.load(out / "meshes" / "t.ply", process=False)
    assert np.abs(baked.vertices).max() == 1.0
