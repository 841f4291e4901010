"""Visibility and AO queries (pyshadow.visibility and the Scene wrappers): the CSM kernels
against Embree, invariants, input validation, dtypes, batch sizes, launch shapes and the
portable code path (the backends against their mirrors: test_visibility_backends.py)."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import Sampling, embree, visibility
from pyshadow._cl import launch
from pyshadow.scene import GROUND_ID
from pyshadow.visibility.csm import CSMVisibility

from conftest import load, on_ground, surface_queries, unit_frame


# ---------------------------------------------------------------------------
# the CSM kernels against Embree
# ---------------------------------------------------------------------------
def test_visible_agrees_with_embree_bunny(bunny_scene, rng):
    p, d = surface_queries(bunny_scene, 0, 20000, 16, rng)
    ours = bunny_scene.visible(p, d)
    truth = embree.visible(bunny_scene, p, d)
    assert 0.2 < truth.mean() < 0.9                     # both outcomes are common
    assert (ours == truth).mean() >= 0.99


def test_visible_agrees_with_embree_two_objects(two_object_scene, rng):
    scene = two_object_scene
    for inst in (0, 1):
        p, d = surface_queries(scene, inst, 10000, 16, rng)
        ours = scene.visible(p, d)
        truth = embree.visible(scene, p, d)
        assert 0.2 < truth.mean() < 0.95
        assert (ours == truth).mean() >= 0.99, inst
    # the fandisk really shadows the bunny and the other way round somewhere
    p, d = surface_queries(scene, 1, 4000, 16, rng)
    without = pyshadow.Scene(ground=0.0)
    without.add(scene.instances[1].csm, scene.transform(1), mesh=scene.instances[1].mesh)
    assert (embree.visible(scene, p, d) != embree.visible(without, p, d)).any()


def test_visible_uniform_hemisphere_directions(bunny_scene, rng):
    """Uniform (not cosine-weighted) directions include many grazing ones: lower bound."""
    p, d = surface_queries(bunny_scene, 0, 10000, 8, rng, uniform=True)
    agree = (bunny_scene.visible(p, d) == embree.visible(bunny_scene, p, d)).mean()
    assert agree >= 0.98


def test_vote_visible_uniform_directions_reach_99_percent(bunny_scene, two_object_scene, rng):
    """Uniform hemisphere directions with lookup="vote", 64x128 maps at 128^2:
    at least 99 % agreement with Embree on the bunny alone and on both bodies
    of the two-object scene (the one-texel lookup: 98.6-99.0 %)."""
    p, d = surface_queries(bunny_scene, 0, 10000, 8, rng, uniform=True)
    truth = embree.visible(bunny_scene, p, d)
    assert (bunny_scene.visible(p, d, lookup="vote") == truth).mean() >= 0.99
    for inst in (0, 1):
        p, d = surface_queries(two_object_scene, inst, 10000, 8, rng, uniform=True)
        truth = embree.visible(two_object_scene, p, d)
        ids = np.full(len(p), inst)
        assert (two_object_scene.visible(p, d, surface_ids=ids, lookup="vote") == truth).mean() >= 0.99, inst


@pytest.mark.parametrize("lookup", ["nearest", "vote"])
def test_ambient_occlusion_is_visible_over_sample_directions(bunny_scene, lookup):
    """scene_ao makes the directions of sample_directions on the device and asks
    them as scene_visible does: the AO of a point is the mean of visible() over
    its directions, with the points' normals (the surface rule, which AO always applies)."""
    pts, nrm = bunny_scene.vertex_points(0)
    pts, nrm = pts[:2000], nrm[:2000]
    ao = bunny_scene.ambient_occlusion(pts, nrm, sampling=Sampling(36), surface_ids=0, lookup=lookup)
    d = pyshadow.sample_directions(nrm, sampling=Sampling(36)).reshape(-1, 3)
    vis = bunny_scene.visible(np.repeat(pts, 36, axis=0), d, surface_ids=0, lookup=lookup,
                              normals=np.repeat(nrm, 36, axis=0))
    mean = vis.reshape(-1, 36).mean(axis=1)
    assert 0.3 < ao.mean() < 0.95
    np.testing.assert_allclose(ao, mean, atol=1e-6)


