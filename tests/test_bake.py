"""Batch baking (pyshadow.bake): assets and frames on a Dask LocalCluster, an external
Dask cluster with a worker killed mid-run, a process pool and serially; reruns,
damaged outputs, interrupts, and the files' contents against direct calls."""
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.bake import AssetParams, bake_assets, find_assets
from pyshadow.bake.frames import bake_frames, render_chunk, scene_payload
from pyshadow.bake.motion import default_motion, read_motion, write_motion
from pyshadow.bake.params import code_digest
from pyshadow.bake.runner import open_executor, sweep_temporaries

pytest.importorskip("distributed")

# small CSMs and few samples: the bake machinery is under test, not the CSM's accuracy
PARAMS = AssetParams(theta=16, phi=32, resolution=64, samples=16)
BAD = {"corrupt": "corrupt.obj", "empty": "empty.stl"}


def _sources(folder: Path) -> Path:
    folder.mkdir()
    for name in pyshadow.data.MESHES:
        pyshadow.data.mesh_file(name, folder)
    rng = np.random.default_rng(0)
    (folder / "corrupt.obj").write_bytes(rng.integers(0, 256, 3000, dtype=np.uint8).tobytes())
    (folder / "empty.stl").write_bytes(b"")
    (folder / "notes.txt").write_text("not a mesh")
    return folder


def _outputs(out: Path) -> dict:
    """Relative path -> bytes of every baked file (CSMs and meshes)."""
    return {str(p.relative_to(out)): p.read_bytes() for sub in ("csm", "meshes")
            for p in sorted((out / sub).iterdir())}


def _temporaries(out: Path) -> list:
    return [p for p in out.rglob("*") if ".tmp" in p.name]


def _done_marks(out: Path) -> list:
    """The assets' records, not a record's temporary file (pathlib's ``*`` matches hidden names)."""
    return [p for p in out.glob("records/*.json") if not p.name.startswith(".")]


@pytest.fixture(scope="module")
def sources(tmp_path_factory):
    return _sources(tmp_path_factory.mktemp("bake") / "src")


@pytest.fixture(scope="module")
def serial(sources, tmp_path_factory):
    """The single-process bake every other executor is compared with."""
    out = tmp_path_factory.mktemp("serial")
    m = bake_assets(sources, out, PARAMS, executor="serial", progress=False)
    return out, m


def test_find_assets_names_and_ignores(tmp_path):
    for f in ("a.obj", "a.PLY", "b c.stl", ".hidden.obj", "readme.md"):
        (tmp_path / f).write_text("x")
    assets, ignored = find_assets(tmp_path)
    assert [n for n, _ in assets] == ["a_ply", "a_obj", "b_c"]
    assert [Path(p).name for p in ignored] == ["readme.md"]
    with pytest.raises(FileNotFoundError, match="no such mesh file"):
        find_assets(tmp_path / "missing")


def test_serial_bake_reports_bad_assets_and_matches_direct_calls(serial, sources):
    out, m = serial
    by = {e["name"]: e for e in m["assets"]}
    assert m["summary"] == {"baked": 9, "skipped": 0, "failed": 2, "interrupted": 0}
    assert by["corrupt"]["action"] == by["empty"]["action"] == "failed"
    assert "corrupt.obj" in by["corrupt"]["error"] and "empty.stl" in by["empty"]["error"]
    assert m["ignored"] == [str(sources / "notes.txt")]
    assert not (out / "csm" / "corrupt.csm").exists() and not (out / "records" / "empty.json").exists()
    # the spot asset against the same steps done directly in this process
    mesh = pyshadow.load_mesh(sources / "spot.obj")
    csm = pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(16, 32), resolution=64, progress=False)
    direct = out / "direct.csm"
    csm.save(direct, reproducible=True)
    assert (out / "csm" / "spot.csm").read_bytes() == direct.read_bytes()
    scene = pyshadow.Scene()
    scene.add(csm, np.eye(4), mesh=mesh)
    ao, bent = scene.vertex_ao(0, sampling=pyshadow.Sampling(16), return_bent_normals=True)
    ply = trimesh.load(out / "meshes" / "spot.ply", process=False)
    raw = ply.metadata["_ply_raw"]["vertex"]["data"]
    np.testing.assert_array_equal(raw["ao"], ao)
    np.testing.assert_array_equal(np.stack([raw["bent_nx"], raw["bent_ny"], raw["bent_nz"]], 1), bent)
    np.testing.assert_array_equal(ply.vertices, mesh.vertices.astype(np.float32))
    grey = np.round(255 * pyshadow.io.linear_to_srgb(ao)).astype(np.uint8)
    np.testing.assert_array_equal(ply.visual.vertex_colors[:, 0], grey)
    rec = json.loads((out / "records" / "spot.json").read_text())
    assert rec["key"] == by["spot"]["key"] and rec["mesh"]["vertices"] == len(mesh.vertices)
    assert rec["ao"]["mean"] == pytest.approx(float(ao.mean()))


