"""A CSM chosen for an accuracy with one lookup, asked with the other (pyshadow/csm/choose.py,
``warn_unchosen_lookup``).

``Scene.add(mesh, max_error=..., lookup="auto")`` may choose the vote; the
scene's queries ask ``lookup="nearest"`` unless told, and the accuracy
chosen holds for the chosen lookup only.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.csm.choose import choose_csm

TINY = dict(points=60, samples=4, near=300)
SMALL = ((4, 8, 16), (8, 16, 16), (4, 8, 32))


@pytest.fixture(scope="module")
def chosen():
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)         # the tiny candidates miss the target: said, not here
        csm, c = choose_csm(box, 0.01, lookup="vote", verify=False, **TINY, candidates=SMALL)
    assert c["lookup"] == "vote"
    csm.choice = c                                        # as build(max_error=...) keeps it
    return box, csm


def _scene(box, csm):
    scene = pyshadow.Scene(ground=None)
    scene.add(csm, np.eye(4), mesh=box)
    return scene


def test_the_other_lookup_is_said(chosen):
    """Was: a query with the default lookup answered from a CSM chosen for the vote, silently, at an error the
    choice never measured."""
    p, d = np.array([[0.0, 2.0, 0.0]]), np.array([[0.0, -1.0, 0.0]])
    with pytest.warns(UserWarning, match="lookup='vote'"):
        assert not _scene(*chosen).visible(p, d)[0]


def test_the_chosen_lookup_and_plain_csms_say_nothing(chosen):
    """The chosen lookup warns nothing, nor does a CSM built without a choice."""
    p, d = np.array([[0.0, 2.0, 0.0]]), np.array([[0.0, -1.0, 0.0]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert not _scene(*chosen).visible(p, d, lookup="vote")[0]
        plain = pyshadow.CoherentShadowMap.build(chosen[0], pyshadow.ViewSet.zigzag(4, 8), resolution=16,
                                                 progress=False)
        assert not _scene(chosen[0], plain).visible(p, d)[0]
