"""A long run keeps what it derives from a mesh once per live mesh (pyshadow.mesh_kept).

A receiver's mesh may be changed in place between frames (a waving sheet). Its corner normals and closed
surface were kept in WeakKeyDictionaries keyed by the mesh, which look it up by trimesh's hash of its
content: each change missed (as it should) and left the old entry behind until the mesh died, one entry a
frame. A ShadowMapVisibility kept every mesh it drew (and its device buffer) for as long as it lived: one backend
used on scene after scene of reloaded meshes held all of them. The id()-keyed caches are also asked with a new
object at the address of a dead one (its id reused): none may answer for the dead one.
"""
from __future__ import annotations

import gc

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import contact, shading_normals
from pyshadow.lighting import ShadowMapVisibility

FRAMES = 10


def _box():
    box = trimesh.creation.box((0.6, 0.6, 0.6))
    box.apply_translation([0.0, 0.3, 0.0])
    return box


def _sheet(nx=6, ny=5):
    """A receiver: a grid of triangles facing +z behind the box."""
    x, y = np.meshgrid(np.linspace(-1.0, 1.0, nx), np.linspace(0.05, 1.0, ny))
    v = np.column_stack([x.ravel(), y.ravel(), np.full(x.size, -0.8)])
    k = np.arange(nx * ny).reshape(ny, nx)
    a, b, c, d = k[:-1, :-1].ravel(), k[:-1, 1:].ravel(), k[1:, 1:].ravel(), k[1:, :-1].ravel()
    return trimesh.Trimesh(v, np.r_[np.c_[a, b, c], np.c_[a, c, d]], process=False)


@pytest.fixture(scope="module")
def box_csm():
    box = _box()
    return box, pyshadow.CoherentShadowMap.build(box, pyshadow.ViewSet.zigzag(4, 8), resolution=16)


def _same_geometry(mesh):
    return trimesh.Trimesh(np.array(mesh.vertices), np.array(mesh.faces), process=False)


def test_receiver_changed_in_place_every_frame_keeps_one_entry(box_csm):
    box, csm = box_csm
    scene = pyshadow.Scene(ground=0.0)
    scene.add(csm, mesh=box)
    sheet = _sheet()
    sid = scene.add(sheet, casts=False)
    cam = pyshadow.Camera(eye=[0.0, 1.2, 2.5], target=[0.0, 0.4, -0.5], width=24, height=16)
    rng = np.random.default_rng(3)
    pts = np.column_stack([rng.uniform(-0.9, 0.9, 40), np.full(40, 0.5), np.full(40, -0.78)])
    normals = np.tile([0.0, 0.0, 1.0], (40, 1))
    base = np.array(sheet.vertices)
    caches = {"corner normals": shading_normals._CORNERS, "closed surfaces": contact._SURFACES}
    before = {}
    for f in range(FRAMES + 1):
        v = base.copy()
        v[:, 2] += 0.01 * np.sin(3.0 * base[:, 0] + f)
        sheet.vertices[:] = v                   # in place: trimesh sees the write, its hash changes
        scene.render(cam, sampling=pyshadow.Sampling(4), normals="smooth")
        scene.ambient_occlusion(pts, normals, sampling=pyshadow.Sampling(4), surface_ids=sid)
        before = before or {name: len(c) for name, c in caches.items()}     # after the first frame
    gc.collect()
    grown = {name: len(c) - before[name] for name, c in caches.items()}
    assert max(grown.values()) <= 0, f"entries added over {FRAMES} more frames of one sheet: {grown}"
    # what is kept is the sheet's as it is now
    fresh = shading_normals.corner_normals(_same_geometry(sheet))
    assert np.array_equal(shading_normals.corner_normals(sheet), fresh)


def test_shadow_map_backend_keeps_no_mesh_it_drew_once_gone(box_csm):
    box, csm = box_csm
    backend = ShadowMapVisibility(32)
    pts = np.array([[0.8, 0.0, 0.1], [-0.8, 0.0, -0.1], [0.0, 0.0, 0.9]])
    sun = np.tile(np.array([0.3, 1.0, 0.2]) / np.linalg.norm([0.3, 1.0, 0.2]), (3, 1))
    answers = []
    for k in range(FRAMES):                     # a scene a shot, its mesh reloaded each time
        scene = pyshadow.Scene(ground=0.0)
        scene.add(csm, mesh=_same_geometry(box))
        answers.append(backend.visible(scene, pts, sun))
        del scene
    gc.collect()
    assert len(backend._meshes) <= 1, f"{len(backend._meshes)} meshes kept by the backend after {FRAMES} scenes"
    assert all(np.array_equal(a, answers[0]) for a in answers)


