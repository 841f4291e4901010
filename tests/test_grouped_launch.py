"""Points in several anchor groups: one upload a window, a launch per group (pyshadow.visibility.grouped).

The answers must be those of the launch per group that the grouped path replaced, to the bit: the AO
kernel's ``_ao_launch`` over each group's rows alone, and ``_visible_kernel`` with each group's anchor.
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


def _ao_per_group(backend, scene, p, normals, groups):
    """AO and bent normals by one ``_ao_launch`` per group (the path before the grouped one)."""
    sampling = pyshadow.Sampling(SAMPLES)
    defines = backend.query_defines(scene, "scene_ao", SAMPLES=SAMPLES, BENT_NORMALS=1, TRANSFER=0,
                                    SURFACE_NORMALS=1)
    k = _cl.kernel("visibility.cl", "scene_ao", defines)
    table = _cl.to_device(launch.lane_table(direction_table(SAMPLES, sampling.strategy, sampling.patterns,
                                                            sampling.seed)))
    n = normals.astype(np.float32)
    pidx = pattern_indices(np.arange(len(p)), sampling.patterns, sampling.seed)
    own = scene.caster_slots(None, len(p), p)
    ao, bent = np.full(len(p), np.nan, np.float32), np.full((len(p), 3), np.nan, np.float32)
    for rows, anchor in groups:
        outs = (np.empty(len(rows), np.float32), np.empty((len(rows), 3), np.float32), None, None)
        backend._ao_launch(scene, k, defines, table, anchor, None, p[rows], n[rows], pidx[rows], own[rows], None,
                           None, outs, True, False, None)
        ao[rows], bent[rows] = outs[0], outs[1]
    close_contacts(scene, p, n, ao, bent)      # (the tiny boxes rest on the ground: their footprints' points)
    return ao, bent


@pytest.mark.parametrize("window", ["default", "split", "one group a window"])
def test_grouped_ao_is_the_launch_per_group_to_the_bit(setup, window, monkeypatch):
    scene, p, normals, groups = setup
    backend = pyshadow.visibility.get_backend("csm")
    ref_ao, ref_bent = _ao_per_group(backend, scene, p, normals, groups)
    if window == "split":           # windows of 64 points: the 300 near the origin and larger groups split
        monkeypatch.setattr(launch, "_overrides", [{"ao_chunk_samples": 64 * SAMPLES}])
    elif window == "one group a window":
        monkeypatch.setattr(grouped, "WINDOW_TABLE_BYTES", 1)
    ao, bent = backend.ambient_occlusion(scene, p, normals, sampling=pyshadow.Sampling(SAMPLES),
                                         return_bent_normals=True)
    assert 0.05 < (ao < 1).mean() < 0.95            # the tiny boxes and the body occlude some points
    np.testing.assert_array_equal(ao, ref_ao)
    np.testing.assert_array_equal(bent, ref_bent)


@pytest.mark.parametrize("case", ["default", "split", "one group a window", "float-only device", "float32 rows"])
def test_grouped_visible_is_the_launch_per_group_to_the_bit(setup, case, monkeypatch):
    scene, p, normals, groups = setup
    backend = pyshadow.visibility.get_backend("csm")
    d = pyshadow.sample_directions(normals, sampling=pyshadow.Sampling(4)).reshape(-1, 3)
    P = np.repeat(p, 4, axis=0)
    if case == "float32 rows":
        P, d = P.astype(np.float32), d.astype(np.float32)
    if case == "float-only device":
        monkeypatch.setattr(csm_backend._cl, "has_fp64", lambda: False)
    own = scene.caster_slots(None, len(P), P)
    ref = np.zeros(len(P), bool)
    for rows, anchor in anchor_groups(scene, P.astype(np.float64)):
        ref[rows] = backend._visible_kernel(scene, P[rows], d[rows], own[rows], None, None, None, False, anchor)
    if case == "split":             # windows of 2 batches: groups split over several
        monkeypatch.setattr(launch, "_overrides", [{"query_chunk": 2 * launch.shape().query_batch}])
    elif case == "one group a window":
        monkeypatch.setattr(grouped, "WINDOW_TABLE_BYTES", 1)
    got = backend._visible_kernel(scene, P, d, own, None, None, None, False)    # (no contact rule, no reordering)
    assert 0.02 < (~got).mean() < 0.9
    np.testing.assert_array_equal(got, ref)
