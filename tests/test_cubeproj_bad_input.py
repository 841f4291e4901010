"""Cube-map backend: messages on bad per-ray distances."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.cubemap import CubeMapAO, CubeMapVisibility


@pytest.fixture(scope="module")
def backend():
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    scene.add(trimesh.creation.box((0.3, 0.3, 0.3)), trimesh.transformations.translation_matrix([0.8, 0.15, 0.7]))
    maps = CubeMapAO(scene, 1.0, resolution=16, estimator=None)
    maps.add_probe([0.0, 1.0, 1.0])
    return scene, CubeMapVisibility(maps, unseen="open")


@pytest.mark.parametrize("dist", [[np.nan, np.nan], [0.5, np.nan], np.full((2, 1), np.nan)])
def test_nan_distances_are_named_as_such(backend, dist):
    """Was: ``ValueError: the cube-map backend takes one max_distance for all rays`` for two NaN distances
    (NaN != NaN) and for 0.5 and NaN, which names the wrong fault; now the same message as one NaN distance."""
    scene, vis = backend
    P = np.array([[0.3, 0.0, 0.6]] * 2)
    W = np.array([[0.0, 1.0, 0.0]] * 2)
    with pytest.raises(ValueError, match=r"max_distance must be a finite distance > 0 \(world units\), got nan"):
        vis.visible(scene, P, W, max_distance=dist)


def test_equal_distances_per_ray_still_work(backend):
    scene, vis = backend
    P = np.array([[0.3, 0.0, 0.6]] * 2)
    W = np.array([[0.0, 1.0, 0.0]] * 2)
    np.testing.assert_array_equal(vis.visible(scene, P, W, max_distance=[0.5, 0.5]), vis.visible(scene, P, W,
                                                                                                   max_distance=0.5))
    with pytest.raises(ValueError, match="one max_distance for all rays"):
        vis.visible(scene, P, W, max_distance=[0.5, 0.6])


def test_a_scene_and_camera_pair_is_refused_by_name(backend):
    """Was: ``CubeMapAO(pyshadow.data.default_scene(), 1.0)`` (a (scene, camera) pair) was accepted and the first
    probe raised ``AttributeError: 'tuple' object has no attribute 'ground'``; CubeProbe raised the same."""
    from pyshadow.cubemap import CubeProbe

    scene, _vis = backend
    pair = (scene, pyshadow.Camera([0.0, 1.0, 3.0], [0.0, 0.0, 0.0]))      # default_scene()'s form
    with pytest.raises(TypeError, match="CubeMapAO: scene must be a pyshadow.Scene, got tuple"):
        CubeMapAO(pair, 1.0, estimator=None)
    with pytest.raises(TypeError, match="CubeProbe: scene must be a pyshadow.Scene, got tuple"):
        CubeProbe(pair, [0.0, 1.0, 0.0], 16)