def test_local_cluster_bit_identical_rerun_and_redo(serial, sources, tmp_path):
    ref, _ = serial
    out = tmp_path / "dask"
    m = bake_assets(sources, out, PARAMS, executor="dask", workers=2, progress=False)
    assert m["executor"]["kind"] == "dask" and m["executor"]["workers"] == 2
    assert m["summary"] == {"baked": 9, "skipped": 0, "failed": 2, "interrupted": 0}
    assert len({e["worker"] for e in m["assets"] if e["action"] == "baked"}) == 2   # both workers baked
    assert _outputs(out) == _outputs(ref)            # every good asset, bit for bit
    assert {e["name"] for e in m["assets"] if e["action"] == "failed"} == set(BAD)
    assert _temporaries(out) == []
    stamps = {p: p.stat().st_mtime_ns for p in out.rglob("*") if p.is_file() and p.name != "manifest.json"}
    # a rerun bakes nothing and rewrites no output (the bad files are tried again and fail again)
    m2 = bake_assets(sources, out, PARAMS, executor="dask", workers=2, progress=False)
    assert m2["summary"] == {"baked": 0, "skipped": 9, "failed": 2, "interrupted": 0}
    assert {p: p.stat().st_mtime_ns for p in stamps} == stamps
    # one output deleted: only that asset is baked again
    (out / "meshes" / "spot.ply").unlink()
    m3 = bake_assets(sources, out, PARAMS, executor="dask", workers=2, progress=False)
    assert [e["name"] for e in m3["assets"] if e["action"] == "baked"] == ["spot"]
    assert m3["summary"]["skipped"] == 8
    assert _outputs(out) == _outputs(ref)
    # one output damaged (a bit flipped, same size): only that asset is baked again
    damaged = bytearray((out / "csm" / "teapot.csm").read_bytes())
    damaged[1000] ^= 1
    (out / "csm" / "teapot.csm").write_bytes(bytes(damaged))
    m3 = bake_assets(sources, out, PARAMS, executor="serial", progress=False)
    assert [e["name"] for e in m3["assets"] if e["action"] == "baked"] == ["teapot"]
    assert _outputs(out) == _outputs(ref)
    # new parameters are a new key: everything is baked again
    m4 = bake_assets(sources, out, AssetParams(theta=16, phi=32, resolution=64, samples=8), executor="serial",
                     progress=False)
    assert m4["summary"]["baked"] == 9


def test_process_pool_without_dask_matches(serial, sources, tmp_path, monkeypatch):
    ref, _ = serial
    import pyshadow.bake.runner as runner

    monkeypatch.setattr(runner, "dask_available", lambda: False)
    ex = open_executor(None, workers=2)
    try:
        assert ex.kind == "process"
    finally:
        ex.close()
    with pytest.raises(ImportError, match="pyshadow\\[dask\\]"):
        open_executor("dask")
    m = bake_assets(sources, tmp_path, PARAMS, workers=2, progress=False)
    assert m["executor"]["kind"] == "process"
    assert _outputs(tmp_path) == _outputs(ref)


