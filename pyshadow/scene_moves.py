"""Placing, moving and removing the instances of a :class:`pyshadow.Scene`: their held transforms.

A scene keeps its own read-only copy of each instance's transform: its
queries keep tables derived from the transforms until the scene changes (an
edit in place would leave them stale, answering from the old place; it raises
instead). :func:`set_transforms` moves one instance or many at once: a
simulation that moves thousands of bodies a frame passes their poses as one
array, checked in one pass (``Scene.set_transform`` one at a time spends about
30 microseconds a call on checking its matrix).
"""
from __future__ import annotations

import os
import sys
from collections.abc import Iterable

import numpy as np

from ._validate import check_transform, check_transforms

__all__ = ["add_instances", "checked_ground", "csm_options", "held_transform", "loaded_mesh", "placed_vertices",
           "set_transforms", "remove_instances"]


def held_transform(transform) -> np.ndarray:
    """The scene's own read-only copy of a checked rigid transform (4, 4) float64 (:func:`check_transform`)."""
    T = check_transform(transform, rigid=True, name="transform").copy()
    T.flags.writeable = False
    return T


def checked_ground(height):
    """``Scene.ground``: a height (float, world units) or None; TypeError for a bool, a string or an array.
    ``Scene(ground=True)`` (meaning "a ground plane") put the plane at y = 1, cutting through bodies
    resting on y = 0 (every ray of a point on y = 0 was occluded: AO 0 instead of 0.98); "0.5" was read."""
    if height is not None and (isinstance(height, (bool, np.bool_, str, bytes)) or np.ndim(height) != 0):
        raise TypeError(f"ground must be a height (a number, world units) or None, got {height!r}")
    return None if height is None else float(height)


def csm_options(views, resolution, depth_bits, layers, footprint) -> dict:
    """The options a :class:`pyshadow.Scene` builds its casters' CSMs with (default views
    ``ViewSet.zigzag(64, 128)``), checked as :meth:`pyshadow.CoherentShadowMap.build` checks them when the scene
    is made: ``Scene(resolution=0)`` was taken and refused only by the first mesh added."""
    from .csm.build import check_arguments
    from .views import ViewSet

    if not isinstance(footprint, (bool, np.bool_)):
        raise TypeError(f"footprint must be True or False, got {footprint!r}")
    views = ViewSet.zigzag(64, 128) if views is None else views
    check_arguments(views, resolution, depth_bits, layers)
    return dict(views=views, resolution=resolution, depth_bits=depth_bits, layers=layers, footprint=bool(footprint))


def loaded_mesh(scene, obj):
    """``obj`` where it is a ``trimesh.Trimesh``, else the mesh :func:`pyshadow.mesh.load_mesh` reads from it.

    A file (a path) the scene has loaded before, unchanged since (its size, modification time and the
    geometry read from it) and its mesh unchanged in place, gives the same mesh object again:
    ``Scene.add("chair.obj", T)`` in a loop built one CSM per call (13 s each at the default options; CSMs
    are now kept per geometry, ``Scene._built``) and holds one mesh in memory, not one per call.
    """
    import trimesh

    from .csm import CoherentShadowMap
    from .mesh import load_mesh, mesh_hash

    if isinstance(obj, trimesh.Trimesh):
        return obj
    if isinstance(obj, tuple) and len(obj) == 2 and isinstance(obj[0], CoherentShadowMap):
        raise TypeError("Scene.add: obj is a (CoherentShadowMap, dict) pair, as CSMCache.csm returns; "
                        "pass the CSM alone (csm, info = cache.csm(...))")
    mesh = load_mesh(obj)               # read each time: a file rewritten within its clock's resolution
    if not isinstance(obj, (str, os.PathLike)):
        return mesh
    try:
        st = os.stat(obj)
        key = ("loaded", os.path.realpath(obj), st.st_size, st.st_mtime_ns, mesh_hash(mesh))
    except (OSError, TypeError, ValueError):
        return mesh
    held = scene._built.get(key)
    if held is not None and hash(held[0]) == held[1]:       # (and not changed in place since)
        return held[0]
    scene._built[key] = (mesh, hash(mesh))
    return mesh


