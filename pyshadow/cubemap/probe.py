"""Cube-map probes: six 90-degree G-buffer faces rendered at a point of a scene.

Seed 002, sections 3.1.3 and 4.2 (cube map setup, 4.2.4): a probe stores, per
texel of each of its six faces, the world position, the normal and the
distance from the probe's centre of the surface it sees. Per-texel AO is
computed from these maps (:mod:`pyshadow.cubemap.estimators`) and projected
back onto a camera's pixels (:mod:`pyshadow.cubemap.project`).

Face frames
-----------
Face ``f`` (0..5) looks along ``+x, -x, +y, -y, +z, -z``; it is the
:class:`pyshadow.Camera` with ``fov_y = 90``, square ``R x R``, up hint
``+y`` for the side faces and ``-z`` / ``+z`` for ``+y`` / ``-y``. A world
direction ``d`` from the centre belongs to the face of its largest
``|component|`` (the first axis on ties), and inside that face to
``x = d.right / d.forward``, ``y = d.up / d.forward`` in ``[-1, 1]``: column
``floor((x + 1) R / 2)``, row ``floor((1 - y) R / 2)`` (row 0 at the top),
both clamped to ``0..R-1``.
"""
from __future__ import annotations

import numpy as np

from .._validate import check_int, point3, rows3
from ..camera import Camera, axis_camera
from ..gbuffer import render_gbuffer
from ..scene import GROUND_ID

__all__ = ["CubeProbe", "FACE_FORWARD", "face_camera", "MIN_RESOLUTION", "MAX_RESOLUTION", "face_frames",
           "direction_texels"]

#: Smallest and largest accepted face resolution (texels per side).
MIN_RESOLUTION, MAX_RESOLUTION = 16, 2048

#: Viewing direction of each face, (6, 3).
FACE_FORWARD = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=np.float64)
_UP_HINT = np.array([[0, 1, 0], [0, 1, 0], [0, 0, -1], [0, 0, 1], [0, 1, 0], [0, 1, 0]], dtype=np.float64)

#: Fraction of a probe's texels that may show back faces of closed meshes before it counts as inside one.
INSIDE_FRACTION = 0.5


def face_frames() -> np.ndarray:
    """Rows (right, up, forward) of each face camera, (6, 3, 3) float64 (``Camera.rotation``)."""
    return np.stack([Camera([0, 0, 0], FACE_FORWARD[f], up=_UP_HINT[f], fov_y=90.0, width=16, height=16).rotation
                     for f in range(6)])


_FRAMES = face_frames()


def face_camera(centre, face: int, resolution: int) -> Camera:
    """The square 90-degree :class:`pyshadow.Camera` of face ``face`` (0..5) at ``centre``."""
    face = check_int(face, "face", 0, 5)        # (-1 was face 5's camera, 1.0 an IndexError)
    return axis_camera(centre, FACE_FORWARD[face], _UP_HINT[face], resolution)


def direction_texels(directions, resolution: int):
    """Face and texel of world directions from a probe's centre (module docstring rule).

    Parameters
    ----------
    directions : array_like, shape (N, 3) or (3,), real
        World directions (any length; a zero vector gets a valid texel of face 0). Finite real numbers:
        ValueError for another shape or a NaN or infinite entry (a NaN row had no face: it read the
        centre texel of face 4), TypeError for bools, complex numbers, strings.
    resolution : int

    Returns
    -------
    face, row, col : ndarray, shape (N,), int64
    x, y : ndarray, shape (N,), float64
        The face-plane coordinates in ``[-1, 1]``.
    """
    R = check_int(resolution, "resolution", 1)
    a = np.asarray(directions)
    d = rows3(a.reshape(1, 3) if a.shape == (3,) else a, "direction_texels: directions")
    return _direction_texels(d, R)


