"""A body whose mesh has faces wound against their neighbours (an asset's flipped triangles) resting on another
(pyshadow/contact_bodies.py): its contact is found as for one wound consistently.

The contact search needs each closed caster's faces wound out of the part they bound; a closed mesh with one
face turned had none (``_outward`` gave up), so a box with a flipped triangle resting on a box left the lower
box's top under its edge open, while the ground's footprint rule, which takes any winding, closed it. Checked
against Embree on the same rays.
"""
import numpy as np
import pytest
import trimesh
from trimesh.transformations import translation_matrix

import pyshadow
from pyshadow import embree
from pyshadow.contact_bodies import _outward, body_patches

VIEWS = pyshadow.ViewSet.zigzag(8, 16)
BOX = trimesh.creation.box((1.0, 1.0, 1.0))


def _turned(mesh, rows):
    """``mesh`` with the faces ``rows`` wound the other way."""
    f = np.array(mesh.faces)
    f[rows] = f[rows][:, ::-1]
    return trimesh.Trimesh(np.array(mesh.vertices), f, process=False)


def _under_upper(n, seed):
    """``n`` points of the lower box's top under the upper box (centred at (0.3, 1.5, 0.2)), half of them within
    2 cm of its edge (but 1e-4 inside), and the up normals."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-0.5 + 1e-4, 0.5 - 1e-4, (n, 2))
    k, rows = rng.integers(0, 2, n // 2), np.arange(n // 2)
    q[rows, k] = np.sign(q[rows, k]) * (0.5 - rng.uniform(1e-4, 0.02, n // 2))
    return np.column_stack([q[:, 0] + 0.3, np.ones(n), q[:, 1] + 0.2]), np.tile([0.0, 1.0, 0.0], (n, 1))


@pytest.mark.parametrize("faces", ["a bottom triangle", "a side triangle", "a whole side"])
def test_a_box_with_a_flipped_face_resting_on_a_box_closes_its_top_in(faces):
    """Was: no patch of the upper box; AO up to 0.50-0.53 (mean 0.12-0.13) on the lower box's top under it,
    half the points within 2 cm of its edge (8 x 16 maps of 32 texels), Embree 0."""
    down, side = np.flatnonzero(BOX.face_normals[:, 1] < -0.5), np.flatnonzero(BOX.face_normals[:, 0] > 0.5)
    rows = {"a bottom triangle": down[:1], "a side triangle": side[:1], "a whole side": side}[faces]
    upper = _turned(BOX, rows)
    scene = pyshadow.Scene(ground=0.0, views=VIEWS, resolution=32)
    scene.add(trimesh.creation.box((2.0, 1.0, 2.0)), translation_matrix([0.0, 0.5, 0.0]))
    scene.add(upper, translation_matrix([0.3, 1.5, 0.2]))
    assert len(body_patches(scene)) == 2
    p, up = _under_upper(400, 1)
    s = pyshadow.Sampling(32)
    assert embree.ambient_occlusion(scene, p, up, sampling=s).max() == 0.0
    assert scene.ambient_occlusion(p, up, sampling=s, surface_ids=0).max() == 0.0


@pytest.mark.parametrize("share", [0.01, 0.5, 1.0])
def test_a_closed_mesh_is_wound_out_of_its_parts_whichever_faces_are_flipped(share):
    """Was: None where some but not all faces of a part were flipped (no winding out of the mesh; all of them,
    share 1.0, an inverted mesh, was wound out already). A sphere, a box with a cavity and two boxes in one
    mesh, a share of their faces flipped at random: every face comes back wound as in the consistently wound
    mesh (a cavity's faces out of the cavity's part, as before)."""
    box = BOX
    cavity = trimesh.util.concatenate([box, trimesh.Trimesh(box.vertices * 0.5, box.faces[:, ::-1], process=False)])
    two = trimesh.util.concatenate([box, trimesh.Trimesh(box.vertices + [3.0, 0.0, 0.0], box.faces, process=False)])
    rng = np.random.default_rng(4)
    for mesh in (trimesh.creation.icosphere(2), cavity, two):
        u, ref = _outward(mesh)
        flipped = _turned(mesh, rng.random(len(mesh.faces)) < share)
        got = _outward(flipped)
        assert got is not None and np.array_equal(got[0], u)
        # the same faces (rows in the same order), each wound the same way up to a rotation of its corners
        same = [sorted(a) == sorted(b) and tuple(np.roll(b, -list(b).index(a[0]))) == tuple(a)
                for a, b in zip(ref.tolist(), got[1].tolist())]
        assert all(same)
