"""Bad input and edge cases of choosing a CSM from the accuracy or the size asked for (pyshadow.csm.choose,
pyshadow.csm.error_model)."""
import gc
import itertools
import re
import weakref
from fractions import Fraction

import numpy as np
import pytest
import trimesh

import pyshadow
import pyshadow.csm.choose as choose
from pyshadow.csm.choose import choose_csm, choose_within
from pyshadow.csm.error_model import MODEL_RATIO, predict, rays_for

TINY = dict(points=60, samples=4, near=300)
SMALL = ((4, 8, 16), (8, 16, 16), (4, 8, 32))


@pytest.fixture(scope="module")
def box():
    return trimesh.creation.box()


def _fake_predict(value):
    """A stand-in for the error model: ``value(maps, resolution)`` as the disagreement, no tracing."""
    def fake(mesh, maps, resolution, depth_bits, lookup, *, rays=None):
        return {"layout": f"{maps[0]}x{maps[1]} r{resolution} {depth_bits}b", "maps": [int(maps[0]), int(maps[1])],
                "resolution": int(resolution), "depth_bits": int(depth_bits), "lookup": lookup,
                "disagreement": value(maps, resolution)}
    return fake


def test_max_error_must_be_a_real_number(box):
    """choose_csm took max_error="0.01" (a string) as 0.01 and built a CSM; True and False were refused
    only as 1.0 and 0.0 out of range (ValueError), not as the wrong type."""
    for v in ("0.01", True, False, np.bool_(True), None, [0.01]):
        with pytest.raises(TypeError, match="max_error must be a float"):
            choose_csm(box, v, **TINY, candidates=SMALL[:1])
    for v in (0, 0.0, 1, 1.5, -0.01, float("nan"), float("inf"), np.int64(0), 10 ** 400):
        with pytest.raises(ValueError, match=r"max_error must lie in \(0, 1\)"):
            choose_csm(box, v, **TINY, candidates=SMALL[:1])


def test_max_bytes_must_be_a_finite_positive_number(box):
    """max_bytes=inf raised OverflowError and nan a bare 'cannot convert float NaN to integer'; 0.5 was
    reported as 'got 0'; True was taken as 1 byte and "1000000" as a number, after drawing the rays and
    building the pilots; no candidates at all ended in 'min() arg is an empty sequence'."""
    for v in (float("inf"), -float("inf"), float("nan")):
        with pytest.raises(ValueError, match="max_bytes must be finite"):
            choose_within(box, v, **TINY, candidates=SMALL)
    for v in (0, -5, 0.5, np.int64(0)):
        with pytest.raises(ValueError, match=rf"max_bytes must be positive .*got {re.escape(repr(v))}$"):
            choose_within(box, v, **TINY, candidates=SMALL)
    for v in (True, np.bool_(True), "1000000", None, 1j):
        with pytest.raises(TypeError, match="max_bytes must be a number of bytes"):
            choose_within(box, v, **TINY, candidates=SMALL)
    with pytest.raises(ValueError, match="at least one candidate"):
        choose_within(box, 10 ** 6, **TINY, candidates=())
    with pytest.raises(TypeError, match="max_bytes"):
        pyshadow.CoherentShadowMap.build(box, max_bytes=True, progress=False)
    # a float budget of a whole number of bytes, a Fraction and a huge int still work (bytes compare as ints)
    for v in (1.5e6, Fraction(3, 2) * 10 ** 6, 10 ** 400):
        csm, c = choose_within(box, v, **TINY, verify=False, candidates=SMALL[:1])
        assert c["budget_bytes"] == int(v) and csm.stats["bytes"] <= c["budget_bytes"]


def test_predict_validates_its_layout():
    """predict took depth_bits 8 or 24 (modelled silently as 32-bit), resolution 0 or -4 (a prediction
    out of divisions by zero, with RuntimeWarnings) and 16.5 (taken as 16)."""
    ball = trimesh.creation.icosphere(1)
    rays = rays_for(ball, points=20, samples=2, near=50)
    for d in (8, 24, True, "16"):
        with pytest.raises(ValueError, match="depth_bits must be 16 or 32"):
            predict(ball, (4, 8), 16, depth_bits=d, rays=rays)
    for r in (0, -4, 4097):
        with pytest.raises(ValueError, match="resolution must be in"):
            predict(ball, (4, 8), r, rays=rays)
    for r in (16.5, 16.0, True):
        with pytest.raises(TypeError, match="resolution must be an int"):
            predict(ball, (4, 8), r, rays=rays)
    with pytest.raises(ValueError, match="lookup must be"):
        predict(ball, (4, 8), 16, lookup="auto", points=20, samples=2, near=50)
    assert predict(ball, (4, 8), np.int64(16), depth_bits=np.int64(32), rays=rays)["layout"] == "4x8 r16 32b"


def test_prediction_is_scale_free_down_to_micrometres():
    """The same torus in micrometres: trimesh zeroes the face normals of faces that small, and the own AO
    rays failed ('normals: N rows are zero vectors') though the CSM builds. The prediction is now the same
    at 1e-6, 1e6 and far from the origin."""
    torus = pyshadow.data.mesh("torus")
    kw = dict(points=120, samples=4, near=600, seed=3)
    ref = predict(torus, (8, 16), 32, **kw)
    assert ref["own"]["disagreement"] > 0 and ref["near"]["disagreement"] > 0
    for scale, offset in ((1e-6, 0.0), (1e6, 0.0), (1e-6, 1e-3), (1.0, 1e6)):
        m = torus.copy()
        m.apply_scale(scale)
        m.apply_translation([offset, -offset, 0.0])
        p = predict(m, (8, 16), 32, **kw)
        for k in ("own", "near"):
            assert p[k]["disagreement"] == pytest.approx(ref[k]["disagreement"], rel=1e-9, abs=1e-15), (scale, k)


