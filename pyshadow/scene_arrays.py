"""A scene's instances as stacked arrays, kept until the scene changes.

Every query needs each instance's transform and world bounding sphere; with
10,000 instances, gathering them one Python object at a time costs more
than the query. :func:`scene_arrays` stacks them once per change of the
scene (``Scene.add`` and ``Scene.set_transform`` advance its version) and
computes the world spheres for all instances at once, with the same
operations, in the same order, as :meth:`pyshadow.scene.Instance.world_sphere`
(so the results are bit-identical to it).
"""
from __future__ import annotations

import weakref

import numpy as np

__all__ = ["scene_arrays"]

_HELD = weakref.WeakKeyDictionary()


def scene_arrays(scene) -> dict:
    """Stacked per-instance data of ``scene`` (read-only arrays; do not modify).

    Returns
    -------
    dict
        ``transform`` (n, 4, 4) float64; ``scale`` (n,) (cube root of the
        3x3 part's determinant); ``object_centre`` (n, 3), ``object_radius``
        (n,) (the CSM's bounding sphere, or the mesh's for a receiver);
        ``world_centre`` (n, 3), ``world_radius`` (n,); ``casts`` (n,) bool;
        ``types`` (the distinct CSMs of the casters, in first-use order),
        ``type_index`` (``{id(csm): index}``), ``itype`` (n,) int32 (each
        instance's type, -1 for a receiver). Callers may keep derived data
        of their own in the dict (it is dropped with it when the scene changes).
    """
    version = getattr(scene, "_version", None)
    held = _HELD.get(scene)
    if held is not None and version is not None and held["version"] == version \
            and held["n"] == len(scene.instances):
        return held
    insts = scene.instances
    n = len(insts)
    T = np.stack([inst.transform for inst in insts]) if n else np.zeros((0, 4, 4))
    spheres = [inst.object_sphere() for inst in insts]
    c = np.array([np.asarray(s[0], np.float64) for s in spheres]).reshape(n, 3)
    r = np.array([float(s[1]) for s in spheres], np.float64)
    A = T[:, :3, :3]
    scale = np.cbrt(np.linalg.det(A)) if n else np.zeros(0)
    wc = np.matmul(A, c[:, :, None])[:, :, 0] + T[:, :3, 3] if n else np.zeros((0, 3))
    types, index = [], {}
    for inst in insts:                  # the distinct CSMs of the casters, in first-use order
        if inst.casts and id(inst.csm) not in index:
            index[id(inst.csm)] = len(types)
            types.append(inst.csm)
    itype = np.array([index[id(i.csm)] if i.casts else -1 for i in insts], np.int32)
    out = {"types": tuple(types), "type_index": index, "itype": itype, "version": version, "n": n, "transform": T, "scale": scale, "object_centre": c, "object_radius": r,
           "world_centre": wc, "world_radius": r * scale, "casts": np.array([i.casts for i in insts], bool)}
    for v in out.values():
        if isinstance(v, np.ndarray):
            v.flags.writeable = False
    _HELD[scene] = out
    return out
