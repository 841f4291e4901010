"""A scene's stacked arrays after moves only (``scene_arrays``): what the transforms change made again, the
rest kept -- the same arrays, bit for bit, as a scene built at the final poses."""
import numpy as np
import trimesh

import pyshadow
from pyshadow.scene_arrays import scene_arrays


def _build(csm, box, ball, poses):
    s = pyshadow.Scene(ground=0.0)
    for k, T in enumerate(poses):
        if k % 3 == 2:
            s.add(ball, T, casts=False)                 # a receiver (its mesh's sphere)
        else:
            s.add(csm, T, mesh=box)
    return s


def _poses(rng, n, far):
    out = []
    for _ in range(n):
        R = trimesh.transformations.random_rotation_matrix(rng.random(3))
        R[:3, :3] *= rng.uniform(0.01, 100.0)
        R[:3, 3] = rng.uniform(-far, far, 3)
        out.append(R)
    return np.array(out)


def test_moved_scene_arrays_equal_a_scene_built_there(box_csm):
    """Moves by one call each and by one stacked call, scales 0.01-100, 1e4 from the origin: every array
    equal to a new scene's at the final poses; the static ones (CSM types, object spheres, meshes) the
    same objects as before the moves; the derived entries a query kept are dropped."""
    box, csm = box_csm
    ball = trimesh.creation.icosphere(1, radius=0.4)
    rng = np.random.default_rng(5)
    scene = _build(csm, box, ball, _poses(rng, 12, 10.0))
    before = scene_arrays(scene)
    before["derived"] = 1                               # what a query keeps with the arrays
    final = _poses(rng, 12, 1e4)
    scene.set_transform(np.arange(6), final[:6])
    for i in range(6, 12):
        scene.set_transform(i, final[i])
    after, fresh = scene_arrays(scene), scene_arrays(_build(csm, box, ball, final))
    assert after is not before and "derived" not in after
    for key in ("transform", "scale", "object_centre", "object_radius", "world_centre", "world_radius",
                "casts", "itype"):
        assert after[key].dtype == fresh[key].dtype and np.array_equal(after[key], fresh[key]), key
        assert not after[key].flags.writeable, key
    for key in ("types", "type_index", "meshes", "receivers", "object_centre", "mesh_id"):
        assert after[key] is before[key], key
    # each world sphere as the instance's own (the rule scene_arrays keeps bit-identical)
    for i, inst in enumerate(scene.instances):
        c, r = inst.world_sphere()
        assert np.array_equal(after["world_centre"][i], c) and after["world_radius"][i] == r


def test_scene_arrays_made_anew_after_an_add_or_a_receiver_changed(box_csm):
    """An add after moves (a new instance) and a receiver's mesh changed in place (a new sphere): the
    arrays made anew, not kept -- the new instance is in them, the receiver's sphere is its new one."""
    box, csm = box_csm
    ball = trimesh.creation.icosphere(1, radius=0.4)
    rng = np.random.default_rng(6)
    scene = _build(csm, box, ball, _poses(rng, 6, 5.0))
    first = scene_arrays(scene)
    scene.set_transform(0, np.eye(4))
    scene.add(csm, np.eye(4), mesh=box)
    grown = scene_arrays(scene)
    assert grown["n"] == 7 and len(grown["casts"]) == 7 and grown["object_centre"] is not first["object_centre"]
    r0 = grown["object_radius"][2]
    scene.set_transform(1, np.eye(4))
    ball.vertices *= 2.0                                # the receiver's mesh changed in place
    again = scene_arrays(scene)
    assert np.isclose(again["object_radius"][2], 2 * r0, rtol=1e-12)
