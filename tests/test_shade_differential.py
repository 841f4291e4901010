"""Shading against independent computations: the sun's visible fraction against Embree on the back of a
sphere, the "transfer" term's host sums in chunks against one pass, and lights copied or given as
tuples against the originals (pyshadow.lighting.shade, .transfer, ._value)."""
import copy
import importlib
import pickle

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import Sampling
from pyshadow.lighting import DirectionalLight, Lighting, PointLight, shade_terms
from pyshadow.lighting.sun import SunLight

shade_mod = importlib.import_module("pyshadow.lighting.shade")
transfer_mod = importlib.import_module("pyshadow.lighting.transfer")


def sphere_scene():
    """A unit icosphere of 320 faces, its face centres and normals; 4 x 8 maps at 16^2."""
    scene = pyshadow.Scene(ground=None, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    sph = trimesh.creation.icosphere(2, 1.0)
    scene.add(sph)
    return scene, sph.triangles_center, sph.face_normals


@pytest.mark.parametrize("radius, k", [(0.0, 1), (0.1, 8)])
@pytest.mark.parametrize("backend", ["csm", "numpy"])
def test_sun_behind_the_face_is_not_visible_as_embree_says(radius, k, backend):
    """The sun's visible fraction on the back of a sphere is 0 (Embree, the ground truth, on every point).

    Before, the CSM backends (kernel and NumPy mirror alike) reported the sun as reaching 3 (hard sun)
    and 9 (a 0.1 rad disc, 8 rays) of the 130 faces turned more than 11.5 degrees away from it -- their
    rays pass into the sphere and the self-bias let them out -- and 35 / 140 of 2042 on a finer sphere
    and CSM: a speckled shadow mask on the dark side. The radiance was already 0 there (n . l <= 0); it
    stays bit for bit what it was everywhere, and the fraction on the lit side is unchanged."""
    scene, p, nrm = sphere_scene()
    d = np.array([0.2, 0.9, -0.3])
    d /= np.linalg.norm(d)
    light = Lighting(sun=DirectionalLight(d, [1.0, 1.0, 1.0], radius), albedo=1.0, sun_samples=k)
    got = shade_terms(scene, p, nrm, light, backend=backend, surface_ids=0, sampling=Sampling(1))
    ref = shade_terms(scene, p, nrm, light, backend="embree", surface_ids=0, sampling=Sampling(1))
    cos = nrm @ d
    back = cos < -0.2
    assert back.sum() == 130
    assert (got.sun_visibility[back] == 0).all() and (ref.sun_visibility[back] == 0).all()
    assert (got.sun[cos <= -np.sin(radius)] == 0).all()
    # the sun's own disc directions: a fraction counts only those above the face's plane
    dirs = shade_mod.sun_directions(light.sun, k, np.arange(len(p)), 0)
    above = (np.einsum("nkj,nj->nk", dirs, nrm) > 0).mean(axis=1)
    assert (got.sun_visibility <= above + 1e-7).all()
    lit = cos > 0.3                 # clear of the terminator, on a lone sphere: every sun ray reaches the sky
    assert lit.sum() > 100
    assert (got.sun_visibility[lit] == 1).all() and (ref.sun_visibility[lit] == 1).all()
    want = np.einsum("nkj,nj->nk", dirs, nrm).clip(0).mean(axis=1) / np.pi
    np.testing.assert_allclose(got.sun[lit, 0], want[lit], rtol=1e-6, atol=0)


@pytest.mark.parametrize("backend, geometric", [("numpy", False), ("embree", False), ("csm", True)])
def test_transfer_host_sums_go_in_chunks_of_rays_and_equal_one_pass(monkeypatch, backend, geometric):
    """sh_transfer's host route (any backend without the kernel's sums, or shading normals) asks
    ``visible`` in chunks of at most SAMPLED_CHUNK_RAYS rays, as the "sampled" sky does, and its answers
    equal those of one pass bit for bit.

    Before, it traced every point's S directions at once and kept (N, S, 9) float64 basis values, 190
    bytes a ray: 1.3 GB more for 100,000 points at 64 samples on Embree (the "sampled" sky 0.3 GB), so a
    1080p frame at 64 samples in mode "transfer" with smooth normals (which takes this route on the
    CSM too) needed some 25 GB; here the 1,200 rays (1,150 above the geometric planes) went in one call."""
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)))
    rng = np.random.default_rng(3)
    p = np.column_stack([rng.uniform(0.7, 3, 75) * rng.choice([-1, 1], 75), np.zeros(75), rng.uniform(-3, 3, 75)])
    g = np.tile([0.0, 1.0, 0.0], (75, 1))
    n = g + rng.normal(size=(75, 3)) * 0.3
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    ids = rng.choice([-2, -1, 0], 75)
    kw = dict(backend=backend, sampling=Sampling(16), surface_ids=ids, indices=np.arange(75) * 3,
              geometric_normals=g if geometric else None)
    one = transfer_mod.sh_transfer(scene, p, n, **kw)
    calls = []
    visible = pyshadow.visibility.visible

    def counted(scene, points, directions, **k):
        calls.append(len(points))
        return visible(scene, points, directions, **k)

    monkeypatch.setattr(pyshadow.visibility, "visible", counted)
    monkeypatch.setattr(shade_mod, "SAMPLED_CHUNK_RAYS", 100)
    chunked = transfer_mod.sh_transfer(scene, p, n, **kw)
    assert calls and max(calls) <= 100 and sum(calls) <= 75 * 16
    for a, b in zip(one, chunked):
        assert a.dtype == b.dtype == np.float32
        np.testing.assert_array_equal(a, b)
    assert (one[0] < 1).sum() > 20                  # the box occludes: the chunks carry real visibility


