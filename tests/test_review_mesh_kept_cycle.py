"""A :class:`pyshadow.mesh_kept.MeshKept` that is dropped lets its values go at once, as the dict and the
``WeakKeyDictionary`` it replaced did: its weak references' callbacks held its own dict, a reference cycle
(dict -> entry -> weak reference -> callback -> dict) that only the cyclic garbage collector frees. A
:class:`pyshadow.lighting.ShadowMapVisibility` made per frame (``backend=ShadowMapVisibility()`` in a call)
kept the device buffers of every mesh it drew after it was gone, until a full collection."""
import gc
import sys
import weakref

import numpy as np
import trimesh

import pyshadow
from pyshadow.mesh_kept import MeshKept


class _Value:
    pass


def test_a_dropped_mesh_kept_lets_its_values_go_at_once():
    mesh = trimesh.creation.box()
    kept, value = MeshKept(), _Value()
    kept[mesh] = value
    gone = weakref.ref(value)
    del value
    was = gc.isenabled()
    gc.disable()                        # (no collection may free a cycle in between)
    try:
        del kept
        assert gone() is None, "the value outlived its MeshKept (a reference cycle)"
    finally:
        if was:
            gc.enable()
    assert mesh is not None             # (the mesh lives on: the value went with the MeshKept, not the mesh)


def test_the_entry_still_goes_with_its_mesh():
    kept, mesh = MeshKept(), trimesh.creation.box()
    kept[mesh] = 1
    assert len(kept) == 1
    del mesh
    gc.collect()                        # (a trimesh mesh is itself in cycles: its visuals hold it)
    assert len(kept) == 0


def test_a_dropped_shadow_map_backend_lets_its_meshes_device_buffers_go(box_csm):
    from pyshadow.lighting import ShadowMapVisibility

    box, csm = box_csm
    scene = pyshadow.Scene(ground=0.0)
    scene.add(csm, trimesh.transformations.translation_matrix([0.0, 0.15, 0.0]), mesh=box)
    backend = ShadowMapVisibility(32)
    backend.visible(scene, np.array([[0.5, 0.0, 0.0]]), np.array([[-0.6, 0.8, 0.0]]))
    buffer = backend._meshes.get(box)[0]
    was = gc.isenabled()
    gc.disable()
    try:
        refs = sys.getrefcount(buffer)
        del backend
        assert sys.getrefcount(buffer) == refs - 1, "the mesh's device buffer outlived its backend"
    finally:
        if was:
            gc.enable()
