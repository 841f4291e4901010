"""Kernels launched from several Python threads at once (pyshadow/_cl/launch.py, ``Kernel.__call__``).

:func:`pyshadow._cl.kernel` gives every thread the same kernel object, and a launch sets that object's arguments,
then enqueues it: two threads launching one kernel at once enqueued one launch with the other thread's buffers
(wrong answers, or a segmentation fault where those buffers had been freed). Each test runs its threads in a child
process, so that a crash is reported as a failure, with Python's thread switch interval at 1 microsecond (the
default 5 ms makes the race rarer, not absent), and compares every answer bit for bit with the same calls made
one after another. Before the launch lock, the child crashed or answered wrongly in 9 (the first test) and
10 (the second) of 10 runs.
"""
from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

_CHILD = """
import hashlib, sys
from concurrent.futures import ThreadPoolExecutor
import numpy as np
import pyshadow

def digest(x):
    parts = x if isinstance(x, tuple) else (x,)
    if hasattr(x, "keys"):
        parts = tuple(x[k] for k in sorted(x.keys()) if x[k] is not None)
    return hashlib.sha1(b"".join(np.ascontiguousarray(a).tobytes() for a in parts)).hexdigest()

{setup}
calls = list(range({calls}))
serial = [digest(call(i)) for i in calls]
sys.setswitchinterval(1e-6)
for _ in range({rounds}):
    with ThreadPoolExecutor(8) as ex:
        got = list(ex.map(lambda i: digest(call(i)), calls))
    bad = [i for i in calls if got[i] != serial[i]]
    assert not bad, f"calls {{bad}} of {{len(calls)}} answered otherwise from 8 threads than one after another"
print("equal")
"""


def _child(setup: str, calls: int, rounds: int, device: str):
    code = textwrap.dedent(_CHILD).format(setup=textwrap.dedent(setup), calls=calls, rounds=rounds)
    env = {**os.environ, "PYSHADOW_DEVICE": device, "PYTHONPATH": str(REPO)}
    res = subprocess.run([sys.executable, "-c", code], cwd=REPO, env=env, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0 and res.stdout.strip().endswith("equal"), (
        f"exit status {res.returncode} (-11: a segmentation fault)\n{res.stdout[-2000:]}\n{res.stderr[-3000:]}")


def test_one_kernel_launched_from_threads(cl_target):
    """``pyshadow.sample_directions`` (one kernel, ``sample_directions``) from 8 threads: 8 x 50 calls."""
    _child("""
        S = pyshadow.Sampling(8)

        def call(i):
            return pyshadow.sample_directions(np.random.default_rng(i).normal(size=(64, 3)), sampling=S)
        """, 400, 1, cl_target[0])


def test_scene_queried_from_threads(cl_target):
    """One scene (a box on the ground) asked ``visible``, ``ambient_occlusion`` (with and without bent normals)
    and ``render`` from 8 threads, different inputs each call: the answers of the calls one after another."""
    _child("""
        import trimesh
        scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
        scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), trimesh.transformations.translation_matrix([0, 0.5, 0]))

        def call(i):
            rng = np.random.default_rng(i)
            p = np.c_[rng.uniform(-2, 2, 100), np.zeros(100), rng.uniform(-2, 2, 100)]
            n = np.tile([0.0, 1.0, 0.0], (100, 1))
            if i % 4 == 0:
                d = rng.normal(size=(100, 3))
                d[:, 1] = np.abs(d[:, 1]) + 0.05
                return scene.visible(p, d, surface_ids=-2)
            if i % 4 == 3:
                cam = pyshadow.Camera((3 * np.cos(i), 2.0, 3 * np.sin(i)), (0, 0.3, 0), width=16, height=12)
                return scene.render(cam, sampling=pyshadow.Sampling(8))
            return scene.ambient_occlusion(p, n, sampling=pyshadow.Sampling(8 + 8 * (i % 4)), surface_ids=-2,
                                           return_bent_normals=i % 4 == 2)
        """, 160, 2, cl_target[0])
