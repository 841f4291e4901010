"""Casters of equal geometry made apart share one CSM; Scene.transform of several ids."""
import numpy as np
import pytest
import trimesh

import pyshadow


def _scene():
    return pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)


def test_equal_meshes_made_apart_share_one_csm(monkeypatch):
    """Was: Scene.add built one CSM per mesh object: twenty trimesh.creation.box() made in a loop built twenty
    CSMs (7 s each at the default options) of the same bytes, and held twenty on the device. Now one build;
    the AO is the same bit for bit as twenty builds (a build is deterministic) or one object added twenty times."""
    builds = []
    real = pyshadow.CoherentShadowMap.build
    monkeypatch.setattr(pyshadow.CoherentShadowMap, "build",
                        classmethod(lambda cls, *a, **k: builds.append(1) or real(*a, **k)))
    xz = [(2.0 * i, 0.0) for i in range(5)]
    shared, single = _scene(), _scene()
    for x, z in xz:
        shared.add(trimesh.creation.box((1.0, 1.0, 1.0)), trimesh.transformations.translation_matrix([x, 0.5, z]))
    assert len(builds) == 1
    assert len({id(inst.csm) for inst in shared.instances}) == 1
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    single.add(box, np.stack([trimesh.transformations.translation_matrix([x, 0.5, z]) for x, z in xz]))
    rng = np.random.default_rng(0)
    p = np.c_[rng.uniform(-1, 9, 400), np.zeros(400), rng.uniform(-2, 2, 400)]
    up = np.tile([0.0, 1.0, 0.0], (400, 1))
    s = pyshadow.Sampling(16)
    np.testing.assert_array_equal(shared.ambient_occlusion(p, up, sampling=s),
                                  single.ambient_occlusion(p, up, sampling=s))


def test_other_geometry_or_an_edited_mesh_gets_its_own_csm():
    """A mesh of other vertices (or the same object edited in place since) is not given the first one's CSM."""
    scene = _scene()
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    scene.add(box)
    scene.add(trimesh.creation.box((1.0, 2.0, 1.0)))
    box.vertices = box.vertices * 0.5
    scene.add(box)
    csms = [inst.csm for inst in scene.instances]
    assert len({id(c) for c in csms}) == 3
    assert csms[0].mesh_hash != csms[2].mesh_hash == pyshadow.mesh.mesh_hash(box)


def test_transform_of_several_ids():
    """Was: scene.transform(ids) raised 'IndexError: no instance array([0, 1, 2])' although set_transform takes
    arrays of ids; now (k, 4, 4) copies, in the order asked."""
    scene = _scene()
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    T = np.stack([trimesh.transformations.translation_matrix([2.0 * i, 0.5, 0.0]) for i in range(3)])
    ids = scene.add(box, T)
    got = scene.transform(np.array([2, 0]))
    np.testing.assert_array_equal(got, T[[2, 0]])
    got[0, 0, 3] = 99.0
    np.testing.assert_array_equal(scene.transform(2), T[2])
    assert scene.transform([]).shape == (0, 4, 4)
    np.testing.assert_array_equal(scene.transform(list(ids)), T)
    with pytest.raises((IndexError, ValueError)):
        scene.transform([0, 5])
