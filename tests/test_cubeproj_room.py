"""A probe inside a closed room whose faces look inwards (``trimesh.Trimesh.invert``), against the room's
distances in closed form: every texel, seams and cube corners included, at odd and even resolutions, far
from the origin and at small and large scales."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.cubemap import CubeProbe

LO, HI = np.array([-1.0, -1.5, -2.0]), np.array([1.3, 1.1, 0.7])     # the room's corners around the probe


def room_scene(shift: float, scale: float, invert: bool = True):
    room = trimesh.creation.box(bounds=[LO * scale, HI * scale])
    if invert:
        room.invert()
    room.apply_translation(np.full(3, shift))
    scene = pyshadow.Scene(ground=None, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    scene.add(room)
    return scene


def closed_form_depth(R: int, scale: float) -> np.ndarray:
    """Distance from the room's origin to its walls along each texel's centre ray (6 R R,), float64; face
    frames written out here (right = forward x up)."""
    fwd = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    up = np.array([[0, 1, 0], [0, 1, 0], [0, 0, -1], [0, 0, 1], [0, 1, 0], [0, 1, 0]], float)
    rows, cols = np.mgrid[0:R, 0:R]
    x, y = 2 * (cols + 0.5) / R - 1, 1 - 2 * (rows + 0.5) / R
    d = np.concatenate([(f + x[..., None] * np.cross(f, u) + y[..., None] * u).reshape(-1, 3)
                        for f, u in zip(fwd, up)])
    with np.errstate(divide="ignore"):
        t = np.where(d > 0, HI * scale / d, np.where(d < 0, LO * scale / d, np.inf))
    return t.min(axis=1) * np.linalg.norm(d, axis=1)


@pytest.mark.parametrize("shift, scale, R", [(0.0, 1.0, 16), (0.0, 1e-3, 17), (1e5, 1.0, 33), (1e4, 1e3, 16)])
def test_probe_inside_an_inverted_room_sees_its_walls(shift, scale, R):
    """Was: ``ValueError: CubeProbe: centre ... lies inside instance 0 (100% of its texels see back faces of
    closed meshes)`` for every probe in the room: the back-face test read trimesh's cached ``face_normals``,
    which ``invert()`` leaves pointing out of the box while it turns the faces' winding in."""
    probe = CubeProbe(room_scene(shift, scale), np.full(3, shift), R)
    ref = closed_form_depth(R, scale)
    np.testing.assert_allclose(probe.depth.reshape(-1), ref, rtol=1e-6)
    assert (probe.object_id == 0).all()


def test_probe_inside_a_room_facing_out_is_still_refused():
    """The same room with its faces looking out (a closed body around the probe) is refused, as before."""
    with pytest.raises(ValueError, match="lies inside instance 0"):
        CubeProbe(room_scene(0.0, 1.0, invert=False), np.zeros(3), 16)
