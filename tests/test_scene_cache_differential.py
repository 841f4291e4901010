"""The scene's kept arrays and the CSM cache against an independent computation of the same answer.

A scene changed in place answers as one built afresh (``scene_arrays``, ``Scene.anchor``, ``Scene.scale``
and the queries), and the cache gives back what was stored, shape included.
"""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.cache import CSMCache
from pyshadow.csm import CoherentShadowMap
from pyshadow.scene_arrays import scene_arrays

tt = trimesh.transformations
VIEWS = pyshadow.ViewSet.zigzag(4, 8)


@pytest.fixture(scope="module")
def box():
    mesh = trimesh.creation.box((1.0, 1.0, 1.0))
    return mesh, CoherentShadowMap.build(mesh, VIEWS, resolution=16, progress=False)


def test_a_receiver_mesh_changed_in_place_moves_the_scene_anchor_and_scale_as_a_fresh_scene(box):
    """A receiver's mesh grown in place (``mesh.apply_scale(1000)``, then moved down 500) after a query: its
    bounding sphere was found once and kept with the instance and the scene's arrays, so ``Scene.scale()``
    stayed 0.866 (a fresh scene: 866), ``Scene.anchor()`` stayed (-1.5, 0.25, 0) (fresh: (-1.5, -249.75, 0))
    and Embree's AO, whose ground tolerance follows the scene's scale, differed from a fresh scene's on 5 of
    4,000 ground points. Now the sphere and the arrays follow the changed mesh, bit for bit."""
    mesh, csm = box
    receiver = trimesh.creation.box((1.0, 1.0, 1.0))

    def build():
        scene = pyshadow.Scene(ground=0.0, views=VIEWS, resolution=16)
        scene.add(csm, tt.translation_matrix([0.0, 0.5, 0.0]), mesh=mesh)
        scene.add(receiver, tt.translation_matrix([-3.0, 0.0, 0.0]), casts=False)
        return scene

    rng = np.random.default_rng(0)
    points = rng.uniform([-4.0, 0.01, -4.0], [4.0, 2.0, 4.0], (200, 3))
    directions = rng.normal(size=(200, 3))
    ground = np.c_[rng.uniform(-3.0, 3.0, 200), rng.choice([0.0, 1e-6, 3e-5], 200), rng.uniform(-3.0, 3.0, 200)]
    up = np.tile([0.0, 1.0, 0.0], (200, 1))

    def answers(scene):
        out = {"anchor": scene.anchor(), "scale": np.float64(scene.scale())}
        out.update({k: scene_arrays(scene)[k] for k in ("world_centre", "world_radius")})
        for backend in ("csm", "embree"):
            out["visible " + backend] = scene.visible(points, directions, backend=backend)
            out["ao " + backend] = scene.ambient_occlusion(ground, up, sampling=pyshadow.Sampling(16),
                                                           backend=backend, surface_ids=-2)
        return out

    scene = build()
    assert scene.scale() == pytest.approx(np.sqrt(0.75))
    answers(scene)
    receiver.apply_scale(1000.0)
    receiver.apply_translation([0.0, -500.0, 0.0])
    got, want = answers(scene), answers(build())
    assert got["scale"] == pytest.approx(1000.0 * np.sqrt(0.75))
    assert got["anchor"].tolist() == [-1.5, -249.75, 0.0]
    for name in want:
        assert got[name].tobytes() == want[name].tobytes(), name
    c, r = scene.instances[1].world_sphere()
    assert (c.tolist(), r) == ([-3.0, -500.0, 0.0], pytest.approx(1000.0 * np.sqrt(0.75)))


@pytest.mark.parametrize("value", [np.float64(2.5), 2.5, np.array(2.5)])
def test_cached_array_keeps_the_shape_of_a_zero_dimensional_array(tmp_path, value):
    """``put_array`` of a 0-d array (or a Python float) and ``array`` gave back shape (1,), not (): the
    float32 conversion (``np.ascontiguousarray``) made every 0-d array one-dimensional. Now the array comes
    back with the shape and float32 value it was stored with."""
    cache = CSMCache(tmp_path)
    cache.put_array("ab12", value)
    got = cache.array("ab12")
    assert got.dtype == np.float32 and got.shape == np.shape(value)
    assert got.tolist() == np.asarray(value, np.float32).tolist()
