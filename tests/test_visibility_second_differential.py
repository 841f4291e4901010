"""Second differential pass over the host side of the visibility queries (kernel against its NumPy mirror,
the SH transfer against the mirror's sum, chunked launches, the exposure of a mesh's back faces under
motion). No defect was found by these (2026-12 audit, vis2); they guard the agreements measured."""
import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

import pyshadow
from pyshadow import visibility
from pyshadow._cl import launch
from pyshadow.csm import exposure
from pyshadow.lighting.sh import sh_basis
from pyshadow.sampling import sample_directions_reference


@pytest.fixture(scope="module")
def spot():
    mesh = pyshadow.data.mesh("spot")
    csm = pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(5, 7), resolution=32, progress=False)
    return mesh, csm


def _surface(mesh, n, R, scale, offset, seed=1):
    pts, fi = trimesh.sample.sample_surface(mesh, n, seed=seed)
    return pts @ R.T * scale + offset, mesh.face_normals[fi] @ R.T


def test_kernel_equals_mirror_beside_seams_and_poles_under_motion(spot):
    """Surface points of a rotated, scaled body far from the origin (beside a second caster), rays within
    1e-4 .. 1e-3 rad of the poles and of the azimuth seams at +-x of a 7-column zigzag (a column boundary
    at pi): the kernel answers as the float64 mirror, nearest and vote, with and without the surface rule,
    and as the same scene at the origin at unit size (the rays rotated with it)."""
    mesh, csm = spot
    rng = np.random.default_rng(3)
    m = 24
    e = rng.choice([-1.0, 1.0], (m, 1)) * rng.uniform(1e-4, 1e-3, (m, 1))
    side = rng.uniform(-1, 1, (m, 1))
    local = np.concatenate([np.c_[e, np.ones((m, 1)), e[::-1]], np.c_[e[::-1], -np.ones((m, 1)), e],
                            np.c_[np.ones((m, 1)), side, e], np.c_[-np.ones((m, 1)), side, e]])
    answers = []
    turn = Rotation.from_euler("xyz", [0.3, 1.1, -0.7]).as_matrix()
    for R, scale, offset in ((np.eye(3), 1.0, np.zeros(3)), (turn, 2.0 ** 6, np.array([1e5, -3e4, 7e4]))):
        s = pyshadow.Scene(ground=None)
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R * scale, offset
        s.add(csm, T)
        T2 = T.copy()
        T2[:3, 3] = offset + R @ [0.9, 0.2, 0.0] * scale
        s.add(csm, T2)
        p, n = _surface(mesh, 40, R, scale, offset)
        d = local @ R.T
        P, D, N = np.repeat(p, len(d), 0), np.tile(d, (len(p), 1)), np.repeat(n, len(d), 0)
        up = np.einsum("ij,ij->i", D, N) > 0
        got = []
        for lookup in ("", "-vote"):
            for kw in (dict(normals=N[up]), {}):
                a = visibility.visible(s, P[up], D[up], backend="csm" + lookup, surface_ids=0, **kw)
                b = visibility.visible(s, P[up], D[up], backend="numpy" + lookup, surface_ids=0, **kw)
                np.testing.assert_array_equal(a, b)
                got.append(a)
        answers.append(np.concatenate(got))
    np.testing.assert_array_equal(answers[0], answers[1])
    assert 0.1 < (~answers[0]).mean() < 0.9           # both answers occur


