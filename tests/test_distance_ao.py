"""Distance-limited and distance-weighted AO (seed 002 eq. 3.2-3.4) on every backend, against the
closed forms of a floor in front of a wall and a sphere resting on the ground (benchmarks/analytic_ao.py).

Tolerances: a point is asked ``COPIES`` times with its own sample pattern
(COPIES x SAMPLES rays); the sampling error of a mean of n Bernoulli rays is
at most 4 sigma = 4 sqrt(p (1 - p) / n) (the scrambled Hammersley patterns
do better); the icosphere's value lies between the closed forms of its
inscribed and circumscribed balls (half that bracket is added); the CSM's
quadrature for weighted AO adds at most 1 / (2Q) per ray; the CSM's own
texel error is bounded by its disagreement with Embree on the identical
rays, measured here and held to ``CSM_RAYS`` of the rays.
"""
import sys

import numpy as np
import pytest

from conftest import REPO

sys.path.insert(0, str(REPO / "benchmarks"))
import analytic_ao as A  # noqa: E402

import pyshadow  # noqa: E402
from pyshadow import embree, visibility  # noqa: E402
from pyshadow.visibility import finite  # noqa: E402

SAMPLES, COPIES = 64, 48
SAMPLING = pyshadow.Sampling(SAMPLES)
# these CSMs (wall: 32x64 maps, sphere: 8x16, both at 64^2) disagree with Embree on <= 1.3 % of the rays
CSM_RAYS = 0.02
Q = 16


@pytest.fixture(scope="module")
def wall():
    return A.wall_scene(maps=64, resolution=64)


@pytest.fixture(scope="module")
def sphere():
    return A.sphere_scene(maps=16, resolution=64)


def ground(point, copies=COPIES):
    return np.tile(np.asarray(point, np.float64), (copies, 1)), np.tile([0.0, 1.0, 0.0], (copies, 1))


def ao(scene, point, backend, **kw):
    p, n = ground(point)
    return visibility.ambient_occlusion(scene, p, n, backend=backend, sampling=SAMPLING, surface_ids=-2,
                                        indices=np.arange(COPIES), **kw)


def bound(value, geometric=0.0):
    return A.noise_bound(value, SAMPLES * COPIES) + geometric


# ---------------------------------------------------------------------------
# input checks and the defaults
# ---------------------------------------------------------------------------
def test_bad_options_launch_nothing(small_scene, no_launch):
    p, n = ground((3.0, 0.0, 0.0), 2)
    for backend in ("csm", "csm-vote", "numpy", "embree"):
        for bad in (0.0, -1.0, np.nan, [1.0, 2.0, 3.0]):
            with pytest.raises(ValueError, match="max_distance"):
                visibility.ambient_occlusion(small_scene, p, n, backend=backend, max_distance=bad)
        for kw, what in (({"obscurance": 0.0}, "obscurance"), ({"obscurance": np.inf}, "obscurance"),
                         ({"obscurance": 1.0, "quadrature": 0}, "quadrature"),
                         ({"max_distance": 1.0, "quadrature": 1.5}, "quadrature"),
                         ({"max_distance": 1.0, "straddle": "guess"}, "straddle")):
            with pytest.raises(ValueError, match=what):
                visibility.ambient_occlusion(small_scene, p, n, backend=backend, **kw)
    with pytest.raises(TypeError, match="obscurance"):
        visibility.ambient_occlusion(small_scene, p, n, obscurance="far")


