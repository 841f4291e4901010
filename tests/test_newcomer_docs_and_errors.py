"""A newcomer's pass over the README and the public API (helper newcomer): a camera changed in place, a scene's
CSM options checked when it is made, the CSM cache's (csm, info) pair given to ``Scene.add``, and the README's
sentences on the cache and the benchmark's files.

Each test whose docstring starts "Was:" failed on the code before the fix and says what happened.
"""
from __future__ import annotations

import re
import types

import numpy as np
import pytest
import trimesh

import pyshadow
from conftest import REPO

README = (REPO / "README.md").read_text()


def _same_frame(a, b):
    for k in ("eye", "target", "forward", "right", "up"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k), err_msg=k)
    np.testing.assert_array_equal(a.ray_directions(), b.ray_directions())


@pytest.mark.parametrize("name, index, value, eye, target", [
    ("eye", 1, 10.0, (3.0, 10.0, 4.0), (0.0, 0.5, 0.0)),
    ("target", 0, 1.0, (3.0, 2.0, 4.0), (1.0, 0.5, 0.0)),
])
def test_eye_or_target_changed_in_place_turns_the_frame(name, index, value, eye, target):
    """Was: ``camera.eye[1] = 10`` moved the eye but kept the old frame, so the camera looked past its target
    (forward (-0.575, -0.287, -0.766) where a camera made at the new eye has (-0.279, -0.885, -0.373)) and a
    render showed another view than ``camera.target`` says, without an error. Now the frame follows, bit for bit
    as a camera made anew; ``camera.eye += step`` still works."""
    cam = pyshadow.Camera((3.0, 2.0, 4.0), (0.0, 0.5, 0.0), width=8, height=6)
    getattr(cam, name)[index] = value
    _same_frame(cam, pyshadow.Camera(eye, target, width=8, height=6))
    cam.eye += np.array([1.0, 0.0, 0.0])
    _same_frame(cam, pyshadow.Camera(np.add(eye, (1.0, 0.0, 0.0)), target, width=8, height=6))


def test_frame_vectors_are_read_only():
    """Was: ``camera.forward[0] = 1`` was taken, leaving a frame that is not orthonormal."""
    cam = pyshadow.Camera((3.0, 2.0, 4.0), (0.0, 0.5, 0.0), width=8, height=6)
    for name in ("forward", "right", "up"):
        with pytest.raises(ValueError, match="read-only"):
            getattr(cam, name)[0] = 1.0


@pytest.mark.parametrize("options, error, match", [
    (dict(resolution=0), ValueError, "resolution must be in 1..4096"),
    (dict(resolution=1.5), TypeError, "resolution must be an int"),
    (dict(depth_bits=8), ValueError, "depth_bits must be 16 or 32"),
    (dict(layers=5), ValueError, "layers must be 'auto', 2 or 3"),
    (dict(views="zigzag"), TypeError, "views must be a pyshadow.ViewSet"),
])
def test_scene_checks_its_csm_options_when_made(options, error, match):
    """Was: ``Scene(resolution=0)`` (or a depth_bits of 8, views given as a string) was taken, and the error
    came only from the first mesh added, far from the line that made the scene."""
    with pytest.raises(error, match=match):
        pyshadow.Scene(ground=0.0, **options)


def test_scene_keeps_valid_options():
    views = pyshadow.ViewSet.hilbert(1)
    scene = pyshadow.Scene(views=views, resolution=8, depth_bits=32, layers=2)
    assert scene.csm_options == dict(views=views, resolution=8, depth_bits=32, layers=2, footprint=False)


@pytest.mark.parametrize("mesh", [False, True])
def test_scene_add_names_the_pair_csm_cache_returns(tmp_path, mesh):
    """Was: the pair ``(csm, info)`` that ``CSMCache.csm`` returns, given to ``Scene.add`` as the README's
    sentence read, raised "load_mesh expects a path, a trimesh.Trimesh/Scene or a pyvista mesh, got tuple", or
    with ``mesh=`` "mesh= is only for CSMs; pass the mesh as obj" (it was a CSM's pair)."""
    box = trimesh.creation.box()
    pair = pyshadow.cache.CSMCache(tmp_path).csm("box", box, pyshadow.ViewSet.zigzag(2, 4), 8, 16)
    scene = pyshadow.Scene(ground=-0.5)
    with pytest.raises(TypeError, match=r"\(CoherentShadowMap, dict\) pair, as CSMCache.csm returns"):
        scene.add(pair, mesh=box if mesh else None)
    assert len(scene.instances) == 0
    assert scene.add(pair[0], mesh=box if mesh else None) == 0
    with pytest.raises(ValueError, match="mesh= is only for CSMs"):
        scene.add(box, mesh=box)


def test_readme_cache_sentence_unpacks_the_pair():
    """Was: the README gave ``CSMCache(...).csm(...)`` as what "builds on the first call and loads on the next
    ones", which returns ``(csm, info)``, not a CSM."""
    assert re.search(r"`csm, info = pyshadow\.cache\.CSMCache\(", README)


def test_readme_names_every_file_the_main_job_writes():
    """Was: the README's first paragraph left out ``reference.exr`` and ``converged.exr``."""
    from pyshadow.bench.cli import _outputs

    first = README[README.index("The first command"):README.index("The second command")]
    args = types.SimpleNamespace(sweep=False, sky=None, light=None, frame_budget=None)
    for name in _outputs(args, answer_mode=False):
        assert f"`{name}`" in first, name


def test_a_pyvista_multiblock_is_refused_with_how_to_merge_it():
    """Was: ``load_mesh(pv.MultiBlock(...))`` (what ``pv.read`` gives for a multi-part file) said only
    "expected a pyvista dataset, got MultiBlock". Now the message says how to merge it, and the merged blocks
    load."""
    pv = pytest.importorskip("pyvista")
    blocks = pv.MultiBlock([pv.Cube(), pv.Cube(center=(3.0, 0.0, 0.0))])
    with pytest.raises(TypeError, match=r"got MultiBlock \(merge its blocks first: blocks\.combine\(\)\)"):
        pyshadow.load_mesh(blocks)
    assert pyshadow.load_mesh(blocks.combine()).faces.shape == (24, 3)