def _direction_texels(d, R):
    """:func:`direction_texels` of checked float64 directions (N, 3) (the lookups' own, every march step)."""
    a = np.abs(d)
    axis = np.where((a[:, 0] >= a[:, 1]) & (a[:, 0] >= a[:, 2]), 0, np.where(a[:, 1] >= a[:, 2], 1, 2))
    neg = d[np.arange(len(d)), axis] < 0
    face = 2 * axis + neg
    fr = _FRAMES[face]
    fwd = np.einsum("ij,ij->i", d, fr[:, 2])
    with np.errstate(divide="ignore", invalid="ignore"):
        x = np.nan_to_num(np.einsum("ij,ij->i", d, fr[:, 0]) / fwd)    # a zero vector: some valid texel
        y = np.nan_to_num(np.einsum("ij,ij->i", d, fr[:, 1]) / fwd)
    col = np.clip(np.floor((x + 1.0) * 0.5 * R), 0, R - 1).astype(np.int64)
    row = np.clip(np.floor((1.0 - y) * 0.5 * R), 0, R - 1).astype(np.int64)
    return face, row, col, x, y


def _check_scene(scene, who: str) -> None:
    """TypeError unless ``scene`` is a :class:`pyshadow.Scene` (``pyshadow.data.default_scene()``'s (scene,
    camera) pair failed only at the first probe: "'tuple' object has no attribute 'ground'")."""
    from ..scene import Scene

    if not isinstance(scene, Scene):
        raise TypeError(f"{who}: scene must be a pyshadow.Scene, got {type(scene).__name__}")


def _check_resolution(resolution) -> int:
    if isinstance(resolution, bool) or not isinstance(resolution, (int, np.integer)) \
            or not MIN_RESOLUTION <= resolution <= MAX_RESOLUTION:
        raise ValueError(f"CubeProbe: resolution must be an int in {MIN_RESOLUTION}..{MAX_RESOLUTION}, "
                         f"got {resolution!r}")
    return int(resolution)