def _start_cluster(tmp_path, n):
    """A Dask scheduler and ``n`` single-threaded workers without nannies (a killed one stays dead)."""
    sched_file = tmp_path / "scheduler.json"
    env = dict(os.environ, **pyshadow.bake.runner.thread_env(1))
    procs = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--scheduler-file",
                               str(sched_file), "--port", "0", "--dashboard-address", ":0", "--no-show"],
                              env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    deadline = time.time() + 60
    while not sched_file.exists() and time.time() < deadline:
        time.sleep(0.2)
    for _ in range(n):
        procs.append(subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", "--scheduler-file",
                                       str(sched_file), "--nthreads", "1", "--no-nanny", "--no-dashboard"],
                                      env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
    return sched_file, procs


def test_worker_killed_mid_run_job_completes_on_the_other(serial, sources, tmp_path):
    from distributed import Client

    ref, _ = serial
    sched_file, procs = _start_cluster(tmp_path, 2)
    try:
        client = Client(scheduler_file=str(sched_file), timeout="60s")
        client.wait_for_workers(2, timeout=120)
        pids = client.run(os.getpid)                     # worker address -> pid
        victim = sorted(pids)[0]
        killed = {}

        def kill_when_busy():
            deadline = time.time() + 120
            while time.time() < deadline:
                busy = client.processing(workers=[victim]).get(victim, ())
                if busy:
                    os.kill(pids[victim], signal.SIGKILL)
                    killed["tasks"] = list(busy)
                    return
                time.sleep(0.01)

        t = threading.Thread(target=kill_when_busy)
        t.start()
        m = bake_assets(sources, tmp_path / "out", PARAMS, scheduler=str(sched_file), progress=False)
        t.join()
        assert killed["tasks"], "the worker was never seen with a task"
        assert m["summary"] == {"baked": 9, "skipped": 0, "failed": 2, "interrupted": 0}
        assert _outputs(tmp_path / "out") == _outputs(ref)
        assert list(client.scheduler_info()["workers"]) == [a for a in pids if a != victim]
        survivor = f":{pids[[a for a in pids if a != victim][0]]}"
        late = [e for e in m["assets"] if e["action"] == "baked" and e["worker"].endswith(survivor)]
        assert late, "nothing was baked by the surviving worker"
        client.close()
    finally:
        for p in procs:
            p.kill()
            p.wait()


def test_interrupt_leaves_complete_files_and_rerun_finishes(serial, sources, tmp_path):
    ref, _ = serial
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "pyshadow.bake", "assets", str(sources), "-o", str(out), "--maps", "16x32",
           "--resolution", "64", "--samples", "16", "--workers", "2", "--quiet"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    deadline = time.time() + 300
    while time.time() < deadline and len(_done_marks(out)) < 2:
        time.sleep(0.05)
    marked = len(_done_marks(out))
    os.killpg(proc.pid, signal.SIGINT)                   # Ctrl-C at a terminal: the whole process group
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130, stderr.decode()[-2000:]
    m = json.loads((out / "manifest.json").read_text())
    assert m["summary"]["interrupted"] >= 1, m["summary"]
    assert _temporaries(out) == []
    assert marked >= 2, f"only {marked} assets were done after 300 s"
    for rec in _done_marks(out):                          # every asset marked done is complete
        for rel, meta in json.loads(rec.read_text())["outputs"].items():
            assert (out / rel).read_bytes() == (ref / rel).read_bytes()
    m2 = bake_assets(sources, out, PARAMS, executor="serial", progress=False)
    assert m2["summary"]["skipped"] == 9 - m2["summary"]["baked"] >= 2
    assert _outputs(out) == _outputs(ref)


