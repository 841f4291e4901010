"""Bad input to the visibility layer's parts: the backend registry and the bias check (base), the
"sampled" sky on the AO kernel, the Embree backend and the instance tree over bounding spheres."""
import numpy as np
import pytest

import pyshadow
from pyshadow import visibility
from pyshadow.visibility import EmbreeVisibility, base, bvh, grid

P = np.array([[0.0, 1.0, 0.0]])           # a point above the ground plane y = 0, nothing else in the scene
UP = np.array([[0.0, 1.0, 0.0]])


@pytest.fixture(scope="module")
def open_scene():
    return pyshadow.Scene(ground=0.0)


class _Dummy:
    """A backend answering every ray open (AO 1)."""

    name = "dummy"

    def visible(self, scene, points, directions, *, bias=None, surface_ids=None):
        return np.ones(len(points), bool)

    def ambient_occlusion(self, scene, points, normals, *, sampling, return_bent_normals=False, bias=None,
                          indices=None, surface_ids=None):
        return np.ones(len(points), np.float32)


# -- base: the bias check and the registry ------------------------------------------------------------

@pytest.mark.parametrize("bias", [10**400, -(10**400)], ids=["1e400", "-1e400"])
def test_bias_an_int_beyond_float64_is_named(open_scene, bias):
    """Was: OverflowError "int too large to convert to float" from check_bias (no word of bias), in
    visibility.visible and in every backend."""
    with pytest.raises(ValueError, match=r"bias must be finite .* got an int of 1329 bits"):
        base.check_bias(bias)
    with pytest.raises(ValueError, match="bias must be finite"):
        visibility.visible(open_scene, P, UP, backend="numpy", bias=bias)
    assert base.check_bias(10**30) == 10**30                    # within float32's range: unchanged


@pytest.mark.parametrize("replace", ["no", "False", 0, None, np.array([True])])
def test_register_replace_must_be_a_bool(replace):
    """Was: replace="no" (any truthy value) silently replaced the registered backend; an array raised
    NumPy's "truth value ... is ambiguous"."""
    first, second = _Dummy(), _Dummy()
    visibility.register("test-parts-dummy", first)
    try:
        with pytest.raises(TypeError, match=r"replace: expected True or False"):
            visibility.register("test-parts-dummy", second, replace=replace)
        assert visibility.get_backend("test-parts-dummy") is first
        visibility.register("test-parts-dummy", second, replace=np.True_)
        assert visibility.get_backend("test-parts-dummy") is second
    finally:
        base._REGISTRY.pop("test-parts-dummy", None)


def test_a_backend_class_is_refused_by_name(open_scene):
    """Was: the class EmbreeVisibility (a class attribute ``name`` and the two methods) passed the
    protocol's isinstance check as a backend and could be registered; the query then failed with
    "EmbreeVisibility.visible() missing 1 required positional argument: 'directions'"."""
    with pytest.raises(TypeError, match=r"got the class EmbreeVisibility, not a backend object"):
        visibility.visible(open_scene, P, UP, backend=EmbreeVisibility)
    with pytest.raises(TypeError, match=r"got the class EmbreeVisibility"):
        open_scene.ambient_occlusion(P, UP, backend=EmbreeVisibility)
    with pytest.raises(TypeError, match=r"got the class _Dummy"):
        visibility.register("test-parts-class", _Dummy)
    assert "test-parts-class" not in visibility.backends()
    assert visibility.visible(open_scene, P, UP, backend=EmbreeVisibility()).tolist() == [True]


# -- the "sampled" sky on the AO kernel ---------------------------------------------------------------

def _sky(scene, env, layout=None, sampling=None):
    csm = visibility.get_backend("csm")
    return csm.sampled_sky(scene, P, UP, env, layout, sampling=pyshadow.Sampling(16) if sampling is None
                           else sampling)