@pytest.mark.parametrize("backend", ["csm", "csm-vote", "numpy", "embree"])
def test_unbounded_is_todays_ao(sphere, backend, rng):
    """max_distance=inf (the AO kernel compiled with FINITE_RAYS=1 for the CSM) gives the default
    answers bit for bit, bent normals included."""
    scene, _ = sphere
    p = np.column_stack([rng.uniform(-3, 3, 200), np.zeros(200), rng.uniform(-3, 3, 200)])
    n = np.tile([0.0, 1.0, 0.0], (200, 1))
    a, ab = visibility.ambient_occlusion(scene, p, n, backend=backend, return_bent_normals=True, surface_ids=-2)
    b, bb = visibility.ambient_occlusion(scene, p, n, backend=backend, return_bent_normals=True, surface_ids=-2,
                                         max_distance=np.inf)
    assert 0.2 < a.mean() < 0.99
    assert np.array_equal(a, b) and np.array_equal(ab, bb)


def test_kernel_path_matches_the_rays(sphere, rng):
    """Points whose rays cannot end inside the sphere's bounding sphere take the AO kernel with
    FINITE_RAYS; it answers as the visibility kernel does ray by ray (the same directions) and as the
    NumPy mirror, up to float32 rounding at decision boundaries."""
    scene, _ = sphere
    N = 300
    s = rng.uniform(1.3, 2.5, N)
    phi = rng.uniform(0, 2 * np.pi, N)
    p = np.column_stack([s * np.cos(phi), np.zeros(N), s * np.sin(phi)])
    n = np.tile([0.0, 1.0, 0.0], (N, 1))
    d = np.hypot(s, 1.0)
    D = d - 1.0 + rng.uniform(0.3, 0.9, N) * (s - (d - 1.0))        # inside the band: rays can straddle
    D_clear = np.where(rng.random(N) < 0.5, 0.9 * (d - 1.0), d + 1.05)   # shell clear of the sphere
    assert finite.shell_clear(scene, p, D_clear).all() and not finite.shell_clear(scene, p, D).any()
    got = visibility.ambient_occlusion(scene, p, n, sampling=SAMPLING, surface_ids=-2, max_distance=D_clear)
    dirs = SAMPLING.directions(n).reshape(-1, 3)
    vis = scene.visible(np.repeat(p, SAMPLES, axis=0), dirs, surface_ids=-2, normals=np.repeat(n, SAMPLES, axis=0),
                        max_distance=np.repeat(D_clear, SAMPLES)).reshape(N, SAMPLES)
    assert np.mean(got != vis.mean(axis=1).astype(np.float32)) <= 0.01
    ref = visibility.ambient_occlusion(scene, p, n, backend="numpy", sampling=SAMPLING, surface_ids=-2,
                                       max_distance=D_clear)
    assert np.abs(got - ref).max() <= 2.0 / SAMPLES and np.mean(got != ref) <= 0.02
    # the straddling points go ray by ray (the sphere is convex and fills its bounding sphere: the
    # unbounded answer is right for every ray that ends inside the body)
    emb = visibility.ambient_occlusion(scene, p, n, backend="embree", sampling=SAMPLING, max_distance=D)
    for policy in ("embree", "infinite"):
        csm = visibility.ambient_occlusion(scene, p, n, sampling=SAMPLING, surface_ids=-2, max_distance=D,
                                           straddle=policy)
        assert np.abs(csm - emb).mean() <= CSM_RAYS


# ---------------------------------------------------------------------------
# the straddle rule
# ---------------------------------------------------------------------------
def test_straddle_rule_on_the_wall(wall):
    """Every AO ray of length D near the wall ends inside its (loose) bounding sphere: refused by
    default; 'embree' answers the undecided rays exactly; 'infinite' answers as unbounded (too dark)."""
    x, D = 0.5, A.WALL["D"]
    pt = (0.0, 0.0, -x)
    for backend in ("csm", "numpy"):
        with pytest.raises(ValueError, match="caster instance 0 .*straddle='embree'"):
            ao(wall, pt, backend, max_distance=D)
    exact = A.wall_ao(x, D=D)
    unlimited = A.wall_ao(x, b=A.WALL["b"], h=A.WALL["h"])
    for backend in ("csm", "csm-vote", "numpy"):
        a = ao(wall, pt, backend, max_distance=D, straddle="embree").mean()
        assert abs(a - exact) <= bound(exact) + CSM_RAYS
        inf = ao(wall, pt, backend, max_distance=D, straddle="infinite")
        assert np.array_equal(inf, ao(wall, pt, backend))               # the unbounded AO, exactly
        assert abs(inf.mean() - unlimited) <= bound(unlimited) + CSM_RAYS < exact - unlimited