def test_sweep_temporaries_removes_only_atomic_leftovers(tmp_path):
    keep = [tmp_path / "a.csm", tmp_path / ".hidden", tmp_path / "x.tmp"]
    gone = [tmp_path / ".a.0123456789ab.tmp.csm", tmp_path / "sub" / ".frame.abcdefabcdef.tmp.png"]
    for p in keep + gone:
        p.parent.mkdir(exist_ok=True)
        p.write_text("x")
    assert sorted(sweep_temporaries(tmp_path)) == sorted(gone)
    assert all(p.exists() for p in keep) and not any(p.exists() for p in gone)


# ---------------------------------------------------------------- motion files and frames
def test_motion_round_trip_and_rigidity(tmp_path):
    T, names = default_motion(6)
    for ext in ("npz", "json"):
        write_motion(tmp_path / f"m.{ext}", T, names)
        T2, n2 = read_motion(tmp_path / f"m.{ext}")
        np.testing.assert_array_equal(T2, T)
        assert n2 == names
    bad = T.copy()
    bad[3, 1, 0, 0] *= 1.5                               # stretched along x: not rigid
    with pytest.raises(ValueError, match="frame 3, body 1.*not rigid"):
        write_motion(tmp_path / "bad.npz", bad)
    with pytest.raises(ValueError, match="shape"):
        write_motion(tmp_path / "bad.npz", T[0])
    with pytest.raises(ValueError, match=r"\.npz or \.json"):
        read_motion(tmp_path / "m.txt")


def test_default_motion_keeps_bodies_on_the_ground_and_apart():
    T, names = default_motion(12)
    parts = pyshadow.data.default_parts()
    assert names == [p[0] for p in parts]
    lows, centres = {}, {}
    for b, (name, mesh, T0, casts) in enumerate(parts):
        np.testing.assert_allclose(T[0, b], T0, atol=1e-12)             # frame 0 is the bundled scene
        v = np.asarray(mesh.vertices)
        w = np.einsum("fij,vj->fvi", T[:, b, :3, :3], v) + T[:, b, None, :3, 3]
        lows[name] = w[..., 1].min(axis=1)
        c = w.mean(axis=1)
        centres[name] = (c, np.linalg.norm((w - c[:, None])[..., [0, 2]], axis=2).max())
    np.testing.assert_allclose(lows["bunny"], 0.0, atol=1e-9)
    np.testing.assert_allclose(lows["torus"], 0.0, atol=1e-9)
    (cb, rb), (ct, rt) = centres["bunny"], centres["torus"]
    assert (np.linalg.norm((cb - ct)[:, [0, 2]], axis=1) > rb + rt).all()   # their swept cylinders are apart


def _small_frames(tmp_path, executor, frames=5):
    T, _ = default_motion(frames)
    parts = [(n, m, c) for n, m, _, c in pyshadow.data.default_parts()]
    cam = pyshadow.Camera([2.4, 2.1, 4.8], [0.8, 0.5, 0.0], fov_y=45.0, width=96, height=72)

    def csm_for(name, mesh):
        return pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(16, 32), resolution=64,
                                                progress=False)

    m = bake_frames(tmp_path, parts, cam, T, samples=8, csm_for=csm_for, chunk=2, executor=executor, workers=2,
                    progress=False)
    return m, parts, cam, T


