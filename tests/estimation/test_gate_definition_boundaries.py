"""The innovation gate's definition checks on both sides of every boundary: probability in
the open interval (0, 1), scale finite and > 0, at least one rejection, indices inside the
measurement vector, non-empty disjoint groups, and the thresholds as scaled chi-square
quantiles."""

from __future__ import annotations

import math

import pytest
from scipy.stats import chi2

from ballbot_casadi.errors import BallbotTypeError, ShapeError
from ballbot_casadi.estimation.core import InnovationGate

G = (("a", (0,)),)


@pytest.mark.parametrize("kw", [{"probability": 0.0}, {"probability": 1.0}, {"probability": -0.1},
                                {"scale": 0.0}, {"scale": math.inf}, {"scale": math.nan},
                                {"max_rejections": 0}, {"max_rejections": 2.0}])
def test_out_of_range_settings_are_refused(kw):
    with pytest.raises(ShapeError):
        InnovationGate(G, **kw)


@pytest.mark.parametrize("kw", [{"probability": 1e-9}, {"probability": 1 - 1e-12}, {"scale": 1e-9},
                                {"max_rejections": 1}])
def test_settings_just_inside_the_range_are_accepted(kw):
    InnovationGate(G, **kw)


@pytest.mark.parametrize("groups,err", [((), ShapeError), ((("a", ()),), BallbotTypeError),
                                        ((("a", (-1,)),), BallbotTypeError),
                                        ((("a", (0, 1)), ("b", (2, 0))), ShapeError)])
def test_bad_groups_are_refused(groups, err):
    with pytest.raises(err):
        InnovationGate(groups)


def test_indices_must_lie_inside_the_measurement_vector():
    gate = InnovationGate((("a", (0, 1)), ("b", (2,))))
    assert gate.function(3).name() == "innovation_gate"
    with pytest.raises(ShapeError, match="beyond"):
        gate.function(2)


def test_thresholds_are_scaled_quantiles_per_number_of_valid_components():
    gate = InnovationGate((("a", (0, 1, 2)), ("b", (3,))), probability=0.99, scale=2.5)
    th = gate.thresholds()
    assert [len(t) for t in th] == [3, 1]
    for k in (1, 2, 3):
        assert th[0][k - 1] == pytest.approx(2.5 * chi2.ppf(0.99, k), rel=1e-12)
    assert th[1][0] == pytest.approx(2.5 * chi2.ppf(0.99, 1), rel=1e-12)
    assert gate.names == ("a", "b")
