"""Differential tests of the bake (pyshadow.bake): a bake's outputs against the same quantity computed
directly (Scene.render, Scene.vertex_ao), under rigid motion, and across reruns. Each test named after a
defect found in an audit says in its docstring what happened before; the others guard agreements
measured in that audit. The bakes are tiny (4x8 maps of 16 texels, images of a few pixels)."""
import bz2
import io
import json
import tarfile

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.bake import AssetParams, bake_assets, find_assets
from pyshadow.bake.assets import bake_asset, csm_file_bytes
from pyshadow.bake.frames import bake_frames, scene_payload
from pyshadow.bake.motion import read_motion, write_motion

BOX = trimesh.creation.box((1.0, 1.0, 1.0))
BOX.apply_translation((0.0, 0.5, 0.0))
FLOOR = trimesh.creation.box((4.0, 0.1, 4.0))


def _csm(name, mesh):
    return pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(4, 8), resolution=16, progress=False)


def _quarter_turns(frames, offset):
    """Per frame: the box still, the floor turned by f quarter turns (exact 0/1 entries) and moved by ``offset``."""
    T = np.tile(np.eye(4), (frames, 2, 1, 1))
    for f in range(frames):
        c, s = [1, 0, -1, 0][f % 4], [0, 1, 0, -1][f % 4]
        T[f, :, :3, 3] = offset
        T[f, 1, :3, :3] = [[c, 0, s], [0, 1, 0], [-s, 0, c]]
        T[f, 1, :3, 3] += [0.1 * f, -0.05, 0.0]
    return T


def test_frames_casts_as_numpy_bools_bake_like_python_bools(tmp_path):
    """Parts whose ``casts`` flag was a NumPy bool (``flags[i]`` of a bool array) made bake_frames raise
    TypeError "'numpy.bool' object cannot be interpreted as an integer" (scene_payload hashed
    ``bytes([casts])``), after the first caster's CSM was built. Now the scene, its key and every frame
    equal those of Python bools."""
    flags = np.array([True, False])
    cam = pyshadow.Camera([3.0, 2.0, 4.0], [0.0, 0.5, 0.0], width=8, height=6)
    render = {"samples": 2, "lookup": "nearest", "denoise": None}
    parts = [("box", BOX, True), ("floor", FLOOR, False)]
    numpy_parts = [("box", BOX, flags[0]), ("floor", FLOOR, flags[1])]
    a = scene_payload(parts, cam, ground=0.0, render=render, csm_for=_csm)
    b = scene_payload(numpy_parts, cam, ground=0.0, render=render, csm_for=_csm)
    assert a["key"] == b["key"] and [p["casts"] for p in b["parts"]] == [True, False]
    T = _quarter_turns(2, [0.0, 0.0, 0.0])
    ma = bake_frames(tmp_path / "a", parts, cam, T, samples=2, csm_for=_csm, executor="serial", progress=False)
    mb = bake_frames(tmp_path / "b", numpy_parts, cam, T, samples=2, csm_for=_csm, executor="serial",
                     progress=False)
    assert ma["summary"] == mb["summary"] == {"rendered": 2, "skipped": 0, "failed": 0, "interrupted": 0}
    assert ma["scene"] == mb["scene"]
    scene = pyshadow.Scene(ground=0.0)
    scene.add(_csm("box", BOX), T[1, 0], mesh=BOX)
    scene.add(FLOOR, T[1, 1], casts=False)
    direct = scene.render(cam, sampling=pyshadow.Sampling(2))
    for out in ("a", "b"):
        np.testing.assert_array_equal(pyshadow.read_image(tmp_path / out / "exr" / "frame_0001.exr"), direct.ao)
    assert (tmp_path / "a" / "png" / "frame_0001.png").read_bytes() == \
        (tmp_path / "b" / "png" / "frame_0001.png").read_bytes()


def test_frames_far_from_origin_and_resumed_equal_direct_renders(tmp_path):
    """Guard: a motion of exact quarter turns 1e6 from the origin, rendered in one run, equals each frame
    rendered directly (Scene.render), and a rerun after frames' records were lost renders just those,
    to the same pixels."""
    T = _quarter_turns(3, [1e6, 0.0, -1e3])
    cam = pyshadow.Camera([1e6 + 3.0, 2.0, -1e3 + 4.0], [1e6, 0.5, -1e3], width=6, height=5)
    parts = [("box", BOX, True), ("floor", FLOOR, True)]
    m = bake_frames(tmp_path, parts, cam, T, samples=2, csm_for=_csm, chunk=2, executor="serial", progress=False)
    assert m["summary"]["rendered"] == 3
    first = [pyshadow.read_image(tmp_path / "exr" / f"frame_{f:04d}.exr") for f in range(3)]
    scene = pyshadow.Scene(ground=0.0)
    for name, mesh, _ in parts:
        scene.add(pyshadow.CoherentShadowMap.load(tmp_path / "csm" / f"{name}.csm"), np.eye(4), mesh=mesh)
    for f in range(3):
        for i in range(2):
            scene.set_transform(i, T[f, i])
        np.testing.assert_array_equal(first[f], scene.render(cam, sampling=pyshadow.Sampling(2)).ao)
    for f in (0, 2):
        (tmp_path / "records" / f"frame_{f:04d}.json").unlink()
    again = bake_frames(tmp_path, parts, cam, T, samples=2, csm_for=_csm, chunk=1, executor="serial",
                        progress=False)
    assert again["summary"] == {"rendered": 2, "skipped": 1, "failed": 0, "interrupted": 0}
    for f in range(3):
        np.testing.assert_array_equal(pyshadow.read_image(tmp_path / "exr" / f"frame_{f:04d}.exr"), first[f])


