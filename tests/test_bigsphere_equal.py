"""The bounding sphere's faster fit (pyshadow.mesh_sphere) answers as trimesh's ``minimum_nsphere`` did, bit for
bit, on awkward meshes: tiny, huge, far, flat, degenerate, on or near one sphere (helper bigsphere).

A refactor's equality test: it passes on the code before too (there the fit was trimesh's own). The Voronoi
step is checked on both of trimesh's ways of measuring radii (``cdist``, and its loop beyond 4 GB).
"""
import numpy as np
import pytest
import trimesh
from scipy.spatial import ConvexHull, Delaunay

import pyshadow.mesh as pm
import pyshadow.mesh_sphere as ms
from pyshadow.data import mesh as bundled


def _trimesh_fit(points):
    with np.errstate(all="ignore"):
        return trimesh.nsphere.minimum_nsphere(trimesh.Trimesh(points, process=False))


def _answer(fn, *args):
    try:
        c, r = fn(*args)
    except Exception as e:          # the same error, or the same bits
        return type(e).__name__, str(e)
    return np.asarray(c, np.float64).tobytes(), np.float64(r).tobytes()


def _rotation(seed):
    q = np.random.default_rng(seed).normal(size=4)
    return trimesh.transformations.quaternion_matrix(q / np.linalg.norm(q))[:3, :3]


def _near_sphere(n, amp, seed=3):
    """n points within a relative ``amp`` of the unit sphere, as the faces of their hull: a hull of n vertices
    whose furthest-site Voronoi diagram trimesh searches (its least-squares fit is off by more than 1e-6)."""
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    p *= (1.0 + amp * rng.standard_normal((n, 1))) / np.linalg.norm(p, axis=1)[:, None]
    return trimesh.Trimesh(p, ConvexHull(p).simplices, process=False)


def _meshes():
    T = lambda v, f: trimesh.Trimesh(np.asarray(v, float), np.asarray(f), process=False)     # noqa: E731
    out = {}
    for name in ("teapot", "fandisk", "spot"):
        m = bundled(name)
        out[name] = m
        for k in (-70, 21):
            out[f"{name} * 2**{k}"] = T(m.vertices * 2.0 ** k, m.faces)
        out[f"{name} * 1e-20"] = T(m.vertices * 1e-20, m.faces)
        out[f"{name} + 1e12"] = T(m.vertices + np.array([1e12, -1e12 / 3, 1e12 / 7]), m.faces)
        out[f"{name} * 1e-3 + 1e3"] = T(m.vertices * 1e-3 + 1e3, m.faces)
        out[f"{name} at extent 2**-9"] = T(m.vertices * 2.0 ** -9 / np.ptp(m.vertices, axis=0).max(), m.faces)
    out["flat tetrahedron"] = T([[0, 0, 0], [1, 0, 0], [0.5, 0.1, 0], [0.5, 0.05, 0.01]],
                                [[0, 1, 2], [0, 3, 1], [1, 3, 2], [2, 3, 0]])
    for seed in range(3):
        for tri in ([[0, 0, 0], [1, 0, 0], [0.3, 0.8, 0]], [[0, 0, 0], [1, 0, 0], [0.4, 0.1, 0]]):
            out[f"triangle {tri[2]} {seed}"] = T(np.array(tri, float) @ _rotation(seed).T * 1e4 + 1e7, [[0, 1, 2]])
    xy = np.random.default_rng(1).random((50, 2))
    out["flat plane"] = T(np.c_[xy, np.zeros(50)], Delaunay(xy).simplices)
    box = trimesh.creation.box(extents=(2, 4, 6))
    out["box and a far unused vertex"] = T(np.r_[box.vertices, [[1e6, 0, 0]]], box.faces)
    out["box without faces"] = T(box.vertices, np.zeros((0, 3), np.int64))
    out["collinear"] = T([[0, 0, 0], [1, 1, 1], [2, 2, 2]], [[0, 1, 2]])
    out["coincident"] = T([[1, 1, 1]] * 3, [[0, 1, 2]])
    out["cylinder"] = trimesh.creation.cylinder(radius=1, height=3, sections=64)
    ico = trimesh.creation.icosphere(subdivisions=4)
    for amp in (0.0, 1e-7, 1e-5, 1e-3):
        out[f"icosphere, noise {amp}"] = T(
            ico.vertices * (1.0 + amp * np.random.default_rng(7).standard_normal((len(ico.vertices), 1))), ico.faces)
    out["half an icosphere"] = T(ico.vertices, ico.faces[ico.triangles_center[:, 2] > 0.2])
    out["near a sphere, 1e-5"] = _near_sphere(1500, 1e-5)
    out["near a sphere, 1e-9"] = _near_sphere(1500, 1e-9)
    return out