@pytest.mark.parametrize("how", ["deepcopy", "pickle"])
@pytest.mark.parametrize("make", [lambda: DirectionalLight([0.0, 1.0, 0.0], [1.0, 2.0, 3.0], 0.1),
                                  lambda: PointLight([0.0, 2.0, 0.0], [1.0, 1.0, 1.0], 0.2)])
def test_copied_lights_keep_read_only_fields(how, make):
    """A light from copy.deepcopy or pickle (multiprocessing, joblib) keeps its arrays read-only, and
    equals and hashes as the original.

    Before, both set the fields without __post_init__: the copy's arrays were writeable, so
    ``light.direction[0] = nan`` made a light the constructor refuses, and the light was no longer found
    in the set that held it (its hash changed)."""
    light = make()
    c = copy.deepcopy(light) if how == "deepcopy" else pickle.loads(pickle.dumps(light))
    assert c == light and hash(c) == hash(light) and len({c, light}) == 1
    for name in ("direction", "irradiance", "position", "intensity"):
        a = getattr(c, name, None)
        if a is not None:
            assert not a.flags.writeable
            with pytest.raises(ValueError, match="read-only"):
                a[0] = np.nan
            np.testing.assert_array_equal(a, getattr(light, name))
    assert c in {light}


def test_sun_light_from_tuples_equals_and_hashes_as_from_arrays():
    """A SunLight written with tuples or lists equals the one of arrays and hashes alike; its fields
    are read-only arrays.

    Before, the tuples were kept as given: the two lights compared equal but hashed apart (a set of
    both held 2), and with lists ``hash`` raised "unhashable type: 'list'"."""
    arrays = SunLight(np.array([0.0, 1.0, 0.0]), np.array([1.0, 2.0, 3.0]), 0.01, np.array([3, 4]),
                      np.array([[1.0, 1.0, 1.0], [2.0, 2.0, 2.0]]))
    tuples = SunLight((0.0, 1.0, 0.0), (1.0, 2.0, 3.0), 0.01, (3, 4), ((1.0, 1.0, 1.0), (2.0, 2.0, 2.0)))
    lists = SunLight([0.0, 1.0, 0.0], [1.0, 2.0, 3.0], 0.01, [3, 4], [[1.0, 1.0, 1.0], [2.0, 2.0, 2.0]])
    assert tuples == arrays == lists
    assert hash(tuples) == hash(arrays) and len({tuples, arrays}) == 1
    assert hash(lists) == hash(arrays) and len({tuples, arrays, lists}) == 1
    for light in (tuples, lists):
        assert isinstance(light.texels, np.ndarray) and light.texels.tolist() == [3, 4]
        assert not light.excess.flags.writeable
        np.testing.assert_array_equal(light.texel_radiance((2, 4)).reshape(-1, 3)[[3, 4]], arrays.excess)
    assert DirectionalLight.of(tuples) == DirectionalLight.of(arrays)
    with pytest.raises(ValueError, match=r"excess: expected an array"):
        SunLight((0.0, 1.0, 0.0), (1.0, 2.0, 3.0), 0.01, (3, 4), ((1.0, 1.0, 1.0), (2.0, 2.0)))
