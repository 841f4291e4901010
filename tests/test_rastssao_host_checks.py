"""Host-side checks of pyshadow.raster: bad arguments raise before any kernel is built or any buffer written."""
import numpy as np
import pyopencl as cl
import pytest
import trimesh

import pyshadow
from pyshadow import _cl
from pyshadow.raster import DepthRenderer, render_depth


@pytest.fixture(scope="module")
def sphere():
    return trimesh.creation.icosphere(1)


@pytest.mark.parametrize("block, exc", [(0, ValueError), (-3, ValueError), (2.0, TypeError), (True, TypeError)])
def test_render_depth_checks_block_before_building_the_kernel(sphere, no_launch, block, exc):
    """Was: ``block`` was checked only after the mesh was uploaded and the raster kernel built
    (``render_depth(..., block=0)`` compiled raster.cl, then raised), against the docstring's
    "Nothing is launched"."""
    with pytest.raises(exc, match="block"):
        render_depth(sphere, pyshadow.ViewSet.zigzag(2, 2), resolution=4, block=block)


@pytest.mark.parametrize("progress", ["no", "False", 0, None])
def test_render_depth_progress_must_be_true_or_false(sphere, no_launch, progress, capsys):
    """Was: ``progress="no"`` (any truthy non-bool) drew a progress bar and rendered; 0 and None
    silently meant False. Now a TypeError naming progress, before the kernel is built."""
    with pytest.raises(TypeError, match="progress"):
        render_depth(sphere, pyshadow.ViewSet.zigzag(2, 2), resolution=4, progress=progress)
    assert "depth maps" not in capsys.readouterr().err


def test_render_depth_progress_false_and_true_still_render(sphere):
    """Was: (the accepted values) -- True and False give the same maps as before."""
    views = pyshadow.ViewSet.zigzag(2, 2)
    a = render_depth(sphere, views, resolution=6, progress=False)
    b = render_depth(sphere, views, resolution=6, progress=np.bool_(True))
    np.testing.assert_array_equal(a, b)
    assert np.isfinite(a).any()


@pytest.mark.parametrize("front_bytes", [None, 15])
def test_render_leaves_the_callers_buffer_alone_when_front_is_missing(sphere, front_bytes):
    """Was: ``DepthRenderer(facing=True).render(bases, out)`` without a (big enough) front buffer
    first filled the caller's ``out`` with +inf (all 16 texels of a 7.0-filled buffer became inf),
    then raised."""
    r = DepthRenderer(sphere, 4, 1, facing=True)
    q = _cl.queue()
    out = _cl.empty(4 * 16)
    cl.enqueue_fill_buffer(q, out, np.float32(7.0), 0, 64)
    front = None if front_bytes is None else _cl.empty(front_bytes)
    with pytest.raises(ValueError, match="front buffer of 16 bytes"):
        r.render(np.eye(3)[None], out, front)
    got = np.empty(16, np.float32)
    cl.enqueue_copy(q, got, out)
    q.finish()
    np.testing.assert_array_equal(got, 7.0)


def test_render_with_a_front_buffer_still_renders(sphere):
    """Was: (the accepted call) -- with both buffers the maps and flags come back as from render_depth."""
    r = DepthRenderer(sphere, 4, 1, facing=True)
    q = _cl.queue()
    out, front = _cl.empty(4 * 16), _cl.empty(16)
    r.render(np.eye(3)[None], out, front)
    d = np.empty((1, 1, 4, 4), np.float32)
    f = np.empty((1, 1, 4, 4), np.uint8)
    cl.enqueue_copy(q, d, out)
    cl.enqueue_copy(q, f, front)
    q.finish()
    views = pyshadow.ViewSet(np.array([[0.0, 0.0, 1.0]]), np.eye(3)[None])
    ref, ref_front = render_depth(sphere, views, resolution=4, layers=1, facing=True)
    np.testing.assert_array_equal(d, ref)
    np.testing.assert_array_equal(f.view(bool), ref_front)
    assert np.isfinite(d).any()
