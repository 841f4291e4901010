"""A ShadowMapVisibility that has answered queries still pickles and copies (Dask sends task arguments
pickled): its kept maps and the meshes' device buffers are left behind, and the copy answers as the original."""
import copy
import pickle

import numpy as np
import trimesh

import pyshadow
from pyshadow.lighting.shadow_map import ShadowMapVisibility


def test_used_shadow_map_backend_pickles_and_copies_with_the_same_answers():
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    scene.add(box, trimesh.transformations.translation_matrix([0.0, 0.5, 0.0]))
    rng = np.random.default_rng(3)
    p = np.c_[rng.uniform(-2, 2, 400), np.zeros(400), rng.uniform(-2, 2, 400)]
    d = np.tile(np.array([-0.6, 0.64, -0.48]) / np.linalg.norm([-0.6, 0.64, -0.48]), (400, 1))
    sm = ShadowMapVisibility(resolution=256)
    before = sm.visible(scene, p, d)
    assert sm._maps and len(sm._meshes)             # it keeps a map and a mesh's buffer (what did not pickle)
    assert 0 < before.mean() < 1                    # some points in the box's shadow, some not
    for clone in (pickle.loads(pickle.dumps(sm)), copy.deepcopy(sm)):
        assert (clone.resolution, clone.pcf, clone.bias, clone.bias_texels) == (sm.resolution, sm.pcf, sm.bias,
                                                                                sm.bias_texels)
        assert not clone._maps and not len(clone._meshes)
        np.testing.assert_array_equal(clone.visible(scene, p, d), before)
    np.testing.assert_array_equal(sm.visible(scene, p, d), before)   # the original keeps its maps
