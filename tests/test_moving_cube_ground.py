"""Cube-map probes follow a change of the scene's ground height (``scene.ground = h``) as they follow moves.

A probe draws the ground plane into its maps; it recorded the transforms but not the ground, so after
``scene.ground = h`` it was not stale and its users answered from the old plane without a word.
"""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.cubemap import CubeMapAO, CubeMapVisibility

VIEWS = pyshadow.ViewSet.zigzag(8, 16)
CENTRE = [0.0, 1.5, 2.0]


@pytest.fixture(scope="module")
def box():
    mesh = trimesh.creation.box((1.0, 1.0, 1.0))
    return mesh, pyshadow.CoherentShadowMap.build(mesh, VIEWS, resolution=32, progress=False)


def _scene(box, ground):
    mesh, csm = box
    scene = pyshadow.Scene(ground=ground, views=VIEWS, resolution=32)
    scene.add(csm, trimesh.transformations.translation_matrix([0.8, 0.5, 0.0]), mesh=mesh)
    return scene


def _rays():
    rng = np.random.default_rng(0)
    p = np.c_[rng.uniform(-2, 2, 200), np.full(200, 0.3), rng.uniform(0.5, 3.5, 200)]
    return p, np.abs(rng.normal(size=(200, 3))) * [1.0, 1.0, -1.0]


def test_a_ground_height_set_after_the_render_makes_the_probe_stale_and_refresh_draws_the_new_plane(box):
    """Was: after ``scene.ground = 0.3`` the probe rendered with the ground at 0 was not stale (no warning,
    no error): 647 of its 1536 depths and 23 of these 200 marched rays answered from the old plane."""
    scene = _scene(box, 0.0)
    maps = CubeMapAO(scene, 2.0, resolution=16, estimator=None)
    maps.add_probe(CENTRE)
    backend = CubeMapVisibility(maps, unseen="open")
    p, d = _rays()
    before = scene.visible(p, d, backend=backend)
    scene.ground = 0.3
    assert maps.probes[0].stale and maps.stale
    with pytest.raises(ValueError, match="stale"):
        scene.visible(p, d, backend=backend)
    assert maps.refresh() == 1 and not maps.stale
    want = CubeMapAO(_scene(box, 0.3), 2.0, resolution=16, estimator=None)
    want.add_probe(CENTRE)
    assert maps.probes[0].depth.tobytes() == want.probes[0].depth.tobytes()
    got = scene.visible(p, d, backend=backend)
    assert got.tobytes() == want.scene.visible(p, d, backend=CubeMapVisibility(want, unseen="open")).tobytes()
    assert (got != before).sum() >= 10                # the plane moved up to the rays' start


def test_the_same_ground_set_again_and_no_ground_then_back(box):
    """Was: only moves and additions made a probe stale. Setting the height it was rendered with is no
    change; removing the plane is one, and setting it back is none again."""
    scene = _scene(box, 0.0)
    probe = pyshadow.cubemap.CubeProbe(scene, CENTRE, 16)
    scene.ground = 0
    assert not probe.stale
    scene.ground = None
    assert probe.stale
    scene.ground = 0.0
    assert not probe.stale
