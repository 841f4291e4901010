"""Scene.remove: after removing bodies, every query answers bit for bit as a scene built without them.

Scene ``removed`` places a receiver plate and casters of two CSM types (boxes resting on the ground, a box
stacked on one, a ball), asks once (so that its tables, atlas, contact footprints and body patches are kept),
then removes a resting box, the stacked box, the only ball (a caster type gone) and the receiver. Scene
``built`` places only the others, in the same order: its ids are the survivors' positions among them
(``IDS``). The outputs that name instances (object ids, surface ids) are compared through that map.
"""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import Sampling
from pyshadow.scene import GROUND_ID
from pyshadow.lighting import DirectionalLight, Lighting, PointLight

tr = trimesh.transformations.translation_matrix

# (kind, pose); the removed ones are marked
BODIES = [("plate", tr([-1.6, 0.05, -1.0])),                            # 0 receiver, kept
          ("box", tr([-0.6, 0.15, 0.0])),                               # 1 kept
          ("box", tr([0.0, 0.15, 0.0])),                                # 2 removed (resting on the ground)
          ("box", tr([0.0, 0.45, 0.0])),                                # 3 removed (stacked on 2)
          ("ball", tr([0.7, 0.2, 0.4])),                                # 4 removed (the only ball)
          ("plate", tr([1.2, 0.05, -0.8])),                             # 5 receiver, removed
          ("box", tr([0.6, 0.15, -0.2]) @ trimesh.transformations.rotation_matrix(0.4, [0, 1, 0])),   # 6 kept
          ("box", tr([-0.6, 0.45, 0.0])),                               # 7 kept (stacked on 1)
          ("tray", tr([-0.2, 0.05, 0.6])),                              # 8 removed (an open box: a ground sheet)
          ("tray", tr([0.5, 0.05, 0.6]))]                               # 9 kept
REMOVED = [2, 3, 4, 5, 8]
IDS = {a: b for b, a in enumerate(i for i in range(len(BODIES)) if i not in REMOVED)}   # removed's id -> built's


@pytest.fixture(scope="module")
def scenes(box_csm):
    box, csm = box_csm
    ball = trimesh.creation.icosphere(2, 0.2)
    ball_csm = pyshadow.CoherentShadowMap.build(ball, pyshadow.ViewSet.zigzag(8, 16), resolution=32, progress=False)
    plate = trimesh.creation.box((0.6, 0.1, 0.6))
    tray = trimesh.creation.box((0.4, 0.1, 0.4))
    tray = trimesh.Trimesh(tray.vertices, tray.faces[tray.face_normals[:, 1] < 0.5], process=False)     # no lid
    tray_csm = pyshadow.CoherentShadowMap.build(tray, pyshadow.ViewSet.zigzag(8, 16), resolution=32, progress=False)
    objs = {"box": ((csm,), {"mesh": box}), "ball": ((ball_csm,), {"mesh": ball}),
            "plate": ((plate,), {"casts": False}), "tray": ((tray_csm,), {"mesh": tray})}

    def place(scene, k):
        args, kw = objs[BODIES[k][0]]
        return scene.add(*args, BODIES[k][1], **kw)

    removed, built = pyshadow.Scene(ground=0.0), pyshadow.Scene(ground=0.0)
    assert [place(removed, k) for k in range(len(BODIES))] == list(range(len(BODIES)))
    assert [place(built, k) for k in IDS] == list(IDS.values())
    p, n = _queries()
    removed.ambient_occlusion(p, n, sampling=Sampling(8))           # its tables kept, then dropped by remove
    removed.ambient_occlusion(p, n, sampling=Sampling(8), lookup="vote")
    removed.render(_camera(), sampling=Sampling(4))
    removed.remove(REMOVED[:1])
    removed.remove(np.array(REMOVED[1:]))
    return removed, built