def test_unverified_choice_reports_met_as_the_walk_decided(box, monkeypatch):
    """Without verify, the walk keeps a candidate whose prediction is at most max_error / MODEL_RATIO[1];
    'met' was recomputed as prediction * MODEL_RATIO[1] <= max_error, which rounding can turn False for
    the very candidate the walk accepted: it stopped there, then warned that no candidate met the target."""
    target = 0.0495435087091941                        # (target / 1.3) * 1.3 > target in floating point
    assert (target / MODEL_RATIO[1]) * MODEL_RATIO[1] > target
    monkeypatch.setattr(choose, "predict", _fake_predict(lambda maps, res: target / MODEL_RATIO[1]))
    csm, c = choose_csm(box, target, verify=False, **TINY, candidates=SMALL)     # warnings are errors here
    assert c["met"] and len(c["tried"]) == 1 and "bytes" in c["tried"][0]


def test_no_candidate_met_warning_names_what_is_kept(box, monkeypatch):
    """The warning called the last candidate's measurement 'best' when an earlier build had measured
    lower, left out the lookup kept, and without verify gave prediction x MODEL_RATIO[1] as 'predicted'."""
    monkeypatch.setattr(choose, "predict", _fake_predict(lambda maps, res: 0.0))      # every candidate is built
    got = itertools.count()
    monkeypatch.setattr(choose, "measure", lambda csm, mesh, rays, lk: {"disagreement": (0.02, 0.05, 0.03)[next(got)]})
    with pytest.warns(UserWarning, match="no candidate CSM meets max_error=0.01") as w:
        csm, c = choose_csm(box, 0.01, **TINY, candidates=SMALL)
    msg = str(w[0].message)
    assert not c["met"] and c["measured"]["disagreement"] == 0.03
    assert "(nearest): measured 0.0300" in msg and "the lowest measured, 0.0200" in msg, msg
    first = next(t for t in c["tried"] if t["measured"]["disagreement"] == 0.02)["predicted"]["layout"]
    assert first in msg and first != c["predicted"]["layout"]
    monkeypatch.setattr(choose, "predict", _fake_predict(lambda maps, res: 0.5))
    with pytest.warns(UserWarning, match="no candidate CSM meets") as w:
        csm, c = choose_csm(box, 0.01, lookup="auto", verify=False, **TINY, candidates=SMALL)
    msg = str(w[0].message)
    assert c["lookup"] == "vote" and "(vote): predicted 0.5000, up to 0.6500" in msg, msg


def test_rejected_csms_are_let_go_before_the_next_build(box, monkeypatch):
    """choose_csm and choose_within kept every CSM built (the pilots, every miss, every over-budget
    build) alive in their cache until they returned: the next, larger candidate was built while all the
    rejected ones were still held. Only a CSM a later candidate reuses is kept now."""
    real, seen = choose._build, []

    def spy(mesh, cand, depth_bits, layers, progress, built):
        if cand not in built:
            gc.collect()
            alive = [c for c, ref in seen if ref() is not None]
            if cand in SMALL:           # no pilot (none is a candidate here), no earlier miss still held
                assert alive == [], (cand, alive)
            out = real(mesh, cand, depth_bits, layers, progress, built)
            seen.append((cand, weakref.ref(out[0])))
            return out
        return real(mesh, cand, depth_bits, layers, progress, built)
    monkeypatch.setattr(choose, "_build", spy)
    monkeypatch.setattr(choose, "predict", _fake_predict(lambda maps, res: 0.0))
    monkeypatch.setattr(choose, "measure", lambda csm, mesh, rays, lk: {"disagreement": 0.5})
    with pytest.warns(UserWarning, match="no candidate CSM meets"):
        csm, c = choose_csm(box, 0.01, **TINY, candidates=SMALL)
    assert sum(c in SMALL for c, _ in seen) == 3 and (tuple(c["maps"]) + (c["resolution"],)) == seen[-1][0]
    # the budget's walk: every candidate predicted to fit, none does once built
    seen.clear()
    monkeypatch.setattr(choose, "size_model", lambda *a, **k: ((lambda t, p, r: 1.0), {}))
    with pytest.raises(ValueError, match="no candidate CSM fits in 100 bytes"):
        choose_within(box, 100, **TINY, candidates=SMALL)
    assert sorted(c for c, _ in seen) == sorted(SMALL)


@pytest.mark.parametrize("bad, error", [("abc", TypeError), ("0.01", TypeError), (True, TypeError), (2.0, ValueError)])
def test_scene_add_checks_max_error_before_anything_is_built(bad, error):
    """Scene.add(max_error="abc") failed in its own float() with Python's generic message."""
    scene = pyshadow.Scene()
    with pytest.raises(error, match="max_error"):
        scene.add(trimesh.creation.box(), max_error=bad)
    assert scene.instances == []
