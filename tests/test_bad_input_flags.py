"""Flags that must be True or False (``pyshadow._validate.flag``) where a string or a number was read as
its truth: load_mesh, Scene, CoherentShadowMap.build, the Embree and CSM backends' AO; and a query's bias, which
must be >= 0.

Each test failed on the code before its fix; its docstring says what happened.
"""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import embree
from pyshadow.visibility.csm import CSMVisibility

VIEWS = pyshadow.ViewSet.zigzag(4, 8)


@pytest.fixture(scope="module")
def scene():
    s = pyshadow.Scene(ground=0.0, views=VIEWS, resolution=16)
    s.add(trimesh.creation.box((1.0, 1.0, 1.0)), trimesh.transformations.translation_matrix([0, 0.5, 0]))
    return s


def _open_box():
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    return trimesh.Trimesh(box.vertices, box.faces[box.face_normals[:, 1] < 0.5], process=False)


@pytest.mark.parametrize("value", ["no", "False", 0, None, np.array([True, False])])
def test_load_mesh_fill_holes_is_a_flag(value):
    """Was: ``load_mesh(open_box, fill_holes="no")`` closed the lid (10 faces became 14), 0 and None
    read as False, an array raised NumPy's "truth value ... ambiguous"."""
    with pytest.raises(TypeError, match="fill_holes: expected True or False"):
        pyshadow.load_mesh(_open_box(), fill_holes=value)
    assert len(pyshadow.load_mesh(_open_box(), fill_holes=False).faces) == 10
    assert len(pyshadow.load_mesh(_open_box(), fill_holes=np.True_).faces) == 14


@pytest.mark.parametrize("make", [lambda: pyshadow.Scene(progress="no"),
                                  lambda: pyshadow.CoherentShadowMap.build(trimesh.creation.box(), VIEWS,
                                                                           resolution=8, progress="no")])
def test_progress_is_a_flag(make):
    """Was: ``progress="no"`` drew progress bars (a scene's builds, a CSM's)."""
    with pytest.raises(TypeError, match="progress: expected True or False"):
        make()


@pytest.mark.parametrize("ask", [
    lambda s, p, n, **k: embree.ambient_occlusion(s, p, n, **k),
    lambda s, p, n, **k: CSMVisibility().ambient_occlusion(s, p, n, **k),
    lambda s, p, n, **k: CSMVisibility().ambient_occlusion(s, p, n, max_distance=2.0, **k),
])
def test_return_bent_normals_is_a_flag(scene, ask):
    """Was: ``return_bent_normals="False"`` returned the pair (ao, bent) from embree.ambient_occlusion and
    the CSM backend called directly (the Scene's and visibility's front ends already refused it)."""
    p, n = np.array([[2.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]])
    s = pyshadow.Sampling(8)
    with pytest.raises(TypeError, match="return_bent_normals: expected True or False"):
        ask(scene, p, n, sampling=s, return_bent_normals="False")
    ao = ask(scene, p, n, sampling=s, return_bent_normals=np.False_)
    assert isinstance(ao, np.ndarray) and ao.shape == (1,) and 0.5 < ao[0] <= 1.0


@pytest.mark.parametrize("backend", ["csm", "csm-vote", "numpy", "embree"])
def test_a_negative_bias_is_refused(scene, backend):
    """Was: ``bias=-1.0`` was taken: a ray straight up from the box's lid, open to the sky, came back
    blocked (CSM and NumPy backends; the shadow map already refused a negative bias). 0 is the least."""
    p, up = np.array([[0.0, 1.0, 0.0]]), np.array([[0.0, 1.0, 0.0]])
    with pytest.raises(ValueError, match="bias must be >= 0"):
        pyshadow.visibility.visible(scene, p, up, backend=backend, bias=-1.0)
    assert pyshadow.visibility.visible(scene, p + [0.0, 1e-3, 0.0], up, backend=backend, bias=0.0).tolist() == [True]