def _queries(n=600, seed=4):
    """Points on and around the bodies and the ground (a third on the ground, some on the removed bodies'
    footprints), random normals turned to the upper side for those on the ground."""
    rng = np.random.default_rng(seed)
    p = rng.uniform([-1.2, 0.0, -0.8], [1.2, 0.8, 0.8], (n, 3))
    p[: n // 3, 1] = 0.0
    p[: n // 12, [0, 2]] = rng.uniform(-0.15, 0.15, (n // 12, 2))       # under the removed resting box
    p[n // 12: n // 6, [0, 2]] = rng.uniform(-0.2, 0.2, (n // 12, 2)) + [[-0.2, 0.6]]    # in the removed tray
    p[n // 6: n // 4, [0, 2]] = rng.uniform(-0.2, 0.2, (n // 12, 2)) + [[0.5, 0.6]]      # in the kept one
    nrm = rng.normal(size=(n, 3))
    nrm[: n // 3] = [0.0, 1.0, 0.0]
    return p, nrm


def _camera():
    return pyshadow.Camera([1.8, 1.4, 2.2], [0.0, 0.2, 0.0], width=40, height=28)


def _same(a, b):
    a, b = np.atleast_1d(a), np.atleast_1d(b)
    assert a.shape == b.shape and a.dtype == b.dtype
    assert np.array_equal(a.view(np.uint8), b.view(np.uint8))         # bit for bit (NaNs included)


def _ids(a):
    """Instance ids of the removed-from scene as the built scene's (-1, -2 as they are)."""
    a = np.asarray(a)
    return np.where(a >= 0, np.vectorize(lambda i: IDS.get(int(i), -99), otypes=[a.dtype])(a), a) if a.size else a


def test_the_scene_describes_itself_as_the_one_built_without_them(scenes):
    removed, built = scenes
    assert [removed.instances[i].removed for i in range(len(BODIES))] == [i in REMOVED for i in range(len(BODIES))]
    assert [IDS[i] for i in removed.casters] == built.casters
    assert removed.caster_types()[0] == built.caster_types()[0]       # the ball's CSM is no type any more
    _same(removed.anchor(), built.anchor())
    assert removed.scale() == built.scale()
    slots = removed.caster_slots(np.array(list(IDS)), len(IDS))
    _same(slots, built.caster_slots(np.array(list(IDS.values())), len(IDS)))
    _same(removed.caster_slots(np.array(REMOVED), len(REMOVED)), np.full(len(REMOVED), -2, np.int32))
    p, _ = _queries()                   # the ground's points in a tray take its slot (its sheet), as built
    on_ground = np.full(len(p), GROUND_ID)
    _same(removed.caster_slots(on_ground, len(p), p), built.caster_slots(on_ground, len(p), p))
    assert (built.caster_slots(on_ground, len(p), p) == built.casters.index(IDS[9])).any()
    (ia, ida), (ib, idb) = removed.draw_items(), built.draw_items()
    _same(_ids(ida), idb)
    assert len(ia) == len(ib) and all(ma is mb for (ma, _), (mb, _) in zip(ia[:-1], ib[:-1]))
    for (ma, ta), (mb, tb) in zip(ia, ib):
        _same(ta, tb)
        _same(np.asarray(ma.vertices), np.asarray(mb.vertices))
    _same(removed.ground_quad().vertices, built.ground_quad().vertices)


@pytest.mark.parametrize("lookup", ["nearest", "vote"])
def test_visible_and_ambient_occlusion_are_those_of_the_scene_built_without_them(scenes, lookup):
    removed, built = scenes
    p, n = _queries()
    d = np.random.default_rng(5).normal(size=p.shape)
    d[:, 1] = np.abs(d[:, 1])
    for scene_kw in ({}, {"normals": n * np.sign(np.einsum("ij,ij->i", n, d))[:, None]}):
        _same(removed.visible(p, d, lookup=lookup, **scene_kw), built.visible(p, d, lookup=lookup, **scene_kw))
    _same(removed.ambient_occlusion(p, n, lookup=lookup), built.ambient_occlusion(p, n, lookup=lookup))
    ground = np.where(p[:, 1] == 0.0, GROUND_ID, -1)                   # the ground's points as such (sheets)
    _same(removed.ambient_occlusion(p, n, lookup=lookup, surface_ids=ground),
          built.ambient_occlusion(p, n, lookup=lookup, surface_ids=ground))
    ao_r, bent_r = removed.ambient_occlusion(p, n, lookup=lookup, return_bent_normals=True)
    ao_b, bent_b = built.ambient_occlusion(p, n, lookup=lookup, return_bent_normals=True)
    _same(ao_r, ao_b)
    _same(bent_r, bent_b)
    assert (ao_r < 1).any() and (ao_r == 1).any()
    # the points on the survivors, asked with their surface ids (the built scene's ids for the same bodies)
    for i in (1, 6, 0):
        _same(removed.vertex_ao(i, lookup=lookup), built.vertex_ao(IDS[i], lookup=lookup))
        ao_r, bent_r = removed.vertex_ao(i, lookup=lookup, return_bent_normals=True)
        ao_b, bent_b = built.vertex_ao(IDS[i], lookup=lookup, return_bent_normals=True)
        _same(ao_r, ao_b)
        _same(bent_r, bent_b)


def test_the_embree_reference_is_that_of_the_scene_built_without_them(scenes):
    import pyshadow.embree as embree

    removed, built = scenes
    p, n = _queries(300)
    d = np.random.default_rng(6).normal(size=p.shape)
    _same(removed.visible(p, d, backend="embree"), built.visible(p, d, backend="embree"))
    _same(embree.visible(removed, p, d), embree.visible(built, p, d))
    _same(embree.visible(removed, p, d, max_distance=0.5), embree.visible(built, p, d, max_distance=0.5))
    s = Sampling(16)
    _same(removed.ambient_occlusion(p, n, sampling=s, backend="embree"),
          built.ambient_occlusion(p, n, sampling=s, backend="embree"))
    got = [embree.ambient_occlusion(sc, p, n, sampling=s, return_bent_normals=True) for sc in (removed, built)]
    for a, b in zip(*got):
        _same(a, b)
    _same(removed.vertex_ao(1, sampling=s, backend="embree"), built.vertex_ao(IDS[1], sampling=s, backend="embree"))
    _same(embree.caster_scene(removed)[1], embree.caster_scene(built)[1])
    _same(embree.surface_epsilon(removed, p), embree.surface_epsilon(built, p))
    _same(embree.surface_epsilon(removed), embree.surface_epsilon(built))


@pytest.mark.parametrize("kw", [{}, {"lookup": "vote", "ao_scale": 2}, {"backend": "embree"}],
                         ids=["csm", "vote-scale2", "embree"])
def test_render_is_that_of_the_scene_built_without_them(scenes, kw):
    removed, built = scenes
    a, b = (sc.render(_camera(), sampling=Sampling(8), **kw) for sc in (removed, built))
    for key in ("ao", "bent_normal", "depth", "normal", "position"):
        _same(a[key], b[key])
    _same(_ids(a.object_id), b.object_id)
    assert (b.object_id == -2).any() and (b.object_id >= 0).any()


def test_a_lit_render_is_that_of_the_scene_built_without_them(scenes):
    removed, built = scenes
    sun = DirectionalLight(np.array([0.4, 0.8, 0.3]) / np.linalg.norm([0.4, 0.8, 0.3]), 3.0)
    lamp = PointLight([0.2, 1.6, 0.9], 2.0)
    frames = [sc.render(_camera(), sampling=Sampling(4), lighting=Lighting(np.full((9, 3), 0.2), sun=sun,
                                                                         lights=[lamp], albedo=0.6,
                                                                         albedos=albedos))
              for sc, albedos in ((removed, {6: 0.3, 2: 0.9}), (built, {IDS[6]: 0.3}))]
    _same(frames[0].radiance, frames[1].radiance)
    assert np.isfinite(frames[1].radiance).all() and frames[1].radiance.max() > 0


def test_a_cube_probe_sees_the_scene_built_without_them(scenes):
    from pyshadow.cubemap import CubeProbe

    removed, built = scenes
    a, b = (CubeProbe(sc, [0.0, 1.2, 0.0], 16) for sc in (removed, built))
    for key in ("depth", "position", "normal", "occluder"):
        _same(getattr(a, key), getattr(b, key))
    _same(_ids(a.object_id), b.object_id)
    assert not a.stale
    removed.remove([])                  # removing none changes nothing
    assert not a.stale