def add_instances(scene, transforms, place) -> np.ndarray:
    """Place one object k times in ``scene`` (``Scene.add(obj, transforms)`` with a stack).

    The first instance is made by ``place(T)`` (``Scene.add``'s own checks,
    and the CSM built or checked once); the others share its CSM, mesh and
    role. All transforms are checked first, as one array (the same matrices
    as one ``Scene.add`` each, bit for bit): on an error none is placed.

    Parameters
    ----------
    scene : pyshadow.Scene
    transforms : array_like, shape (k, 4, 4)
        Object-to-world rigid transforms (world units), as ``Scene.add`` takes one; an empty
        sequence (shape (0,), ``[]``) is k = 0: none placed, nothing built.
    place : callable
        ``place(T)`` -> the :class:`pyshadow.scene.Instance` of the object at the held transform ``T``.

    Returns
    -------
    ndarray, shape (k,), int64
        The new instances' ids, in the order of ``transforms``.
    """
    if np.shape(transforms) == (0,):            # a list of no poses (a level without this object) was refused as
        transforms = np.zeros((0, 4, 4))        # "transform must be a 4x4 matrix, got shape (0,)"
    T = check_transforms(transforms, rigid=True, label=lambda k: f"transforms[{k[0]}]")
    if T.ndim != 3:
        raise ValueError(f"transforms must have shape (k, 4, 4), got {T.shape}")
    n = len(scene.instances)
    if not len(T):
        return np.zeros(0, np.int64)
    T.flags.writeable = False                   # each instance's transform: a read-only view of one row
    first = place(T[0])
    if first.csm is None:                       # a receiver: its mesh's sphere found once, not once per instance
        first.object_sphere()
    made = [first] + [type(first)(t, first.casts, csm=first.csm, mesh=first.mesh, _stamp=first._stamp,
                                  _sphere=first._sphere, _sphere_stamp=first._sphere_stamp) for t in T[1:]]
    list.extend(scene._placed, made)
    scene._version += 1
    return np.arange(n, n + len(T), dtype=np.int64)


def placed_vertices(inst, instance_id):
    """``Scene.vertex_points`` of instance ``inst`` (id ``instance_id``): world vertex positions (V, 3) and
    unit vertex normals (V, 3) of its mesh, float64."""
    if inst.mesh is None:
        raise ValueError(f"instance {instance_id} was added as a CSM without its mesh (pass mesh=)")
    T = inst.transform
    pts = np.asarray(inst.mesh.vertices) @ T[:3, :3].T + T[:3, 3]
    # trimesh's own cache of the normals, which it drops when the mesh changes (a copy kept here did not)
    nrm = np.asarray(_winding_mesh(inst.mesh).vertex_normals, dtype=np.float64) @ inst.rotation.T
    return pts, nrm


def _winding_mesh(mesh):
    """``mesh``, or where its face normals point against its faces' winding, the same faces rebuilt: trimesh
    5.2's ``creation.box(...).invert()`` (a room) flips the faces but keeps the normals it was made with,
    so its vertex normals pointed out of the room (vertex AO asked the outside's hemisphere)."""
    import trimesh

    v = np.asarray(mesh.vertices, dtype=np.float64)[np.asarray(mesh.faces)]
    wound = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    if not (np.einsum("ij,ij->i", wound, np.asarray(mesh.face_normals, dtype=np.float64)) < 0).any():
        return mesh
    return trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)


