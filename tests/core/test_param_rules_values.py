"""Each parameter range rule by hand: its ends, which end is open (as its own message
text says: "> 0", "strictly between", "between ... and ..."), and ``contains`` exactly at,
one ulp inside and one ulp outside each finite end."""

from __future__ import annotations

import math

import pytest

from ballbot_casadi.core.params import PARAM_RULES

PI = math.pi
#: key: (lo, hi, lo included, hi included), written from the texts of the rules
HAND = {
    "pos": (0.0, math.inf, False, True),
    "nonneg": (0.0, math.inf, True, True),
    "mass": (0.0, 1e4, False, True),
    "length": (1e-3, 10.0, True, True),
    "inertia": (0.0, 1e4, False, True),
    "wheel_inertia": (0.0, 1.0, False, True),
    "friction": (0.0, 1e3, True, True),
    "torque": (0.0, 1e3, False, True),
    "ticks": (0.0, 1e9, False, True),
    "gravity": (0.0, 100.0, True, True),
    "offset": (-1.0, 1.0, True, True),
    "baumgarte": (0.0, 2000.0, True, True),
    "any": (-math.inf, math.inf, True, True),
    "alpha": (0.0, PI / 2, False, False),
    "gamma": (0.0, PI, False, False),
    "misalignment": (-PI / 4, PI / 4, True, True),
}


def test_every_rule_is_in_the_hand_table():
    assert set(PARAM_RULES) == set(HAND)


@pytest.mark.parametrize("key", sorted(HAND))
def test_rule_ends_and_openness(key):
    rule = PARAM_RULES[key]
    lo, hi, lo_in, hi_in = HAND[key]
    assert (rule.lo, rule.hi) == (lo, hi)
    if math.isfinite(lo):
        assert rule.contains(lo) is lo_in
        assert rule.contains(math.nextafter(lo, math.inf)) is True
        assert rule.contains(math.nextafter(lo, -math.inf)) is False
    if math.isfinite(hi):
        assert rule.contains(hi) is hi_in
        assert rule.contains(math.nextafter(hi, -math.inf)) is True
        assert rule.contains(math.nextafter(hi, math.inf)) is False
    for bad in (math.nan, math.inf, -math.inf):
        assert rule.contains(bad) is False
    # the message text says the same
    text = rule.text
    if "strictly between" in text:
        assert not lo_in and not hi_in
    elif "> 0" in text:
        assert not lo_in
    elif "between" in text:
        assert lo_in and hi_in
