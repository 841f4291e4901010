"""The bake's executors: a process pool sends a run's shared data once per worker process, and a Dask bake
survives the loss of the scene it sent to the workers (a restarted cluster) or fails with a clear message,
keeping its finished frames."""
import threading
import time

import numpy as np
import pytest

import pyshadow
from pyshadow.bake import runner
from pyshadow.bake.frames import bake_frames
from pyshadow.bake.motion import default_motion
from pyshadow.bake.runner import open_executor

_SENT = []


class _Counted:
    """Pickles as ``dict(data)``, counting each pickling (in this process: the driver's)."""

    def __init__(self, data):
        self.data = data

    def __reduce__(self):
        _SENT.append(1)
        return (dict, (self.data,))


def test_process_pool_sends_shared_once_per_worker_not_per_task():
    """Was: the shared data went with every task (these 20 tasks on 2 workers: pickled 20 times; a frame bake's
    scene at the CLI's CSM defaults: 34 MB and 0.29 s per chunk of frames), though the docs said once per
    worker."""
    _SENT.clear()
    shared = _Counted({"csm": b"x" * 1000})
    ex = open_executor("process", workers=2, threads=1)
    try:
        out = list(ex.run(len, [(i, ()) for i in range(16)], shared=shared))
        again = list(ex.run(len, [(i, ()) for i in range(4)], shared=shared))     # same data: no new pool
    finally:
        ex.close()
    assert sorted(t for t, _, _ in out) == list(range(16))
    assert all(err is None and res == 1 for _, res, err in out + again)      # len(dict) of the data sent
    assert 1 <= len(_SENT) <= 2, len(_SENT)         # one per worker process started


def _scene(frames):
    T, _ = default_motion(frames)
    parts = [(n, m, c) for n, m, _, c in pyshadow.data.default_parts()]
    cam = pyshadow.Camera([2.4, 2.1, 4.8], [0.8, 0.5, 0.0], fov_y=45.0, width=16, height=12)
    csms = {}

    def csm_for(name, mesh):
        if name not in csms:
            csms[name] = pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(4, 8), resolution=16,
                                                          progress=False)
        return csms[name]

    return parts, cam, T, csm_for


def _when_done(out, n, action):
    """Run ``action()`` in a thread once ``n`` frames of ``out`` are marked done."""
    def watch():
        deadline = time.time() + 60
        while time.time() < deadline and len(list(out.glob("records/frame_*.json"))) < n:
            time.sleep(0.01)
        action()

    t = threading.Thread(target=watch, daemon=True)
    t.start()
    return t


@pytest.fixture()
def cluster():
    distributed = pytest.importorskip("distributed")
    cluster = distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, scheduler_port=0,
                                       dashboard_address=None, silence_logs=50)
    client = distributed.Client(cluster)
    yield cluster, client
    client.close()
    cluster.close()


def test_dask_restart_mid_bake_sends_the_scene_again(cluster, tmp_path):
    """Was: a restart mid-run (or every worker dying) lost the scattered scene and Dask cancelled every task
    needing it: 27 of 30 frames 'failed' ('FutureCancelledError: ... lost dependencies') while the restarted
    workers sat idle."""
    cluster, client = cluster
    parts, cam, T, csm_for = _scene(10)
    ref = bake_frames(tmp_path / "serial", parts, cam, T, samples=2, csm_for=csm_for, chunk=1,
                      executor="serial", progress=False)
    out = tmp_path / "dask"
    t = _when_done(out, 2, lambda: client.restart(wait_for_workers=False))
    m = bake_frames(out, parts, cam, T, samples=2, csm_for=csm_for, chunk=1, scheduler=cluster.scheduler_address,
                    progress=False)
    t.join()
    assert m["summary"] == {"rendered": 10, "skipped": 0, "failed": 0, "interrupted": 0}, m["summary"]
    for a, b in zip(ref["frames"], m["frames"]):
        assert a["outputs"] == b["outputs"]         # the same bytes (sha256) as the serial bake


def test_dask_workers_gone_for_good_fail_clearly_and_keep_finished_frames(cluster, tmp_path, monkeypatch):
    """Was: every frame after the loss failed with 'FutureCancelledError: render_chunk-<uuid> cancelled for
    reason: lost dependencies.', nothing said why (no message that the workers lost the scene)."""
    cluster, client = cluster
    monkeypatch.setattr(runner._Dask, "resend_timeout", 1.0, raising=False)
    parts, cam, T, csm_for = _scene(8)
    out = tmp_path / "out"
    t = _when_done(out, 2, lambda: cluster.scale(0))
    m = bake_frames(out, parts, cam, T, samples=2, csm_for=csm_for, chunk=1, scheduler=cluster.scheduler_address,
                    progress=False)
    t.join()
    s = m["summary"]
    assert s["rendered"] >= 2 and s["rendered"] + s["failed"] == 8 and s["failed"] >= 1, s
    errors = {f["error"] for f in m["frames"] if f["action"] == "failed"}
    assert all(e.startswith("SharedDataLost: the Dask workers lost the data every task needs") for e in errors), errors
    again = bake_frames(out, parts, cam, T, samples=2, csm_for=csm_for, chunk=1, executor="serial", progress=False)
    assert again["summary"] == {"rendered": s["failed"], "skipped": s["rendered"], "failed": 0, "interrupted": 0}
    assert np.isfinite([f["ao_mean"] for f in again["frames"]]).all()