def test_visible_agreement_rises_with_maps_and_resolution(rng):
    bunny = load("stanford-bunny.obj")
    agreement = {}
    p = d = None
    for grid, R in [((8, 16), 64), ((16, 32), 64), ((32, 64), 64), ((32, 64), 32), ((32, 64), 128)]:
        scene = pyshadow.Scene(ground=float(bunny.bounds[0, 1]), views=pyshadow.ViewSet.zigzag(*grid),
                               resolution=R)
        scene.add(bunny)
        if p is None:
            p, d = surface_queries(scene, 0, 8000, 8, rng)
            truth = embree.visible(scene, p, d)
        agreement[grid, R] = (scene.visible(p, d) == truth).mean()
    assert agreement[(8, 16), 64] < agreement[(16, 32), 64] < agreement[(32, 64), 64]
    assert agreement[(32, 64), 32] < agreement[(32, 64), 64] < agreement[(32, 64), 128]


def test_vertex_ao_matches_embree_256_samples(bunny_scene):
    ours = bunny_scene.vertex_ao(0, sampling=Sampling(256))
    pts, nrm = bunny_scene.vertex_points(0)
    truth = embree.ambient_occlusion(bunny_scene, pts, nrm, sampling=Sampling(256))
    err = np.abs(ours.astype(np.float64) - truth)
    assert ours.dtype == np.float32 and ours.shape == (len(pts),)
    assert err.mean() <= 0.01
    assert np.quantile(err, 0.99) <= 0.05
    assert truth.min() < 0.2 and truth.max() > 0.9         # occluded and open vertices both occur


@pytest.mark.parametrize("name", ["featuretype.STL", "teapot.obj"])
def test_front_margin_keeps_self_shadowing(name, monkeypatch):
    """Surfaces behind the first one that face the light (a closed mesh's re-entry
    surface z3 under layers=3; the second sheet z2 of an open mesh) are asked with a
    self-bias: the CSM's margin in front of them keeps them in shadow. Measured on
    the default builds (featuretype: layers=3, teapot: 2) against the same builds
    without the margin: 98.5 against 96.8 % and 98.7 against 98.3 %. On the closed
    mesh layers=3 then agrees with Embree as well as layers=2."""
    import pyshadow.csm.core as csm_core

    mesh = load(name)
    T = on_ground(mesh, unit_frame(mesh))
    views = pyshadow.ViewSet.zigzag(16, 32)
    rng = np.random.default_rng(11)
    agree = {}
    p = d = truth = None
    runs = [("default", "auto", None), ("no margin", "auto", 0.0)]
    if mesh.is_watertight:
        runs.append(("layers=2", 2, None))
    for label, layers, margin in runs:
        if margin is not None:
            monkeypatch.setattr(csm_core, "FRONT_MARGIN_TEXELS", margin)
        else:
            monkeypatch.undo()
        csm = pyshadow.CoherentShadowMap.build(mesh, views, resolution=64, layers=layers, progress=False)
        scene = pyshadow.Scene(ground=0.0)
        scene.add(csm, T, mesh=mesh)
        if p is None:
            p, d = surface_queries(scene, 0, 4000, 8, rng)
            truth = embree.visible(scene, p, d)
        agree[label] = (scene.visible(p, d, surface_ids=0) == truth).mean()
    assert agree["default"] >= 0.98
    assert agree["no margin"] < agree["default"] - 0.003
    if "layers=2" in agree:
        assert agree["default"] >= agree["layers=2"] - 0.001