def test_frames_on_dask_equal_serial_and_direct_render(tmp_path):
    ms, parts, cam, T = _small_frames(tmp_path / "serial", "serial")
    md, *_ = _small_frames(tmp_path / "dask", "dask")
    assert ms["summary"]["rendered"] == md["summary"]["rendered"] == 5
    for f in range(5):
        a = pyshadow.read_image(tmp_path / "serial" / "exr" / f"frame_{f:04d}.exr")
        b = pyshadow.read_image(tmp_path / "dask" / "exr" / f"frame_{f:04d}.exr")
        np.testing.assert_array_equal(a, b)
        png = f"png/frame_{f:04d}.png"
        assert (tmp_path / "serial" / png).read_bytes() == (tmp_path / "dask" / png).read_bytes()
    # frame 3 rendered directly, in this process, from the same CSM files
    scene = pyshadow.Scene(ground=0.0)
    for (name, mesh, casts), M in zip(parts, T[3]):
        if casts:
            scene.add(pyshadow.CoherentShadowMap.load(tmp_path / "dask" / "csm" / f"{name}.csm"), M, mesh=mesh)
        else:
            scene.add(mesh, M, casts=False)
    direct = scene.render(cam, sampling=pyshadow.Sampling(8))
    np.testing.assert_array_equal(pyshadow.read_image(tmp_path / "dask" / "exr" / "frame_0003.exr"), direct.ao)
    # the turning bodies change the image from frame to frame
    assert not np.array_equal(pyshadow.read_image(tmp_path / "dask" / "exr" / "frame_0000.exr"), direct.ao)
    again, *_ = _small_frames(tmp_path / "dask", "dask")
    assert again["summary"] == {"rendered": 0, "skipped": 5, "failed": 0, "interrupted": 0}


def test_render_chunk_keeps_one_scene_per_worker():
    T, _ = default_motion(2)
    parts = [(n, m, c) for n, m, _, c in pyshadow.data.default_parts()]
    cam = pyshadow.Camera([2.4, 2.1, 4.8], [0.8, 0.5, 0.0], width=32, height=24)
    built = []

    def csm_for(name, mesh):
        built.append(name)
        return pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(8, 16), resolution=32,
                                                progress=False)

    payload = scene_payload(parts, cam, ground=0.0, render={"samples": 4, "lookup": "nearest", "denoise": None},
                            csm_for=csm_for)
    assert built == ["bunny", "torus"]                   # receivers get no CSM
    from pyshadow.bake import frames as fr

    a = render_chunk([0], T[:1], payload)
    scene = fr._SCENES[payload["key"]][0]
    b = render_chunk([1, 0], T[[1, 0]], payload)
    assert fr._SCENES[payload["key"]][0] is scene         # the scene is built once, then reused
    assert b[1]["files"]["png/frame_0000.png"] == a[0]["files"]["png/frame_0000.png"]
    assert b[0]["files"]["png/frame_0001.png"] != a[0]["files"]["png/frame_0000.png"]


def test_cli_assets_and_frames_errors(tmp_path, capsys):
    from pyshadow.bake.cli import main

    src = tmp_path / "src"
    src.mkdir()
    pyshadow.data.mesh_file("suzanne.ply", src)
    rc = main(["assets", str(src), "-o", str(tmp_path / "out"), "--maps", "8x16", "--resolution", "32",
               "--samples", "4", "--executor", "serial", "--quiet", "--format", "glb"])
    text = capsys.readouterr().out
    assert rc == 0 and "suzanne" in text and "1 baked" in text
    glb = trimesh.load(tmp_path / "out" / "meshes" / "suzanne.glb", force="mesh", process=False)
    rec = json.loads((tmp_path / "out" / "records" / "suzanne.json").read_text())
    assert glb.vertex_attributes["_ao"].mean() == pytest.approx(rec["ao"]["mean"], rel=1e-6)
    with pytest.raises(SystemExit):
        main(["frames", "-o", str(tmp_path / "f"), "--mesh", str(src / "suzanne.ply")])   # no --motion
    assert "--mesh needs --motion" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["assets", str(tmp_path / "nope"), "-o", str(tmp_path / "o2")])
    assert "no such mesh file" in capsys.readouterr().err


def test_reproducible_csm_files(tmp_path):
    mesh = pyshadow.data.mesh("suzanne")
    views = pyshadow.ViewSet.zigzag(8, 16)
    files = []
    for i in range(2):
        csm = pyshadow.CoherentShadowMap.build(mesh, views, resolution=32, progress=False)
        files.append((csm.save(tmp_path / f"r{i}.csm", reproducible=True), csm.save(tmp_path / f"t{i}.csm")))
    (r0, t0), (r1, t1) = files
    assert r0.read_bytes() == r1.read_bytes()
    back = pyshadow.CoherentShadowMap.load(r0)
    assert np.isnan(back.stats["build_seconds"])
    assert pyshadow.CoherentShadowMap.load(t0).stats["build_seconds"] > 0   # the plain file keeps its build time
    for a in ("offsets", "iend", "depth"):
        np.testing.assert_array_equal(getattr(back, a), getattr(pyshadow.CoherentShadowMap.load(t0), a))


