"""Points in several anchor groups: one upload a window, a launch per group (pyshadow.visibility.grouped).

The answers must be those of the launch per group that the grouped path replaced, to the bit: the AO
kernel's ``_ao_launch`` over each group's rows alone (AO and bent normals, the shadowed SH transfer, the
sampled sky), and ``_visible_kernel`` with each group's anchor.
Both are compared over a scene whose points make many groups (1 mm boxes spread over 12 m beside a
0.3 m box near the origin, points beside the tiny boxes), with the windows the defaults give, windows
smaller than a group (a group split over several), one window per group (the table budget at 1 byte),
and on a float-only device (the host rounds each group's points relative to its anchor).
"""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import _cl
from pyshadow._cl import launch
from pyshadow.contact import close_contacts
from pyshadow.sampling import direction_table, pattern_indices
from pyshadow.scene_arrays import anchor_groups
from pyshadow.visibility import csm as csm_backend
from pyshadow.visibility import grouped

BOX = trimesh.creation.box((1.0, 1.0, 1.0))
SAMPLES = 8
#: a lat-long sky of 8 x 16 texels, each its own radiance (the sampled sky's output)
ENV = np.random.default_rng(3).uniform(0.0, 2.0, (8, 16, 3)).astype(np.float32)


@pytest.fixture(scope="module")
def setup():
    csm = pyshadow.CoherentShadowMap.build(BOX, pyshadow.ViewSet.zigzag(8, 16), resolution=32, progress=False)
    scene = pyshadow.Scene(ground=0.0)
    rng = np.random.default_rng(4)
    centres = []
    for i in range(25):                 # 1 mm boxes on a 5 x 5 grid 2.4 m apart, jittered
        c = np.array([(i % 5 - 2) * 2.4 + rng.uniform(-0.5, 0.5), 0.0005, (i // 5 - 2) * 2.4 + rng.uniform(-0.5, 0.5)])
        T = np.diag([1e-3, 1e-3, 1e-3, 1.0])
        T[:3, 3] = c
        scene.add(csm, T, mesh=BOX)
        centres.append(c)
    T = np.diag([0.3, 0.3, 0.3, 1.0])
    T[:3, 3] = [0.2, 0.15, -0.1]
    scene.add(csm, T, mesh=BOX)
    n = 1500
    p = np.c_[rng.uniform(-6, 6, n), np.zeros(n), rng.uniform(-6, 6, n)]
    p[:300] = np.c_[rng.uniform(-0.5, 0.5, 300), np.zeros(300), rng.uniform(-0.5, 0.5, 300)]
    j = rng.integers(0, 25, 700)        # beside the tiny boxes: 0.6 to 3 mm from their centres, up to their top
    ang, d = rng.uniform(0, 2 * np.pi, 700), rng.uniform(6e-4, 3e-3, 700)
    c = np.array(centres)[j]
    p[300:1000] = np.c_[c[:, 0] + d * np.cos(ang), rng.uniform(0, 1e-3, 700), c[:, 2] + d * np.sin(ang)]
    normals = rng.normal(size=(n, 3))
    normals[:, 1] = np.abs(normals[:, 1]) + 0.3
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    groups = anchor_groups(scene, p)
    assert len(groups) > 50 and groups[0][0] is not None
    return scene, p, normals, groups


def _ao_per_group(backend, scene, p, normals, groups, output):
    """The AO kernel's outputs by one ``_ao_launch`` per group (the path before the grouped one): (ao, bent),
    (ao, bent, transfer) or (sky, ao, bent) for ``output`` 'ao', 'transfer' or 'sky'."""
    sampling = pyshadow.Sampling(SAMPLES)
    extra = {"TRANSFER": int(output == "transfer")} | ({"SKY_SAMPLED": 1} if output == "sky" else {})
    defines = backend.query_defines(scene, "scene_ao", SAMPLES=SAMPLES, BENT_NORMALS=1, SURFACE_NORMALS=1, **extra)
    k = _cl.kernel("visibility.cl", "scene_ao", defines)
    table = _cl.to_device(launch.lane_table(direction_table(SAMPLES, sampling.strategy, sampling.patterns,
                                                            sampling.seed)))
    n = normals.astype(np.float32)
    pidx = pattern_indices(np.arange(len(p)), sampling.patterns, sampling.seed)
    own = scene.caster_slots(None, len(p), p)
    sky_env = [_cl.to_device(ENV), np.int32(ENV.shape[0]), np.int32(ENV.shape[1])] if output == "sky" else None
    N = len(p)
    ao, bent = np.full(N, np.nan, np.float32), np.full((N, 3), np.nan, np.float32)
    tr = np.full((N, 9), np.nan, np.float32) if output == "transfer" else None
    sky = np.zeros((N, 3), np.float32) if output == "sky" else None
    for rows, anchor in groups:
        outs = tuple(None if a is None else np.empty((len(rows), *a.shape[1:]), np.float32)
                     for a in (ao, bent, tr, sky))
        backend._ao_launch(scene, k, defines, table, anchor, None, p[rows], n[rows], pidx[rows], own[rows], None,
                           sky_env, outs, True, output == "transfer", None)
        for a, got in zip((ao, bent, tr, sky), outs):
            if a is not None:
                a[rows] = got
    close_contacts(scene, p, n, ao, bent, tr, sky)      # (the tiny boxes rest on the ground: their footprints)
    return {"ao": (ao, bent), "transfer": (ao, bent, tr), "sky": (sky, ao, bent)}[output]


@pytest.mark.parametrize("output", ["ao", "transfer", "sky"])
@pytest.mark.parametrize("window", ["default", "split", "one group a window"])
def test_grouped_ao_is_the_launch_per_group_to_the_bit(setup, window, output, monkeypatch):
    scene, p, normals, groups = setup
    backend = pyshadow.visibility.get_backend("csm")
    want = _ao_per_group(backend, scene, p, normals, groups, output)
    if window == "split":           # windows of 64 points: the 300 near the origin and larger groups split
        monkeypatch.setattr(launch, "_overrides", [{"ao_chunk_samples": 64 * SAMPLES}])
    elif window == "one group a window":
        monkeypatch.setattr(grouped, "WINDOW_TABLE_BYTES", 1)
    sampling = pyshadow.Sampling(SAMPLES)
    if output == "ao":
        got = backend.ambient_occlusion(scene, p, normals, sampling=sampling, return_bent_normals=True)
    elif output == "transfer":
        got = backend.sh_transfer(scene, p, normals, sampling=sampling)
    else:
        got = backend.sampled_sky(scene, p, normals, ENV, sampling=sampling)
    ao = got[1] if output == "sky" else got[0]
    assert 0.05 < (ao < 1).mean() < 0.95            # the tiny boxes and the body occlude some points
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g, w)


@pytest.mark.parametrize("case", ["default", "split", "one group a window", "float-only device", "float32 rows",
                                  "vote lookup", "surface normals", "finite rays"])
def test_grouped_visible_is_the_launch_per_group_to_the_bit(setup, case, monkeypatch):
    scene, p, normals, groups = setup
    backend = pyshadow.visibility.get_backend("csm-vote" if case == "vote lookup" else "csm")
    d = pyshadow.sample_directions(normals, sampling=pyshadow.Sampling(4)).reshape(-1, 3)
    P = np.repeat(p, 4, axis=0)
    m = np.repeat(normals, 4, axis=0).astype(np.float32) if case == "surface normals" else None
    tm = np.random.default_rng(1).uniform(1e-4, 4e-3, len(P)).astype(np.float32) if case == "finite rays" else None
    if case == "float32 rows":
        P, d = P.astype(np.float32), d.astype(np.float32)
    if case == "float-only device":
        monkeypatch.setattr(csm_backend._cl, "has_fp64", lambda: False)
    own = scene.caster_slots(None, len(P), P)
    ref = np.zeros(len(P), bool)
    for rows, anchor in anchor_groups(scene, P.astype(np.float64)):
        ref[rows] = backend._visible_kernel(scene, P[rows], d[rows], own[rows], None if m is None else m[rows], None,
                                            None if tm is None else tm[rows], False, anchor)
    if case == "split":             # windows of 2 batches: groups split over several
        monkeypatch.setattr(launch, "_overrides", [{"query_chunk": 2 * launch.shape().query_batch}])
    elif case == "one group a window":
        monkeypatch.setattr(grouped, "WINDOW_TABLE_BYTES", 1)
    got = backend._visible_kernel(scene, P, d, own, m, None, tm, False)         # (no contact rule, no reordering)
    assert 0.02 < (~got).mean() < 0.9
    np.testing.assert_array_equal(got, ref)


def test_a_refused_launch_waits_for_the_launches_before_it(setup, monkeypatch):
    """The rows of a window are host memory the kernels read in place: where a launch after the first is
    refused, the call waits for those already enqueued before it raises (and the rows are freed)."""
    scene, p, normals, _ = setup
    backend = pyshadow.visibility.get_backend("csm")
    d = pyshadow.sample_directions(normals, sampling=pyshadow.Sampling(4)).reshape(-1, 3)
    P = np.repeat(p, 4, axis=0)
    own = scene.caster_slots(None, len(P), P)
    real_kernel, real_queue = csm_backend._cl.kernel, _cl.queue
    events = []

    class Refusing:                 # the kernel: its third launch refused
        def __init__(self, k):
            self.k = k

        def __getattr__(self, name):
            return getattr(self.k, name)

        def __call__(self, queue, *args, **kw):
            events.append("launch")
            if events.count("launch") == 3:
                raise RuntimeError("refused")
            return self.k(queue.q, *args, **kw)

    class Queue:                    # the queue: its waits noted
        def __init__(self, q):
            self.q = q

        def finish(self):
            events.append("finish")
            return self.q.finish()

    monkeypatch.setattr(csm_backend._cl, "kernel", lambda *a, **k: Refusing(real_kernel(*a, **k)))
    monkeypatch.setattr(grouped._cl, "queue", lambda: Queue(real_queue()))
    with pytest.raises(RuntimeError, match="refused"):
        backend._visible_kernel(scene, P, d, own, None, None, None, False)
    assert events == ["launch", "launch", "launch", "finish"]
