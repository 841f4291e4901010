"""Scenes of rigid bodies: placement of CSM casters, mesh receivers and a ground plane.

A scene holds instances of Coherent Shadow Maps (casters) and of plain
meshes (receivers), each with a rigid 4x4 transform (rotation, translation,
uniform scale), and optionally an analytic ground plane ``y = ground``.
Moving an instance changes one small table; no CSM is rebuilt.

The queries (:meth:`Scene.visible`, :meth:`Scene.ambient_occlusion`,
:meth:`Scene.vertex_ao`, :meth:`Scene.render`) are thin wrappers over
:mod:`pyshadow.visibility` (backends by name) and :mod:`pyshadow.render`.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np
import trimesh

from ._compat import deprecated, keyword_only, legacy_sampling
from ._validate import FLOAT32_MAX, LOOKUPS, check_lookup, flag, uniform_scale
from .contact import ground_sheet_slots
from .csm import CoherentShadowMap
from .csm.choose import _max_bytes, _max_error
from .csm.core import DEFAULT_BIAS_TAN, DEFAULT_BIAS_TEXELS, VOTE_BIAS_TEXELS
from .mesh import bounding_sphere, check_mesh, mesh_hash, normalised_bounds, referenced_mesh
from .sampling import Sampling
from .scene_arrays import scene_arrays
from .scene_moves import (add_instances, checked_ground, csm_options, held_transform, live_instance, loaded_mesh,
                          placed_vertices, remove_instances, set_transforms)
from .vertex_points import corner_ao
from .views import ViewSet

__all__ = ["Scene", "Instance", "GROUND_ID", "DEFAULT_BIAS_TEXELS", "DEFAULT_BIAS_TAN",
           "VOTE_BIAS_TEXELS", "LOOKUPS"]

GROUND_ID = -2           # object id of the ground plane in rendered images
_AO_ORDER = ("samples", "strategy", "patterns", "seed", "bent_normals")
_RENDER_ORDER = ("samples", "strategy", "seed", "patterns")


def _query_options(where, args, old, sampling, return_bent_normals, lookup, backend, default, order=_AO_ORDER):
    """(sampling, return_bent_normals, backend name) of a Scene query, old forms included."""
    filtered = old.pop("filtered", None)
    sampling, extra = legacy_sampling(where, args, order, sampling, old, default, stacklevel=5)
    bent = flag(extra.get("bent_normals", return_bent_normals), "return_bent_normals")   # "False" was true
    return sampling, bent, _backend(where, lookup, backend, filtered, stacklevel=5)


def _backend(where, lookup, backend, filtered, stacklevel=4):
    """The visibility backend a Scene query asks: from ``lookup`` unless ``backend`` names one."""
    if filtered is not None:
        deprecated(f"{where}(filtered=...)", 'lookup="vote" (or "nearest")', stacklevel=stacklevel)
        if lookup != "nearest":
            raise TypeError(f"{where}: pass lookup= or the old filtered=, not both")
        lookup = "vote" if filtered else "nearest"
    check_lookup(lookup)
    if backend is None:
        return "csm" if lookup == "nearest" else "csm-vote"
    if lookup != "nearest":
        raise TypeError(f"{where}: lookup= chooses between the CSM backends; with backend= leave it out")
    return backend


#: The fields of an :class:`Instance` its scene's kept tables are derived from (see ``Instance.__setattr__``).
_HELD_FIELDS = frozenset({"transform", "casts", "csm", "mesh", "removed"})
_PLACED_ONLY = ("Scene.instances is read-only: Scene.add places an object, Scene.set_transform moves one and "
                "Scene.remove takes one out, the others keeping their ids (the queries keep tables derived from the "
                "list; an edit would leave them answering for the old one)")


class _Placed(list):
    """:attr:`Scene.instances`: a list that only :meth:`Scene.add` extends (every mutator refuses)."""

    def _refuse(self, *args, **kwargs):
        raise TypeError(_PLACED_ONLY)

    append = extend = insert = pop = remove = clear = sort = reverse = _refuse
    __setitem__ = __delitem__ = __iadd__ = __imul__ = _refuse

    def __reduce__(self):               # pickle and copy through the constructor, not append/extend
        return _Placed, (list(self),)


def _copied(scene):
    """``copy.copy`` of a :class:`Scene`: its own list of its own :class:`Instance` objects (sharing the
    CSMs, meshes and read-only transforms). The default copy shared the list and the instances: moving an
    instance of the copy moved the original's, whose kept tables (its version unchanged) went on answering
    from the old place, and adding to the copy added to the original."""
    other = object.__new__(type(scene))
    other.__dict__.update(scene.__dict__)
    other._placed = _Placed([copy.copy(inst) for inst in scene._placed])
    other._built, other.csm_options = dict(scene._built), dict(scene.csm_options)
    return other


@dataclass(eq=False)
class Instance:
    """One placed object of a :class:`Scene` (compared by identity; its fields are read-only once placed:
    move it with :meth:`Scene.set_transform`)."""

    transform: np.ndarray
    casts: bool
    csm: CoherentShadowMap | None = None
    mesh: trimesh.Trimesh | None = None
    # a receiver's sphere (object frame)
    _sphere: tuple | None = field(default=None, repr=False)
    # trimesh's hash of a caster's mesh as placed: pyshadow.scene_arrays.check_meshes
    _stamp: int | None = field(default=None, repr=False)
    # trimesh's hash of the receiver's mesh its _sphere was found for (a mesh changed in place: found again)
    _sphere_stamp: int | None = field(default=None, repr=False)
    removed: bool = False       # a placeholder of Scene.remove (casts False, no CSM, no mesh) keeping its id's place

    @property
    def scale(self) -> float:
        return float(uniform_scale(self.transform[:3, :3]))

    @property
    def rotation(self) -> np.ndarray:
        return self.transform[:3, :3] / self.scale

    def __setattr__(self, name, value):
        if name in _HELD_FIELDS and name in self.__dict__:
            raise AttributeError(f"Instance.{name} is read-only: the scene's queries keep tables derived from it "
                                 "(move an instance with Scene.set_transform; add another for a new object)")
        object.__setattr__(self, name, value)

    def __setstate__(self, state):
        """Restored by pickle or deepcopy: the transform read-only again (NumPy does not keep the flag)."""
        self.__dict__.update(state)
        if isinstance(self.__dict__.get("transform"), np.ndarray):
            self.transform.flags.writeable = False

    def object_sphere(self):
        if self.removed:
            raise ValueError("a removed instance (a placeholder of Scene.remove) has no bounding sphere")
        if self.csm is not None:
            return self.csm.centre, self.csm.radius
        stamp = hash(self.mesh)                 # a receiver: its mesh's sphere (a convex hull), found again
        if self._sphere is None or self._sphere_stamp != stamp:     # where the mesh was changed in place
            self._sphere, self._sphere_stamp = bounding_sphere(self.mesh), stamp
        return self._sphere

    def world_sphere(self):
        c, r = self.object_sphere()
        T = self.transform
        return T[:3, :3] @ c + T[:3, 3], r * self.scale


def _set_ground(scene, height) -> None:
    """``scene.ground = height``, checked as :class:`Scene` checks its ``ground``: a NaN set later dropped the
    plane silently (every ray passed it) and 1e40 overflowed float32 in the kernels."""
    height = checked_ground(height)
    if height is not None and not abs(height) <= FLOAT32_MAX:       # the kernels take it as a float32
        raise ValueError(f"ground must be a finite height within float32's range, got {height}")
    scene._ground = height


class Scene:
    """Rigid bodies with CSMs, receivers and an optional ground plane.

    Threads may query one scene at once, but not change it meanwhile (:func:`pyshadow.scene_moves.set_transforms`).

    Parameters
    ----------
    ground : float, optional
        Height ``h`` of an infinite ground plane ``y = h`` (analytic, no CSM):
        a ray from a point above it that points downwards is occluded.
    views : ViewSet, optional
        Map directions for CSMs built by :meth:`add` from meshes; default
        ``ViewSet.zigzag(64, 128)`` (the thesis's 8192 maps).
    resolution, depth_bits, layers, footprint :
        Passed to :meth:`CoherentShadowMap.build` for meshes added as casters.
    progress : bool, optional
        Progress bars while building CSMs.

    Examples
    --------
    >>> import trimesh
    >>> scene = Scene(ground=0.0, views=ViewSet.zigzag(8, 16), resolution=32)
    >>> box = trimesh.creation.box((1, 1, 1))
    >>> i = scene.add(box, trimesh.transformations.translation_matrix([0, 0.5, 0]))
    >>> float(scene.ambient_occlusion([[3.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]], sampling=Sampling(64))[0]) > 0.8
    True
    """

    def __init__(self, ground: float | None = None, *, views: ViewSet | None = None,
                 resolution: int = 128, depth_bits: int = 16, layers="auto", footprint: bool = False,
                 progress: bool = False):
        self.ground = ground                # checked (_set_ground)
        self.csm_options = csm_options(views, resolution, depth_bits, layers, footprint)    # checked now, not at add
        self.progress = flag(progress, "progress")     # "no" drew progress bars
        self._placed = _Placed()
        self._built: dict = {}           # ("csm", mesh hash[, max_error, max_bytes, lookup]) -> (mesh, its CSM)
        self._version = 0                # advanced by add(), set_transform() and remove() (scene_arrays)

    __copy__ = _copied                  # its own instance list and instances (see _copied)
    remove = remove_instances           # take instances out, the others keeping their ids
    ground = property(lambda self: self._ground, _set_ground,
                      doc="Height of the ground plane (float, world units) or None; settable, checked as in __init__.")
    instances = property(lambda self: self._placed, doc="The placed :class:`Instance` objects, by instance id "
                         "(read-only: :meth:`add` places, :meth:`set_transform` moves, :meth:`remove` marks removed).")

    # ------------------------------------------------------------------
    # building the scene
    # ------------------------------------------------------------------
    @keyword_only("Scene.add", old=1)
    def add(self, obj, transform=None, *, casts: bool = True, mesh=None, max_error: float | None = None,
            max_bytes: int | None = None, lookup: str = "nearest") -> int:
        """Place an object; returns its instance id, or the ids (k,) int64 of k transforms (k, 4, 4).

        Parameters
        ----------
        obj : CoherentShadowMap, trimesh.Trimesh, pyvista mesh or path
            A CSM (a caster; several instances share one CSM and its device
            buffers), or a mesh (a pyvista one or a file: :func:`pyshadow.load_mesh`).
            A mesh with ``casts=True`` gets a CSM built with the scene's options
            (once per geometry: equal meshes share one); with ``casts=False`` it only receives.
        transform : array_like, shape (4, 4) or (k, 4, 4), optional
            Object-to-world transform: rotation (5 decimals suffice: placed as the nearest), translation,
            uniform positive scale. Default identity. A stack places the object k times at once (one CSM, one
            check of the stack: :func:`pyshadow.scene_moves.add_instances`); an empty one (``[]``) places none.
        casts : bool, optional
        mesh : trimesh.Trimesh, optional
            The mesh of a CSM given as ``obj``, needed to draw it
            (:meth:`render`) and for :meth:`vertex_ao` and the Embree
            reference; it must be the mesh the CSM was built from.
        max_error, max_bytes, lookup : optional
            For a mesh that casts: its CSM's maps and resolution chosen for this accuracy (disagreement
            with Embree), within these bytes, or both, and this lookup (:meth:`CoherentShadowMap.build`).

        Raises
        ------
        ValueError
            Non-rigid transform, a CSM added with ``casts=False``, or a mesh
            that does not match the CSM.
        """
        chosen = (max_error, max_bytes, lookup)
        if np.ndim(transform) == 3 or np.shape(transform) == (0,):     # a stack, or no transforms ([])
            return add_instances(self, transform, lambda T: _new_instance(self, obj, T, casts, mesh, *chosen))
        T = held_transform(np.eye(4) if transform is None else transform)
        list.append(self._placed, _new_instance(self, obj, T, casts, mesh, *chosen))
        self._version += 1
        return len(self.instances) - 1

    def _instance(self, instance_id) -> Instance:
        if isinstance(instance_id, bool) or not isinstance(instance_id, (int, np.integer)):    # was IndexError
            raise TypeError(f"an instance id is an int (as Scene.add returns), got {instance_id!r}")
        if not 0 <= instance_id < len(self.instances):
            raise IndexError(f"no instance {instance_id!r} (the scene has {len(self.instances)})")
        return live_instance(self.instances[int(instance_id)], instance_id)

    def set_transform(self, instance_id, transform) -> None:
        """Move an instance (id, 4x4 rigid transform as in :meth:`add`) or many: ids (k,), transforms (k, 4, 4).
        Nothing is rebuilt; all are checked before any moves (:func:`pyshadow.scene_moves.set_transforms`)."""
        set_transforms(self, instance_id, transform)

    def transform(self, instance_id) -> np.ndarray:
        """The current 4x4 transform of an instance (a copy); of a sequence of k ids, (k, 4, 4)."""
        if np.ndim(instance_id) == 1:       # as set_transform takes them
            return np.array([self._instance(i).transform for i in np.asarray(instance_id).tolist()]).reshape(-1, 4, 4)
        return self._instance(instance_id).transform.copy()

    @property
    def casters(self) -> list[int]:
        return np.flatnonzero(scene_arrays(self)["casts"]).tolist()

    def caster_types(self):
        """The distinct CSMs of the casters (list, in first-use order) and ``{id(csm): type index}``."""
        a = scene_arrays(self)
        return list(a["types"]), dict(a["type_index"])

    def caster_slots(self, surface_ids, n, points=None):
        """Caster slot of each point's surface, (n,) int32: -1 unknown, -2 not a caster.

        ``surface_ids`` are instance ids (or -1 unknown, ``GROUND_ID``); a caster's slot is its position
        in :attr:`casters`. ``points`` ((n, 3) world): :func:`pyshadow.contact.ground_sheet_slots`."""
        return _caster_slots(self, surface_ids, n, points)

    def anchor(self, points=None) -> np.ndarray:
        """A world point near the scene, (3,) float64; device coordinates are relative to it.

        The mean of the instances' bounding-sphere centres (of ``points``
        for an empty scene).
        """
        held = scene_arrays(self)               # kept with the scene's arrays until it changes
        if held["live"].any():                  # (a scene whose instances were all removed: as an empty one)
            if "anchor" not in held:
                held["anchor"] = np.mean(held["world_centre"][held["live"]], axis=0)
            return held["anchor"].copy()
        return _points_anchor(points)

    def scale(self) -> float:
        """Largest world bounding-sphere radius of the instances not removed (1 for none)."""
        held = scene_arrays(self)
        return float(held["world_radius"][held["live"]].max()) if held["live"].any() else 1.0

    # ------------------------------------------------------------------
    # queries: thin wrappers over pyshadow.visibility and pyshadow.render
    # ------------------------------------------------------------------
    def visible(self, points, directions, *, lookup: str = "nearest", bias: float | None = None,
                surface_ids=None, backend=None, filtered=None, normals=None, max_distance=None,
                straddle: str = "error") -> np.ndarray:
        """Is each ray unoccluded by the scene's casters and ground plane?

        :func:`pyshadow.visibility.visible` on this scene, which documents
        every parameter: ``points``, ``directions`` (N, 3) world positions
        and directions (normalised there); ``bias``; ``surface_ids``;
        ``normals`` (grazing rays over a flat face are not shadowed by it, and
        a wall rising beside the point is seen);
        ``max_distance`` (float or (N,), world units: finite rays, e.g.
        towards a point light; :mod:`pyshadow.visibility.finite`) and
        ``straddle`` (``'error'`` or ``'embree'``: rays ending inside a
        caster's bounding sphere, which a CSM cannot answer).

        Parameters
        ----------
        lookup : {'nearest', 'vote'}, optional
            The CSM lookup: one texel of each caster's nearest map (backend
            ``"csm"``), or the weighted vote of four maps times four texels
            (``"csm-vote"``).
        backend : str or VisibilityBackend, optional
            Another backend (:func:`pyshadow.visibility.backends`), e.g.
            ``"embree"`` or ``"numpy"``. ``filtered``: deprecated ``lookup``.

        Returns
        -------
        ndarray, shape (N,), bool
            True where the ray reaches the sky (or its end).
        """
        from . import visibility

        name = _backend("Scene.visible", lookup, backend, filtered)
        return visibility.visible(self, points, directions, backend=name, bias=bias, surface_ids=surface_ids,
                                  normals=normals, max_distance=max_distance, straddle=straddle)

    def ambient_occlusion(self, points, normals, *args, sampling: Sampling | None = None,
                          return_bent_normals: bool = False, lookup: str = "nearest", bias: float | None = None,
                          indices=None, surface_ids=None, backend=None, max_distance=None, obscurance=None, **old):
        """Ambient occlusion of surface points (1 = open): :func:`pyshadow.visibility.ambient_occlusion`.

        Parameters
        ----------
        points, normals : array_like, shape (N, 3)
            World positions and surface normals (normalised here; zero
            normals are an error).
        sampling : Sampling, optional
            Default ``Sampling()`` (36 Hammersley directions, 256 patterns).
        return_bent_normals : bool, optional
            Also return the normalised sum of the unoccluded directions.
        lookup, bias, surface_ids, backend : optional
            As in :meth:`visible`.
        indices : array_like of int, optional
            Sample-pattern index of each point; default ``arange(N)``.
        max_distance, obscurance : optional
            Distance-limited and distance-weighted AO (:func:`pyshadow.visibility.ambient_occlusion`).
        **old
            Deprecated: ``samples, strategy, patterns, seed, bent_normals``
            (also positionally, in that order) and ``filtered``.

        Returns
        -------
        ao : ndarray, shape (N,), float32
            Unoccluded cosine-weighted fraction in [0, 1].
        bent : ndarray, shape (N, 3), float32
            Only with ``return_bent_normals=True``.
        """
        from . import visibility

        sampling, bent, name = _query_options("Scene.ambient_occlusion", args, old, sampling, return_bent_normals,
                                              lookup, backend, Sampling())
        return visibility.ambient_occlusion(self, points, normals, backend=name, sampling=sampling,
                                            return_bent_normals=bent, bias=bias, indices=indices,
                                            surface_ids=surface_ids, max_distance=max_distance, obscurance=obscurance)

    # ------------------------------------------------------------------
    # meshes, vertices, images
    # ------------------------------------------------------------------
    def vertex_points(self, instance_id: int):
        """World vertex positions (V, 3) and unit vertex normals (V, 3) of an instance, float64."""
        return placed_vertices(self._instance(instance_id), instance_id)

    def vertex_ao(self, instance_id: int, *args, sampling: Sampling | None = None,
                  return_bent_normals: bool = False, lookup: str = "nearest", bias: float | None = None,
                  backend=None, **old):
        """Per-vertex AO of an instance's mesh (for display), as :meth:`ambient_occlusion`.

        Points are the vertices of ``instances[instance_id].mesh`` in world space (a file or pyvista mesh added is
        cleaned first: coincident points merged; :func:`pyshadow.viz.point_values` puts the values on a pyvista
        dataset's own points), normals its area-weighted vertex normals; the default sampling is ``Sampling(64)``.
        Returns ``(V,)`` float32 (and ``(V, 3)`` bent normals with ``return_bent_normals=True``).
        """
        sampling, bent, name = _query_options("Scene.vertex_ao", args, old, sampling, return_bent_normals,
                                              lookup, backend, Sampling(64))
        pts, nrm = self.vertex_points(instance_id)
        ok = np.linalg.norm(nrm, axis=1) > 0
        nrm = nrm if ok.all() else np.where(ok[:, None], nrm, [0.0, 1.0, 0.0])   # isolated vertices: any normal
        out = self.ambient_occlusion(pts, nrm, sampling=sampling, return_bent_normals=bent, bias=bias,
                                     surface_ids=int(instance_id), backend=name)
        return corner_ao(self, instance_id, pts, nrm, sampling, out, name, bias)   # concave corners and edges

    def ground_quad(self, size: float | None = None) -> trimesh.Trimesh:
        """A finite square of the ground plane for drawing: :func:`pyshadow.render.ground_quad`."""
        from .render import ground_quad

        return ground_quad(self, size)

    def draw_items(self, ground_size: float | None = None):
        """(mesh, transform) items to draw and the object id of each: :func:`pyshadow.render.draw_items`."""
        from .render import draw_items

        return draw_items(self, ground_size)

    def render(self, camera, *args, sampling: Sampling | None = None, lookup: str = "nearest",
               denoise: str | None = None, ao_scale: int = 1, ground_size: float | None = None,
               bias: float | None = None, backend=None, normals: str = "flat", crease_angle=None, lighting=None,
               **old):
        """Render AO and the G-buffer of the scene from ``camera``: :func:`pyshadow.render.render`.

        Parameters
        ----------
        camera : Camera
        sampling : Sampling, optional
            Default ``Sampling()``; pixel ``(r, c)`` uses pattern index ``r * W + c``.
        lookup, bias, backend : optional
            As in :meth:`visible` (``backend`` answers the AO rays).
        denoise : {None, 'bilateral', 'separable', 'box'}, optional
            Edge-aware filtering of the AO image (:mod:`pyshadow.filters`).
        ao_scale : {1, 2, 4}, optional
            AO at 1/ao_scale resolution, upsampled with the G-buffer.
        ground_size : float, optional
            Side of the drawn ground quad (:meth:`ground_quad`).
        normals, crease_angle, lighting : optional
            Shading normals and a lit frame (``Frame.radiance``), as :func:`pyshadow.render.render`
            (``crease_angle`` None: its default).
        **old
            Deprecated: ``samples, strategy, seed, patterns`` (also
            positionally, in that order), ``filter`` and ``filtered``.

        Returns
        -------
        pyshadow.render.Frame
            Also readable as a mapping (``frame["ao"]``).
        """
        from . import render as render_stage

        if "filter" in old:
            deprecated("Scene.render(filter=...)", "denoise=", stacklevel=3)
            if denoise is not None:
                raise TypeError("Scene.render: pass denoise= or the old filter=, not both")
            denoise = old.pop("filter")
        sampling, _, name = _query_options("Scene.render", args, old, sampling, False, lookup, backend,
                                           Sampling(), _RENDER_ORDER)
        extra = {} if crease_angle is None else {"crease_angle": crease_angle}
        return render_stage.render(self, camera, visibility=name, sampling=sampling, denoise=denoise,
                                   ao_scale=ao_scale, ground_size=ground_size, bias=bias, normals=normals,
                                   lighting=lighting, **extra)


def _points_anchor(points) -> np.ndarray:
    """:meth:`Scene.anchor` of an empty scene: the mean of ``points`` ((N, 3), any array-like), or the origin."""
    if points is None:
        return np.zeros(3)
    if not isinstance(points, np.ndarray):
        points = np.asarray(points, np.float64)
    if points.ndim != 2 or points.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {points.shape}")
    return points.mean(axis=0) if len(points) else np.zeros(3)


def _new_instance(scene, obj, T, casts, mesh, max_error=None, max_bytes=None, lookup="nearest") -> Instance:
    """The :class:`Instance` that :meth:`Scene.add` places (building a caster's CSM once per mesh)."""
    if not isinstance(casts, (bool, np.bool_)):
        raise TypeError(f"casts must be True or False, got {casts!r}")
    if lookup not in ("nearest", "vote", "auto"):
        raise ValueError(f"lookup must be 'nearest', 'vote' or 'auto', got {lookup!r}")
    if isinstance(obj, CoherentShadowMap):
        if not casts:
            raise ValueError("a CoherentShadowMap always casts; add its mesh with casts=False instead")
        if max_error is not None or max_bytes is not None:
            raise ValueError("max_error= and max_bytes= choose the CSM built for a mesh; this CSM is built already")
        if mesh is not None:
            mesh = loaded_mesh(scene, mesh)
            if (digest := mesh_hash(mesh)) != obj.mesh_hash:
                raise ValueError("mesh does not match the CSM (different mesh hash)")
            _check_csm_frame(obj, mesh, digest)
        inst = Instance(T, True, csm=obj, mesh=mesh, _stamp=None if mesh is None else hash(mesh))
    else:
        obj = loaded_mesh(scene, obj)          # first: a (csm, info) pair of CSMCache.csm is named as such
        if mesh is not None:
            raise ValueError("mesh= is only for CSMs; pass the mesh as obj")
        check_mesh(obj, "Scene.add")            # a mesh object is used as it is: checked, not cleaned
        csm = None
        if casts:
            # one CSM per geometry and options: twenty equal boxes made apart built twenty (7 s each) before
            digest = mesh_hash(obj)             # (of the mesh now: one edited in place since gets its own)
            target = (None if max_error is None else _max_error(max_error),
                      None if max_bytes is None else _max_bytes(max_bytes))
            key = ("csm", digest) if target == (None, None) else ("csm", digest, *target, lookup)
            csm = scene._built[key][1] if key in scene._built else None
            o = scene.csm_options
            if csm is None and target != (None, None):
                csm = CoherentShadowMap.build(obj, depth_bits=o["depth_bits"], layers=o["layers"], lookup=lookup,
                                              progress=scene.progress, max_error=target[0], max_bytes=target[1],
                                              footprint=o["footprint"])
            elif csm is None:
                csm = CoherentShadowMap.build(obj, o["views"], resolution=o["resolution"],
                                              depth_bits=o["depth_bits"], layers=o["layers"],
                                              progress=scene.progress, footprint=o["footprint"])
            scene._built[key] = (obj, csm)
        elif max_error is not None or max_bytes is not None:
            raise ValueError("max_error= and max_bytes= choose a caster's CSM; a receiver (casts=False) has none")
        inst = Instance(T, bool(casts), csm=csm, mesh=obj, _stamp=hash(obj) if casts else None)
    return inst


#: the (mesh hash, centre, radius, box) of the CSMs whose frame held their mesh: checked once, not
#: once per instance (10,000 instances of one CSM)
_FRAMES_OK: set = set()


def _check_csm_frame(csm, mesh, digest):
    """The CSM's sphere holds its mesh and its box is the mesh's: the mesh hash does not cover them, so
    a file edited there (and its checksum made good) would shadow from the wrong place."""
    from .raster import check_frame

    key = (digest, csm.centre.tobytes(), float(csm.radius), None if csm.box is None else csm.box.tobytes())
    if key in _FRAMES_OK:
        return
    try:
        check_frame(np.asarray(referenced_mesh(mesh).vertices, np.float64), (csm.centre, csm.radius))
    except ValueError as e:
        raise ValueError(f"the CSM's frame does not hold its mesh ({e}): an edited file?") from None
    if csm.box is not None and not np.allclose(csm.box, normalised_bounds(mesh, csm.centre, csm.radius),
                                               rtol=0.0, atol=1e-9):
        raise ValueError("the CSM's box is not its mesh's box in its frame: an edited file?")
    _FRAMES_OK.add(key)


def _caster_slots(scene, surface_ids, n, points=None):
    """:meth:`Scene.caster_slots`: with ``points``, the ground's points on an open caster's face lying on
    the ground take that caster's slot (:func:`pyshadow.contact.ground_sheet_slots`)."""
    if surface_ids is None:
        return np.full(n, -1, np.int32)
    slots = _slots_of_ids(scene, surface_ids, n)
    return slots if points is None else ground_sheet_slots(scene, points, slots)


def _slots_of_ids(scene, surface_ids, n):
    """Caster slots of the instance ids ``surface_ids`` (not None), validated."""
    ids = np.asarray(surface_ids)
    if not np.issubdtype(ids.dtype, np.integer):
        raise TypeError(f"surface_ids must be integers, got {ids.dtype}")
    if (ids.dtype == np.int32 and ids.shape == (n,) and ids.flags.c_contiguous and n
            and scene_arrays(scene)["casts"].all()
            and ids.min() >= GROUND_ID and ids.max() < len(scene.instances)):
        return ids          # every instance casts: ids are the slots (-1, -2 included)
    if ids.shape not in ((), (1,), (n,)):
        raise ValueError(f"surface_ids must be one id or {n} (one a query), got shape {ids.shape}")
    if ids.dtype.kind == "u" and ids.size and ids.max() > np.iinfo(np.int64).max:    # would wrap negative
        raise ValueError(f"surface_ids must be instance ids, -1 (unknown) or {GROUND_ID} (ground); got {ids.max()}")
    ids = np.broadcast_to(ids, (n,)).astype(np.int64)
    ok = (ids == -1) | (ids == GROUND_ID) | ((ids >= 0) & (ids < len(scene.instances)))
    if not ok.all():
        raise ValueError(f"surface_ids must be instance ids, -1 (unknown) or {GROUND_ID} (ground); "
                         f"got {int(ids[~ok][0])}")
    held = scene_arrays(scene)
    slot = held.get("caster_slot")          # kept with the scene's arrays until it changes
    if slot is None:
        casts = held["casts"]
        slot = np.full(len(casts) + 2, -2, np.int32)         # receivers: -2
        slot[np.flatnonzero(casts)] = np.arange(int(casts.sum()), dtype=np.int32)
        slot[-1] = -1                                        # index -1: unknown
        slot[-2] = -2                                        # index -2: ground
        held["caster_slot"] = slot
    return slot[ids]


def _old_visible_reference(scene, points, directions, *, bias=None, surface_ids=None, filtered=False):
    """``pyshadow.scene.visible_reference`` as it was: ``filtered=`` for ``lookup="vote"``."""
    from .visibility.mirror import visible_reference

    return visible_reference(scene, points, directions, bias=bias, surface_ids=surface_ids,
                             lookup="vote" if filtered else "nearest")


_MOVED = {"visible_reference": ("pyshadow.visibility.mirror", "visible_reference", _old_visible_reference),
          "shadow_vote": ("pyshadow.csm.reference", "shadow_vote", None),
          "FILTERED_BIAS_TEXELS": ("pyshadow.csm.core", "VOTE_BIAS_TEXELS", None)}


def __getattr__(name):
    """Old homes of moved functions: they keep working for a release, with a DeprecationWarning."""
    if name in _MOVED:
        import importlib

        module, attr, old = _MOVED[name]
        deprecated(f"pyshadow.scene.{name}", f"{module}.{attr}")
        return old if old is not None else getattr(importlib.import_module(module), attr)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
