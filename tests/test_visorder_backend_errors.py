"""Backend objects and their selection (pyshadow.visibility.base, .mirror, .raytraced): a wrong backend
object or argument is refused with a message that names what is wrong."""
import numpy as np
import pytest

import pyshadow
from pyshadow import visibility
from pyshadow.visibility import EmbreeVisibility, NumPyVisibility


class _Nameless:
    """A backend written to the protocol's two methods, without its ``name``."""

    def visible(self, scene, points, directions, *, bias=None, surface_ids=None):
        return np.ones(len(points), bool)

    def ambient_occlusion(self, scene, points, normals, *, sampling, return_bent_normals=False, bias=None,
                          indices=None, surface_ids=None):
        return np.ones(len(points), np.float32)


def test_a_backend_without_a_name_is_told_so():
    """Was: a backend with ``visible`` and ``ambient_occlusion`` but no ``name`` was refused by register as
    "lacks visible/ambient_occlusion" (the two it had), and as a query's backend= with "must be a name or a
    backend object". Now both name the missing 'name' (and only it)."""
    with pytest.raises(TypeError, match="not a visibility backend: it lacks 'name'$"):
        visibility.register("test-visorder-nameless", _Nameless())
    assert "test-visorder-nameless" not in visibility.backends()
    scene = pyshadow.Scene(ground=0.0)
    p, d = np.zeros((2, 3)), np.tile([0.0, 1.0, 0.0], (2, 1))
    with pytest.raises(TypeError, match=r"lacks 'name' \("):
        visibility.visible(scene, p, d, backend=_Nameless())

    class OnlyVisible:
        name = "half"

        def visible(self, scene, points, directions, *, bias=None, surface_ids=None):
            return np.ones(len(points), bool)
    with pytest.raises(TypeError, match="lacks 'ambient_occlusion'"):
        visibility.register("test-visorder-half", OnlyVisible())
    with pytest.raises(TypeError, match="lacks 'name', 'visible' and 'ambient_occlusion'"):
        visibility.register("test-visorder-bad", object())
    with pytest.raises(TypeError, match="must be a name or a backend object"):     # not meant as one: as before
        visibility.get_backend(3)


@pytest.mark.parametrize("lookup", ["bogus", "Vote", None, ["vote"]])
def test_numpy_backend_checks_its_lookup_when_made(lookup):
    """Was: NumPyVisibility("bogus") was made, named "numpy-vote" (any lookup but "nearest"), and refused
    only by its first query; CSMVisibility refuses it when made. Now NumPyVisibility does too."""
    with pytest.raises(ValueError, match="lookup must be 'nearest' or 'vote'"):
        NumPyVisibility(lookup)
    assert NumPyVisibility("vote").name == "numpy-vote" and NumPyVisibility().name == "numpy"


@pytest.mark.parametrize("sampling", [8, "sampling", pyshadow.Sampling])
def test_embree_backend_checks_its_sampling(sampling):
    """Was: EmbreeVisibility().ambient_occlusion(..., sampling=8) raised AttributeError "'int' object has
    no attribute 'samples'" (the NumPy backend: TypeError naming sampling). Now a TypeError names it."""
    scene = pyshadow.Scene(ground=0.0)
    p, n = np.zeros((2, 3)), np.tile([0.0, 1.0, 0.0], (2, 1))
    with pytest.raises(TypeError, match="sampling must be a pyshadow.Sampling"):
        EmbreeVisibility().ambient_occlusion(scene, p, n, sampling=sampling)
    ao = EmbreeVisibility().ambient_occlusion(scene, p, n, sampling=pyshadow.Sampling(8))
    np.testing.assert_array_equal(ao, np.ones(2, np.float32))           # an open ground: every sample free


@pytest.mark.parametrize("backend", ["csm", "numpy", "embree"])
def test_visible_and_ao_name_a_scene_that_is_not_one(backend):
    """Was: visibility.visible / ambient_occlusion of pyshadow.data.default_scene()'s (scene, camera) pair,
    a mesh or None raised AttributeError "'tuple' object has no attribute 'caster_slots'" (Embree: "...
    'instances'") from inside the backend. Now a TypeError names the scene."""
    import trimesh

    scene = pyshadow.Scene(ground=0.0)
    p, d = np.array([[0.0, 0.5, 0.0]]), np.array([[0.0, 1.0, 0.0]])
    for bad, hint in (((scene, None), "default_scene"), (trimesh.creation.box(), "Scene.add"), (None, "NoneType")):
        with pytest.raises(TypeError, match=f"scene must be a pyshadow.Scene, got .*{hint}"):
            visibility.visible(bad, p, d, backend=backend)
        with pytest.raises(TypeError, match=f"scene must be a pyshadow.Scene, got .*{hint}"):
            visibility.ambient_occlusion(bad, p, d, backend=backend, sampling=pyshadow.Sampling(8))
    np.testing.assert_array_equal(visibility.visible(scene, p, d, backend=backend), [True])
