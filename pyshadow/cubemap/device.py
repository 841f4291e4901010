"""The ``"raymarch"`` estimator on the OpenCL device (``kernels/cubemap.cl``)."""
from __future__ import annotations

import weakref

import numpy as np
import pyopencl as cl

from .. import _cl
from .probe import _FRAMES

__all__ = ["raymarch_device", "probe_buffers"]

_BUFFERS: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()

#: Rays per launch (bounds the host and device memory of one call).
CHUNK = 1 << 20


def probe_buffers(probe):
    """Device copies of a probe's texel planes, depths, occluder flags and face frames (cached per probe and
    OpenCL context)."""
    ctx = id(_cl.context())
    held = _BUFFERS.get(probe)
    # per context: buffers of another context (pyshadow._cl.use_device) are not the kernel's to read
    if held is None or held[0] != ctx:
        n = probe.normal.reshape(-1, 3).astype(np.float64)
        h = np.einsum("ij,ij->i", n, np.nan_to_num(probe.texel_offsets()))
        plane = np.concatenate([n, h[:, None]], axis=1).astype(np.float32)
        bufs = (_cl.to_device(plane, np.float32), _cl.to_device(probe.depth.reshape(-1), np.float32),
                _cl.to_device(probe.occluder.reshape(-1), np.uint8), _cl.to_device(_FRAMES, np.float32))
        held = _BUFFERS[probe] = (ctx, bufs)
    return held[1]


def raymarch_device(probe, points, directions, opt) -> np.ndarray:
    """March validated rays (world ``points``, unit ``directions``, (N, 3) float64) with options ``opt``
    (:func:`pyshadow.cubemap.estimators.march_defaults`); (N,) bool, True = unoccluded."""
    q = _cl.queue()
    k = _cl.kernel("cubemap.cl", "cubemap_march")
    plane, depth, occ, frames = probe_buffers(probe)
    out = np.empty(len(points), np.uint8)
    for s in range(0, len(points), CHUNK):
        o = np.ascontiguousarray(points[s:s + CHUNK] - probe.centre, dtype=np.float32)
        w = np.ascontiguousarray(directions[s:s + CHUNK], dtype=np.float32)
        n = len(o)
        vbuf = _cl.empty(n)
        k(q, (n,), None, plane, depth, occ, frames, _cl.to_device(o), _cl.to_device(w), np.int32(n),
          np.int32(probe.resolution), np.float32(opt["max_distance"]), np.float32(opt["step"]),
          np.float32(opt["bias"]), np.float32(opt["thickness"]), np.int32(opt["max_steps"]), vbuf)
        cl.enqueue_copy(q, out[s:s + n], vbuf)
    return out.astype(bool)