@pytest.mark.parametrize("layers", [2, "auto"])
def test_point_under_closed_box_has_zero_ao(layers):
    """Ground points under a box resting on the ground see nothing of the sky.

    The box's bottom face lies exactly in the ground plane, so the few samples
    within a map spacing of horizontal can leak through the texel row at the
    boundary: away from the box's edges AO stays below 1/100.
    """
    box = trimesh.creation.box((2.0, 2.0, 2.0))
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(64, 128), resolution=128,
                           layers=layers)
    scene.add(box, trimesh.transformations.translation_matrix([0, 1.0, 0]))
    assert scene.instances[0].csm.layer_rule == (2 if layers == 2 else 3)
    pts = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, -0.3], [-0.6, 0.0, 0.6], [40.0, 0.0, 0.0]])
    up = np.tile([0.0, 1.0, 0.0], (4, 1))
    ao = scene.ambient_occlusion(pts, up, sampling=Sampling(512), surface_ids=GROUND_ID)
    assert ao[0] == 0.0
    assert (ao[1:3] <= 0.01).all()
    assert ao[3] == 1.0                        # far from the box: the open ground plane
    truth = embree.ambient_occlusion(scene, pts, up, sampling=Sampling(512))
    np.testing.assert_array_equal(truth, [0, 0, 0, 1])


def test_open_plane_receiver_has_ao_one():
    floor = trimesh.Trimesh([[-5, 0, -5], [5, 0, -5], [5, 0, 5], [-5, 0, 5]], [[0, 2, 1], [0, 3, 2]])
    scene = pyshadow.Scene(ground=0.0)
    scene.add(floor, casts=False)
    g = np.random.default_rng(0).uniform(-4, 4, size=(500, 3))
    g[:, 1] = 0.0
    ao = scene.ambient_occlusion(g, np.tile([0.0, 1.0, 0.0], (500, 1)), sampling=Sampling(64))
    np.testing.assert_array_equal(ao, 1.0)


@pytest.mark.parametrize("scale, offset", [(1e-3, 0.0), (1e4, 0.0), (1.0, 1e5), (1e3, 1e5), (1e-20, 0.0),
                                           (1e20, 0.0)])
def test_visibility_at_extreme_scales_and_positions(scale, offset, rng):
    bunny = load("stanford-bunny.obj")
    csm = pyshadow.CoherentShadowMap.build(bunny, pyshadow.ViewSet.zigzag(32, 64), resolution=64,
                                           progress=False)
    T = unit_frame(bunny, scale=scale, offset=(offset, offset, -offset))
    v = bunny.vertices @ T[:3, :3].T + T[:3, 3]
    scene = pyshadow.Scene(ground=float(v[:, 1].min()))
    scene.add(csm, T, mesh=bunny)
    p, d = surface_queries(scene, 0, 4000, 8, rng)
    ours = scene.visible(p, d)
    truth = embree.visible(scene, p, d)
    assert 0.2 < truth.mean() < 0.9
    assert (ours == truth).mean() >= 0.985


def test_ambient_occlusion_bent_normals(bunny_scene):
    pts, nrm = bunny_scene.vertex_points(0)
    sel = slice(0, 3000)
    ao, bent = bunny_scene.ambient_occlusion(pts[sel], nrm[sel], sampling=Sampling(64), return_bent_normals=True)
    ref_ao, ref_bent = embree.ambient_occlusion(bunny_scene, pts[sel], nrm[sel], sampling=Sampling(64),
                                                return_bent_normals=True)
    np.testing.assert_allclose(np.linalg.norm(bent, axis=1), 1, atol=1e-5)
    # the same open directions give the same bent normal: most agree to round-off
    angle = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", bent, ref_bent), -1, 1)))
    assert np.median(angle) < 0.01
    assert np.quantile(angle, 0.95) < 10.0
    assert np.abs(ao - ref_ao).mean() < 0.01
    # bent normals lean away from occluders: towards +y on a bunny standing on the ground
    assert (bent[:, 1] - nrm[sel, 1]).mean() > 0