def set_transforms(scene, instance_ids, transforms) -> None:
    """Move instances of ``scene``: one, or many at once (``Scene.set_transform``).

    Nothing is rebuilt: each instance keeps its CSM (or mesh) and takes the
    new rigid transform (rotation, translation and uniform positive scale,
    as :meth:`pyshadow.Scene.add` accepts). All transforms are checked
    before any instance moves: on an error none has moved.

    Threads: queries of one scene from several threads at once are safe,
    but a move (as ``Scene.add`` and setting ``Scene.ground``) is not atomic
    with respect to another thread's query: one made while a query runs may
    make that query answer for some instances (or, for
    :meth:`pyshadow.Scene.render`, some stages: the image drawn at one pose,
    its AO asked at the other) at the old poses and for others at the new
    ones; the queries that start after the move answer for the new poses.
    A simulation thread that moves bodies while a display thread renders
    should move them between frames (a lock of its own, held around
    ``set_transform`` and around each query, or a queue of moves that the
    display thread applies before its next query).

    Parameters
    ----------
    scene : pyshadow.Scene
    instance_ids : int or array_like of int, shape (k,)
        Instance ids (as :meth:`pyshadow.Scene.add` returned them), each at
        most once.
    transforms : array_like, shape (4, 4) or (k, 4, 4)
        Object-to-world transforms (world units): one for a single id, one
        per id for a sequence of ids. float64 (other real dtypes are read as
        float64); a 3x3 part off a scaled rotation by more than 1e-6 is
        replaced by the nearest one, as in ``Scene.add``.

    Raises
    ------
    IndexError
        An id out of range or of a removed instance (it names the id), or
        one id that is not an int (as :meth:`pyshadow.Scene.transform` refuses it).
    TypeError
        A sequence of ids that are not integers (bools included), a set or
        an iterator of ids, or transforms that are not real numbers.
    ValueError
        Shapes that do not match, an id given twice, or a transform that is
        not rigid, not affine, singular, mirrored or not finite (named by
        its position in ``transforms`` and its instance id).
    """
    ids = checked_ids(scene, instance_ids)
    if np.ndim(ids) == 0:                       # one instance: its 4x4
        inst = scene._instance(ids)
        object.__setattr__(inst, "transform", held_transform(transforms))
        scene._version += 1
        return
    T = np.asarray(transforms)
    if not len(ids) and T.shape == (0,):        # no moves given as two empty lists (a frame that moves none)
        return
    if T.shape != (len(ids), 4, 4):
        raise ValueError(f"transforms must have shape ({len(ids)}, 4, 4) for {len(ids)} instance ids, got {T.shape}")
    T = check_transforms(T, rigid=True, label=lambda k: f"transforms[{k[0]}] (instance {ids[k[0]]})")
    T.flags.writeable = False                   # each instance's transform: a read-only view of one row
    insts = scene.instances
    for k, i in enumerate(ids.tolist()):
        object.__setattr__(insts[i], "transform", T[k])
    if len(ids):
        scene._version += 1


def checked_ids(scene, instance_ids):
    """``instance_ids`` of ``Scene.set_transform`` and ``Scene.remove``: one id as given (an int, or a 0-d int
    array as an int; ``Scene._instance`` checks it), or a sequence of ids as (k,) ints, checked here: each of an
    instance placed and not removed, none twice (IndexError, ValueError; TypeError for other types)."""
    if isinstance(instance_ids, np.ndarray) and instance_ids.ndim == 0 and instance_ids.dtype.kind in "iu":
        return int(instance_ids)                # a 0-d int array was "no instance array(2)"
    if isinstance(instance_ids, Iterable) and not isinstance(instance_ids, (str, bytes, np.ndarray)) \
            and np.ndim(instance_ids) == 0:     # a set or an iterator was "no instance {1, 2}"
        raise TypeError("instance_ids must be an int or a 1-D sequence of ints (a list, tuple, range or array), "
                        f"got a {type(instance_ids).__name__}")
    if np.ndim(instance_ids) == 0:
        return instance_ids
    ids = np.asarray(instance_ids)
    if ids.shape == (0,):                       # no ids (an empty list reads as float64)
        ids = ids.astype(np.int64)
    if ids.dtype.kind not in "iu" or ids.ndim != 1:
        raise TypeError(f"instance_ids must be an int or a 1-D sequence of ints, got {ids.dtype} shape {ids.shape}")
    insts = scene.instances
    n = len(insts)
    bad = (ids < 0) | (ids >= n)
    if bad.any():
        raise IndexError(f"no instance {int(ids[bad][0])} (the scene has {n})")
    if getattr(scene, "_removals", 0):          # (Scene.remove's count: none, no placeholder to look for)
        for i in ids.tolist():
            live_instance(insts[i], i)
    if len(np.unique(ids)) != len(ids):
        u, c = np.unique(ids, return_counts=True)
        raise ValueError(f"instance_ids: instance {u[c > 1][0]} is given more than once")
    return ids