def test_without_dask_installed_a_process_pool_bakes(serial, sources, tmp_path):
    ref, _ = serial
    code = ("import sys, json\n"
            "sys.modules['distributed'] = None; sys.modules['dask'] = None   # as if not installed\n"
            "from pyshadow.bake import AssetParams, bake_assets\n"
            "if __name__ == '__main__':\n"
            f"    m = bake_assets({str(sources)!r}, {str(tmp_path)!r}, AssetParams(**{PARAMS.to_dict()!r}),\n"
            "                    workers=2, progress=False)\n"
            "    print(json.dumps([m['executor']['kind'], m['summary']]))\n")
    script = tmp_path / "nodask.py"
    script.write_text(code)
    res = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    kind, summary = json.loads(res.stdout.strip().splitlines()[-1])
    assert kind == "process" and summary == {"baked": 9, "skipped": 0, "failed": 2, "interrupted": 0}
    assert _outputs(tmp_path) == _outputs(ref)


def test_max_error_is_the_error_models_choice():
    import json

    from pyshadow.bake import choose
    from pyshadow.csm.choose import choose_csm

    mesh = pyshadow.data.mesh("spot")
    csm, c = choose.choose_csm(mesh, AssetParams(max_error=0.03))
    assert c["met"] and c["measured"]["disagreement"] <= 0.03
    again, direct = choose_csm(mesh, 0.03)                  # deterministic: every worker chooses alike
    assert (again.maps, again.resolution) == (csm.maps, csm.resolution)
    assert direct["measured"] == c["measured"]
    assert {k: v for k, v in direct["predicted"].items() if k != "seconds"} == \
        {k: v for k, v in c["predicted"].items() if k != "seconds"}
    json.dumps(c)                                            # the manifest can hold it


# ---------------------------------------------------------------- Ctrl-C while the executor closes, CLI checks
class _CloseInterrupted:
    """A serial executor that a Ctrl-C cuts short while it closes (as it can a Dask cluster's seconds-long close)."""

    def __init__(self):
        from pyshadow.bake.runner import _Serial

        self._ex, self.kind, self.workers, self.threads = _Serial(), "serial", 1, None

    def run(self, *args, **kwargs):
        return self._ex.run(*args, **kwargs)

    def close(self):
        raise KeyboardInterrupt


def test_interrupt_while_the_executor_closes_still_writes_the_manifest(tmp_path, monkeypatch, capsys):
    from pyshadow.bake import frames as fr
    from pyshadow.bake import library
    from pyshadow.bake.cli import main

    src, out = tmp_path / "src", tmp_path / "out"
    src.mkdir()
    out.mkdir()
    pyshadow.data.mesh_file("suzanne.ply", src)
    (out / "manifest.json").write_text('{"stale": true}')           # an earlier run's
    monkeypatch.setattr(library, "open_executor", lambda *a, **k: _CloseInterrupted())
    rc = main(["assets", str(src), "-o", str(out), "--maps", "8x16", "--resolution", "32", "--samples", "4",
               "--quiet"])
    assert rc == 130
    assert capsys.readouterr().err == ("interrupted: finished outputs are kept, nothing half-written; "
                                       "rerun to continue\n")
    m = json.loads((out / "manifest.json").read_text())
    assert m["schema"] == library.MANIFEST_SCHEMA and m["executor"]["kind"] == "serial"
    assert m["summary"] == {"baked": 1, "skipped": 0, "failed": 0, "interrupted": 0}
    assert [p.name for p in _done_marks(out)] == ["suzanne.json"] and _temporaries(out) == []
    # the same for frames
    frames = tmp_path / "frames"
    frames.mkdir()
    (frames / "manifest.json").write_text('{"stale": true}')
    monkeypatch.setattr(fr, "open_executor", lambda *a, **k: _CloseInterrupted())
    T, _ = default_motion(2)
    parts = [(n, m, c) for n, m, _, c in pyshadow.data.default_parts()]
    cam = pyshadow.Camera([2.4, 2.1, 4.8], [0.8, 0.5, 0.0], width=32, height=24)

    def csm_for(name, mesh):
        return pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(8, 16), resolution=32,
                                                progress=False)

    with pytest.raises(KeyboardInterrupt):
        bake_frames(frames, parts, cam, T, samples=4, csm_for=csm_for, progress=False)
    m = json.loads((frames / "manifest.json").read_text())
    assert m["schema"] == fr.FRAMES_SCHEMA
    assert m["summary"] == {"rendered": 2, "skipped": 0, "failed": 0, "interrupted": 0}
    assert sorted(p.name for p in (frames / "png").iterdir()) == ["frame_0000.png", "frame_0001.png"]