# Objects of a size no other object has: CPython gives the freed address of one to the next one made, so the
# next mesh (array) of the class takes the id of the dead one.
_SLOTS = tuple(f"s{k}" for k in range(45))


class _Mesh(trimesh.Trimesh):
    __slots__ = _SLOTS


class _Array(np.ndarray):
    __slots__ = _SLOTS


def _reused(make, dead_id, tries=20):
    """An object of ``make()`` at ``dead_id``; None if none came there."""
    held = []
    for _ in range(tries):
        obj = make()
        if id(obj) == dead_id:
            return obj
        held.append(obj)
    return None


def test_mesh_kept_never_answers_for_a_dead_mesh_at_the_same_address():
    from pyshadow.mesh_kept import MeshKept

    kept = MeshKept()
    sheet = _sheet()
    geometry = (np.array(sheet.vertices), np.array(sheet.faces))
    mesh = _Mesh(*geometry, process=False)
    kept[mesh] = "old"
    assert kept.get(mesh) == "old" and mesh in kept and len(kept) == 1
    dead = id(mesh)
    del mesh
    gc.collect()
    assert len(kept) == 0                       # the entry went with its mesh
    kept[sheet] = "other"
    new = _reused(lambda: _Mesh(*geometry, process=False), dead)
    if new is None:
        pytest.skip("no new mesh came at the dead one's address")
    assert new not in kept and kept.get(new) is None    # the same content, the same id: another mesh


def test_mesh_kept_entry_is_replaced_when_the_mesh_changes_in_place():
    from pyshadow.mesh_kept import MeshKept

    kept = MeshKept()
    mesh = _sheet()
    kept[mesh] = "first"
    mesh.vertices[:, 2] += 0.25
    assert mesh not in kept and kept.setdefault(mesh, "second") == "second"
    assert len(kept) == 1 and kept[mesh] == "second"
    with pytest.raises(KeyError):
        kept[_sheet()]


def test_sampled_sky_map_of_a_new_array_at_a_dead_ones_address():
    from pyshadow.visibility import sampled_sky

    def frozen_map(value):
        a = np.full((4, 8, 3), value, np.float32)
        a.flags.writeable = False
        return a

    first = frozen_map(1.0).view(_Array)
    buf = sampled_sky._device_map(first)
    assert buf is sampled_sky._device_map(first)            # kept
    dead = id(first)
    del first
    gc.collect()
    new = _reused(lambda: frozen_map(2.0).view(_Array), dead)
    if new is None:
        pytest.skip("no new array came at the dead one's address")
    host = np.empty((4, 8, 3), np.float32)
    pyshadow._cl.cl.enqueue_copy(pyshadow._cl.queue(), host, sampled_sky._device_map(new)).wait()
    assert (host == 2.0).all()


def test_held_device_copy_of_a_new_array_at_a_dead_ones_address():
    from pyshadow.visibility.held import on_device

    held = {}
    first = np.full(16, 1.0, np.float32).view(_Array)
    on_device(held, first)
    dead = id(first)
    del first
    gc.collect()
    assert _reused(lambda: np.full(16, 2.0, np.float32).view(_Array), dead) is None    # held keeps it: id not reused
    arr = np.full(16, 3.0, np.float32)
    host = np.empty(16, np.float32)
    pyshadow._cl.cl.enqueue_copy(pyshadow._cl.queue(), host, on_device(held, arr)).wait()
    assert (host == 3.0).all()


def test_frame_edges_of_a_new_mesh_at_a_dead_ones_address():
    from pyshadow.gbuffer_frame import EDGE_HELD_FACES, mesh_edges

    sphere = trimesh.creation.icosphere(5)      # over EDGE_HELD_FACES faces: its bounds are kept
    v, faces = np.array(sphere.vertices), np.array(sphere.faces)
    big = _Mesh(v, faces, process=False)
    assert len(big.faces) >= EDGE_HELD_FACES
    mesh_edges(big, v, faces)
    dead = id(big)
    del big
    gc.collect()
    new = _reused(lambda: _Mesh(v * 2.0, faces, process=False), dead)
    if new is None:
        pytest.skip("no new mesh came at the dead one's address")
    v2 = np.asarray(new.vertices, np.float64)
    got = mesh_edges(new, v2, faces)
    from pyshadow.gbuffer_frame import _edge_bounds

    want = _edge_bounds(v2, faces)
    assert np.array_equal(got[0], want[0]) and got[1] == want[1]