class CubeProbe:
    """Six G-buffer faces of a :class:`pyshadow.Scene` seen from one point.

    Parameters
    ----------
    scene : pyshadow.Scene
        What is drawn: every instance with a mesh and the ground quad
        (:func:`pyshadow.render.draw_items`).
    centre : array_like, shape (3,)
        World position of the probe (world units).
    resolution : int, optional
        Texels per face side, ``MIN_RESOLUTION .. MAX_RESOLUTION`` (16..2048).
    ground_size : float, optional
        Side of the drawn ground quad (default of :func:`pyshadow.render.ground_quad`).

    Attributes
    ----------
    centre : ndarray, shape (3,), float64
    resolution : int
    depth : ndarray, shape (6, R, R), float32
        Distance from ``centre`` to the surface along each texel's centre ray
        (world units), ``inf`` where the face sees nothing.
    position : ndarray, shape (6, R, R, 3), float32
        World position of that surface point (NaN where none).
    normal : ndarray, shape (6, R, R, 3), float32
        Unit world face normal turned towards the probe (0 where none).
    object_id : ndarray, shape (6, R, R), int32
        Instance id, ``GROUND_ID`` (-2) for the ground, -1 for nothing.
    occluder : ndarray, shape (6, R, R), bool
        The texel shows a caster (an instance added with ``casts=True``):
        the geometry AO counts as occluding. Receivers (``casts=False``) and
        the ground quad do not (the ground plane is decided analytically).

    Raises
    ------
    ValueError
        A resolution out of range, a centre that is not 3 finite numbers, a
        centre below the ground plane, or a centre inside a closed body (more
        than half of the texels show back faces of watertight meshes; the
        message names the instance).
    TypeError
        A scene that is not a :class:`pyshadow.Scene`.

    Notes
    -----
    The probe records the scene's transforms and ground when rendered;
    :attr:`stale` is True after any later :meth:`pyshadow.Scene.set_transform`,
    :meth:`pyshadow.Scene.add` or change of ``Scene.ground``: its maps then no
    longer show the scene.
    """

    def __init__(self, scene, centre, resolution: int = 128, *, ground_size: float | None = None):
        from ..render import draw_items

        _check_scene(scene, "CubeProbe")
        self.resolution = R = _check_resolution(resolution)
        # strings were converted ("1" as 1.0, "abc" an error naming nothing), complex numbers lost their
        # imaginary part with a ComplexWarning and booleans were read as 0 and 1
        c = point3(centre, "CubeProbe: centre")
        if scene.ground is not None and c[1] < scene.ground:
            raise ValueError(f"CubeProbe: centre {c.tolist()} lies below the ground plane y = {scene.ground}")
        self.centre = c
        self.scene = scene
        self._version = getattr(scene, "_version", None)
        self._transforms = [inst.transform.copy() for inst in scene.instances]
        self._ground = scene.ground     # the plane drawn (a height set later was not stale: the old one answered)
        items, ids = draw_items(scene, ground_size)
        casts = np.array([scene.instances[i].casts if i >= 0 else False for i in ids], dtype=bool)
        self.depth = np.full((6, R, R), np.inf, np.float32)
        self.position = np.full((6, R, R, 3), np.nan, np.float32)
        self.normal = np.zeros((6, R, R, 3), np.float32)
        self.object_id = np.full((6, R, R), -1, np.int32)
        self.occluder = np.zeros((6, R, R), bool)
        back = np.zeros((6, R, R), bool)
        owner = np.full((6, R, R), -1, np.int64)
        for f in range(6):
            cam = self.face_camera(f)
            g = render_gbuffer(items, cam)
            item = g["object_id"]
            hit = item >= 0
            self.depth[f] = g["depth"]
            self.position[f] = g["position"]
            self.normal[f] = g["normal"]
            self.object_id[f] = np.where(hit, ids[np.maximum(item, 0)] if len(ids) else -1, -1)
            self.occluder[f] = hit & (casts[np.maximum(item, 0)] if len(casts) else False)
            back[f], owner[f] = _back_faces(items, g, self.texel_offsets(np.arange(f * R * R, (f + 1) * R * R)))
        self._check_outside(back, owner, items, ids)

    # ------------------------------------------------------------------
    def face_camera(self, face: int) -> Camera:
        """The 90-degree camera of face ``face`` (0..5) at the probe's centre."""
        return face_camera(self.centre, face, self.resolution)

    def _check_outside(self, back, owner, items, ids):
        closed = np.array([bool(m.is_watertight) if hasattr(m, "is_watertight") else False for m, _ in items])
        inside = back & (owner >= 0) & closed[np.maximum(owner, 0)] if len(closed) else np.zeros_like(back)
        if inside.mean() > INSIDE_FRACTION:
            item = int(np.bincount(owner[inside]).argmax())
            raise ValueError(f"CubeProbe: centre {self.centre.tolist()} lies inside instance {int(ids[item])} "
                             f"({inside.mean():.0%} of its texels see back faces of closed meshes)")

    @property
    def stale(self) -> bool:
        """True when the scene changed (a transform set, an instance added or removed, the ground's height) since
        the probe was rendered."""
        sc = self.scene
        if getattr(sc, "_version", None) != self._version or len(sc.instances) != len(self._transforms) \
                or sc.ground != self._ground:
            return True
        return any(not np.array_equal(inst.transform, T) for inst, T in zip(sc.instances, self._transforms))

    @property
    def nbytes(self) -> int:
        """Bytes held by the probe's maps (depth, position, normal, object id, occluder flag)."""
        return sum(a.nbytes for a in (self.depth, self.position, self.normal, self.object_id, self.occluder))

    def texel_points(self):
        """The surface points of every covered texel.

        Returns
        -------
        index : ndarray, shape (K,), int64
            Flat texel index ``(f * R + row) * R + col``.
        points : ndarray, shape (K, 3), float64
            World positions, recomputed in float64 as ``centre + depth * u``
            with ``u`` the texel's unit centre direction.
        normals : ndarray, shape (K, 3), float64
            Unit normals facing the probe.
        """
        index = np.flatnonzero(np.isfinite(self.depth).reshape(-1))
        pts = self.centre + self.texel_offsets(index)
        n = self.normal.reshape(-1, 3)[index].astype(np.float64)
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        return index, pts, n

    def texel_offsets(self, index=None) -> np.ndarray:
        """Surface point of flat texels ``index`` (default all) relative to the centre, ``depth * u``.

        From the distance, not from :attr:`position`: a float32 world
        position far from the origin is rounded by far more than the
        distance (0.06 at 1e6), and planes or vectors taken from it moved
        the answers of a scene under a rigid motion.

        Returns
        -------
        ndarray, shape (K, 3), float64
            NaN where the texel sees nothing.
        """
        R = self.resolution
        index = np.arange(6 * R * R) if index is None else np.asarray(index, dtype=np.int64)
        d = self.depth.reshape(-1)[index].astype(np.float64)
        with np.errstate(invalid="ignore"):
            return np.where(np.isfinite(d)[:, None], d[:, None] * self.texel_directions(index), np.nan)

    def texel_directions(self, index) -> np.ndarray:
        """Unit world direction of the centre ray of flat texels ``index``, (K, 3) float64."""
        R = self.resolution
        index = np.asarray(index, dtype=np.int64)
        if index.size and not (0 <= index.min() and index.max() < 6 * R * R):
            # (-1 read the last texel, 6 R^2 failed with 'index 6 is out of bounds for axis 0 with size 6')
            raise IndexError(f"texel index out of range 0..{6 * R * R - 1} (6 faces of {R} x {R}): "
                             f"{int(index.min())}..{int(index.max())}")
        f, rc = np.divmod(index, R * R)
        row, col = np.divmod(rc, R)
        x = 2.0 * (col + 0.5) / R - 1.0
        y = 1.0 - 2.0 * (row + 0.5) / R
        fr = _FRAMES[f]
        d = fr[:, 2] + x[:, None] * fr[:, 0] + y[:, None] * fr[:, 1]
        return d / np.linalg.norm(d, axis=1, keepdims=True)

    def __repr__(self) -> str:
        return f"CubeProbe(centre={self.centre.tolist()}, resolution={self.resolution}, stale={self.stale})"


