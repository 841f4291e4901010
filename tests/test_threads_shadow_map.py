"""One shadow-map backend (``pyshadow.lighting.ShadowMapVisibility``) asked from several threads at once.

The backend keeps its last rendered maps in an ordered table: a thread looking a map up while another stored a
new one raised ``RuntimeError: OrderedDict mutated during iteration``. The test runs in a child process with
Python's thread switch interval at 1 microsecond (the default 5 ms makes the race rarer, not absent), 8 threads
asking for lights in more directions than the backend keeps, and compares every answer bit for bit with the same
calls made one after another.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

_CHILD = """
import sys
from concurrent.futures import ThreadPoolExecutor
import numpy as np
import trimesh
import pyshadow
from pyshadow.lighting import ShadowMapVisibility

scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), trimesh.transformations.translation_matrix([0, 0.5, 0]))
backend = ShadowMapVisibility(resolution=64)
rng = np.random.default_rng(0)
points = np.c_[rng.uniform(-2, 2, 200), np.zeros(200), rng.uniform(-2, 2, 200)]
suns = [np.array([np.cos(a), 1.0, np.sin(a)]) for a in np.linspace(0, 2 * np.pi, 12, endpoint=False)]

def call(i):
    return backend.lit_fraction(scene, points, np.tile(suns[i % len(suns)], (len(points), 1)), surface_ids=-2)

calls = list(range(96))
serial = [call(i) for i in calls]
sys.setswitchinterval(1e-6)
for _ in range(6):
    with ThreadPoolExecutor(8) as ex:
        got = list(ex.map(call, calls))
    bad = [i for i in calls if not np.array_equal(got[i], serial[i])]
    assert not bad, f"calls {bad} answered otherwise from 8 threads than one after another"
print("equal")
"""


def test_shadow_map_backend_asked_from_threads(cl_target):
    env = {**os.environ, "PYSHADOW_DEVICE": cl_target[0], "PYTHONPATH": str(REPO)}
    res = subprocess.run([sys.executable, "-c", _CHILD], cwd=REPO, env=env, capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 0 and res.stdout.strip().endswith("equal"), (
        f"exit status {res.returncode}\n{res.stdout[-2000:]}\n{res.stderr[-3000:]}")


def test_a_map_rendered_while_a_caster_moved_is_not_kept(cl_target, monkeypatch):
    """A move landing between a query's reading of the poses and its render (another thread's ``set_transform``)
    made a map of the new pose kept under the old one: back at the old pose, a query answered from the moved
    caster's map. The move is made to land there by a wrapped render."""
    import numpy as np
    import trimesh

    import pyshadow
    from pyshadow.lighting import ShadowMapVisibility
    from pyshadow.lighting import shadow_map as sm_module

    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    at, moved = (trimesh.transformations.translation_matrix([x, 0.5, 0]) for x in (0.0, 1.5))
    box = scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), at)
    rng = np.random.default_rng(0)
    points = np.c_[rng.uniform(-2, 3, 400), np.zeros(400), rng.uniform(-1, 1, 400)]
    sun = np.tile([0.3, 1.0, 0.2], (len(points), 1))
    expected = ShadowMapVisibility(resolution=64).lit_fraction(scene, points, sun, surface_ids=-2)

    backend = ShadowMapVisibility(resolution=64)
    render = sm_module.ShadowMapVisibility._render_directional

    def render_after_a_move(self, scene, casters, direction, whole=True):
        scene.set_transform(box, moved)
        return render(self, scene, casters, direction, whole)

    monkeypatch.setattr(sm_module.ShadowMapVisibility, "_render_directional", render_after_a_move)
    backend.lit_fraction(scene, points, sun, surface_ids=-2)
    monkeypatch.setattr(sm_module.ShadowMapVisibility, "_render_directional", render)
    scene.set_transform(box, at)
    got = backend.lit_fraction(scene, points, sun, surface_ids=-2)
    assert np.array_equal(got, expected), f"{int((got != expected).sum())} of {len(points)} points differ"
    assert (expected < 1).any() and backend.renders == 2
