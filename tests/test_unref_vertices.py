"""Meshes with vertices no face uses (trimesh objects given as they are: process=False, update_faces, submesh).

The frame (bounding sphere), the frame's checks, the lowest point and load_mesh's cleaning see only the
vertices the faces use; per-vertex answers still come one per vertex of the mesh given, in its order.
"""
import warnings

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import CoherentShadowMap, Sampling, Scene, ViewSet, bounding_sphere, load_mesh, stand_on_ground
from pyshadow.csm import error_model as em
from pyshadow.mesh import mesh_hash
from pyshadow.sampling import sample_directions


def _with(mesh, extra):
    """``mesh`` with the vertices ``extra`` appended, used by no face (not processed)."""
    return trimesh.Trimesh(np.vstack([mesh.vertices, extra]), mesh.faces, process=False)


@pytest.fixture(scope="module")
def spot():
    m = pyshadow.data.mesh("spot")
    return m, _with(m, m.vertices.mean(axis=0) + [[30.0, 0.0, 0.0]])


def test_sphere_ignores_unused_vertex(spot):
    """Was: spot with one unused vertex 30 units off got a sphere of radius 15.26 (centre 14.8 units off)
    instead of 1.031."""
    m, mu = spot
    c, r = bounding_sphere(m)
    cu, ru = bounding_sphere(mu)
    assert ru == r and np.array_equal(cu, c)
    # a mesh without faces is still a point cloud's sphere
    _, r0 = bounding_sphere(trimesh.Trimesh(mu.vertices, np.zeros((0, 3), np.int64), process=False))
    assert r0 > 10.0


def test_csm_of_mesh_with_unused_vertex_is_the_clean_ones(spot):
    """Was: the CSM framed the unused vertex too (radius 15.26, not 1.031): the maps' texels 15x coarser
    (1,344 segments instead of 13,550 at 8x16 maps of 32^2)."""
    m, mu = spot
    views = ViewSet.zigzag(8, 16)
    a = CoherentShadowMap.build(m, views, resolution=32, progress=False)
    b = CoherentShadowMap.build(mu, views, resolution=32, progress=False)
    assert b.radius == a.radius and np.array_equal(b.centre, a.centre) and np.array_equal(b.box, a.box)
    for x, y in ((a.offsets, b.offsets), (a.depth, b.depth), (a.iend, b.iend)):
        assert np.array_equal(x, y)
    assert b.mesh_hash == mesh_hash(mu) != a.mesh_hash          # the hash of the mesh as given


def test_visibility_with_unused_vertex_agrees_with_embree(spot):
    """Was: 8.3 % of these AO rays from spot's surface disagreed with Embree (2.4 % for the same mesh without
    the unused vertex, and now)."""
    _, mu = spot
    sc = Scene(views=ViewSet.zigzag(16, 32), resolution=64)
    sc.add(mu)
    pts, nrm = sc.vertex_points(0)
    idx = np.random.default_rng(0).choice(len(pts) - 1, 150, replace=False)
    d = sample_directions(nrm[idx], sampling=Sampling(32), indices=idx).reshape(-1, 3).astype(np.float64)
    p = np.repeat(pts[idx] + 1e-3 * nrm[idx], 32, axis=0)
    flip = np.mean(sc.visible(p, d) != sc.visible(p, d, backend="embree"))
    assert flip < 0.05


def test_vertex_ao_one_per_vertex_in_order(spot):
    """Was: vertex_ao of spot with an unused vertex differed from the clean mesh's at the used vertices by up
    to 0.625 (mean 0.062): the CSM framed the unused vertex."""
    m, mu = spot
    out = []
    for x in (m, mu):
        sc = Scene(views=ViewSet.zigzag(8, 16), resolution=32)
        sc.add(x)
        out.append(sc.vertex_ao(0, sampling=Sampling(16)))
    assert out[1].shape == (len(mu.vertices),)
    assert np.array_equal(out[1][:-1], out[0])
    # an unused vertex first (the sampling pattern is the vertex index): as one inside the sphere
    ao = []
    for at in ([0.0, 40.0, 0.0], m.vertices.mean(axis=0)):
        sc = Scene(views=ViewSet.zigzag(8, 16), resolution=32)
        sc.add(trimesh.Trimesh(np.vstack([[at], m.vertices]), m.faces + 1, process=False))
        ao.append(sc.vertex_ao(0, sampling=Sampling(16)))
    assert ao[0].shape == (len(m.vertices) + 1,) and np.array_equal(ao[0][1:], ao[1][1:])


