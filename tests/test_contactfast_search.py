"""The full search of touching faces (``contact_bodies._touching``, ``_plane_faces``, ``_planes``), made faster
(3,600 touching boxes: 1.0 s a search before) without changing one bit of its answers: the conservative
prefilters skip no touching face, and the planes, bases and flattened faces are those of the one-body loops."""
import numpy as np
import pytest
import trimesh
from trimesh.transformations import rotation_matrix

from pyshadow import contact_bodies as cb
from pyshadow.contact_parts import _outlines


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _near_ties(rng, scale, origin, k=30):
    """Three open bodies: random triangles and two copies of each, reversed or not, turned by angles around
    the facing limit (acos(FACING) = sqrt(2e-6)), moved along the normal by about the tolerance; normals
    along axes, near diagonals (the axes' gap near ``_CLEAR``) and random."""
    tol = 5e-5 * scale
    bodies = [[], [], []]
    for _ in range(k):
        kind = rng.integers(4)
        if kind == 0:
            n = np.eye(3)[rng.integers(3)] * rng.choice([-1, 1])
        elif kind == 1:
            n = _unit(np.array([1 + rng.uniform(0, 8e-3), 1, rng.uniform(0, 0.2)]) * rng.choice([-1, 1], 3))
        elif kind == 2:
            n = _unit(1 + rng.normal(size=3) * 1e-3)
        else:
            n = _unit(rng.normal(size=3))
        u = _unit(np.cross(n, rng.normal(size=3)))
        a = rng.uniform(0, 2 * np.pi, 3)
        tri = origin + scale * (rng.normal(size=3) * 3 + rng.choice([0.02, 0.3]) *
                                (np.cos(a)[:, None] * u + np.sin(a)[:, None] * np.cross(n, u)))
        bodies[0].append(tri)
        for i in (1, 2):
            angle = rng.choice([rng.uniform(0, 3e-3), np.sqrt(2e-6) * (1 + rng.normal() * 1e-6), 0.0])
            R = rotation_matrix(angle, _unit(np.cross(n, rng.normal(size=3))))[:3, :3]
            c = tri.mean(axis=0)
            copy = (tri - c) @ R.T + c + n * rng.choice([0, tol, -tol, rng.uniform(-2, 2) * tol])
            copy = copy + rng.normal(size=3) * scale * rng.choice([0, 0.05, 0.2])
            bodies[i].append(copy[::-1] if i == 1 or rng.random() < 0.5 else copy)
    meshes = [trimesh.Trimesh(np.concatenate(b), np.arange(3 * k).reshape(-1, 3), process=False) for b in bodies]
    return cb._world_bodies([cb._Posed(m, np.eye(4)) for m in meshes]), np.full(3, tol)


@pytest.mark.parametrize("scale, origin", [(1.0, 0.0), (1e-3, 0.0), (1e3, 0.0), (1.0, 1e4)])
def test_prefilters_skip_no_touching_face(monkeypatch, scale, origin):
    """Was: every near face pair of two bodies tested (2.3 million for 3,600 touching boxes); now only those
    whose normals' axes (``_axes``) and plane offsets (``_plane_offsets``) can touch. On faces at the facing
    and plane-distance limits, the touching faces are those found with both prefilters off."""
    rng = np.random.default_rng(int(scale * 7 + origin) % 1000)
    pairs = np.array([[0, 1], [1, 0], [0, 2], [2, 0], [1, 2], [2, 1]])
    got, want, hits = [], [], 0
    for _ in range(20):
        (_, faces), tol = _near_ties(rng, scale, origin)
        either = rng.random(len(pairs)) < 0.5
        got.append(cb._touching(faces, pairs, tol, either))
        with monkeypatch.context() as m:
            m.setattr(cb, "_axes", lambda n: np.full(len(n), 6))
            m.setattr(cb, "_plane_offsets", lambda f: (np.zeros(len(f[0])), np.full(len(f[0]), np.inf)))
            want.append(cb._touching(faces, pairs, tol, either))
        hits += int(want[-1].sum())
    assert hits > 20                                    # touching faces among them, not only misses
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g, w)


