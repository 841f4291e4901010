"""A choice of CSM tries only the candidates the memory free can build and check (pyshadow.csm.room):
the others are named, and where none fits a MemoryError says so before any large build."""
import warnings

import pytest

import pyshadow
import pyshadow.csm.build as build_mod
from pyshadow.csm.choose import choose_csm, choose_within, size_model
from pyshadow.csm.room import FIXED, HOLD, need

CANDS = ((4, 8, 16), (8, 16, 32), (16, 32, 64))
RAYS = dict(points=200, samples=4, near=1000)


@pytest.fixture(scope="module")
def torus():
    return pyshadow.data.mesh("torus")


@pytest.fixture(scope="module")
def sizes(torus):
    size, _ = size_model(torus)
    return [size(*c) for c in CANDS]


def layouts(choice):
    return {(*t["predicted"]["maps"], t["predicted"]["resolution"]) for t in choice["tried"]}


def test_need_grows_with_the_check():
    assert need(1e9, True) == FIXED + HOLD[True] * 1e9 > need(1e9, False) == FIXED + HOLD[False] * 1e9


def test_candidates_past_the_memory_free_are_not_tried_and_are_named(torus, sizes, monkeypatch):
    """Memory free for the middle candidate, checked, and not the largest: the largest is neither predicted
    nor built, the choice records it, and the warning of a missed target names it."""
    assert sizes[0] < sizes[1] < sizes[2]
    free = int(need(sizes[1], True)) + 1
    assert need(sizes[2], True) > free
    monkeypatch.setattr(build_mod, "available_memory", lambda: free)
    with pytest.warns(UserWarning, match=r"no candidate CSM meets.*1 candidate predicted to need more than the "
                                         r"[0-9.]+ GiB of memory free was not tried \(16x32 r64\)"):
        csm, c = choose_csm(torus, 1e-6, candidates=CANDS, **RAYS)
    assert c["left_out_for_memory"] == {"memory_free": free, "candidates": ["16x32 r64"]}
    assert layouts(c) == set(CANDS[:2])
    assert (csm.views.params["theta"], csm.resolution) in ((4, 16), (8, 32))
    # unchecked, a build holds less: the same memory then holds the largest too
    if need(sizes[2], False) <= free:
        with pytest.warns(UserWarning, match="no candidate CSM meets"):
            _, c = choose_csm(torus, 1e-6, candidates=CANDS, verify=False, **RAYS)
        assert c["left_out_for_memory"] is None and layouts(c) == set(CANDS)


def test_no_candidate_in_the_memory_free_is_a_memory_error(torus, sizes, monkeypatch):
    free = int(need(sizes[0], True)) - 1
    monkeypatch.setattr(build_mod, "available_memory", lambda: free)
    with pytest.raises(MemoryError, match=r"choose_csm: no candidate CSM can be built and checked in the [0-9.]+ "
                                          r"GiB of memory free: the smallest, 4x8 r16, is predicted at"):
        choose_csm(torus, 0.05, candidates=CANDS, **RAYS)
    with pytest.raises(MemoryError, match="choose_within: no candidate CSM can be built and checked"):
        choose_within(torus, 10 ** 9, candidates=CANDS, **RAYS)


def test_memory_unknown_or_ample_leaves_every_candidate(torus, monkeypatch):
    for free in (None, 1 << 50):
        monkeypatch.setattr(build_mod, "available_memory", lambda: free)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            _, c = choose_csm(torus, 1e-6, candidates=CANDS, **RAYS)
        assert c["left_out_for_memory"] is None and layouts(c) == set(CANDS)


def test_the_budget_direction_tries_only_what_memory_holds(torus, sizes, monkeypatch):
    """choose_within: a budget larger than every candidate, memory for the smallest two: the most accurate
    of those two, the largest never predicted."""
    free = int(need(sizes[1], True)) + 1
    monkeypatch.setattr(build_mod, "available_memory", lambda: free)
    csm, c = choose_within(torus, 10 ** 12, candidates=CANDS, **RAYS)
    assert c["left_out_for_memory"]["candidates"] == ["16x32 r64"]
    assert layouts(c) == set(CANDS[:2])
    assert csm.stats["bytes"] <= sizes[1] * 1.5