def test_motion_files_round_trip_exactly(tmp_path):
    """Guard: quarter turns, scales 1e-3 .. 1e4 and translations up to 1e7 come back bit for bit."""
    T = _quarter_turns(4, [1e7, -3.25e3, 1e-3])
    T[:, 0, :3, :3] *= 1e-3
    T[:, 1, :3, :3] *= 1e4
    for ext in ("npz", "json"):
        got, names = read_motion(write_motion(tmp_path / f"m.{ext}", T, ["box", "floor"]))
        assert names == ["box", "floor"] and got.dtype == np.float64
        np.testing.assert_array_equal(got, T)


def test_asset_bake_equals_direct_vertex_ao_on_the_ground_and_far_away():
    """Guard: the AO stored in the baked PLY equals Scene.vertex_ao of the same CSM, bit for bit, and
    is the same for the mesh moved 1e5 away; the box's corners on the ground see (1 -+ 1/sqrt(3)) / 2
    of the cosine-weighted sky (a tilted plane's view factor), within 256 samples' error."""
    params = AssetParams(theta=4, phi=8, resolution=16, samples=256, ground=True)
    aos = []
    for offset in (0.0, 1e5):
        mesh = trimesh.creation.box((1.0, 1.0, 1.0))
        mesh.apply_translation((offset, offset, -offset))
        res = bake_asset("box", ".ply", mesh.export(file_type="ply"), params.to_dict(), "key")
        assert res["record"]["status"] == "baked"
        ply = trimesh.load(io.BytesIO(res["files"]["meshes/box.ply"]), file_type="ply", process=False)
        ao = ply.metadata["_ply_raw"]["vertex"]["data"]["ao"]
        v = np.asarray(ply.vertices, np.float64)
        scene = pyshadow.Scene(ground=float(v[:, 1].min()))
        scene.add(_csm("box", mesh), np.eye(4), mesh=mesh)
        np.testing.assert_array_equal(ao, scene.vertex_ao(0, sampling=pyshadow.Sampling(256)))
        aos.append(ao)
        low = v[:, 1] == v[:, 1].min()
        np.testing.assert_allclose(ao[low], (1 - 1 / np.sqrt(3)) / 2, atol=0.03)
        np.testing.assert_allclose(ao[~low], (1 + 1 / np.sqrt(3)) / 2, atol=0.03)
    np.testing.assert_array_equal(aos[0], aos[1])


def _gltf(folder, mesh):
    """``mesh`` as ``model.gltf`` with its buffers in separate ``.bin`` files, as trimesh exports it."""
    folder.mkdir(exist_ok=True)
    for name, data in trimesh.Scene(mesh).export(file_type="gltf").items():
        (folder / name).write_bytes(data)
    return folder / "model.gltf"


def test_gltf_with_buffer_files_bakes_like_the_mesh_loaded_directly(tmp_path):
    """A .gltf whose buffers are .bin files beside it (glTF's usual layout) failed to bake: "ValueError:
    model.gltf: could not be read as a mesh (gltf_buffer_0.bin)", the worker having only the .gltf's
    bytes, while pyshadow.load_mesh read it. Now its CSM and per-vertex AO equal those computed directly
    from the loaded mesh, and a changed buffer file bakes the asset again."""
    params = AssetParams(theta=4, phi=8, resolution=16, samples=16, ground=True)
    src = _gltf(tmp_path / "src", BOX)
    m = bake_assets(src.parent, tmp_path / "out", params, executor="serial", progress=False)
    assert m["summary"] == {"baked": 1, "skipped": 0, "failed": 0, "interrupted": 0}, m["assets"]
    mesh = pyshadow.load_mesh(src)
    csm = _csm("model", mesh)
    assert (tmp_path / "out" / "csm" / "model.csm").read_bytes() == csm_file_bytes(csm)
    scene = pyshadow.Scene(ground=float(mesh.vertices[:, 1].min()))
    scene.add(csm, np.eye(4), mesh=mesh)
    ply = trimesh.load(tmp_path / "out" / "meshes" / "model.ply", process=False)
    np.testing.assert_array_equal(ply.metadata["_ply_raw"]["vertex"]["data"]["ao"],
                                  scene.vertex_ao(0, sampling=pyshadow.Sampling(16)))
    again = bake_assets(src.parent, tmp_path / "out", params, executor="serial", progress=False)
    assert again["summary"]["skipped"] == 1
    moved = BOX.copy()
    moved.apply_scale(2.0)
    for name, data in trimesh.Scene(moved).export(file_type="gltf").items():
        if name.endswith(".bin"):               # the .gltf itself the same but for its bounds
            (src.parent / name).write_bytes(data)
    changed = bake_assets(src.parent, tmp_path / "out", params, executor="serial", progress=False)
    assert changed["summary"]["baked"] == 1 and changed["assets"][0]["mesh"]["vertices"] == 8


