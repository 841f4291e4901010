"""Faces of an open mesh whose back is open to the outside (``two_sided='auto'`` of the build).

A CSM keeps a margin before a second surface ``z2`` where that surface faces
the light (:mod:`pyshadow.csm`): a point on it, asked with its self-bias,
must not see a stored depth within the bias. On a closed mesh the back of a
face is never asked: it lies inside the solid. On an open one it can be: the
inner floor of a box without a lid is the back of its bottom face, and a
point there, in the shadow of a wall, was reported lit where the map's
stored depth came within the bias of the floor (``two_sided=True`` keeps the
margin before every ``z2``, at 1.4-1.5x the bytes of the bundled open meshes).
Which faces need it follows from the geometry: those whose back side a ray
from outside can reach, that is, from whose back side a ray can leave the
mesh without meeting it again (:func:`exposed_back_faces`).

Where most of a mesh's area has its back open to the outside (a bowl, a box
without a lid, a sheet: :func:`open_sheet`), the space in front of those
backs is free space where other bodies lie (a ball in the bowl): the build
then also ends a map's interval near ``z1`` where ``z2`` is such a back or
faces the light (:mod:`pyshadow.csm`, "free space behind z1").
"""
from __future__ import annotations

import os

import numpy as np

from .._embree_checks import float32_rays, traced_in_chunks
from .._validate import check_int
from .surface_rule import _fibonacci_sphere

__all__ = ["exposed_back_faces", "escape_fractions", "both_sided_faces", "open_sheet", "is_auto",
           "EXPOSURE_DIRECTIONS"]

#: directions of the sphere tried from each face's back side (about half of
#: them lie in its back hemisphere)
EXPOSURE_DIRECTIONS = 64


#: faces of a mesh traced along every direction first, to order the directions for the others (at most
#: about ``_SAMPLE_FACES``, every ``_SAMPLE_STEP``-th at most)
_SAMPLE_FACES, _SAMPLE_STEP = 4096, 16


