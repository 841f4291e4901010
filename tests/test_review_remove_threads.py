"""Scene.remove from another thread while a query runs: the query answers (for the state before, after, or a
mix of them, as README's threads paragraph promises), never fails. The backends that read the instances
(``scene.instances[i]``) at positions taken from the scene's arrays read a placeholder where a removal landed
in between: the shadow-map backend failed with "'NoneType' object has no attribute 'vertices'" and the numpy
backend with "a removed instance (a placeholder of Scene.remove) has no bounding sphere" (both seen with two
real threads). Here the removal is made at that point, as the other thread's would be."""
import numpy as np
import trimesh

import pyshadow
from pyshadow.scene_arrays import scene_arrays

tr = trimesh.transformations.translation_matrix
SUN = np.array([0.3, 0.9, 0.1]) / np.linalg.norm([0.3, 0.9, 0.1])


def _scene(box_csm):
    box, csm = box_csm
    scene = pyshadow.Scene(ground=0.0)
    scene.add(csm, np.stack([tr([x, 0.15, 0.0]) for x in (-0.6, 0.0, 0.6)]), mesh=box)
    return scene


def _points():
    rng = np.random.default_rng(7)
    p = rng.uniform([-1.0, 0.0, -0.6], [1.0, 0.0, 0.6], (64, 3))
    return p, np.tile(SUN, (len(p), 1))


def _either(got, before, after):
    assert got.shape == before.shape and got.dtype == before.dtype
    assert ((got == before) | (got == after)).all()


def test_a_shadow_map_query_answers_across_a_removal(box_csm, monkeypatch):
    from pyshadow.lighting import ShadowMapVisibility, shadow_map_kept

    p, d = _points()
    scene = _scene(box_csm)
    before = ShadowMapVisibility(32).visible(scene, p, d)
    after = ShadowMapVisibility(32).visible(_removed(box_csm), p, d)
    checked = shadow_map_kept.check_meshes

    def removal_lands(s):               # after the query read the scene's arrays, before it reads the instances
        checked(s)
        if not s.instances[1].removed:
            s.remove(1)

    monkeypatch.setattr(shadow_map_kept, "check_meshes", removal_lands)
    _either(ShadowMapVisibility(32).visible(scene, p, d), before, after)


def test_a_numpy_query_answers_across_a_removal(box_csm, monkeypatch):
    from pyshadow.visibility import mirror

    p, d = _points()
    scene = _scene(box_csm)
    before = scene.visible(p, d, backend="numpy")
    after = _removed(box_csm).visible(p, d, backend="numpy")
    scene_arrays(scene)
    occludes = mirror.caster_occludes

    def removal_lands(*args, **kwargs):     # between two casters' lookups
        if not scene.instances[1].removed:
            scene.remove(1)
        return occludes(*args, **kwargs)

    monkeypatch.setattr(mirror, "caster_occludes", removal_lands)
    _either(scene.visible(p, d, backend="numpy"), before, after)


def _removed(box_csm):
    scene = _scene(box_csm)
    scene.remove(1)
    return scene


def test_the_arrays_describe_one_list_of_instances(box_csm):
    """``scene_arrays``' ``placed``: the instances its rows describe (a placeholder where removed)."""
    scene = _removed(box_csm)
    held = scene_arrays(scene)
    assert held["placed"] == tuple(scene.instances) and held["placed"][1].removed
    scene.set_transform(0, tr([-0.7, 0.15, 0.0]))
    assert scene_arrays(scene)["placed"] == tuple(scene.instances)


def test_body_patches_of_arrays_read_before_another_threads_add(box_csm):
    """The bodies' contact patches of the arrays a query read are those of the arrays' bodies, whatever
    another thread added since (``IndexError: index 3 is out of bounds for axis 0 with size 3`` before: the
    instance count was the list's now; seen with two real threads)."""
    from pyshadow.contact_bodies import _patches, body_patches

    box, csm = box_csm
    scene = _scene(box_csm)             # three boxes 0.3 apart: no two touch
    held = scene_arrays(scene)
    scene.add(csm, tr([0.0, 0.45, 0.0]), mesh=box)      # stacked on the middle one
    assert _patches(scene, held) == []
    assert len(body_patches(scene)) == 2                # the stacked pair: the lid and the bottom
