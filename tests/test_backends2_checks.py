"""Argument checks of the visibility backends called directly (``visibility.get_backend(name)``): every
registered backend refuses what ``visibility.visible`` / ``ambient_occlusion`` refuse, with the same error,
whatever the scene (also where the CSM backends launch no kernel), and the registry's errors."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import visibility
from pyshadow.visibility.base import _REGISTRY

P = np.array([[2.0, 0.3, 0.0], [0.0, 1.0, 0.0], [3.0, 0.0, 1.0]])
D = np.array([[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
S = pyshadow.Sampling(8)


def _scene(kind):
    """'box': a unit box on the ground; 'ground': the ground alone; 'empty': neither."""
    scene = pyshadow.Scene(ground=None if kind == "empty" else 0.0, views=pyshadow.ViewSet.zigzag(4, 8),
                           resolution=16)
    if kind == "box":
        scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), trimesh.transformations.translation_matrix((0, 0.5, 0)))
    return scene


@pytest.mark.parametrize("name", ["csm", "csm-vote"])
@pytest.mark.parametrize("sampling", [8, 8.0, "8", None])
def test_csm_backend_names_a_sampling_that_is_not_one(name, sampling):
    """Was: get_backend('csm').ambient_occlusion(..., sampling=8) (an int, as the number of samples) raised
    "AttributeError: 'int' object has no attribute 'samples'" (None: "'NoneType' object ..."), and
    sh_transfer likewise; the NumPy and Embree backends raised a TypeError naming sampling. Now the CSM
    backends do too."""
    backend = visibility.get_backend(name)
    scene = _scene("box")
    with pytest.raises(TypeError, match="sampling must be a pyshadow.Sampling"):
        backend.ambient_occlusion(scene, P, D, sampling=sampling)
    with pytest.raises(TypeError, match="sampling must be a pyshadow.Sampling"):
        backend.ambient_occlusion(scene, P, D, sampling=sampling, max_distance=1.0, straddle="embree")
    with pytest.raises(TypeError, match="sampling must be a pyshadow.Sampling"):
        backend.sh_transfer(scene, P, D, sampling=sampling)
    ao = backend.ambient_occlusion(scene, P, D, sampling=S)
    assert ao.shape == (3,) and ao.dtype == np.float32 and ao[1] == 1.0        # the box's lid, facing up


@pytest.mark.parametrize("kind", ["box", "ground", "empty"])
@pytest.mark.parametrize("bias, error", [(-1.0, ValueError), (np.nan, ValueError), ("0.1", TypeError),
                                         (np.array([0.1, 0.2, 0.3]), TypeError), (True, TypeError)])
def test_every_backend_refuses_a_bad_bias_on_any_scene(kind, bias, error):
    """Was: on a scene without casters and ground (no kernel launched) the CSM backends answered
    visible(..., bias=-1 / nan / '0.1' / an array / True) all True and AO all 1, where the NumPy and Embree
    backends (and visibility.visible) raised (with casters or a ground plane the kernel's arguments
    checked it). Now every backend raises, whatever the scene."""
    scene = _scene(kind)
    for name in visibility.backends():
        backend = visibility.get_backend(name)
        with pytest.raises(error, match="bias must"):
            backend.visible(scene, P, D, bias=bias)
        with pytest.raises(error, match="bias must"):
            backend.ambient_occlusion(scene, P, D, sampling=S, bias=bias)
        if hasattr(backend, "sh_transfer"):
            with pytest.raises(error, match="bias must"):
                backend.sh_transfer(scene, P, D, sampling=S, bias=bias)


@pytest.mark.parametrize("kind", ["box", "ground", "empty"])
def test_every_backend_refuses_unused_bad_options(kind):
    """Was: the CSM backends ignored visible(..., straddle='x') without max_distance and
    ambient_occlusion(..., quadrature=0 / 1.5 / 300 / True, straddle='x') without max_distance and
    obscurance (the answers of the default query: [False, True, True] and AO [0.5, 1, 1] on the box scene),
    where the NumPy and Embree backends and visibility.visible / ambient_occlusion raised. Now all raise."""
    scene = _scene(kind)
    for name in visibility.backends():
        backend = visibility.get_backend(name)
        with pytest.raises(ValueError, match="straddle must be one of"):
            backend.visible(scene, P, D, straddle="x")
        with pytest.raises(ValueError, match="straddle must be one of"):
            backend.ambient_occlusion(scene, P, D, sampling=S, straddle="x")
        for q in (0, 1.5, 300, True):
            with pytest.raises(ValueError, match="quadrature must be an int in 1..256"):
                backend.ambient_occlusion(scene, P, D, sampling=S, quadrature=q)
        with pytest.raises(ValueError, match="obscurance"):
            backend.ambient_occlusion(scene, P, D, sampling=S, obscurance=-1.0)


def test_backends_agree_once_the_options_are_good():
    """The checks change no answer: each backend's default query on the box scene with good options given
    (straddle, quadrature unused) equals its query without them."""
    scene = _scene("box")
    for name in visibility.backends():
        backend = visibility.get_backend(name)
        assert (backend.visible(scene, P, D, straddle="embree") == backend.visible(scene, P, D)).all()
        np.testing.assert_array_equal(backend.ambient_occlusion(scene, P, D, sampling=S, quadrature=4),
                                      backend.ambient_occlusion(scene, P, D, sampling=S))
    np.testing.assert_array_equal(visibility.get_backend("csm").visible(scene, P, D), [False, True, True])


class _Uncallable:
    name = "uncallable"
    visible = None
    ambient_occlusion = 3


class _IntMembers:
    name = "int-members"
    visible = 2
    ambient_occlusion = 3


def test_registry_refuses_members_that_are_not_methods():
    """Was: register('x', obj) with obj.visible = 2 and obj.ambient_occlusion = 3 was accepted, as was the
    object as backend=; every query then failed with "TypeError: 'int' object is not callable". With
    visible = None it was refused as "... is not a visibility backend: it lacks " (naming nothing). Now
    both are refused, naming the members."""
    with pytest.raises(TypeError, match=r"'visible' \(NoneType\) and 'ambient_occlusion' \(int\) must be callable"):
        visibility.register("test-backends2-uncallable", _Uncallable())
    with pytest.raises(TypeError, match=r"'visible' \(int\) and 'ambient_occlusion' \(int\) must be callable"):
        visibility.register("test-backends2-uncallable", _IntMembers())
    assert "test-backends2-uncallable" not in visibility.backends()
    for bad in (_Uncallable(), _IntMembers()):
        with pytest.raises(TypeError, match="must be callable"):
            visibility.visible(_scene("empty"), P, D, backend=bad)


def test_registry_keeps_names_as_str():
    """Was: a numpy str_ name was kept as such, and backends() listed np.str_('...') beside the str names.
    Now names are kept as str."""
    backend = visibility.get_backend("numpy")
    try:
        visibility.register(np.str_("test-backends2-npstr"), backend)
        names = visibility.backends()
        assert "test-backends2-npstr" in names and all(type(n) is str for n in names)
        assert visibility.get_backend("test-backends2-npstr") is backend
    finally:
        _REGISTRY.pop("test-backends2-npstr", None)
