"""The error model on shapes it was not calibrated on (benchmarks/error_model.py's part 4): a comb of thin fins
with narrow gaps and a thin ring. Its constants and rules were measured on the bundled meshes; here the choice
for a 2 % target is built and verified on independent rays, and the measured disagreement must lie within issue
22's factor 1.5 of the prediction and meet the target."""
from __future__ import annotations

import sys
import warnings

import pytest

import pyshadow
from conftest import REPO

sys.path.insert(0, str(REPO / "benchmarks"))


@pytest.mark.parametrize("name", ["comb", "ring"])
def test_prediction_holds_on_a_shape_outside_the_calibration(name):
    from error_model import SHAPES

    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)        # a miss would warn
        csm = pyshadow.CoherentShadowMap.build(SHAPES[name](), max_error=0.02, progress=False)
    c = csm.stats["choice"]
    predicted, measured = c["predicted"]["disagreement"], c["measured"]["disagreement"]
    assert c["met"] and measured <= 0.02
    # measured on 32,000 own and 16,000 near rays: the Wilson half-width at 1.5 % is about 0.2 points,
    # a seventh of the prediction, well inside the factor
    assert predicted > 0.002, "the shape must be hard enough for the factor to mean something"
    assert 1 / 1.5 <= measured / predicted <= 1.5, (predicted, measured)
