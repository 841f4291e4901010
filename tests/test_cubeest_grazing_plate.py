"""The cube-map march on a flat caster seen at a grazing angle from the probe (``pyshadow.cubemap.estimators``).
Reference: Embree on the identical rays, the same ``max_distance``."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.cubemap import CubeProbe, raymarch_visible


def _plate_scene():
    """A caster plate 80 x 0.2 x 80 (top at y = 0) with 30 boxes of 0.5 on it, no ground plane."""
    scene = pyshadow.Scene(ground=None, views=pyshadow.ViewSet.zigzag(8, 16), resolution=32)
    plate = trimesh.creation.box((80.0, 0.2, 80.0))
    plate.apply_translation([0.0, -0.1, 0.0])
    scene.add(plate)
    box = trimesh.creation.box((0.5, 0.5, 0.5))
    rng = np.random.default_rng(0)
    for _ in range(30):
        scene.add(box, trimesh.transformations.translation_matrix([rng.uniform(-25, 25), 0.25, rng.uniform(-25, 25)]))
    return scene


@pytest.mark.parametrize("device", [True, False])
def test_rays_along_a_plate_far_from_the_probe_are_not_occluded_by_it(device):
    """Was: 13-17 % of rays leaving the plate along it (elevation 0, 1e-3, 0.05 rad) 8-15 from a probe 1
    above it read occluded (390-497 of 3,000 each, device and NumPy alike), against none 0.5-8 away: the
    march read its own texel's centre depth where the plate is grazing from the probe (|n.u| < 0.1), and a
    point in front of the plate off the texel's centre lay behind that depth. Now within 1 % falsely
    occluded, as near the probe."""
    scene = _plate_scene()
    probe = CubeProbe(scene, [0.0, 1.0, 0.0], 64)
    rng = np.random.default_rng(0)
    r, a = rng.uniform(8, 15, 1500), rng.uniform(0, 2 * np.pi, 1500)
    p = np.stack([r * np.cos(a), np.zeros(1500), r * np.sin(a)], axis=1)
    for el in (0.0, 1e-3, 0.05):
        b = rng.uniform(0, 2 * np.pi, 1500)
        w = np.stack([np.cos(b) * np.cos(el), np.full(1500, np.sin(el)), np.sin(b) * np.cos(el)], axis=1)
        ref = pyshadow.embree.visible(scene, p, w, max_distance=1.0)
        got = raymarch_visible(probe, p, w, 1.0, device=device)
        assert ref.mean() > 0.9
        assert (ref & ~got).sum() <= 15, el