# ---------------------------------------------------------------------------
# the closed forms
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("x", A.WALL["x"])
@pytest.mark.parametrize("estimator", ["unlimited", "limited", "weighted"])
def test_wall_closed_form(wall, x, estimator):
    value, geo = A.wall_truth(x, estimator)
    kw = A.estimators(A.WALL["D"])[estimator]
    emb = ao(wall, (0.0, 0.0, -x), "embree", **kw).mean()
    assert abs(emb - value) <= bound(value, geo)
    extra = {} if not kw else {"straddle": "embree", "quadrature": Q}
    quad = 0.5 / Q if estimator == "weighted" else 0.0
    for backend in ("csm", "csm-vote"):
        got = ao(wall, (0.0, 0.0, -x), backend, **kw, **extra).mean()
        assert abs(got - emb) <= CSM_RAYS + quad
        assert abs(got - value) <= bound(value, geo) + CSM_RAYS + quad


@pytest.mark.parametrize("s", A.SPHERE["s"])
@pytest.mark.parametrize("estimator", ["unlimited", "limited", "weighted"])
def test_sphere_closed_form(sphere, s, estimator):
    scene, r_in = sphere
    value, geo = A.sphere_truth(s, estimator, r_in)
    assert geo < 0.01
    kw = A.estimators(A.SPHERE["D"])[estimator]
    emb = ao(scene, (s, 0.0, 0.0), "embree", **kw).mean()
    assert abs(emb - value) <= bound(value, geo)
    # 'infinite' on a sphere: wrong only for rays ending between the icosphere and its bounding sphere
    extra = {} if not kw else {"straddle": "infinite", "quadrature": Q}
    quad = 0.5 / Q if estimator == "weighted" else 0.0
    for backend in ("csm", "csm-vote", "numpy"):
        got = ao(scene, (s, 0.0, 0.0), backend, **kw, **extra).mean()
        assert abs(got - emb) <= CSM_RAYS + quad
        assert abs(got - value) <= bound(value, geo) + CSM_RAYS + quad


def test_closed_forms_agree_with_each_other():
    """Limits: D -> inf and tau -> 0 give the unlimited forms, tau -> inf AO 1; an infinite wall is 1/2."""
    assert A.wall_ao(1.0) == 0.5
    assert abs(A.wall_ao(1.0, D=1e9) - 0.5) < 1e-8
    assert abs(A.wall_ao(1.0, b=1e6, h=1e6) - 0.5) < 1e-5
    assert abs(A.wall_ao(1.0, tau=1e-9) - 0.5) < 1e-8
    assert abs(A.wall_ao(1.0, tau=50.0) - 1.0) < 1e-12
    for s in (0.3, 1.0, 2.5):
        d = np.hypot(s, 1.0)
        assert abs(A.sphere_ao(s, 1.0) - (1 - d ** -3)) < 1e-15
        assert abs(A.sphere_ao(s, 1.0, D=s) - A.sphere_ao(s, 1.0)) < 1e-14     # the tangent length: the whole cap
        assert A.sphere_ao(s, 1.0, D=d - 1.0) == 1.0
        assert abs(A.sphere_ao(s, 1.0, tau=1e-9) - A.sphere_ao(s, 1.0)) < 1e-8
        assert A.sphere_ao(s, 1.0, tau=1.0) > A.sphere_ao(s, 1.0, tau=0.5) > A.sphere_ao(s, 1.0)


