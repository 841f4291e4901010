"""An EmbreeTracer refuses rays once its scene changed (a body moved or added, the ground set).

Was: the tracer kept the triangles and anchor of the scene it was built from while prepare() read
the ground, the points' anchors and the lift of the scene as it is now: after a move it traced the old
bodies from a half-updated setup, without a word (its docstring said changes were not seen).
"""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.embree import EmbreeTracer


def _scene():
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    csm = pyshadow.CoherentShadowMap.build(box, pyshadow.ViewSet.zigzag(8, 16), resolution=32, progress=False)
    s = pyshadow.Scene(ground=0.0)
    s.add(csm, trimesh.transformations.translation_matrix([0.0, 0.5, 0.0]), mesh=box)
    return s, csm, box


def _rays(tracer):
    p = np.array([[1.0, 0.0, 0.0], [-1.2, 0.0, 0.3]])
    up = np.tile([0.0, 1.0, 0.0], (2, 1))
    d = pyshadow.sample_directions(up, sampling=pyshadow.Sampling(8)).reshape(-1, 3).astype(np.float32)
    return tracer.prepare(p, up, d, 8)


@pytest.mark.parametrize("change", ["move", "add", "ground"])
def test_a_tracer_refuses_rays_after_its_scene_changed(change):
    s, csm, box = _scene()
    with EmbreeTracer(s, 1) as tracer:
        ground, todo, o, d = _rays(tracer)
        assert len(todo) and not tracer.occluded(o, d).all()
        if change == "move":
            s.set_transform(0, trimesh.transformations.translation_matrix([3.0, 0.5, 0.0]))
        elif change == "add":
            s.add(csm, trimesh.transformations.translation_matrix([0.0, 0.5, 3.0]), mesh=box)
        else:
            s.ground = -0.25
        with pytest.raises(ValueError, match="the scene changed since the tracer was built"):
            _rays(tracer)
    with EmbreeTracer(s, 1) as tracer:                 # a new tracer of the scene as it is
        assert len(_rays(tracer)[1])
