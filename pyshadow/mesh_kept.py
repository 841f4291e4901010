"""What pyshadow derives from a mesh, kept per mesh object while it lives, for its content as it is.

Corner normals, closed surfaces and concave stars are found once per mesh and kept between queries. They were
kept in ``weakref.WeakKeyDictionary`` objects keyed by the mesh, which look a mesh up by trimesh's hash: the hash
of its content. A mesh changed in place (a receiver's may be: a sheet waved every frame) missed its entry, as it
should, but the old entry stayed under the old hash until the mesh died: a sheet waved every frame held one
more closed surface and one more set of corner normals a frame. :class:`MeshKept` keeps one entry per live mesh,
with the hash it was made for: a changed mesh misses, and the entry made then replaces the old one.
"""
from __future__ import annotations

import weakref

__all__ = ["MeshKept"]


class MeshKept:
    """``{mesh: value}``: at most one entry per live mesh object (by identity), for the content it had then.

    A lookup hits only the entry stored for this object (a weak reference to it: another mesh at the address of
    a dead one never reads its entry) while trimesh's hash of the mesh (of its content; cheap while unchanged)
    is the one it was stored with. Storing replaces the mesh's entry; an entry goes with its mesh. It answers
    ``in``, ``[]``, ``get``, ``setdefault`` and ``len`` as the ``WeakKeyDictionary`` it replaces.
    """

    def __init__(self):
        self._data: dict = {}       # id(mesh) -> (weak reference to the mesh, its hash then, value)

    def _entry(self, mesh):
        got = self._data.get(id(mesh))
        if got is not None and got[0]() is mesh and got[1] == hash(mesh):
            return got
        return None

    def __contains__(self, mesh) -> bool:
        return self._entry(mesh) is not None

    def __getitem__(self, mesh):
        got = self._entry(mesh)
        if got is None:
            raise KeyError(mesh)
        return got[2]

    def get(self, mesh, default=None):
        got = self._entry(mesh)
        return default if got is None else got[2]

    def __setitem__(self, mesh, value) -> None:
        # (the callback holding the dict itself made a cycle: a dropped MeshKept's values lived until a collection)
        key, kept = id(mesh), weakref.ref(self)

        def drop(ref):                  # the mesh is gone: its entry too, unless another took the key since
            data = getattr(kept(), "_data", {})
            if data.get(key, (None,))[0] is ref:
                data.pop(key, None)

        self._data[key] = (weakref.ref(mesh, drop), hash(mesh), value)

    def setdefault(self, mesh, default):
        got = self._entry(mesh)
        if got is None:
            self[mesh] = default
            return default
        return got[2]

    def __len__(self) -> int:
        return len(self._data)
