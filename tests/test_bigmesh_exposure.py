"""exposed_back_faces with fewer rays and over several cores: the same faces as tracing every direction in order.

A face is exposed where any of its back rays escapes, so the order of the rays cannot change the answer:
the directions are tried in the order a sample of the faces escapes along (the bunny's inside sees out
through its base: most of its exposed faces escape along the first they try), and each direction's rays
are split over threads (Embree answers each ray alone).
"""
import threading

import numpy as np
import pytest
import trimesh

import pyshadow
import pyshadow.embree as pe
from pyshadow.csm import exposure
from pyshadow.csm.exposure import exposed_back_faces
from pyshadow.csm.surface_rule import _fibonacci_sphere


def _reference(mesh, frame, directions=exposure.EXPOSURE_DIRECTIONS):
    """Every direction of the lattice in order, each face until its first escape (the answer's definition)."""
    n, o, live, scene = exposure._back_rays(mesh, frame)
    out = np.zeros(len(n), bool)
    for d in _fibonacci_sphere(directions) if scene is not None else ():
        ask = np.flatnonzero(live & ~out & (n @ d < 0.0))
        if len(ask):
            out[ask] = ~scene.occluded(o[ask], np.broadcast_to(d, (len(ask), 3)))
    return out


class _Counted:
    """An embreex scene that counts the rays it traces and the threads that trace them."""

    def __init__(self, scene):
        self.scene, self.rays, self.threads = scene, 0, set()

    def run(self, o, d, **kw):
        self.rays += len(o)
        self.threads.add(threading.get_ident())
        return self.scene.run(o, d, **kw)


@pytest.fixture
def counted(monkeypatch):
    scenes = []
    real = pe.EmbreeScene.__init__

    def init(self, triangles):
        real(self, triangles)
        self._scene = _Counted(self._scene)
        scenes.append(self._scene)

    monkeypatch.setattr(pe.EmbreeScene, "__init__", init)
    return scenes


def _open_meshes():
    C = trimesh.creation
    box = C.box()
    ball = C.icosphere(3)
    x, y = np.meshgrid(np.linspace(0, 1, 12), np.linspace(0, 1, 9))
    a = (np.arange(11 * 8) // 11) * 12 + np.arange(11 * 8) % 11
    cells = np.concatenate([np.column_stack([a, a + 1, a + 12]), np.column_stack([a + 1, a + 13, a + 12])])
    sheet = trimesh.Trimesh(np.column_stack([x.ravel(), y.ravel(), 0.05 * np.sin(5 * x.ravel())]), cells,
                            process=False)
    return {"teapot": pyshadow.data.mesh("teapot"),
            "lidless box": trimesh.Trimesh(box.vertices, box.faces[box.face_normals[:, 2] < 0.5], process=False),
            "bowl": trimesh.Trimesh(ball.vertices, ball.faces[ball.triangles_center[:, 1] < 0.3], process=False),
            "sheet": sheet, "closed ball": ball}


@pytest.mark.parametrize("name", sorted(_open_meshes()))
@pytest.mark.parametrize("directions", [1, 7, 64, 200])
def test_bigmesh_exposure_is_the_lattice_orders(name, directions):
    m = _open_meshes()[name]
    frame = pyshadow.bounding_sphere(m)
    assert np.array_equal(exposed_back_faces(m, frame, directions), _reference(m, frame, directions))


def test_bigmesh_exposure_of_the_bunny_traces_fewer_rays(counted):
    """Was: 2.11M rays (every face tries the lattice in order until it escapes); now 1.74M, the same
    19,871 faces exposed."""
    m = pyshadow.data.mesh("stanford-bunny")
    frame = pyshadow.bounding_sphere(m)
    want = _reference(m, frame)
    got = exposed_back_faces(m, frame)
    assert np.array_equal(got, want) and got.sum() > 10_000
    before, now = counted[0].rays, counted[1].rays
    assert now < 0.9 * before, f"{now} rays traced, {before} by the lattice's order"


def test_bigmesh_exposure_splits_the_rays_over_threads(counted, monkeypatch):
    """Was: one thread traced every ray; now a direction's rays are split over the process's cores (two
    asked here; the caller's thread traces the sample's few), with the answer of one thread."""
    m = pyshadow.data.mesh("stanford-bunny")
    frame = pyshadow.bounding_sphere(m)
    monkeypatch.setattr(exposure, "_threads", lambda: 1, raising=False)
    one = exposed_back_faces(m, frame)
    monkeypatch.setattr(exposure, "_threads", lambda: 2, raising=False)
    two = exposed_back_faces(m, frame)
    assert np.array_equal(one, two)
    assert len(counted[0].threads) == 1 and 2 <= len(counted[1].threads) <= 3     # (the caller's too)


def test_bigmesh_exposure_reports_each_pass(monkeypatch):
    """Was: the build's bar stood still (its elapsed time too) through the exposed backs, 15 s on a mesh of
    10^6 faces; now each pass along a direction is reported, and the build names it on its bar."""
    m = _open_meshes()["teapot"]
    frame = pyshadow.bounding_sphere(m)
    seen = []
    got = exposed_back_faces(m, frame, 7, progress=lambda done, total: seen.append((done, total)))
    assert np.array_equal(got, _reference(m, frame, 7))
    assert seen == [(k, 14) for k in range(1, 15)]
    from pyshadow.csm import build

    stages = []
    monkeypatch.setattr(build, "_stage", lambda bar, what: stages.append(what))
    pyshadow.CoherentShadowMap.build(m, pyshadow.ViewSet.zigzag(2, 4), resolution=16, progress=False)
    steps = [s for s in stages if s.startswith("exposed backs ")]
    assert steps[-1] == f"exposed backs {2 * exposure.EXPOSURE_DIRECTIONS}/{2 * exposure.EXPOSURE_DIRECTIONS}"
    assert len(steps) == 2 * exposure.EXPOSURE_DIRECTIONS
