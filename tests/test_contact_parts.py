"""The contact rules' batched tests (pyshadow/contact_parts.py) against one part at a time.

The footprints of bodies on the ground, the patches of bodies on bodies and
the points closed in by them are found for all parts at once; each must
give what the part alone gives, to the bit: the same triangles, outlines
and points, whatever the number of parts, their sizes and the order of the
points.
"""
from __future__ import annotations

import numpy as np
import trimesh
from trimesh.transformations import rotation_matrix, translation_matrix

import pyshadow
from pyshadow import contact
from pyshadow.contact_parts import _in_parts, _kept_parts, _outlines, _slab_pairs


def _one_part(q, tri, seg, tol):
    """A part alone, written out: in its box, in one triangle (signed areas), far from every segment."""
    lo, hi = tri.reshape(-1, 2).min(axis=0), tri.reshape(-1, 2).max(axis=0)
    out = np.zeros(len(q), bool)
    for i, x in enumerate(q):
        if not np.all((x >= lo) & (x <= hi)):
            continue
        for a, b, c in tri:
            s = [(v[0] - u[0]) * (x[1] - u[1]) - (v[1] - u[1]) * (x[0] - u[0]) for u, v in ((a, b), (b, c), (c, a))]
            if all(v >= 0 for v in s) or all(v <= 0 for v in s):
                break
        else:
            continue
        far = True
        for a, b in seg:
            d, y = b - a, x - a
            t = min(max(np.sum(y * d) / max(np.sum(d * d), 1e-300), 0.0), 1.0)
            r = y - t * d
            far &= bool(np.sum(r * r) > tol * tol)
        out[i] = far
    return out


def test_points_in_many_parts_as_in_each_alone():
    """Random parts (1-6 triangles, 3-8 segments, tolerances 1e-3-0.1) and points around them; some
    points asked of several parts: the batched answer of every (point, part) pair is the part's alone."""
    rng = np.random.default_rng(4)
    tris = [rng.uniform(-1, 1, (rng.integers(1, 7), 3, 2)) + rng.uniform(-3, 3, 2) for _ in range(40)]
    segs = [rng.uniform(-1, 1, (rng.integers(3, 9), 2, 2)) + t.mean(axis=(0, 1)) for t in tris]
    tol = rng.uniform(1e-3, 0.02, len(tris))
    pid = rng.integers(0, len(tris), 3000)
    w = rng.dirichlet(np.ones(3), len(pid))            # in one of its part's triangles, or near it
    q = np.array([w[i] @ tris[k][rng.integers(len(tris[k]))] for i, k in enumerate(pid)])
    q += rng.normal(0.0, 0.05, q.shape) * (rng.random(len(q)) < 0.3)[:, None]
    got = _in_parts(q, pid, _kept_parts({}, "parts", lambda: (tris, segs, None)), tol)
    want = np.array([_one_part(q[i:i + 1], tris[k], segs[k], tol[k])[0] for i, k in enumerate(pid)])
    assert np.array_equal(got, want)
    assert 50 < got.sum() < len(q) - 50               # both answers occur


def test_slab_pairs_hold_every_point_in_each_box():
    """The candidates of each box are a superset of the points in it (exactly those within its slab on the
    axis chosen), each once."""
    rng = np.random.default_rng(5)
    p = rng.uniform(0, 10, (2000, 2))
    lo = rng.uniform(0, 9, (50, 2))
    hi = lo + rng.uniform(0, 2, (50, 2))
    pid, rows = _slab_pairs(p, lo, hi)
    for k in range(len(lo)):
        mine = rows[pid == k]
        inside = np.flatnonzero(np.all((p >= lo[k]) & (p <= hi[k]), axis=1))
        assert set(inside) <= set(mine) and len(set(mine)) == len(mine)


def test_outlines_are_each_items_edges_of_one_face():
    """Per item, the edges its faces have once, in the order of their vertex numbers (as of the item
    alone, with ``np.unique`` over index pairs)."""
    rng = np.random.default_rng(6)
    items = [np.sort(rng.integers(0, 12, (rng.integers(1, 9), 3)), axis=1) for _ in range(30)]
    edge, cut = _outlines(np.concatenate(items), np.repeat(np.arange(30), [len(f) for f in items]), 30)
    for k, f in enumerate(items):
        e, n = np.unique(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [0, 2]]]), axis=0, return_counts=True)
        assert np.array_equal(edge[cut[k]:cut[k + 1]], e[n == 1])


def test_footprints_of_many_bodies_as_of_each_alone():
    """30 bodies of 5 meshes (shared) on a ground at y = 5, turned, some resting, some 1e-3 above, one
    tilted: each footprint is the one of the body alone in a scene of its own, triangles and outline."""
    rng = np.random.default_rng(7)
    meshes = [trimesh.creation.box((1, 1, 1)), trimesh.creation.box((2, 0.5, 1)), trimesh.creation.cylinder(0.5, 1.0),
              trimesh.creation.cone(0.5, 1.0), trimesh.creation.icosphere(2)]
    views = pyshadow.ViewSet.zigzag(4, 8)
    csm = {id(m): pyshadow.CoherentShadowMap.build(m, views, resolution=16, progress=False) for m in meshes}
    placed = []
    for j in range(30):
        m = meshes[j % 5]
        T = translation_matrix([rng.uniform(-20, 20), 0, rng.uniform(-20, 20)]) @ rotation_matrix(rng.uniform(0, 6),
                                                                                                    [0, 1, 0])
        T[1, 3] = 5.0 - (m.vertices @ T[:3, :3].T)[:, 1].min() + (1e-3 if j % 4 == 3 else 0.0)
        placed.append((m, T @ rotation_matrix(0.3, [1, 0, 0]) if j == 7 else T))
    scene = pyshadow.Scene(ground=5.0)
    for m, T in placed:
        scene.add(csm[id(m)], T, mesh=m)
    together = {k: x for k, x, _ in contact._on_ground(scene, "contact", contact._footprints)}
    assert 8 <= len(together) < 30                   # the boxes resting on the ground at least
    for k, (m, T) in enumerate(placed):
        alone = pyshadow.Scene(ground=5.0)
        alone.add(csm[id(m)], T, mesh=m)
        fp = contact.footprints(alone)
        assert (k in together) == bool(fp)
        if fp:
            assert all(np.array_equal(a, b) for a, b in zip(together[k], fp[0]))