def test_build_with_frame_checks_only_used_vertices(spot):
    """Was: build(frame=the used vertices' sphere) refused: 'frame: a vertex lies 30 from the centre, outside
    the radius 1.03'."""
    m, mu = spot
    views = ViewSet.zigzag(4, 8)
    frame = bounding_sphere(m)
    a = CoherentShadowMap.build(m, views, resolution=16, progress=False, frame=frame)
    b = CoherentShadowMap.build(mu, views, resolution=16, progress=False, frame=frame)
    assert np.array_equal(a.depth, b.depth) and np.array_equal(a.offsets, b.offsets)


def test_error_model_with_unused_vertex():
    """Was: ao_rays(backs=True) and predict() of an open mesh (suzanne) with a far unused vertex raised
    'frame: a vertex lies 40 from the centre, outside the radius 1.4'."""
    m = pyshadow.data.mesh("suzanne")
    mu = _with(m, [[40.0, 0.0, 0.0]])
    for x, y in zip(em.ao_rays(m, 100, 4, backs=True), em.ao_rays(mu, 100, 4, backs=True)):
        assert np.array_equal(x, y)
    L, Lu = em.Layout.for_mesh(m, (8, 16), 32), em.Layout.for_mesh(mu, (8, 16), 32)
    assert Lu.radius == L.radius and np.array_equal(Lu.box, L.box)
    for x, y in zip(em.near_rays(m, 50), em.near_rays(mu, 50)):
        assert np.array_equal(x, y)


def test_stand_on_ground_uses_faces_vertices():
    """Was: a unit box with an unused vertex 5 below it stood 1.61 above the ground (the unused vertex on it)."""
    box = trimesh.creation.box()
    T = stand_on_ground(_with(box, [[0.0, -5.0, 0.0]]))
    low = (box.vertices @ T[:3, :3].T + T[:3, 3])[:, 1].min()
    assert abs(low) < 1e-12


def test_load_mesh_drops_unused_nan_vertex():
    """Was: load_mesh refused a box with one NaN vertex no face uses ('1 of 9 vertices are not finite'),
    though it drops unused vertices anyway."""
    box = trimesh.creation.box()
    got = load_mesh(_with(box, [[np.nan, 0.0, 0.0]]))
    assert mesh_hash(got) == mesh_hash(load_mesh(box))
    with pytest.raises(ValueError, match="not finite"):       # a NaN vertex a face uses: still refused
        v = box.vertices.copy()
        v[0, 0] = np.nan
        load_mesh(trimesh.Trimesh(v, box.faces, process=False))


def test_mesh_object_with_unused_nan_vertex_message():
    """Was: Scene.add refused a mesh whose only NaN vertex no face uses without saying so (nor how to drop
    it). A mesh object is used as it is (vertex_ao answers one per vertex): still refused, now named."""
    box = _with(trimesh.creation.box(), [[np.inf, 0.0, 0.0]])
    with pytest.raises(ValueError, match="no face uses them"):
        Scene().add(box, casts=False)
    v = trimesh.creation.box().vertices.copy()
    v[3] = np.nan
    with pytest.raises(ValueError, match=r"not finite \(NaN or inf\), e.g. vertex 3 = \[nan") as e:
        Scene().add(trimesh.Trimesh(v, trimesh.creation.box().faces, process=False), casts=False)
    assert "no face uses" not in str(e.value)


def test_load_mesh_merge_tolerance_ignores_unused_vertex():
    """Was: a 1.6-micrometre bunny with one unused vertex 1 unit away merged at the tolerance of a unit mesh
    (1e-8): 68,098 of its 69,451 faces kept instead of all."""
    b = pyshadow.data.bunny()
    v = (b.vertices - b.vertices.min(axis=0)) / np.ptp(b.vertices, axis=0).max() * 1.6e-6
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", pyshadow.MeshCleanupWarning)
        clean = load_mesh(trimesh.Trimesh(v, b.faces, process=False))
        got = load_mesh(trimesh.Trimesh(np.vstack([v, [[1.0, 0.0, 0.0]]]), b.faces, process=False))
    assert len(got.faces) == len(clean.faces) and mesh_hash(got) == mesh_hash(clean)