def test_reference_ground_occludes_world_and_anchored():
    """The public ground test: above looking down or below looking up is blocked; the
    anchored form (rays relative to caster_scene's anchor) gives the same answers."""
    bunny = load("stanford-bunny.obj")
    scene = pyshadow.Scene(ground=1.0e4)
    scene.add(bunny, on_ground(bunny, unit_frame(bunny, offset=(3.0e4, 1.0e4, -2.0e4))))
    eps = pyshadow.contact.ground_tolerance(scene)      # one float32 spacing at y = 1e4: 9.8e-4
    assert eps == float(np.spacing(np.float32(1.0e4))) > 1e-5 * scene.scale()
    p = np.array([[3e4, 1e4 + 1.0, -2e4], [3e4, 1e4 - 1.0, -2e4], [3e4, 1e4 - 0.5 * eps, -2e4],
                  [3e4, 1e4 - 2.0 * eps, -2e4]])
    down, up, flat = [0.1, -1.0, 0.2], [0.1, 1.0, 0.2], [1.0, 0.0, 0.0]
    for d, want in ((down, [True, False, True, False]), (up, [False, True, False, True]),
                    (flat, [False, False, False, False])):
        dirs = np.tile(d, (4, 1))
        assert embree.ground_occludes(scene, p, dirs).tolist() == want
        rays, anchor = embree.caster_scene(scene)
        assert embree.ground_occludes(scene, p - anchor, dirs, anchor).tolist() == want
    assert not embree.ground_occludes(pyshadow.Scene(), p, np.tile(down, (4, 1))).any()


# ---------------------------------------------------------------------------
# input validation
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("points, dirs, match", [
    ([[0, np.nan, 0]], [[0, 1, 0]], "points: 1 rows are not finite"),
    ([[0, 0, 0]], [[0, np.inf, 0]], "directions: 1 rows are not finite"),
    ([[0, 0, 0]], [[0, 0, 0]], "zero vectors"),
    ([[0, 0, 0], [1, 1, 1]], [[0, 1, 0]], "shapes must match"),
    ([[0, 0]], [[0, 1]], r"shape \(N, 3\)"),
])
def test_visible_rejects_bad_input(small_scene, no_launch, points, dirs, match):
    with pytest.raises(ValueError, match=match):
        small_scene.visible(points, dirs)


@pytest.mark.parametrize("kwargs, exc, match", [
    (dict(normals=[[0, 0, 0]]), ValueError, "zero vectors"),
    (dict(points=[[0, 0, 0], [1, 0, 0]]), ValueError, "shapes must match"),
    (dict(points=[[0, 0, np.nan]]), ValueError, "not finite"),
    (dict(sampling=36), TypeError, "sampling must be a pyshadow.Sampling, got 36"),
    (dict(indices=[0, 1]), ValueError, r"indices must have shape \(1,\)"),
    (dict(lookup="linear"), ValueError, "lookup must be 'nearest' or 'vote', got 'linear'"),
    (dict(lookup="vote", backend="numpy"), TypeError, "with backend= leave it out"),
])
def test_ambient_occlusion_rejects_bad_input(small_scene, no_launch, kwargs, exc, match):
    """Sampling's own checks (samples, strategy, patterns, seed): test_sampling."""
    args = dict(points=[[0.0, 0.0, 0.0]], normals=[[0.0, 1.0, 0.0]])
    args.update(kwargs)
    with pytest.raises(exc, match=match):
        small_scene.ambient_occlusion(**args)


def test_visibility_functions_reject_bad_input(small_scene, no_launch):
    p, d = [[0.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]]
    with pytest.raises(TypeError, match="sampling must be a pyshadow.Sampling"):
        visibility.ambient_occlusion(small_scene, p, d, sampling=(36, "halton"))
    with pytest.raises(ValueError, match="lookup must be 'nearest' or 'vote', got 'linear'"):
        small_scene.visible(p, d, lookup="linear")
    with pytest.raises(TypeError, match="with backend= leave it out"):
        small_scene.visible(p, d, lookup="vote", backend="embree")
    with pytest.raises(ValueError, match="surface_ids must be instance ids"):
        small_scene.visible(p, d, surface_ids=4)
    for name in ("numpy", "numpy-vote"):
        with pytest.raises(ValueError, match="zero vectors"):
            visibility.visible(small_scene, p, [[0.0, 0.0, 0.0]], backend=name)


