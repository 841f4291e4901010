"""EmbreeTracer.prepare / occluded against pyshadow.embree.ambient_occlusion: the tracer's rays are those of
ambient_occlusion (its docstring), so its inputs are read as ambient_occlusion reads them."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import embree
from pyshadow.sampling import Sampling, sample_directions

S = 16


@pytest.fixture(scope="module")
def sphere_scene():
    """A sphere (icosphere, radius 1) at the origin beside a unit box; 300 points on the sphere, face normals."""
    scene = pyshadow.Scene(views=pyshadow.ViewSet.zigzag(2, 4), resolution=8)
    mesh = trimesh.creation.icosphere(2)
    scene.add(mesh, np.eye(4))
    T = np.eye(4)
    T[0, 3] = 3.0
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), T)
    p, f = trimesh.sample.sample_surface(mesh, 300, seed=1)
    return scene, np.asarray(p, np.float64), np.asarray(mesh.face_normals[f], np.float64)


def traced_ao(scene, p, n, dirs):
    with embree.EmbreeTracer(scene, 2) as tracer:
        ground, todo, o32, d32 = tracer.prepare(p, n, dirs, S)
        occ = ground.copy()
        occ[todo] = tracer.occluded(o32, d32)
    return (~occ.reshape(len(p), S)).mean(axis=1)


@pytest.mark.parametrize("length", [1e-4, 0.01, 3.0])
def test_prepare_normalises_the_normals_as_ambient_occlusion_does(sphere_scene, length):
    """Was: prepare took the normals as given and lifted each origin by surface_epsilon times the normal's
    length; ambient_occlusion (whose rays the tracer's are, bit for bit) normalises them. With normals of
    length 1e-4 the origins were lifted 1e-4 of the lift, and the sphere's rays met the sphere they leave:
    1,852 of 4,800 rays occluded instead of 58 (those towards the box), the AO of 114 of 300 points wrong
    (0 instead of 1)."""
    scene, p, n = sphere_scene
    sampling = Sampling(S)
    dirs = sample_directions(n, sampling=sampling).reshape(-1, 3)
    with embree.EmbreeTracer(scene, 1) as tracer:
        unit = tracer.prepare(p, n, dirs, S)
        scaled = tracer.prepare(p, length * n, dirs, S)
    for a, b in zip(unit, scaled):
        np.testing.assert_array_equal(a, b)
    expected = embree.ambient_occlusion(scene, p, length * n, sampling=sampling)
    got = traced_ao(scene, p, length * n, dirs)
    np.testing.assert_array_equal(got, expected)
    assert 0.9 < expected.mean() < 1.0          # open but towards the box


def test_prepare_refuses_zero_and_non_finite_normals_and_directions(sphere_scene):
    """Was: a zero normal was accepted (its origin not lifted at all: its rays start on the surface they
    leave), and a NaN direction went to Embree and came back "not occluded"; ambient_occlusion refuses
    both."""
    scene, p, n = sphere_scene
    dirs = sample_directions(n[:2], sampling=Sampling(S)).reshape(-1, 3)
    with embree.EmbreeTracer(scene, 1) as tracer:
        with pytest.raises(ValueError, match="normals: 1 rows are zero"):
            tracer.prepare(p[:2], np.array([n[0], [0.0, 0.0, 0.0]]), dirs, S)
        with pytest.raises(ValueError, match="normals: 1 rows are not finite"):
            tracer.prepare(p[:2], np.array([n[0], [np.nan, 1.0, 0.0]]), dirs, S)
        bad = dirs.copy()
        bad[5] = np.nan
        with pytest.raises(ValueError, match="dirs32: 1 rows are not finite"):
            tracer.prepare(p[:2], n[:2], bad, S)
        bad = dirs.copy()
        bad[7] = 0.0
        with pytest.raises(ValueError, match="dirs32: 1 rows are zero"):
            tracer.prepare(p[:2], n[:2], bad, S)
        with pytest.raises(TypeError, match="dirs32 must be real numbers"):
            tracer.prepare(p[:2], n[:2], dirs.astype(complex), S)
        with pytest.raises(ValueError, match=r"dirs32 must have shape \(32, 3\)"):
            tracer.prepare(p[:2], n[:2], dirs[:-1], S)


def test_occluded_takes_lists_as_embree_scene_does(sphere_scene):
    """Was: EmbreeTracer.occluded given lists raised AttributeError ("'list' object has no attribute
    'dtype'"); it now answers as for the arrays (rays towards and away from the sphere)."""
    scene, _, _ = sphere_scene
    with embree.EmbreeTracer(scene, 2) as tracer:
        o = (np.array([[0.0, 5.0, 0.0], [0.0, 5.0, 0.0]]) - tracer.anchor).tolist()     # over the sphere
        d = [[0.0, -1.0, 0.0], [0.0, 1.0, 0.0]]
        got = tracer.occluded(o, d)
        np.testing.assert_array_equal(got, [True, False])
        np.testing.assert_array_equal(got, tracer.occluded(np.array(o, np.float32), np.array(d, np.float32)))