def test_sh_transfer_equals_the_mirrors_sum(spot):
    """``sh_transfer``: AO and bent normals are those of ``ambient_occlusion`` bit for bit, and each
    transfer term is pi / S times the sum of Y_k over the mirror's unoccluded sample directions (float32
    sums of 36 terms of size <= 0.49 * pi / 36: within 1e-6)."""
    mesh, csm = spot
    s = pyshadow.Scene(ground=0.0)
    for i in range(3):
        T = np.eye(4)
        T[:3, :3] = Rotation.from_euler("y", i).as_matrix() * 0.5 / csm.radius
        T[:3, 3] = [0.6 * i, 0.5, 0.0]
        s.add(csm, T)
    R = s.instances[1].transform[:3, :3]
    p, n = _surface(mesh, 60, R / np.cbrt(np.linalg.det(R)), np.cbrt(np.linalg.det(R)), s.instances[1].transform[:3, 3])
    samp = pyshadow.Sampling()
    dirs = sample_directions_reference(n, sampling=samp)
    Y = sh_basis(dirs.reshape(-1, 3)).reshape(len(p), samp.samples, 9)
    for lookup in ("", "-vote"):
        ao, bent, tr = visibility.get_backend("csm" + lookup).sh_transfer(s, p, n, sampling=samp, surface_ids=1)
        ao2, bent2 = visibility.ambient_occlusion(s, p, n, backend="csm" + lookup, surface_ids=1,
                                                  return_bent_normals=True)
        np.testing.assert_array_equal(ao, ao2)
        np.testing.assert_array_equal(bent, bent2)
        vis = visibility.visible(s, np.repeat(p, samp.samples, 0), dirs.reshape(-1, 3), backend="numpy" + lookup,
                                 surface_ids=1, normals=np.repeat(n, samp.samples, 0)).reshape(len(p), -1)
        np.testing.assert_allclose(tr, np.pi / samp.samples * (Y * vis[..., None]).sum(1), rtol=0, atol=1e-6)
        assert 0.2 < ao.mean() < 0.95


def test_chunked_launches_answer_as_one(spot):
    """``query_chunk`` of 7 rows and ``ao_chunk_samples`` of 37 (a chunk of one point): the same answers
    as one launch, for rays, AO and bent normals, nearest and vote."""
    mesh, csm = spot
    s = pyshadow.Scene(ground=0.0)
    for i in range(18):                      # enough casters for the instance grid
        T = np.eye(4)
        T[:3, :3] = Rotation.random(random_state=i).as_matrix() * 0.4 / csm.radius
        T[:3, 3] = [i % 6 - 3, 0.4, i // 6 - 1]
        s.add(csm, T, mesh=mesh)    # (a rotated CSM without its mesh near the ground: contact._box_bottom warns)
    rng = np.random.default_rng(4)
    P = np.c_[rng.uniform(-3, 3, 301), rng.uniform(0, 1, 301), rng.uniform(-1.5, 1.5, 301)]
    D, N = rng.normal(size=(301, 3)), rng.normal(size=(301, 3))

    def answers():
        return [x for b in ("csm", "csm-vote") for x in
                (visibility.visible(s, P, D, backend=b), visibility.visible(s, P, D, backend=b, normals=N),
                 *visibility.ambient_occlusion(s, P[:40], N[:40], backend=b, return_bent_normals=True))]
    whole = answers()
    with launch.override(query_chunk=7, ao_chunk_samples=37):
        chunked = answers()
    for a, b in zip(chunked, whole):
        np.testing.assert_array_equal(a, b)
    assert 30 < (~whole[0]).sum() < 270


def test_exposure_follows_the_geometry_not_its_placement():
    """``exposed_back_faces``: closed meshes (box, icosphere, torus) rotated expose no back; the box wound
    inwards exposes all 12, a box without its lid its 10 faces, whatever the rotation; the teapot's answer
    is the same bit for bit moved 1e5 away or scaled by 1e-3 and 1e4 (the rays are traced in the frame)."""
    box = trimesh.creation.box()
    lidless = trimesh.Trimesh(box.vertices, box.faces[box.face_normals[:, 1] < 0.5], process=False)
    inward = trimesh.Trimesh(box.vertices, box.faces[:, ::-1], process=False)

    def frame(m):
        c = (m.vertices.max(0) + m.vertices.min(0)) / 2
        return c, 1.01 * np.linalg.norm(m.vertices - c, axis=1).max()

    for k in range(3):
        R = Rotation.random(random_state=k).as_matrix()
        for m, want in ((box, 0), (trimesh.creation.icosphere(3), 0), (trimesh.creation.torus(1.0, 0.3), 0),
                        (inward, 12), (lidless, 10)):
            moved = trimesh.Trimesh(m.vertices @ R.T, m.faces, process=False)
            assert exposure.exposed_back_faces(moved, frame(moved)).sum() == want
    teapot = pyshadow.data.mesh("teapot")
    base = exposure.exposed_back_faces(teapot, frame(teapot))
    assert 500 < base.sum() < 1500
    for scale, offset in ((1.0, 1e5), (1e-3, 0.0), (1e4, 1e3)):
        moved = trimesh.Trimesh(teapot.vertices * scale + offset, teapot.faces, process=False)
        np.testing.assert_array_equal(exposure.exposed_back_faces(moved, frame(moved)), base)
