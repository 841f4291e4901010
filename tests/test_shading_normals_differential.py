"""Differential checks of shading_normals.ambient_occlusion: the tilted points' rays in chunks against all at once.

A chunked computation must give the answer of the unchunked one bit for bit (each point's directions
depend on its own index only, each ray's visibility on that ray only).
"""
import importlib
import math

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import Sampling
from pyshadow.lighting import transfer
from pyshadow.scene import GROUND_ID
from pyshadow.shading_normals import ambient_occlusion, corner_normals

shade = importlib.import_module("pyshadow.lighting.shade")     # the module, not pyshadow.lighting.shade the function


@pytest.fixture(scope="module")
def tilted_points():
    """A unit box on the ground (y = 0); 320 points on the ground around it, 300 of whose shading normals
    lean 40 degrees off the ground's normal (some of their directions fall below the ground's plane),
    20 with the ground's normal."""
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)))
    rng = np.random.default_rng(7)
    N = 320
    p = np.column_stack([rng.uniform(-2, 2, N), np.zeros(N), rng.uniform(-2, 2, N)])
    ng = np.tile([0.0, 1.0, 0.0], (N, 1))
    t = math.radians(40.0)
    n = np.tile([math.sin(t), math.cos(t), 0.0], (N, 1))
    n[::16] = ng[::16]
    return scene, p, n, ng


@pytest.mark.parametrize("backend", ["csm", "embree"])
def test_tilted_points_are_traced_in_chunks_with_identical_answers(tilted_points, backend, monkeypatch):
    """Was: every tilted point with a direction below the geometric plane went to ``sample_visibility`` in
    one call, all N S rays at once: a peak of 833 MB (csm) and 1405 MB (embree) of host memory for 100,000
    points at 64 samples, growing with N S (a 1080p frame at 64 samples: some 17 to 29 GB), where the
    "sampled" sky works in chunks of SAMPLED_CHUNK_RAYS rays (153 MB on csm with the chunks). Now in chunks
    of SAMPLED_CHUNK_RAYS // S points, with the unchunked answer bit for bit."""
    scene, p, n, ng = tilted_points
    s = Sampling(16)
    ids = np.where(np.arange(len(p)) % 2, GROUND_ID, -1).astype(np.int32)     # per point, so chunked too
    want = ambient_occlusion(scene, p, n, ng, backend=backend, sampling=s, surface_ids=ids)
    calls = []
    real = transfer.sample_visibility

    def counted(scene, points, *a, **k):
        calls.append(len(points))
        return real(scene, points, *a, **k)
    monkeypatch.setattr(transfer, "sample_visibility", counted)
    monkeypatch.setattr(shade, "SAMPLED_CHUNK_RAYS", 16 * 37)     # 37 points a chunk
    got = ambient_occlusion(scene, p, n, ng, backend=backend, sampling=s, surface_ids=ids)
    assert max(calls) <= 37 and sum(calls) == 300 and len(calls) == math.ceil(300 / 37)
    np.testing.assert_array_equal(got[0], want[0])
    np.testing.assert_array_equal(got[1], want[1])
    # the ground alone would give (1 + cos 40 deg) / 2 = 0.883 (the rule's share of a tilted cosine lobe); the box
    # takes some more
    assert 0.75 < want[0][n[:, 0] != 0].mean() < 0.883
    outside = np.abs(p[:, [0, 2]]).max(axis=1) > 0.5                      # not under the box
    assert (want[0][(n[:, 0] == 0) & outside] > 0.5).all()