def test_bias_must_be_finite(small_scene):
    p, d = [[0.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]]
    for name in ("csm", "csm-vote"):
        for bias in (np.inf, np.nan):
            with pytest.raises(ValueError, match="bias must be finite"):
                visibility.visible(small_scene, p, d, backend=name, bias=bias)


@pytest.mark.parametrize("dtype", [np.float64, np.float32, np.int64])
def test_check_values_matches_the_exact_definition(dtype):
    """The one-pass checks of visible() against isfinite / any row by row, on
    small arrays drawn from values that hit every case (zeros of both signs,
    overflowing sums, inf, nan)."""
    from pyshadow._validate import check_values

    rng = np.random.default_rng(3)
    big = np.finfo(dtype).max / 2 if dtype != np.int64 else 2**62
    values = [0, 1, -2, big] + ([-0.0, np.inf, -np.inf, np.nan] if dtype != np.int64 else [])
    raised = 0
    for _ in range(3000):
        a = rng.choice(np.array(values, dtype=dtype), size=(int(rng.integers(1, 7)), 3))
        bad = int((~np.isfinite(a).all(axis=1)).sum()) if dtype != np.int64 else 0
        zero = int((~a.any(axis=1)).sum())
        expect = (f"x: {bad} rows are not finite" if bad else
                  f"x: {zero} rows are zero vectors" if zero else None)
        try:
            check_values(a, "x", nonzero=True)
            got = None
        except ValueError as e:
            got = str(e)
        assert got == expect, a
        raised += got is not None
    assert 100 < raised < 2900                      # both outcomes were exercised


def test_unit_normals_of_tiny_and_huge_rows():
    """Normals are divided by their length: ordinary rows exactly as by
    np.linalg.norm, rows whose squared length underflows or overflows after
    scaling by their largest component (they used to come out nan or zero),
    and rows of zeros are refused."""
    from pyshadow._validate import unit_normals

    rng = np.random.default_rng(5)
    m = np.concatenate([rng.normal(size=(5000, 3)), rng.normal(size=(50, 3)) * 1e-100,
                        np.repeat([[0.0, 1.0, 0.0]], 50, axis=0)])
    assert np.array_equal(unit_normals(m, len(m)), m / np.linalg.norm(m, axis=1, keepdims=True))
    odd = np.array([[1e-170, 0.0, 0.0], [0.0, -1e200, 1e200], [3e-200, 4e-200, 0.0], [5e-324, 0.0, 0.0],
                    [1.5e308, 1.5e308, 1.5e308]])
    h = 0.5 ** 0.5
    expect = np.array([[1.0, 0, 0], [0, -h, h], [0.6, 0.8, 0], [1.0, 0, 0], [3 ** -0.5] * 3])
    np.testing.assert_allclose(unit_normals(odd, len(odd)), expect, rtol=1e-15, atol=0)
    with pytest.raises(ValueError, match="normals: 1 rows are zero vectors"):
        unit_normals(np.array([[0.0, 0.0, 0.0], [1e-300, 0.0, 0.0]]), 2)
    # float32 out (what the AO kernel reads): the float64 quotients rounded once, ordinary and odd rows
    both = np.concatenate([m, odd])
    want = unit_normals(both, len(both)).astype(np.float32)
    got = unit_normals(both, len(both), dtype=np.float32)
    assert got.dtype == np.float32 and np.array_equal(got, want)


def test_unit_normals_of_rows_whose_squares_are_subnormal():
    """Was: only rows whose squared length was exactly 0 or inf were rescaled; a row with components between about
    1e-162 and 1e-154 squared to a subnormal, which keeps fewer digits, and came out up to 6e-6 off unit length
    ((3e-160, 0, -4e-160): 1.0000055664551362). Now such rows are scaled by their largest component first."""
    from pyshadow._validate import unit_normals

    odd = np.array([[3e-160, 0.0, -4e-160], [0.0, 1e-158, 1e-158], [2e-155, 2e-155, 1e-155]])
    h = 0.5 ** 0.5
    expect = np.array([[0.6, 0.0, -0.8], [0.0, h, h], [2 / 3, 2 / 3, 1 / 3]])
    np.testing.assert_allclose(unit_normals(odd, len(odd)), expect, rtol=1e-15, atol=0)


