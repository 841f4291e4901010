"""Scale of the ground's sheet test (pyshadow.contact.ground_sheet_slots) over many open casters."""
from __future__ import annotations

import types

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import contact


@pytest.fixture(scope="module")
def litter():
    """400 lidless boxes (open casters) scattered on the ground, and 2,000 ground points among them."""
    b = trimesh.creation.box((1.0, 1.0, 1.0))
    m = trimesh.Trimesh(b.vertices, b.faces[b.face_normals[:, 1] < 0.5], process=False)
    csm = pyshadow.CoherentShadowMap.build(m, pyshadow.ViewSet.zigzag(4, 8), resolution=16, progress=False)
    rng = np.random.default_rng(3)
    s = pyshadow.Scene(ground=0.0)
    for _ in range(400):
        T = np.eye(4)
        sc = rng.uniform(0.3, 1.0)
        T[:3, :3] *= sc
        T[:3, 3] = [rng.uniform(-15, 15), 0.5 * sc, rng.uniform(-15, 15)]
        s.add(csm, T, mesh=m)
    p = np.c_[rng.uniform(-15, 15, 2000), np.zeros(2000), rng.uniform(-15, 15, 2000)]
    return s, p


def _reference(scene, p):
    """Brute force: each point against each sheet in order, the last sheet holding it wins."""
    out = np.full(len(p), -2, np.int32)
    for slot, tri, tol in contact._on_ground(scene, "sheets", contact._sheets):
        a, b, c = tri[None, :, 0], tri[None, :, 1], tri[None, :, 2]
        inside = contact._inside(a, b, c, p[:, None, [0, 2]]).any(axis=1) & (np.abs(p[:, 1]) <= tol)
        out[inside] = slot
    return out


def test_sheet_slots_are_found_without_testing_every_point_against_every_sheet(litter, monkeypatch):
    """Was: every sheet tested every point against its box (400 sheets x 2,000 points: 1.6e6 comparisons
    through np.all; 100,000 leaves on the ground and 20,000 points: about 13 s); now the points within each
    sheet's slab only (about 1e4 here), with the same slots as a brute-force test."""
    scene, p = litter
    seen = []

    def counting_all(a, *args, **kwargs):
        seen.append(np.size(a))
        return np.all(a, *args, **kwargs)

    proxy = types.SimpleNamespace(**{k: getattr(np, k) for k in dir(np) if not k.startswith("__")})
    proxy.all = counting_all
    monkeypatch.setattr(contact, "np", proxy)
    got = contact.ground_sheet_slots(scene, p, np.full(len(p), -2, np.int32))
    monkeypatch.undo()
    assert sum(seen) < 20 * len(p), sum(seen)
    np.testing.assert_array_equal(got, _reference(scene, p))
    assert (got >= 0).sum() > 100
