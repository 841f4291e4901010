"""The maps a :class:`pyshadow.lighting.shadow_map.ShadowMapVisibility` keeps, and the state each answers for.

A backend object may be asked from several threads at once: its kept maps are read and changed under one lock
(not held while a map renders), and a map is kept only where no caster moved while it rendered: a move landing
there (another thread's ``set_transform``) kept a map of the new poses under the old ones.
"""
from __future__ import annotations

import threading

import numpy as np

from .. import _cl
from ..scene_arrays import check_meshes, scene_arrays

_MAPS_LOCK = threading.Lock()


def _placed_casters(scene, arr):
    """The casters' instance numbers, their instances and ``{id(mesh): trimesh's content hash}`` of each
    distinct mesh (once each: many instances share one); ValueError for a caster without its mesh or with
    one changed in place since :meth:`Scene.add` (refused as on the other backends)."""
    check_meshes(scene)
    casters = np.flatnonzero(arr["casts"])
    placed = [arr["placed"][i] for i in casters]       # (those of the arrays: not a placeholder removed since)
    for i, p in zip(casters, placed):
        if p.mesh is None:
            raise ValueError(f"caster instance {int(i)} has no mesh: a shadow map rasterises the casters' "
                             f"triangles (Scene.add(csm, mesh=...))")
    return casters, placed, {k: hash(m) for k, m in {id(p.mesh): p.mesh for p in placed}.items()}


def _placed_state(scene, kind, resolution, placed=None, content=None) -> tuple:
    """What a kept map answers for: context, scene, light's kind, resolution, each caster's mesh (content hash)
    and transform (``placed``, ``content``: :func:`_placed_casters`'s, found where not given)."""
    _, placed, content = _placed_casters(scene, scene_arrays(scene)) if placed is None else (0, placed, content)
    return (id(_cl.context()), id(scene), kind, resolution,
            tuple((id(p.mesh), content[id(p.mesh)], p.transform.tobytes()) for p in placed))


def _kept_map(maps, state, light, tol):
    """The kept map of ``state`` whose light lies within ``tol`` of ``light`` (now the most recent), or None."""
    with _MAPS_LOCK:
        for key, sm in maps.items():
            if key[0] == state and np.abs(sm.light - light).max() <= tol:
                maps.move_to_end(key)
                return sm
    return None


def _keep_map(backend, scene, state, sm, limit: int) -> None:
    """Keep ``sm``, rendered for ``state`` (the ``limit`` most recent kept), unless a caster moved while it
    rendered (another thread's move)."""
    with _MAPS_LOCK:
        backend.renders += 1
        if _placed_state(scene, state[2], state[3]) == state:
            backend._maps[(state, sm.light.tobytes())] = sm
            while len(backend._maps) > limit:
                backend._maps.popitem(last=False)
