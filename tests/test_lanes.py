"""Answers are bit-identical at every lane width the device runs.

For each bundled mesh, at each width the device passed the probe at (also
with ``PYSHADOW_LANES`` set: the probe checks the forced width): layered
depth maps, CSM segment lists (zigzag 16-bit and hilbert 32-bit), and
visibility (one-texel and vote lookups) and AO with bent normals in a
scene of both CSMs on a ground plane. Small sizes: the kernels' lane code is
the same at any size.
"""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import _cl
from pyshadow.raster import render_depth

from conftest import load


def widths():
    return _cl.lane_choice()["supported"]


def answers(mesh):
    """Everything the lane kernels compute for ``mesh``, as host arrays."""
    out = {}
    depth, front = render_depth(mesh, pyshadow.ViewSet.zigzag(4, 8), resolution=32, layers=3,
                                facing=True)
    out["depth"], out["front"] = depth, front
    zz = pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(8, 16), resolution=32,
                                          depth_bits=16, progress=False)
    hb = pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.hilbert(2), resolution=32,
                                          depth_bits=32, progress=False)
    for tag, c in (("zigzag16", zz), ("hilbert32", hb)):
        out[f"{tag}.offsets"], out[f"{tag}.iend"], out[f"{tag}.depth"] = c.offsets, c.iend, c.depth
    scene = pyshadow.Scene(ground=float(mesh.bounds[0, 1]))
    scene.add(zz, mesh=mesh)
    T = trimesh.transformations.translation_matrix([1.3 * float(np.ptp(mesh.bounds[:, 0])), 0, 0])
    scene.add(hb, T, mesh=mesh)
    rng = np.random.default_rng(7)
    pts, nrm = scene.vertex_points(0)
    pick = rng.choice(len(pts), min(len(pts), 600), replace=False)
    p = np.repeat(pts[pick], 8, axis=0)
    d = pyshadow.sample_directions(nrm[pick], sampling=pyshadow.Sampling(8, seed=3))
    d = d.reshape(-1, 3).astype(np.float64)
    for tag, ids in (("own", 0), ("unknown", None)):
        out[f"visible.{tag}"] = scene.visible(p, d, surface_ids=ids)
        out[f"visible.{tag}.vote"] = scene.visible(p, d, surface_ids=ids, lookup="vote")
    out["visible.float32"] = scene.visible(p.astype(np.float32), d.astype(np.float32), surface_ids=0)
    for lookup in ("nearest", "vote"):
        ao, bent = scene.ambient_occlusion(pts[pick], nrm[pick], sampling=pyshadow.Sampling(36), surface_ids=0,
                                           return_bent_normals=True, lookup=lookup)
        out[f"ao.{lookup}"], out[f"bent.{lookup}"] = ao, bent
    return out


@pytest.mark.parametrize("name", pyshadow.data.MESHES)
def test_answers_are_bit_identical_across_lane_widths(name):
    ws = widths()
    if len(ws) < 2:
        pytest.skip(f"the device runs only {ws} lanes")
    mesh = load(name)
    per = {}
    for w in ws:
        with _cl.use_lanes(w):
            assert _cl.lanes() == w
            per[w] = answers(mesh)
    ref = per[ws[0]]
    # the answers are not trivial: both shadowed and lit rays, open and closed points
    for k in ("visible.own", "visible.own.vote", "visible.unknown"):
        assert 0.02 < ref[k].mean() < 0.98, (k, ref[k].mean())
    assert 0.05 < ref["ao.nearest"].mean() < 0.98
    assert np.isfinite(ref["depth"]).any() and np.isinf(ref["depth"]).any()
    for w in ws[1:]:
        for k, a in ref.items():
            b = per[w][k]
            assert a.dtype == b.dtype and a.shape == b.shape, (w, k)
            assert np.array_equal(a, b), f"{name}: {k} differs between {ws[0]} and {w} lanes"
