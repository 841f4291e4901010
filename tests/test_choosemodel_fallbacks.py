"""Choosing a CSM (pyshadow.csm.choose): what is built and said where the model was shown wrong or the size
prediction fell short."""
import re

import numpy as np
import pytest
import trimesh

import pyshadow.csm.choose as choose
from pyshadow.csm.choose import choose_csm, choose_within

TINY = dict(points=60, samples=4, near=300)
#: by build work (maps x texels): 8,192, 32,768, 131,072, 524,288
LADDER = ((4, 8, 16), (8, 16, 16), (8, 16, 32), (16, 32, 32))


@pytest.fixture(scope="module")
def box():
    return trimesh.creation.box()


def _by_work(*args, **kwargs):
    """A stand-in for the size model (no pilot builds): bytes grow with maps x texels."""
    return (lambda theta, phi, resolution: float(theta * phi * resolution ** 2)), {"seconds_per_work": 1e-9}


def _fake_predict(table):
    """A stand-in for the error model: ``table[candidate] = (disagreement, (low, high))`` on the own rays."""
    def fake(mesh, maps, resolution, depth_bits, lookup, *, rays=None):
        e, interval = table[(maps[0], maps[1], resolution)]
        return {"layout": f"{maps[0]}x{maps[1]} r{resolution} {depth_bits}b", "maps": [int(maps[0]), int(maps[1])],
                "resolution": int(resolution), "depth_bits": int(depth_bits), "lookup": lookup,
                "own": {"disagreement": e, "interval": interval, "rays": 1000}, "disagreement": e}
    return fake


def test_model_predicting_zero_then_missing_keeps_the_most_accurate_fallback(box, monkeypatch):
    """Was: where the first candidate was predicted 0.0 and measured a miss (0.05 for 0.01: the model's
    target for its lookup became 0), every other prediction was 'infinitely' far from it and the fallback
    built the smallest candidate left, 8x16 r16 predicted 0.020, not 8x16 r32 predicted 0.012, the most
    accurate. Now the predictions are still ranked by their disagreement."""
    table = {LADDER[0]: (0.0, (0.0, 0.004)), LADDER[1]: (0.020, (0.017, 0.023)),
             LADDER[2]: (0.012, (0.011, 0.0125)), LADDER[3]: (0.030, (0.027, 0.033))}
    monkeypatch.setattr(choose, "size_model", _by_work)
    monkeypatch.setattr(choose, "predict", _fake_predict(table))
    monkeypatch.setattr(choose, "measure", lambda csm, mesh, rays, lk: {"disagreement": 0.05})
    with pytest.warns(UserWarning, match="no candidate CSM meets"):
        csm, c = choose_csm(box, 0.01, **TINY, candidates=LADDER)
    built = [t["predicted"]["layout"] for t in c["tried"] if "bytes" in t]
    assert built == ["4x8 r16 16b", "8x16 r32 16b"], built
    assert (tuple(c["maps"]), c["resolution"]) == ((8, 16), 32)


def test_within_budget_error_says_the_predicted_fits_were_built_larger(box):
    """Was: a budget the size model's prediction fit but the built CSM did not (4x8 r16 of the box: 7336 bytes
    predicted, 7376 built, max_bytes=7350) raised 'no candidate CSM fits in 7350 bytes (the smallest is
    predicted at 7336 bytes)': a prediction inside the budget given as the reason nothing fits. Now the
    message says the candidate predicted to fit was built larger, and its size."""
    with pytest.raises(ValueError) as err:
        choose_within(box, 7350, candidates=LADDER[:1], verify=False, **TINY)
    msg = str(err.value)
    m = re.search(r"no candidate CSM fits in 7350 bytes \(1 candidate predicted to fit was built larger; the "
                  r"smallest built, 4x8 r16 16b, takes (\d+) bytes\)$", msg)
    assert m, msg
    assert int(m.group(1)) > 7350


def test_largest_seed_is_taken_for_the_check_too(box, monkeypatch):
    """Was: seed=2**32 - 1 (the largest the ray draws take) raised 'seed must be in 0..4294967295 ..., got
    4294967296' from the verification's seed + 1, and np.int32(2**31 - 1) overflowed to -2**31 (a
    RuntimeWarning, then the same ValueError). Now the check's seed wraps past the largest to 0."""
    from pyshadow.sampling import MAX_SEED

    monkeypatch.setattr(choose, "size_model", _by_work)         # no pilot builds
    for seed in (MAX_SEED, np.int32(2 ** 31 - 1), np.uint32(MAX_SEED)):
        csm, c = choose_csm(box, 0.5, seed=seed, **TINY, candidates=LADDER[:1])
        assert c["met"] and 0.0 <= c["measured"]["disagreement"] <= 0.5, seed
    csm, c = choose_within(box, 10 ** 6, seed=MAX_SEED, **TINY, candidates=LADDER[:1])
    assert 0.0 <= c["measured"]["disagreement"] <= 1.0
    assert choose._check_seed(7) == 8 and choose._check_seed(MAX_SEED) == 0
