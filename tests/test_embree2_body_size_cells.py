"""pyshadow._embree_lift.sphere_size (the body size each Embree lift is 2e-5 of) in scenes of many bodies:
the same values as its rule evaluated over every sphere, without evaluating every point-sphere pair."""
from __future__ import annotations

import numpy as np
import pytest

from pyshadow import _embree_lift


def rule(P, c, r):
    """sphere_size's documented rule, point by point over every sphere (float64)."""
    out = np.empty(len(P))
    for i, p in enumerate(P):
        gap = np.linalg.norm(p - c, axis=1) - r * (1.0 + 1e-6)
        inside = gap <= 0.0
        size = r[inside].max() if inside.any() else r[np.argmin(gap)]
        out[i] = min(size, _embree_lift.NEAR_SIZES * np.maximum(gap, r).min())
    return out


def spheres(kind, rng, M=300, N=1500):
    c = rng.uniform(-100.0, 100.0, (M, 3))
    r = 10.0 ** rng.uniform(-2.0, 0.5, M)
    P = rng.uniform(-110.0, 110.0, (N, 3))
    if kind == "huge":              # one sphere holds every point
        r[7] = 1e4
    elif kind == "ties":            # equal radii on a grid: equally near spheres (argmin takes the first)
        c, r = np.round(c / 10.0) * 10.0, np.full(M, 2.0)
        P = np.round(P / 5.0) * 5.0
    elif kind == "flat":            # points in a plane (one cell across y)
        P[:, 1] = 3.0
    elif kind == "on bodies":       # points on and near the spheres
        k = rng.integers(0, M, N)
        d = rng.normal(size=(N, 3))
        P = c[k] + d / np.linalg.norm(d, axis=1, keepdims=True) * r[k, None] * rng.uniform(0.9, 1.1, (N, 1))
    elif kind == "far":
        c, P = c + [1e5, 0.0, -1e5], P + [1e5, 0.0, -1e5]
    return P, c, r


@pytest.mark.parametrize("kind", ["plain", "huge", "ties", "flat", "on bodies", "far"])
def test_sphere_size_of_many_bodies_keeps_its_rule(kind):
    """The rule's values exactly (each point's own loop over every sphere), for 1,500 points among 300
    spheres: one sphere holding all, ties, points in a plane, on the spheres, 1e5 from the origin."""
    P, c, r = spheres(kind, np.random.default_rng(3))
    np.testing.assert_array_equal(_embree_lift.sphere_size(P, c, r), rule(P, c, r))


def test_sphere_size_does_not_pair_every_point_with_every_body(monkeypatch):
    """Was: every point was measured against every body's sphere: surface_epsilon of 100,000 points among
    2,000 bodies took 40 s here (now 1.1 s), pyshadow.embree.ambient_occlusion of 20,000 points at 16
    samples 7.3 s (now 0.7 s), a 1 M pixel frame of such a scene minutes of lifts before any ray. Counted:
    the point-sphere distances norm() was asked for, N M = 40,000,000 before, 8 % of that now."""
    P, c, r = spheres("plain", np.random.default_rng(4), M=2000, N=20000)
    expected = rule(P[::100], c, r)
    asked = []
    norm = np.linalg.norm

    def counting(x, *args, **kwargs):
        x = np.asarray(x)
        if x.ndim == 3:
            asked.append(x.shape[0] * x.shape[1])
        return norm(x, *args, **kwargs)

    monkeypatch.setattr(np.linalg, "norm", counting)
    got = _embree_lift.sphere_size(P, c, r)
    monkeypatch.undo()
    np.testing.assert_array_equal(got[::100], expected)
    assert sum(asked) < 0.2 * len(P) * len(c)