MESHES = _meshes()


@pytest.mark.parametrize("name", list(MESHES))
def test_bounding_sphere_is_the_one_of_trimeshs_fit(name, monkeypatch):
    """``bounding_sphere`` (not kept: ``__wrapped__``) with the new fit and with trimesh's: the same bits, or the
    same error."""
    mesh = MESHES[name]
    new = _answer(pm.bounding_sphere.__wrapped__, mesh)
    monkeypatch.setattr(pm, "minimum_nsphere", _trimesh_fit)
    assert _answer(pm.bounding_sphere.__wrapped__, mesh) == new


@pytest.mark.parametrize("name", ["teapot", "teapot * 2**-70", "teapot + 1e12", "teapot * 1e-3 + 1e3",
                                  "flat plane", "triangle [0.3, 0.8, 0] 0", "collinear", "cylinder",
                                  "half an icosphere", "icosphere, noise 1e-05", "near a sphere, 1e-5"])
@pytest.mark.parametrize("scale", [1.0, 1e-5, 1e-8])
def test_minimum_nsphere_is_trimeshs(name, scale):
    """On raw coordinates too (no unit scale, no shift): hulls whose tiny faces trimesh drops as without area
    (1e-5: 2/3 of the teapot's; 1e-8: all of them) and whose vertices it merges (1e12 away: into one)."""
    v = np.asarray(MESHES[name].vertices) * scale
    assert _answer(ms.minimum_nsphere, v) == _answer(_trimesh_fit, v)


@pytest.mark.parametrize("amp", [1e-5, 1e-3])
def test_smallest_voronoi_vertex_beyond_trimeshs_4gb_loop(amp, monkeypatch):
    """Where trimesh loops over the Voronoi vertices instead of one ``cdist`` (its estimate over 4 GB, here
    forced): the same vertex and squared radius as its loop's ``argmin``."""
    from scipy import spatial

    p = np.asarray(_near_sphere(400, amp, seed=11).vertices)
    p = (p - p.min(axis=0)) / np.ptp(p, axis=0).min()
    vor = spatial.Voronoi(p, furthest_site=True)
    radii_2 = np.array([((p - v) ** 2).sum(axis=1).max() for v in vor.vertices])
    monkeypatch.setattr(ms, "_LOOP_BYTES", 0.0)
    i, r2 = ms._smallest_vertex(vor, p)
    assert i == radii_2.argmin() and r2 == radii_2[i]
    monkeypatch.setattr(ms, "_LOOP_BYTES", 4e9)
    assert ms._smallest_vertex(vor, p) == (i, r2)


def test_the_sphere_is_kept_per_mesh_content():
    """A second call answers from the kept sphere (a copy of its centre); a mesh changed in place is fitted
    again."""
    m = _near_sphere(800, 1e-4, seed=5)
    c, r = pm.bounding_sphere(m)
    c[:] = 7.0
    c2, r2 = pm.bounding_sphere(m)
    assert _answer(lambda: (c2, r2)) == _answer(pm.bounding_sphere.__wrapped__, m) and r2 == r
    m.vertices[0] = m.vertices[0] * 1.5
    assert _answer(pm.bounding_sphere, m) == _answer(pm.bounding_sphere.__wrapped__, m)
    assert pm.bounding_sphere(m)[1] > 1.2          # (1.25: the old sphere, 1.0, was not kept)


def test_smallest_voronoi_vertex_not_finite_is_trimeshs_argmin():
    """A vertex not finite (no bound can rule it out): every radius measured, as trimesh, whose ``argmin`` is
    the first NaN."""
    from types import SimpleNamespace

    from scipy import spatial

    p = np.random.default_rng(2).random((30, 3))
    vor = SimpleNamespace(vertices=np.array([[0.5, 0.5, 0.5], [np.nan, 0.0, 0.0], [0.4, 0.5, 0.5]]))
    radii_2 = spatial.distance.cdist(vor.vertices, p, metric="sqeuclidean").max(axis=1)
    i, r2 = ms._smallest_vertex(vor, p)
    assert i == radii_2.argmin() == 1 and np.isnan(r2)