def test_dask_close_interrupted_still_closes_the_cluster():
    from pyshadow.bake import runner

    closed = []

    class Client:
        def close(self):
            closed.append("client")
            raise KeyboardInterrupt

    class Cluster:
        def close(self):
            closed.append("cluster")

    ex = object.__new__(runner._Dask)
    ex.client, ex.cluster, ex._futures = Client(), Cluster(), []
    assert isinstance(runner.close_executor(ex), KeyboardInterrupt)
    assert closed == ["client", "cluster"]
    assert runner.close_executor(None) is None
    assert runner.close_executor(runner._Serial()) is None


def test_cli_rejects_an_unusable_out_folder(tmp_path, capsys):
    from pyshadow.bake.cli import main

    src = tmp_path / "src"
    src.mkdir()
    afile = tmp_path / "afile"
    afile.write_text("x")
    for cmd in (["assets", str(src)], ["frames"]):
        for out, why in ((afile, "exists and is not a directory"),
                         (afile / "x", "cannot write there (Not a directory)")):
            with pytest.raises(SystemExit) as e:
                main(cmd + ["-o", str(out), "--quiet"])
            assert e.value.code == 2
            assert capsys.readouterr().err.splitlines()[-1] == f"pyshadow-bake: error: -o {out}: {why}"
    assert afile.read_text() == "x" and sorted(tmp_path.iterdir()) == [afile, src]
    # a usable folder is made and left without the probe file
    rc = main(["assets", str(src), "-o", str(tmp_path / "new" / "out"), "--executor", "serial", "--quiet"])
    assert rc == 0 and list((tmp_path / "new" / "out").rglob(".pyshadow-bake-*")) == []


def test_cli_rejects_non_finite_numbers(tmp_path, capsys):
    from pyshadow.bake.cli import main

    out = tmp_path / "out"
    for opt, text, msg in (("--ground", "nan", "must be a finite number, got 'nan'"),
                           ("--ground", "inf", "must be a finite number, got 'inf'"),
                           ("--ground", "-inf", "must be a finite number, got '-inf'"),
                           ("--ground", "y", "expected a number, got 'y'")):
        with pytest.raises(SystemExit) as e:
            main(["frames", "-o", str(out), f"{opt}={text}"])
        assert e.value.code == 2
        assert capsys.readouterr().err.splitlines()[-1] == f"pyshadow-bake frames: error: argument {opt}: {msg}"
    for text in ("nan", "inf"):
        with pytest.raises(SystemExit) as e:
            main(["assets", str(tmp_path), "-o", str(out), f"--max-error={text}"])
        assert e.value.code == 2
        assert capsys.readouterr().err.splitlines()[-1] == \
            f"pyshadow-bake assets: error: argument --max-error: must be a positive finite number, got {text!r}"
    assert not out.exists()                               # rejected before anything is made
    built = []
    parts = [(n, m, c) for n, m, _, c in pyshadow.data.default_parts()]
    for ground in (float("nan"), float("inf"), "0", True):
        with pytest.raises(ValueError, match="ground must be a finite number or None"):
            bake_frames(out, parts, pyshadow.Camera([0, 1, 4], [0, 0, 0]), default_motion(1)[0], ground=ground,
                        csm_for=lambda name, mesh: built.append(name))
    assert built == [] and not out.exists()