def _back_faces(items, g, offsets):
    """Which texels of one face show a mesh face whose winding normal points away from the probe.

    ``offsets`` (R^2, 3): the texels' points relative to the probe's centre (:meth:`CubeProbe.texel_offsets`;
    ``g["position"] - centre`` read float32 world points, 0.5 off at 1e7: a probe inside a 0.3 box there passed).
    """
    item, face = g["object_id"], g["face"]
    back = np.zeros(item.shape, bool)
    hit = item >= 0
    for k, (mesh, T) in enumerate(items):
        sel = hit & (item == k)
        if not sel.any():
            continue
        # the winding's own normal, not trimesh's cached face_normals (Trimesh.invert() flips the faces but left
        # them pointing out: a probe inside an inverted box room was refused as inside it, 100 % back faces);
        # each edge scaled by its largest entry, which keeps the sign and the product within float64's range
        v = np.asarray(mesh.vertices, dtype=np.float64)[np.asarray(mesh.faces)[face[sel]]]
        e1, e2 = v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]
        e1 /= np.maximum(np.abs(e1).max(axis=1, keepdims=True), 1e-300)
        e2 /= np.maximum(np.abs(e2).max(axis=1, keepdims=True), 1e-300)
        fn = np.cross(e1, e2) @ np.asarray(T, np.float64)[:3, :3].T
        back[sel] = np.einsum("ij,ij->i", fn, offsets[sel.reshape(-1)]) > 0
    return back, np.where(hit, item, -1)


def is_ground(object_id) -> np.ndarray:
    """True where ``object_id`` is the ground's."""
    return np.asarray(object_id) == GROUND_ID