# ---------------------------------------------------------------------------
# dtypes, batch sizes, launch shapes, the portable code path
# ---------------------------------------------------------------------------
def test_visible_input_dtypes_scales_and_float_only_devices_agree(bunny_scene, rng, monkeypatch):
    """Bit-identical answers whatever the input dtypes, for directions scaled by
    powers of two far outside float32's range (the kernel's exact rescaling),
    for batches that end mid-vector, split over many launches, and on a device
    without double precision (the host then makes the same roundings)."""
    p, d = surface_queries(bunny_scene, 0, 3001, 16, rng)   # 48016 queries: a partial batch
    p = p.astype(np.float32).astype(np.float64)             # values float32 holds exactly
    d = d.astype(np.float32).astype(np.float64)
    ids = np.zeros(len(p), np.int32)
    base = bunny_scene.visible(p, d, surface_ids=ids)
    assert 0.2 < base.mean() < 0.9
    mixed = d.copy()
    mixed[::7] *= 2.0**-700
    mixed[3::11] *= 2.0**700
    variants = {
        "float32 points": (p.astype(np.float32), d),
        "float32 directions": (p, d.astype(np.float32)),
        "tiny float64 directions": (p, d * 2.0**-700),
        "huge float64 directions": (p, d * 2.0**700),
        "tiny float32 directions": (p, (d * 2.0**-70).astype(np.float32)),
        "huge float32 directions": (p, (d * 2.0**70).astype(np.float32)),
        "mixed scales": (p, mixed),
    }
    for name, (pp, dd) in variants.items():
        assert (bunny_scene.visible(pp, dd, surface_ids=ids) == base).all(), name
    with launch.override(query_chunk=1000):                        # many launches, odd sizes
        assert (bunny_scene.visible(p, d, surface_ids=ids) == base).all(), "chunked"
    monkeypatch.setattr(pyshadow.visibility.csm._cl, "has_fp64", lambda: False)
    for name, (pp, dd) in [("float-only device", (p, d)), ("float-only, huge", (p, d * 2.0**700))]:
        assert (bunny_scene.visible(pp, dd, surface_ids=ids) == base).all(), name


class QueryAnswers:
    """Fixed queries on the bunny and the answers of every query kernel path
    (one-texel and vote ``visible``, AO with bent normals)."""

    def __init__(self, scene, rng, points=1001, vertices=3000):
        self.scene = scene
        self.p, self.d = surface_queries(scene, 0, points, 16, rng)
        pts, nrm = scene.vertex_points(0)
        self.pts, self.nrm = pts[:vertices], nrm[:vertices]
        self.ids = np.zeros(len(self.p), np.int32)
        self.want = self.answers()
        vis, vis_v, ao, _ = self.want
        assert 0.2 < vis.mean() < 0.9 and 0.2 < ao.mean() < 0.95 and (vis_v != vis).any()

    def answers(self):
        s = self.scene
        ao, bent = s.ambient_occlusion(self.pts, self.nrm, sampling=Sampling(36), surface_ids=0,
                                       return_bent_normals=True)
        return (s.visible(self.p, self.d, surface_ids=self.ids),
                s.visible(self.p, self.d, surface_ids=self.ids, lookup="vote"), ao, bent)

    def check(self):
        """The answers now equal the first ones, exactly."""
        for got, want, what in zip(self.answers(), self.want, ("visible", "vote", "ao", "bent")):
            assert got.dtype == want.dtype and np.array_equal(got, want), what