@pytest.mark.parametrize("env", [np.ones((4, 8, 3)) + 1j, np.ones((4, 8, 3), bool), np.full((4, 8, 3), "2")],
                         ids=["complex", "bool", "str"])
def test_sampled_sky_radiance_must_be_real_numbers(open_scene, env):
    """Was: a complex map lost its imaginary part (a ComplexWarning, an error under pytest), a bool map was
    read as radiance 1 and a map of digit strings as those numbers."""
    with pytest.raises(TypeError, match=r"env_radiance must hold real numbers, got dtype"):
        _sky(open_scene, env)
    # an open sky of radiance 2: the mean over the 16 open directions is exactly 2
    sky, ao, _ = _sky(open_scene, np.full((4, 8, 3), 2))
    assert sky.tolist() == [[2.0, 2.0, 2.0]] and ao.tolist() == [1.0]


def test_sampled_sky_refuses_negative_radiance(open_scene):
    """Was: a map of radiance -1 was summed as given: the sky came back (-1, -1, -1) (an EnvironmentMap
    refuses negative radiance)."""
    env = np.ones((4, 8, 3))
    env[1, 2, 0] = -0.5
    with pytest.raises(ValueError, match=r"env_radiance must be >= 0, got 1 texels below 0 \(least -0.5\)"):
        _sky(open_scene, env)


def test_sampled_sky_beyond_float32_is_named(open_scene):
    """Was: radiance 1e39 raised "RuntimeWarning: overflow encountered in cast" (an error under pytest;
    elsewhere a warning before the ValueError) from the float32 cast."""
    with pytest.raises(ValueError, match=r"env_radiance must be finite \(in float32\)"):
        _sky(open_scene, np.full((4, 8, 3), 1e39))


@pytest.mark.parametrize("layout", [5, 4.0])
def test_sampled_sky_layout_shape_not_a_pair_is_named(open_scene, layout):
    """Was: layout_shape=5 raised "TypeError: 'int' object is not iterable" (no word of layout_shape)."""
    with pytest.raises(ValueError, match=r"layout_shape .* does not match env_radiance \(8, 16, 3\)"):
        _sky(open_scene, np.ones((8, 16, 3)), layout)
    # (8, 16) as an array: accepted as before
    assert _sky(open_scene, np.ones((8, 16, 3)), np.array([8, 16]))[0].tolist() == [[1.0, 1.0, 1.0]]


def test_sampled_sky_sampling_must_be_a_sampling(open_scene):
    """Was: sampling=None raised "AttributeError: 'NoneType' object has no attribute 'samples'"."""
    with pytest.raises(TypeError, match=r"sampling must be a pyshadow.Sampling, got None"):
        visibility.get_backend("csm").sampled_sky(open_scene, P, UP, np.ones((4, 8, 3)), sampling=None)


# -- the Embree backend, asked directly ---------------------------------------------------------------

@pytest.mark.parametrize("kwargs, error, match", [
    ({"bias": "0.1"}, TypeError, "bias must be one real number"),
    ({"bias": np.nan}, ValueError, "bias must be finite"),
    ({"straddle": "bogus"}, ValueError, "straddle must be one of"),
])
def test_embree_visible_checks_its_options(open_scene, kwargs, error, match):
    """Was: EmbreeVisibility().visible took bias="0.1", a NaN bias and straddle="bogus" silently (the
    CSM backends and visibility.visible refuse them)."""
    emb = EmbreeVisibility()
    with pytest.raises(error, match=match):
        emb.visible(open_scene, P, UP, **kwargs)
    assert emb.visible(open_scene, P, UP, bias=0.1, straddle="embree").tolist() == [True]