def _threads() -> int:
    """The cores this process may run on (1 where unknown)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


class _Escapes:
    """The rays of :func:`exposed_back_faces` from behind faces ``idx`` along lattice direction ``k``,
    ``escapes(idx, k)`` -> bool (len(idx),), True where the ray meets no face: Embree's answers to the rays
    :meth:`pyshadow.embree.EmbreeScene.occluded` traces, the same float32 rays (checked here once, made
    once), split over the process's cores (:func:`pyshadow._embree_checks.traced_in_chunks`). A context
    manager (its threads end with it)."""

    def __init__(self, scene, o, lattice):
        from concurrent.futures import ThreadPoolExecutor

        self.run = scene._scene.run
        self.o32 = float32_rays(o, lattice[:1], None, scene.unit)[0]      # (those of faces of no area unused)
        self.d32 = float32_rays(np.zeros((len(lattice), 3)), lattice, None, 1.0)[1]
        self.run(self.o32[:1], self.d32[:1], query="OCCLUDED")     # commits the scene before any thread asks
        self.threads = _threads()
        self.pool = ThreadPoolExecutor(self.threads) if self.threads > 1 else None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        if self.pool is not None:
            self.pool.shutdown()

    def __call__(self, idx, k) -> np.ndarray:
        o, d = self.o32[idx], self.d32[k:k + 1]
        return traced_in_chunks(self.pool, self.threads, len(o),
                                lambda s, e: np.asarray(self.run(o[s:e], d, query="OCCLUDED")) < 0)


def is_auto(two_sided) -> bool:
    """Whether ``two_sided`` is ``'auto'`` (a string compared only as a string: NumPy bools never are)."""
    return isinstance(two_sided, str) and two_sided == "auto"


def _back_rays(mesh, frame):
    """What the rays from behind the faces need: the faces' unit winding normals (F, 3), the rays'
    origin behind each centroid (F, 3), the faces of non-zero area (F,) and the Embree scene, all in
    the normalised frame ``frame`` (centre, radius).

    ``frame`` is checked as the CSM build checks it (:func:`pyshadow.raster.check_frame`: a finite
    centre, a finite radius > 0 reaching every vertex): a negative radius mirrored the mesh through
    its centre (every back of a closed box read as exposed), an infinite one reported no face
    exposed. A mesh without vertices has no face to answer for, whatever the frame."""
    from ..embree import EmbreeScene, ray_epsilon
    from ..mesh import referenced_mesh
    from ..raster import check_frame

    verts = np.asarray(referenced_mesh(mesh).vertices, dtype=np.float64).reshape(-1, 3)
    centre, radius = check_frame(verts, frame) if len(verts) else frame
    tri = (np.asarray(mesh.triangles, dtype=np.float64) - np.asarray(centre, dtype=np.float64)) / float(radius)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(n, axis=1)
    live = length > 0.0
    n[live] /= length[live, None]
    # behind the face by more than the float32 intersection error at the frame's size (1)
    o = tri.mean(axis=1) - n * float(ray_epsilon(1.0)) * 4.0
    return n, o, live, (EmbreeScene(tri) if len(tri) else None)


def exposed_back_faces(mesh, frame, directions: int = EXPOSURE_DIRECTIONS, progress=None) -> np.ndarray:
    """Faces whose back side (against their winding normal) a ray from outside the mesh can reach.

    From a point just behind each face's centroid, rays go out along the
    directions of a Fibonacci lattice that lie in the face's back hemisphere;
    a face is exposed when one of them meets no face of the mesh (Embree).
    On a closed mesh wound outwards none is. A face exposed only away from its
    centroid, or only through an opening narrower than the lattice's spacing
    (about 25 degrees at 64 directions) seen from its centroid, is not found:
    where the inside of an open mesh is seen only through small holes (the
    bunny's base) the count grows with the lattice and has not converged at
    1024 directions (:func:`escape_fractions`; benchmarks/README.md,
    ``exposure.py``).

    Parameters
    ----------
    mesh : trimesh.Trimesh
    frame : (centre, radius)
        The normalised frame (world units) the rays are traced in: float32
        keeps its precision there whatever the mesh's size and position.
    directions : int, optional
        Lattice directions over the whole sphere, >= 1.
    progress : callable, optional
        Called as ``progress(done, total)`` after each pass along one
        direction (``total`` = 2 x ``directions``: the sample's passes, then
        the other faces'): a mesh of 10^6 faces takes seconds.

    Returns
    -------
    ndarray, shape (F,), bool
        True where the face's back side is open to the outside; False for
        faces of zero area.

    Raises
    ------
    TypeError
        ``directions`` is not an int (a float, a bool or a string).
    ValueError
        ``directions`` below 1 (no ray at all: every face read as sealed), or
        ``frame`` not a finite centre and a finite radius > 0 reaching every
        vertex.

    Notes
    -----
    Lattices of different sizes are not nested: a larger ``directions``
    finds more faces on the whole but may miss some that a smaller one
    finds (on the teapot, 323 of the 870 faces found at 64 directions are
    not found at 128). The union of the answers of several sizes is the
    surest set. Each ray's answer is Embree's for that ray alone, so the
    order the rays are traced in (the directions most faces of a sample
    escape along first) and the threads they are split over (the process's
    cores) change no answer.
    """
    directions = check_int(directions, "directions", 1, why="the rays of the lattice")
    n, o, live, scene = _back_rays(mesh, frame)
    out = np.zeros(len(n), bool)
    if scene is None or not live.any():
        return out
    lattice = _fibonacci_sphere(directions)
    # a face is exposed where any of its rays escapes, in whatever order they are traced: a sample of the
    # faces traces every ray first, and the others try the directions in the order of the sample's shares
    # of escapes, each face stopping at its first (fewer rays where faces see out through a few openings:
    # benchmarks/README.md, bigmesh)
    todo = live.copy()
    sample = np.flatnonzero(live)[::max(_SAMPLE_STEP, int(live.sum()) // _SAMPLE_FACES)]
    todo[sample] = False
    escaped, asked = np.zeros(directions), np.zeros(directions)
    tick = (lambda done: progress(done, 2 * directions)) if progress is not None else (lambda done: None)
    with _Escapes(scene, o, lattice) as escapes:
        for k, d in enumerate(lattice):
            ask = sample[(n @ d < 0.0)[sample]]
            if len(ask):
                e = escapes(ask, k)
                out[ask] |= e
                escaped[k], asked[k] = np.count_nonzero(e), len(ask)
            tick(k + 1)
        for i, k in enumerate(np.argsort(-(escaped / np.maximum(asked, 1.0)), kind="stable")):
            ask = np.flatnonzero(todo & (n @ lattice[k] < 0.0))
            if len(ask):
                ask = ask[escapes(ask, k)]
                out[ask], todo[ask] = True, False
            tick(directions + i + 1)
    return out


def escape_fractions(mesh, frame, directions: int = 1024) -> np.ndarray:
    """For each face, the share of its back hemisphere's lattice directions along which a ray from just
    behind its centroid leaves the mesh (the rays of :func:`exposed_back_faces`, every one traced).

    A diagnostic of an open mesh: 0 where the face's back is sealed (as far
    as the lattice sees), small where it sees the outside only through a
    narrow opening, near 1 where it faces open space.

    Parameters
    ----------
    mesh : trimesh.Trimesh
    frame : (centre, radius)
        The normalised frame (world units), as for :func:`exposed_back_faces`.
    directions : int, optional
        Lattice directions over the whole sphere, >= 1.

    Returns
    -------
    ndarray, shape (F,), float64
        In [0, 1]; 0 for faces of zero area.

    Raises
    ------
    TypeError, ValueError
        As :func:`exposed_back_faces`.
    """
    directions = check_int(directions, "directions", 1, why="the rays of the lattice")
    n, o, live, scene = _back_rays(mesh, frame)
    escaped, asked = np.zeros(len(n)), np.zeros(len(n))
    for d in _fibonacci_sphere(directions) if scene is not None else ():
        ask = np.flatnonzero(live & (n @ d < 0.0))
        if len(ask):
            escaped[ask] += ~scene.occluded(o[ask], np.broadcast_to(d, (len(ask), 3)))
            asked[ask] += 1.0
    return escaped / np.maximum(asked, 1.0)


def both_sided_faces(mesh, frame, layer_rule: int, two_sided="auto", progress=None):
    """The faces a build marks as facing the light from both sides, or None (none marked).

    What :meth:`pyshadow.CoherentShadowMap.build` passes to the rasteriser
    (``both_sides`` of :class:`pyshadow.raster.DepthRenderer`): with
    ``two_sided='auto'`` and ``layers=2`` the faces of
    :func:`exposed_back_faces`; otherwise none (``True`` keeps the margin
    before every ``z2`` in the fold instead; a closed mesh's backs are never
    asked). The NumPy mirror of a build is ``compress_reference(*render_depth(..., facing=True,
    both_sides=both), ..., open_air=open_sheet(mesh, both))`` with ``both = both_sided_faces(...)``.

    Parameters
    ----------
    mesh : trimesh.Trimesh
    frame : (centre, radius)
        The CSM's normalised frame (``csm.centre``, ``csm.radius``).
    layer_rule : {2, 3}
        An int (another value, a float or a string is refused).
    two_sided : {'auto', True, False}, optional
    progress : callable, optional
        Passed to :func:`exposed_back_faces` where it runs.

    Returns
    -------
    ndarray, shape (F,), bool, or None

    Raises
    ------
    TypeError
        ``two_sided`` is none of 'auto', True, False; ``layer_rule`` is not an int.
    ValueError
        ``layer_rule`` is not 2 or 3.
    """
    rule = check_int(layer_rule, "layer_rule", 2, 3, why="the layers a map keeps per texel")
    if not (isinstance(two_sided, (bool, np.bool_)) or is_auto(two_sided)):    # as the build ('yes' read as False)
        raise TypeError(f"two_sided must be True, False or 'auto', got {two_sided!r}")
    return exposed_back_faces(mesh, frame, progress=progress) if is_auto(two_sided) and rule == 2 else None


def open_sheet(mesh, exposed) -> bool:
    """Whether faces whose back is open to the outside hold at least half of the mesh's area.

    Such a mesh is mostly an open sheet or container (a bowl, a box without a
    lid: every face), not a closed body with openings (the bunny's base, the
    teapot's spout: about 28 % of their area). With ``two_sided='auto'`` its
    build treats the space behind ``z1`` as free where ``z2`` is one of those
    backs or faces the light (csm.cl's ``OPEN_AIR``).

    Parameters
    ----------
    mesh : trimesh.Trimesh
    exposed : ndarray, shape (F,), bool, or None
        :func:`exposed_back_faces` of the mesh (None: none).

    Returns
    -------
    bool
    """
    if exposed is None or not len(mesh.faces):
        return False
    area = np.asarray(mesh.area_faces, dtype=np.float64)
    return bool(2.0 * area[np.asarray(exposed, bool)].sum() >= area.sum() > 0.0)
