"""Meshes the error model and the accuracy-driven build are handed as they are: checked as the plain build checks.

A ``trimesh.Trimesh(..., process=False)`` may carry a face index past its vertices, a negative one (NumPy
wraps it to the last vertex) or a NaN vertex; ``CoherentShadowMap.build`` refuses each with
``check_mesh``'s message, and so must ``build(max_error=...)``, ``choose_csm``, ``choose_within`` and the
error model's public functions, before any ray is drawn or pilot built.
"""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.csm import choose_csm, choose_within
from pyshadow.csm.error_model import Layout, ao_rays, near_rays, predict, rays_for


def _ball():
    return trimesh.creation.icosphere(1)


def _past():
    s = _ball()
    return trimesh.Trimesh(s.vertices, np.vstack([s.faces, [[0, 1, 500]]]), process=False)


def _negative():
    s = _ball()
    return trimesh.Trimesh(s.vertices, np.vstack([s.faces, [[0, 1, -1]]]), process=False)


def _nan():
    s = _ball()
    m = trimesh.Trimesh(s.vertices.copy(), s.faces.copy(), process=False)
    m.vertices[0] = np.nan
    return m


CALLS = {
    "rays_for": lambda m: rays_for(m, points=10, samples=2, near=10),
    "predict": lambda m: predict(m, (4, 8), 16, points=10, samples=2, near=10),
    "ao_rays": lambda m: ao_rays(m, 10, 2),
    "near_rays": lambda m: near_rays(m, 10),
    "Layout.for_mesh": lambda m: Layout.for_mesh(m, (4, 8), 16),
    "choose_csm": lambda m: choose_csm(m, 0.1, points=10, samples=2, near=10),
    "choose_within": lambda m: choose_within(m, 10 ** 6, points=10, samples=2, near=10),
}


@pytest.mark.parametrize("name", sorted(CALLS))
def test_a_negative_face_index_is_refused_by_the_error_model(name):
    """Was: rays_for, predict, ao_rays, near_rays and Layout.for_mesh drew on and judged a mesh whose face
    index -1 NumPy wrapped to the last vertex (no error; predict gave a disagreement for a mesh the build
    refuses), choose_csm and choose_within failed only in the first pilot build, labelled
    'CoherentShadowMap.build'."""
    with pytest.raises(ValueError, match=f"^{name}: a face refers to a vertex that does not exist$"):
        CALLS[name](_negative())


@pytest.mark.parametrize("name", sorted(CALLS))
def test_a_face_index_past_the_vertices_is_a_valueerror(name):
    """Was: numpy's IndexError 'index 500 is out of bounds for axis 0 with size 42' from every one but
    near_rays, which drew its rays without error."""
    with pytest.raises(ValueError, match=f"^{name}: a face refers to a vertex that does not exist$"):
        CALLS[name](_past())


def test_a_nan_vertex_is_named_by_ao_rays():
    """Was: 'ao_rays: the mesh has no surface area (its 80 faces are all degenerate)' for a ball with one NaN
    vertex (the NaN area made the total NaN)."""
    with pytest.raises(ValueError, match=r"^ao_rays: 1 of 42 vertices are not finite \(NaN or inf\)"):
        ao_rays(_nan(), 10, 2)


@pytest.mark.parametrize("mesh, message", [
    (_past, "a face refers to a vertex that does not exist"),
    (_nan, r"1 of 42 vertices are not finite \(NaN or inf\)"),
    (lambda: trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), int), process=False),
     r"the mesh has no triangles \(empty mesh\)"),
])
def test_build_with_max_error_names_the_fault_as_the_plain_build(mesh, message):
    """Was: build(max_error=0.05) raised IndexError for a face past the vertices, and 'bounding_sphere: ...'
    for a NaN vertex or an empty mesh, where build(views, resolution=...) says 'CoherentShadowMap.build: ...'."""
    with pytest.raises(ValueError, match=f"^CoherentShadowMap.build: {message}"):
        pyshadow.CoherentShadowMap.build(mesh(), pyshadow.ViewSet.zigzag(4, 8), resolution=16, progress=False)
    with pytest.raises(ValueError, match=f"^CoherentShadowMap.build: {message}"):
        pyshadow.CoherentShadowMap.build(mesh(), max_error=0.05, progress=False)