# ---------------------------------------------------------------------------
# the quadrature
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("q", [1, 4, 16])
def test_quadrature_error_bound(sphere, q, rng):
    """rho_Q of every ray (with exact V_t from Embree) lies within 1 / (2Q) of rho(L) for the ray's
    own hit distance L (rays with a node within 1e-4 of L, where the lift decides, left out)."""
    scene, _ = sphere
    N = 60
    p = np.column_stack([rng.uniform(0.2, 2.0, N), np.zeros(N), rng.uniform(-0.5, 0.5, N)])
    n = np.tile([0.0, 1.0, 0.0], (N, 1))
    dirs = SAMPLING.directions(n).astype(np.float64)
    tau, D = 1.5, 2.5
    nodes = finite.ao_nodes(np.full(N, D), tau, q)
    P, W = np.repeat(p, SAMPLES, axis=0), dirs.reshape(-1, 3)

    def answer(k, t):
        return embree.visible(scene, P[k], W[k], max_distance=t)

    w = finite.rays_ao(scene, p, n, dirs, nodes, "embree", answer).reshape(-1)
    rays, anchor = embree.caster_scene(scene)
    L, _, _ = rays.intersect(P - anchor, W)
    L = np.minimum(L + embree.surface_epsilon(scene, P), np.inf)
    exact = finite.obscurance_weight(L, D, tau)
    clean = np.abs(np.repeat(nodes, SAMPLES, axis=0) - L[:, None]).min(axis=1) > 1e-4
    assert clean.mean() > 0.99 and 0.1 < (L < D).mean() < 0.9
    assert np.abs(w - exact)[clean].max() <= 0.5 / q + 1e-12
    assert np.array_equal(w[L > D + 1e-4], np.ones(int((L > D + 1e-4).sum())))     # beyond D: exact


def test_weighted_bent_normals_and_per_point_limits(sphere, rng):
    """Bent normals weight each direction by rho; (N,) limits; the CSM's weighted bent normals
    (ray by ray) agree with Embree's to the quadrature and texel error."""
    scene, _ = sphere
    N = 40
    p = np.column_stack([rng.uniform(0.4, 2.0, N), np.zeros(N), rng.uniform(-0.5, 0.5, N)])
    n = np.tile([0.0, 1.0, 0.0], (N, 1))
    D = rng.uniform(0.5, 3.0, N)
    a, ab = visibility.ambient_occlusion(scene, p, n, backend="embree", sampling=SAMPLING, max_distance=D,
                                         return_bent_normals=True)
    for i in range(0, N, 13):         # one point at a time gives the same answers
        assert a[i] == visibility.ambient_occlusion(scene, p[i:i + 1], n[i:i + 1], backend="embree",
                                                    sampling=SAMPLING, indices=[i], max_distance=D[i])[0]
    dirs = SAMPLING.directions(n).astype(np.float64)
    vis = visibility.visible(scene, np.repeat(p, SAMPLES, axis=0), dirs.reshape(-1, 3), backend="embree",
                             max_distance=np.repeat(D, SAMPLES)).reshape(N, SAMPLES)
    want = (dirs * vis[..., None]).sum(axis=1)
    want /= np.linalg.norm(want, axis=1, keepdims=True)
    assert np.abs(ab - want).max() < 0.02 and np.abs(a - vis.mean(axis=1)).max() <= 1.0 / SAMPLES
    w, wb = visibility.ambient_occlusion(scene, p, n, sampling=SAMPLING, surface_ids=-2, obscurance=1.0,
                                         quadrature=Q, straddle="infinite", return_bent_normals=True)
    e, eb = visibility.ambient_occlusion(scene, p, n, backend="embree", sampling=SAMPLING, obscurance=1.0,
                                         return_bent_normals=True)
    assert np.abs(w - e).mean() <= 0.5 / Q + CSM_RAYS
    assert np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", wb, eb), -1, 1))).max() < 5.0