def test_side_files_are_only_files_beside_the_gltf(tmp_path):
    """Guard (part of the fix above): embedded (data:) buffers, absolute paths, paths through .. and
    missing files are not sent; other formats have none."""
    from pyshadow.bake.assets import side_files

    src = _gltf(tmp_path / "src", BOX)
    doc = json.loads(src.read_text())
    (tmp_path / "outside.bin").write_bytes(b"x")
    doc["buffers"] += [{"uri": "../outside.bin"}, {"uri": "/etc/hostname"}, {"uri": "missing.bin"},
                       {"uri": "data:application/octet-stream;base64,AA=="}, {"byteLength": 4}]
    src.write_text(json.dumps(doc))
    assert sorted(side_files(src)) == ["gltf_buffer_0.bin", "gltf_buffer_1.bin"]
    assert side_files(tmp_path / "src" / "gltf_buffer_0.bin") == {}
    (tmp_path / "bad.gltf").write_text("[1, 2")
    assert side_files(tmp_path / "bad.gltf") == {}


def test_compressed_meshes_bake_like_loaded_directly(tmp_path):
    """Meshes that pyshadow.load_mesh reads compressed were not baked: ``box.tar.gz`` in a folder was
    passed over as no mesh (only its last extension, ``.gz``, was looked at) and, named itself, failed
    with "unknown or unsupported mesh format '.gz'"; ``ball.ply.bz2`` failed with "the file holds no
    geometry" (the worker's copy, ``asset.bz2``, had lost the ``.ply``). Now each one's CSM and AO
    equal those of the mesh loaded directly."""
    src = tmp_path / "src"
    src.mkdir()
    ply = BOX.export(file_type="ply")
    with tarfile.open(src / "box.tar.gz", "w:gz") as tar:
        info = tarfile.TarInfo("box.ply")
        info.size = len(ply)
        tar.addfile(info, io.BytesIO(ply))
    ball = trimesh.creation.icosphere(1, 0.5)
    (src / "ball.ply.bz2").write_bytes(bz2.compress(ball.export(file_type="ply")))
    assets, ignored = find_assets(src)
    assert [n for n, _ in assets] == ["ball.ply", "box.tar"] and ignored == []
    params = AssetParams(theta=4, phi=8, resolution=16, samples=16, ground=True)
    for out, sources in (("folder", src), ("files", [src / "box.tar.gz", src / "ball.ply.bz2"])):
        m = bake_assets(sources, tmp_path / out, params, executor="serial", progress=False)
        assert m["summary"]["baked"] == 2, m["assets"]
        for name, path in assets:
            mesh = pyshadow.load_mesh(path)
            csm = _csm(name, mesh)
            assert (tmp_path / out / "csm" / f"{name}.csm").read_bytes() == csm_file_bytes(csm)
            scene = pyshadow.Scene(ground=float(mesh.vertices[:, 1].min()))
            scene.add(csm, np.eye(4), mesh=mesh)
            baked = trimesh.load(tmp_path / out / "meshes" / f"{name}.ply", process=False)
            np.testing.assert_array_equal(baked.metadata["_ply_raw"]["vertex"]["data"]["ao"],
                                          scene.vertex_ao(0, sampling=pyshadow.Sampling(16)))


def test_frames_match_a_motion_files_bodies_by_name():
    """Was: pyshadow-bake frames applied a motion file's transforms in its order whatever its ``names``: a file
    listing the bundled scene's bodies in another order moved each body by another's transforms. Now names that
    are the bodies' in another order reorder the transforms; other names (labels) keep the order, as before."""
    from pyshadow.bake.cli import _bodies_in_order

    parts = [("bunny", None, True), ("torus", None, True), ("wall", None, False)]
    T = np.random.default_rng(1).normal(size=(3, 3, 4, 4))
    said = []
    got = _bodies_in_order(T, ["wall", "bunny", "torus"], parts, "--motion m.npz", "the bundled scene has",
                           said.append)
    np.testing.assert_array_equal(got, T[:, [1, 2, 0]])
    assert said == ["--motion m.npz lists its bodies as ['wall', 'bunny', 'torus']: matched to "
                    "['bunny', 'torus', 'wall'] by name"]
    for names in (None, ["bunny", "torus", "wall"], ["a", "b", "c"]):
        assert _bodies_in_order(T, names, parts, "m", "x", said.append) is T
    assert len(said) == 1
    with pytest.raises(ValueError, match=r"--motion m.npz moves 3 bodies, --mesh gives 2 \(bunny, torus\)"):
        _bodies_in_order(T, None, parts[:2], "--motion m.npz", "--mesh gives", said.append)