@pytest.mark.parametrize("kwargs, error, match", [
    ({"bias": "0.1"}, TypeError, "bias must be one real number"),
    ({"straddle": "bogus"}, ValueError, "straddle must be one of"),
    ({"quadrature": -3}, ValueError, "quadrature must be an int in 1..256"),
    ({"return_bent_normals": "False"}, TypeError, "return_bent_normals: expected True or False"),
])
def test_embree_ambient_occlusion_checks_its_options(open_scene, kwargs, error, match):
    """Was: EmbreeVisibility().ambient_occlusion took these silently: an AO of 1 came back, and for
    return_bent_normals="False" the tuple (ao, bent)."""
    emb = EmbreeVisibility()
    S = pyshadow.Sampling(16)
    with pytest.raises(error, match=match):
        emb.ambient_occlusion(open_scene, P, UP, sampling=S, **kwargs)
    ao = emb.ambient_occlusion(open_scene, P, UP, sampling=S, return_bent_normals=np.False_, bias=0.1)
    assert isinstance(ao, np.ndarray) and ao.tolist() == [1.0]


# -- the instance tree (and grid) over bounding spheres ------------------------------------------------

@pytest.mark.parametrize("build", [bvh.instance_bvh, lambda c, r: grid.instance_grid(c, r, balanced_only=False)],
                         ids=["bvh", "grid"])
def test_spheres_of_the_wrong_shape_are_refused(build):
    """Was: centres of shape (3, 4) were read as 4 centres (reshape(-1, 3)), radii of shape (1, 4) as 4
    radii: a tree over spheres nobody placed."""
    with pytest.raises(ValueError, match=r"centres must have shape \(N, 3\), got \(3, 4\)"):
        build(np.arange(12.0).reshape(3, 4), np.ones(4))
    with pytest.raises(ValueError, match=r"4 centres and radii of shape \(1, 4\)"):
        build(np.arange(12.0).reshape(4, 3), np.ones((1, 4)))


@pytest.mark.parametrize("what, centres, radii", [
    ("centres", np.zeros((2, 3)) + 1j, np.ones(2)),
    ("centres", np.zeros((2, 3), bool), np.ones(2)),
    ("centres", np.zeros((2, 3)).astype(str), np.ones(2)),
    ("radii", np.zeros((2, 3)), np.array(["1", "1"])),
], ids=["complex", "bool", "str", "str-radii"])
def test_spheres_must_be_real_numbers(what, centres, radii):
    """Was: complex centres lost their imaginary part (a ComplexWarning, an error under pytest), bools and
    digit strings were read as numbers."""
    with pytest.raises(TypeError, match=rf"instance_bvh: {what} must be real numbers"):
        bvh.instance_bvh(centres, radii)


def test_tree_at_the_ends_of_the_float_ranges():
    """Was: spheres at +-3e38 with radius 1e38 (each within float32's range, as the kernels' instance
    table needs) raised "RuntimeWarning: overflow encountered in cast" rounding their boxes to float32,
    and centres at +-1e308 "overflow encountered in subtract" in the Morton codes (errors under pytest).
    The boxes are those of before: beyond float32 +-inf, else rounded outward."""
    nodes, order, depth = bvh.instance_bvh([[-3e38, 0.0, 0.0], [3e38, 0.0, 0.0]], [1e38, 1e38])
    assert order.tolist() == [0, 1] and depth == 1
    lo, hi = nodes["lo"][0].astype(np.float64), nodes["hi"][0].astype(np.float64)
    assert lo[0] == -np.inf and hi[0] == np.inf
    # rounded outward: the float32 just beyond 1e38 (1e38 is no float32), within one float32 spacing
    assert -1e38 * (1 + 2**-23) <= lo[1] < -1e38 and 1e38 < hi[1] <= 1e38 * (1 + 2**-23)
    nodes, order, _ = bvh.instance_bvh([[-1e308, 0.0, 0.0], [1e308, 0.0, 0.0]], [1.0, 1.0])
    assert order.tolist() == [0, 1]
    assert nodes["lo"][0].tolist() == [-np.inf, -1.0, -1.0] and nodes["hi"][0].tolist() == [np.inf, 1.0, 1.0]
