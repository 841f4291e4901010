"""Frame checks outside the build see only the vertices faces use (with scene.py, raster.py, exposure.py changed)."""
import warnings

import numpy as np
import trimesh

import pyshadow
from pyshadow import CoherentShadowMap, Scene, ViewSet, bounding_sphere
from pyshadow.csm.exposure import exposed_back_faces
from pyshadow.raster import render_depth


def _with_far(mesh):
    return trimesh.Trimesh(np.vstack([mesh.vertices, [[40.0, 0.0, 0.0]]]), mesh.faces, process=False)


def test_scene_adds_csm_of_mesh_with_unused_vertex():
    """Was: Scene.add(csm, mesh=mesh) of a mesh with a far unused vertex refused its own CSM ('the CSM's
    frame does not hold its mesh ... an edited file?') once the frame left the unused vertex out."""
    m = pyshadow.data.mesh("suzanne")
    mu = _with_far(m)
    csm = CoherentShadowMap.build(mu, ViewSet.zigzag(4, 8), resolution=16, progress=False)
    sc = Scene()
    sc.add(csm, mesh=mu)
    assert sc.instances[0].csm.radius == bounding_sphere(m)[1]


def test_max_error_build_of_mesh_with_unused_vertex():
    """Was: build(max_error=) of a mesh with a far unused vertex raised in its check (measure: Scene.add
    with mesh=) 'a vertex lies 40 from the centre, outside the radius 1.4'."""
    m = pyshadow.data.mesh("suzanne")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a = CoherentShadowMap.build(m, max_error=0.2, progress=False)
        b = CoherentShadowMap.build(_with_far(m), max_error=0.2, progress=False)
    assert b.radius == a.radius and np.array_equal(b.depth, a.depth)


def test_render_depth_and_exposure_with_frame():
    """Was: render_depth(frame=) and exposed_back_faces refused the used vertices' sphere of a mesh with a far
    unused vertex ('frame: a vertex lies 40 from the centre')."""
    m = pyshadow.data.mesh("suzanne")
    mu, frame = _with_far(m), bounding_sphere(m)
    views = ViewSet.zigzag(2, 4)
    assert np.array_equal(render_depth(mu, views, resolution=8, frame=frame),
                          render_depth(m, views, resolution=8, frame=frame))
    assert np.array_equal(exposed_back_faces(mu, frame, 64), exposed_back_faces(m, frame, 64))