def test_code_digest_is_the_same_from_a_checkout_and_an_install(tmp_path):
    """``python -m pyshadow.bake`` run from the repository root imports the checkout's package (kernels
    beside it), from elsewhere the installed one (kernels inside it): both must key assets alike, or a
    rerun bakes everything again."""
    repo = Path(__file__).resolve().parents[1]
    code = "from pyshadow.bake.params import code_digest; import pyshadow; print(code_digest(), pyshadow.__file__)"
    seen = {}
    for cwd in (repo, tmp_path):
        res = subprocess.run([sys.executable, "-c", code], cwd=cwd, capture_output=True, text=True, timeout=300)
        assert res.returncode == 0, res.stderr
        digest, where = res.stdout.split()
        seen[where] = digest
    assert set(seen.values()) == {code_digest()}, seen


def test_frames_interrupted_while_the_csms_are_built_writes_this_runs_manifest(tmp_path, monkeypatch, capsys):
    """A Ctrl-C before the frames' tasks left the earlier run's manifest, describing CSM files this run replaced."""
    from pyshadow.bake import frames as fr
    from pyshadow.bake.cli import main

    out, write = tmp_path / "frames", fr.write_bytes_atomic          # Ctrl-C at two points, then a rerun
    args = ["frames", "-o", str(out), "--frames", "2", "--size", "32x24", "--samples", "4", "--resolution", "32",
            "--executor", "serial", "--quiet", "--no-cache", "--maps"]
    assert main([*args, "8x16"]) == 0                                                  # the earlier run
    earlier, old_bunny = json.loads((out / "manifest.json").read_text()), (out / "csm" / "bunny.csm").read_bytes()
    assert earlier["summary"]["rendered"] == 2 and sorted(earlier["csm"]) == ["bunny", "torus"]

    def stop(*args, **kwargs):
        raise KeyboardInterrupt

    def write_until_torus(path, data):                  # Ctrl-C once this run has replaced csm/bunny.csm
        return stop() if Path(path).name == "torus.csm" else write(path, data)

    for target, name, value, csm in [(pyshadow.CoherentShadowMap, "build", stop, {}),      # building the first CSM
                                     (fr, "write_bytes_atomic", write_until_torus, {"bunny": "csm/bunny.csm"})]:
        capsys.readouterr()
        with monkeypatch.context() as mp:
            mp.setattr(target, name, value)
            assert main([*args, "8x8"]) == 130
        err, m = capsys.readouterr().err, json.loads((out / "manifest.json").read_text())
        assert err == "interrupted: finished outputs are kept, nothing half-written; rerun to continue\n"
        assert m["schema"] == fr.FRAMES_SCHEMA and m["executor"]["kind"] == "serial" and m["csm"] == csm
        assert m["summary"] == {"rendered": 0, "skipped": 0, "failed": 0, "interrupted": 2}
        assert m["frames"] == [{"frame": f, "key": None, "status": "failed", "action": "interrupted",
                                "error": "interrupted before it finished"} for f in (0, 1)]
        assert (m["scene"] is None) == (csm == {}) and m["scene"] != earlier["scene"] and _temporaries(out) == []
        assert ((out / "csm" / "bunny.csm").read_bytes() == old_bunny) == (csm == {})
    assert main([*args, "8x8"]) == 0                                                   # the rerun finishes
    m = json.loads((out / "manifest.json").read_text())
    assert m["summary"] == {"rendered": 2, "skipped": 0, "failed": 0, "interrupted": 0}
    assert m["csm"] == earlier["csm"] and m["scene"] != earlier["scene"]
