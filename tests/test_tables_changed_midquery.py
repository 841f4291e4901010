"""A query whose scene gains a CSM type from another thread between its compiled program and its tables is
refused with a clear error, instead of launching a kernel that would index past the atlas's types."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.visibility import csm as backend

MAPS = dict(views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)


def _scene():
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    scene = pyshadow.Scene(ground=0.0, **MAPS)
    scene.add(box, trimesh.transformations.translation_matrix([0.0, 0.5, 0.0]))
    ball = trimesh.creation.icosphere(1, 0.4)
    ball_csm = pyshadow.CoherentShadowMap.build(ball, progress=False, **MAPS)
    return scene, ball, ball_csm


P = np.array([[1.5, 0.0, 0.2], [0.2, 0.0, 1.5], [3.0, 0.0, 3.0]])
N = np.tile([0.0, 1.0, 0.0], (3, 1))


@pytest.mark.parametrize("query", ["visible", "ao"])
def test_a_new_caster_type_landing_mid_query_is_refused(monkeypatch, query):
    scene, ball, ball_csm = _scene()
    before = scene.visible(P, N), scene.ambient_occlusion(P, N, sampling=pyshadow.Sampling(8))   # compiled, kept
    real = backend._instance_data

    def added_meanwhile(sc, anchor, lookup="nearest"):      # another thread's add, after the program was chosen
        if len(sc.caster_types()[0]) == 1:
            sc.add(ball_csm, trimesh.transformations.translation_matrix([1.5, 0.4, 1.5]), mesh=ball)
        return real(sc, anchor, lookup)

    monkeypatch.setattr(backend, "_instance_data", added_meanwhile)
    ask = (lambda: scene.visible(P, N)) if query == "visible" else \
        (lambda: scene.ambient_occlusion(P, N, sampling=pyshadow.Sampling(8)))
    with pytest.raises(RuntimeError, match="caster types changed during this query"):
        ask()
    monkeypatch.setattr(backend, "_instance_data", real)
    again = scene.visible(P, N), scene.ambient_occlusion(P, N, sampling=pyshadow.Sampling(8))   # asked again: answers
    built = pyshadow.Scene(ground=0.0, **MAPS)
    built.add(scene.instances[0].csm, scene.transform(0), mesh=scene.instances[0].mesh)
    built.add(ball_csm, scene.transform(1), mesh=ball)
    for a, b in zip(again, (built.visible(P, N), built.ambient_occlusion(P, N, sampling=pyshadow.Sampling(8)))):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(again[1], before[1])          # the ball shadows some of the points