@pytest.mark.parametrize("rounding", [np.float64, np.float32])
def test_a_prism_whose_faces_meet_at_the_crease_angle_is_smoothed_in_every_orientation(rounding):
    """Was: the side faces of a 12-sided prism meet at 30 degrees, the default crease angle, and the
    rounding of the face normals decided each corner: 46 to 52 of its 72 side corners smoothed
    depending on the prism's orientation (6 rotations), the others keeping their flat normals (15
    degrees off); a hexagonal prism at 60 degrees: 12 to 25 of 36. The rule smooths faces meeting at
    up to the crease angle: every side corner's normal is the radial direction of its vertex (to
    float64 rounding; to float32 rounding where the vertices were rounded to float32, as from a file)."""
    from scipy.spatial.transform import Rotation

    tol = 1e-12 if rounding is np.float64 else 1e-6
    for sections in (12, 6):
        base = trimesh.creation.cylinder(0.5, 1.0, sections=sections)
        crease = math.radians(360.0 / sections)
        for seed in range(6):
            R = Rotation.random(random_state=seed).as_matrix() if seed else np.eye(3)
            v = (np.asarray(base.vertices) @ R.T).astype(rounding).astype(np.float64)
            got = corner_normals(trimesh.Trimesh(v, base.faces, process=False), crease)
            axis = R @ [0.0, 0.0, 1.0]
            w = v[np.asarray(base.faces)]                                       # (T, 3, 3) corners
            side = np.abs(np.cross(w[:, 1] - w[:, 0], w[:, 2] - w[:, 0]) @ axis) < 1e-5
            radial = w[side] - np.einsum("fkj,j->fk", w[side], axis)[..., None] * axis
            radial /= np.linalg.norm(radial, axis=2, keepdims=True)
            assert side.sum() == 2 * sections
            np.testing.assert_allclose(got[side], radial, atol=tol)


def _brute_corner_normals(mesh, crease):
    """The module's rule corner by corner: the angle-weighted sum of the unit normals of the faces at the
    corner's vertex within ``crease`` of its face's (the tie rule's tolerance is far below these meshes'
    angles), normalised; the face's own normal where all those are parallel to it."""
    v, F = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces)
    e1, e2 = v[F[:, 1]] - v[F[:, 0]], v[F[:, 2]] - v[F[:, 0]]
    fn = np.cross(e1, e2)
    fn /= np.linalg.norm(fn, axis=1, keepdims=True)
    ang = np.empty(F.shape)
    for k in range(3):
        a, b = v[F[:, (k + 1) % 3]] - v[F[:, k]], v[F[:, (k + 2) % 3]] - v[F[:, k]]
        ang[:, k] = np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b))
    out = np.empty((len(F), 3, 3))
    for f in range(len(F)):
        for k in range(3):
            f2, k2 = np.nonzero(F == F[f, k])
            keep = fn[f2] @ fn[f] >= math.cos(crease)
            s = (ang[f2[keep], k2[keep], None] * fn[f2[keep]]).sum(axis=0)
            out[f, k] = s / np.linalg.norm(s) if (fn[f2[keep]] != fn[f]).any() else fn[f]
    return out


def test_corner_normals_of_a_fan_take_bounded_memory_and_the_same_answer():
    """Was: corner_normals built every pair of corners at each vertex at once, k^2 pairs for a vertex of
    valence k: a peak of 194 MB for a cone of 1,000 sections (2,000 faces), 3.1 GB and 9.4 s for 4,000
    sections, growing as k^2 (some 50 GB for 16,000) -- the apex of a cone, the centre of a fan-triangulated
    disc or cap, the poles of a UV sphere. Now the pairs go in groups of _PAIRS pairs (about
    30 MB): the same normals bit for bit, in groups of any size, as a corner-by-corner oracle's."""
    import tracemalloc

    from pyshadow import shading_normals as sn

    cone = trimesh.creation.cone(0.5, 1.0, sections=1000)
    tracemalloc.start()
    try:
        corner_normals(cone)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 80e6, f"{peak / 1e6:.0f} MB"
    small = trimesh.creation.cone(0.5, 1.0, sections=40)
    want = _brute_corner_normals(small, sn.DEFAULT_CREASE_ANGLE)
    got = {}
    for pairs in (1, 7, 1000, 1 << 30):     # a corner at a time (more than 1 pair each), ..., all at once
        mesh = trimesh.Trimesh(small.vertices, small.faces, process=False)     # not the cached one
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(sn, "_PAIRS", pairs)
            got[pairs] = corner_normals(mesh, return_smooth=True)
        np.testing.assert_array_equal(got[pairs][0], got[1][0])
        np.testing.assert_array_equal(got[pairs][1], got[1][1])
    np.testing.assert_allclose(got[1][0], want, atol=1e-15)
    assert got[1][1].sum() == 40                # the sides are smoothed, the cap keeps its flat normal