def _scene_faces():
    """Touching boxes side by side and stacked, a turned stack and cylinders on boxes (world faces)."""
    box, cyl = trimesh.creation.box((1, 1, 1)), trimesh.creation.cylinder(0.5, 1.0, sections=12)
    R = rotation_matrix(0.7, [0.3, 1, 0.2])[:3, :3]
    inst = []
    for i in range(9):
        for y in range(2):
            T = np.eye(4)
            T[:3, 3] = i % 3, 0.5 + y, i // 3
            inst.append(cb._Posed(box, T))
            T = np.eye(4)
            T[:3, :3], T[:3, 3] = R, R @ [i % 3, 0.5 + y, i // 3] + [10, 1e4, 0]
            inst.append(cb._Posed(box, T))
        T = np.eye(4)
        T[:3, 3] = i % 3, 2.5, i // 3
        inst.append(cb._Posed(cyl, T))
    world, faces = cb._world_bodies(inst)
    pairs = np.array([(i, j) for i in range(len(inst)) for j in range(len(inst)) if i != j])
    tol = 1e-5 * np.full(len(inst), 1.0)
    return world, faces, cb._touching(faces, pairs, tol, np.zeros(len(pairs), bool)), tol


def test_planes_are_the_one_body_loops():
    """Was: each body's planes found by a Python loop per plane (14,160 planes: 0.3 s of a full search), each
    plane's basis and flattening per plane; now all bodies' next planes a round and all planes at once, by the
    same numpy calls on the same shapes: the same bits as the loops (kept here as they were)."""
    world, faces, hit, tol = _scene_faces()
    bodies = np.arange(len(world))[::-1]
    planes = cb._plane_faces(hit, faces, bodies, tol)
    got = []                                            # the loops as they were
    for i in bodies:
        s = slice(faces[5][i], faces[5][i] + faces[6][i])
        h, tri_b, n_b = hit[s].copy(), faces[0][s], faces[1][s]
        while h.any():
            n = -n_b[np.argmax(h)]
            d = float(tri_b[np.argmax(h), 0] @ n)
            same = h & (-n_b @ n >= cb.FACING) & (np.abs(tri_b @ n - d) <= tol[i]).all(axis=1)
            h &= ~same
            got.append((i, n, d, np.flatnonzero(same)))
    assert len(got) == len(planes[0]) > 50
    size = np.array([len(g[3]) for g in got])
    start = np.cumsum(size) - size
    wf = np.concatenate([world[g[0]][1][g[3]] for g in got]).astype(np.int64)
    edge, ecut = _outlines(np.sort(wf, axis=1), np.repeat(np.arange(len(got)), size), len(got))
    e1 = cb._cross(np.array([g[1] for g in got]), np.eye(3)[np.argmin(np.abs([g[1] for g in got]), axis=1)])
    patches = cb._planes(planes, world, faces[0], faces[5], tol)
    for j, ((i, n, d, k), patch) in enumerate(zip(got, patches)):
        unit = e1[j] / np.linalg.norm(e1[j])
        basis = np.array([unit, cb._cross(n, unit)])
        flat = world[i][0] @ basis.T
        k = k + faces[5][i]
        box = np.array([faces[0][k].min(axis=(0, 1)), faces[0][k].max(axis=(0, 1))])
        want = (n, d, float(tol[i]), box, basis, flat[wf[start[j]:start[j] + size[j]]], flat[edge[ecut[j]:ecut[j + 1]]])
        assert planes[0][j] == i and patch[1] == d and patch[2] == want[2]
        for a, b in zip(patch, want):
            assert np.asarray(a).shape == np.asarray(b).shape
            assert np.asarray(a).tobytes() == np.asarray(b).tobytes()