def portable_kernels(monkeypatch):
    """Build the query kernels in their standard-OpenCL forms (vloadN,
    prefetch(): what GPUs compile) instead of their inline CPU forms."""
    defines = CSMVisibility._defines
    monkeypatch.setattr(CSMVisibility, "_defines", lambda self, scene, atlas, **kw: {
        **defines(self, scene, atlas, **kw), "CPU_CLANG": 0})


def test_query_kernels_agree_for_every_batch_size(bunny_scene, rng):
    """A batch of one lane vector (as on GPUs at 16 lanes) gives the CPU's
    answers (512 queries): packing the undecided rays of a batch changes
    nothing but speed."""
    q = QueryAnswers(bunny_scene, rng)
    with launch.override(query_batch=launch.shape().lanes):
        q.check()


@pytest.mark.parametrize("samples", [7, 16])
def test_ao_points_sharing_a_work_item_answer_as_one_point_each(bunny_scene, samples):
    """scene_ao runs launch.ao_points() points a work-item, whose samples share one queue of
    lookups: with the last work-item part-filled, AO, bent normals and the SH transfer are those
    of one point a work-item, bit for bit."""
    from pyshadow.lighting.transfer import sh_transfer
    pts, nrm = bunny_scene.vertex_points(0)
    pts, nrm = pts[:1237], nrm[:1237]

    def answers():
        ao, bent = bunny_scene.ambient_occlusion(pts, nrm, sampling=Sampling(samples), surface_ids=0,
                                                 return_bent_normals=True)
        return (ao, bent, *sh_transfer(bunny_scene, pts, nrm, sampling=Sampling(samples), surface_ids=0))
    s = launch.shape()
    k = launch.ao_points(samples)
    assert k == max(1, s.query_batch // (-(-samples // s.lanes) * s.lanes))
    if k == 1:
        pytest.skip("this device's batch holds one point's samples")
    assert len(pts) % k
    want = answers()
    with launch.override(query_batch=s.lanes):
        assert launch.ao_points(samples) == 1
        got = answers()
    for a, b in zip(got, want):
        np.testing.assert_array_equal(a, b)
    assert 0.2 < want[0].mean() < 0.95 and (want[0] < 1).sum() > 100


def test_ao_points_beyond_the_batch_are_refused(bunny_scene, monkeypatch):
    """scene_ao's private arrays hold one batch of queries: more points a work-item than its samples
    fill (launch.ao_points changed) are refused on the host with the limit, not overrun."""
    pts, nrm = bunny_scene.vertex_points(0)
    k = launch.ao_points(16)
    monkeypatch.setattr(launch, "ao_points", lambda samples, s=None: 2 * k)
    with pytest.raises(ValueError, match=rf"AO_POINTS {2 * k} x .* exceeds the batch of {launch.shape().query_batch}"):
        bunny_scene.ambient_occlusion(pts[:100], nrm[:100], sampling=Sampling(16), surface_ids=0)


def test_gpu_launch_shape_agrees(bunny_scene, rng, monkeypatch):
    """What a GPU runs -- one lane, one query per work-item, groups of 128,
    the kernels' portable OpenCL forms -- gives this device's answers."""
    q = QueryAnswers(bunny_scene, rng, points=701, vertices=2000)
    portable_kernels(monkeypatch)
    with pyshadow._cl.use_lanes(1), launch.override(lanes=1, query_batch=1, query_group=128):
        q.check()


def test_query_kernels_portable_code_path_agrees(bunny_scene, rng, monkeypatch):
    """The kernels' standard-OpenCL forms give the answers of their inline CPU forms (where the device can
    build them: an SSE2 target's compiler warns that their double4 loads change the ABI, and the build is
    refused, _cl.build_source)."""
    q = QueryAnswers(bunny_scene, rng)
    portable_kernels(monkeypatch)
    try:
        q.check()
    except pyshadow.KernelBuildError as exc:
        if pyshadow._cl.ABI_WARNING not in str(exc):
            raise
        pytest.skip(f"this device cannot build the standard-OpenCL forms at {pyshadow._cl.lanes()} lanes "
                    f"({pyshadow._cl.ABI_WARNING})")