def live_instance(inst, instance_id):
    """``inst``, the instance of id ``instance_id``, unless ``Scene.remove`` took it out (IndexError)."""
    if inst.removed:
        raise IndexError(f"instance {instance_id} was removed (Scene.remove; its id is not reused)")
    return inst


def remove_instances(scene, instance_ids) -> None:
    """Take instances out of ``scene`` (``Scene.remove``): one id, or a sequence of ids (k,).

    All ids are checked before any instance is removed, as
    :meth:`pyshadow.Scene.set_transform` checks them. Ids are stable: a
    removed id is never reused (``Scene.add`` returns new ones) and every
    other instance keeps its own. ``scene.instances[i]`` of a removed id is
    then a placeholder :class:`pyshadow.scene.Instance` (``removed`` True,
    ``casts`` False, no CSM and no mesh, its last transform): it casts no
    shadow, receives nothing and is not drawn; every query answers as for
    a scene built without it (as a surface id of a query, its id names a
    surface that casts nothing). :meth:`pyshadow.Scene.transform`,
    ``set_transform``, ``vertex_ao``, ``vertex_points`` and ``remove``
    refuse it, naming it.

    The scene keeps no device buffers of a CSM none of its remaining
    instances uses: its instance and the tables kept with the scene's
    arrays go now, and the packed atlas of its caster types
    (``pyshadow.visibility.csm``) where its types changed. A CSM that
    ``Scene.add`` built for a mesh stays in the scene's host-side cache of
    built CSMs, so that adding that mesh again does not build it again.
    Threads: a removal is a change as a move is (:func:`set_transforms`). The placeholders stay, so a
    scene's per-move cost follows every id it ever placed: for a long run that places and removes
    bodies by the thousand, start a new scene now and then.

    Parameters
    ----------
    scene : pyshadow.Scene
    instance_ids : int or array_like of int, shape (k,)
        Instance ids (as :meth:`pyshadow.Scene.add` returned them), each at
        most once; an empty sequence removes none.

    Raises
    ------
    IndexError
        An id out of range, or one of a removed instance (named).
    TypeError
        An id that is not an int (bools included), a set or an iterator.
    ValueError
        An id given twice.
    """
    ids = checked_ids(scene, instance_ids)
    if np.ndim(ids) == 0:
        scene._instance(ids)
    ids = [int(ids)] if np.ndim(ids) == 0 else ids.tolist()
    if not ids:
        return
    from .scene import Instance
    from .scene_arrays import _HELD

    placed = scene._placed
    for i in ids:       # a placeholder in its place: the instance (its CSM, mesh) is the scene's no more
        list.__setitem__(placed, i, Instance(placed[i].transform, False, removed=True))
    scene._removals = getattr(scene, "_removals", 0) + len(ids)     # n is unchanged: the arrays are made anew
    _HELD.pop(scene, None)                      # (not as after moves), and the tables kept with them go now
    scene._version += 1
    backend = sys.modules.get("pyshadow.visibility.csm")         # (not imported: no atlas was made)
    atlas = None if backend is None else backend._ATLAS.get(scene)
    if atlas is not None and atlas[0][1] != tuple(id(c) for c in scene.caster_types()[0]):
        backend._ATLAS.pop(scene, None)         # the CSMs of other types: made by the next query that needs them
