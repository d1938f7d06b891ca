"""Parameter loading and validation (thesis App. A)."""

import math

import numpy as np
import pytest

from ballbot_casadi import PARAM_NAMES, ParameterError, Params, load_params
from ballbot_casadi.errors import BallbotTypeError


def test_defaults_are_thesis_appendix_a():
    p = load_params()
    expected = dict(Mb=16.154, l=0.4213, Jbx=4.173, Jby=4.161, Jbz=0.1004, Jw=3.19e-3, rw=0.05,
                    rk=0.129, Mk=1.478, Jk=15.4e-3, Bvk=0, Bvm=0, Bvb=0, tau_max=1.9825,
                    n_ticks=70997.33, g=9.81, com_x=0, com_y=0)
    for name, value in expected.items():
        assert getattr(p, name) == pytest.approx(value, rel=0, abs=1e-15), name
    assert p.alpha == pytest.approx(math.radians(45), abs=1e-15)
    assert p.gamma == pytest.approx(math.radians(120), abs=1e-15)
    assert p.beta > 0


def test_names_and_vector_order():
    p = load_params()
    assert p.names == PARAM_NAMES
    assert PARAM_NAMES[:3] == ("Mb", "l", "Jbx") and PARAM_NAMES[-1] == "beta"
    v = p.to_vector()
    assert v.shape == (len(PARAM_NAMES),)
    for i, n in enumerate(PARAM_NAMES):
        assert v[i] == getattr(p, n)
    assert Params.from_vector(v) == p


def test_immutable_and_replace():
    p = load_params()
    with pytest.raises(AttributeError):
        p.Mb = 3.0
    q = p.replace(Mb=20.0, alpha="30 deg")
    assert q.Mb == 20.0 and q.alpha == pytest.approx(math.pi / 6, abs=1e-15)
    assert p.Mb == 16.154


def test_overrides_and_file(tmp_path):
    f = tmp_path / "robot.toml"
    f.write_text('[body]\nMb = 18.5\n[wheels]\ngamma = "2.0 rad"\n')
    p = load_params(f, l=0.5)
    assert (p.Mb, p.gamma, p.l) == (18.5, 2.0, 0.5)
    assert p.Jbx == 4.173  # untouched values come from the defaults


@pytest.mark.parametrize(
    "kw, fragment",
    [
        ({"Mb": -1.0}, "'Mb'"),
        ({"Mk": 0.0}, "'Mk'"),
        ({"Jbz": float("nan")}, "'Jbz'"),
        ({"rk": float("inf")}, "'rk'"),
        ({"rw": 0}, "'rw'"),
        ({"Bvk": -0.1}, "'Bvk'"),
        ({"alpha": "95 deg"}, "'alpha'"),
        ({"gamma": 0.0}, "'gamma'"),
        ({"beta": -1.0}, "'beta'"),
    ],
)
def test_non_physical_values_rejected(kw, fragment):
    with pytest.raises(ParameterError) as exc:
        load_params(**kw)
    assert fragment in str(exc.value) and "must be" in str(exc.value)


def test_unknown_name_lists_allowed():
    with pytest.raises(ParameterError, match="unknown parameter.*'mass'.*allowed names: Mb"):
        load_params(mass=3)
    with pytest.raises(ParameterError, match="unknown"):
        load_params().replace(Jx=1.0)


@pytest.mark.parametrize("value", ["heavy", True, [1.0], None])
def test_wrong_type_rejected(value):
    with pytest.raises((BallbotTypeError, ParameterError)) as exc:
        load_params(Mb=value)
    assert isinstance(exc.value, (TypeError, ValueError))
    assert "'Mb'" in str(exc.value)


def test_bad_files(tmp_path):
    with pytest.raises(ParameterError, match="does not exist"):
        load_params(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("Mb = = 3")
    with pytest.raises(ParameterError, match="not valid TOML"):
        load_params(bad)
    unknown = tmp_path / "unknown.toml"
    unknown.write_text("[body]\nmass = 3\n")
    with pytest.raises(ParameterError, match="unknown parameter"):
        load_params(unknown)
    dup = tmp_path / "dup.toml"
    dup.write_text("[a]\nMb = 3\n[b]\nMb = 4\n")
    with pytest.raises(ParameterError, match="given twice"):
        load_params(dup)


def test_from_vector_wrong_size():
    with pytest.raises(ParameterError, match="expected 21"):
        Params.from_vector(np.ones(5))


@pytest.mark.parametrize("text, expected", [
    ("45deg", math.radians(45)), ("45 degrees", math.radians(45)), ("45 deg", math.radians(45)),
    (" 45 DEG ", math.radians(45)), ("30 degree", math.radians(30)), ("0.5rad", 0.5),
    ("0.5 radians", 0.5), ("1e-1 rad", 0.1),
])
def test_angle_strings_with_units(text, expected):
    assert load_params(alpha=text).alpha == pytest.approx(expected, rel=0, abs=1e-15)


def test_angle_given_as_plain_degrees_number_explains_radians():
    with pytest.raises(ParameterError) as exc:
        load_params(alpha=45)
    msg = str(exc.value)
    assert "'alpha'" in msg and "radians" in msg and '"45 deg"' in msg and "must be" in msg
    with pytest.raises(ParameterError, match='radians.*"120 deg"'):
        load_params(gamma=120)
    # a plain number that is wrong in degrees too: no misleading "did you mean"
    with pytest.raises(ParameterError, match='radians, give degrees as a string such as "45 deg"'):
        load_params(alpha=-0.1)
    for bad in ["45", "45 d", "deg", "x deg", "45 deg deg"]:
        with pytest.raises(BallbotTypeError, match="'<value> deg'"):
            load_params(alpha=bad)


@pytest.mark.parametrize("given", ["100 deg", "-1 rad", "1.6 radians"])
def test_an_angle_given_with_its_unit_gets_no_plain_number_hint(given):
    """The radians hint is for plain numbers only: a string with a unit meant what it said."""
    with pytest.raises(ParameterError) as exc:
        load_params(alpha=given)
    msg = str(exc.value)
    assert msg.endswith("must be an angle strictly between 0 and 90 deg"), msg
    assert "plain numbers" not in msg and "did you mean" not in msg


def test_a_non_angle_parameter_shows_its_value_without_radians_or_degrees():
    """Only angles are shown as "x rad (y deg)": a bad mass is shown as given."""
    with pytest.raises(ParameterError) as exc:
        load_params(Mb=-2.0)
    msg = str(exc.value)
    assert msg.startswith("parameter 'Mb' = -2.0 is invalid: must be"), msg
    assert "rad" not in msg and "deg" not in msg, msg


def test_a_numpy_number_gets_the_plain_number_hint():
    with pytest.raises(ParameterError, match='plain numbers are radians: did you mean "60 deg"'):
        load_params(alpha=np.float32(60.0))


# Expected rule of every parameter, written out independently of PARAM_INFO.
_EXPECTED_RULE = {
    **dict.fromkeys(["Mb", "Mk"], "mass"),
    **dict.fromkeys(["l", "rw", "rk"], "length"),
    **dict.fromkeys(["Jbx", "Jby", "Jbz", "Jk"], "inertia"),
    "Jw": "wheel_inertia",
    **dict.fromkeys(["Bvk", "Bvm", "Bvb"], "friction"),
    "tau_max": "torque",
    "n_ticks": "ticks",
    "g": "gravity",
    **dict.fromkeys(["com_x", "com_y"], "offset"),
    "beta": "baumgarte",
    "alpha": "alpha",
    "gamma": "gamma",
}
_TINY = 5e-324


def _up(v: float) -> float:
    return math.nextafter(v, math.inf)


def _down(v: float) -> float:
    return math.nextafter(v, -math.inf)


# rule -> (values exactly on or just inside a boundary that must pass, values that must fail)
_BOUNDARIES = {
    "mass": ([_TINY, 1e4], [0.0, -0.0, -_TINY, _up(1e4), math.inf]),
    "length": ([1e-3, 10.0], [_down(1e-3), _up(10.0), 0.0, math.inf]),
    "inertia": ([_TINY, 1e4], [0.0, -_TINY, _up(1e4)]),
    "wheel_inertia": ([_TINY, 1.0], [0.0, _up(1.0)]),
    "friction": ([0.0, -0.0, 1e3], [-_TINY, _up(1e3), math.inf]),
    "torque": ([_TINY, 1e3], [0.0, _up(1e3)]),
    "ticks": ([_TINY, 1e9], [0.0, _up(1e9)]),
    "gravity": ([0.0, 100.0], [-_TINY, _up(100.0)]),
    "offset": ([-1.0, 1.0, 0.0], [_down(-1.0), _up(1.0), math.nan]),
    "baumgarte": ([0.0, 2000.0], [-_TINY, _up(2000.0)]),
    "alpha": ([_TINY, math.nextafter(math.pi / 2, 0.0)], [0.0, math.pi / 2, -_TINY]),
    "gamma": ([_TINY, math.nextafter(math.pi, 0.0)], [0.0, math.pi, -_TINY]),
}


def test_every_parameter_has_its_expected_rule():
    from ballbot_casadi.core.params import PARAM_INFO

    assert {n: PARAM_INFO[n][2] for n in PARAM_NAMES} == _EXPECTED_RULE


@pytest.mark.parametrize("name", list(_EXPECTED_RULE))
def test_range_boundary_exactly(name):
    """Sit exactly on each range boundary: a '<' turned into '<=' (or back) fails here."""
    good, bad = _BOUNDARIES[_EXPECTED_RULE[name]]
    for v in good:
        assert getattr(load_params(**{name: v}), name) == v
    for v in bad:
        with pytest.raises(ParameterError, match=f"'{name}'.*must be"):
            load_params(**{name: v})


def test_range_rules_defined_once_as_plain_tuples():
    """PARAM_RULES is the one table; (lo, hi, lo_open, hi_open, text) tuples others can read."""
    from ballbot_casadi.core.params import PARAM_INFO, PARAM_RULES

    assert {rule for _, _, rule in PARAM_INFO.values()} <= set(PARAM_RULES)
    for rule in PARAM_RULES.values():
        lo, hi, lo_open, hi_open, text = rule  # unpacks like the FMU's table
        assert lo < hi and isinstance(lo_open, bool) and isinstance(hi_open, bool) and text
        # contains() agrees with the tuple on its own boundaries
        assert rule.contains(lo) is (not lo_open) or not math.isfinite(lo)
        assert rule.contains(hi) is (not hi_open) or not math.isfinite(hi)
    assert PARAM_RULES["alpha"][:4] == (0.0, math.pi / 2, True, True)
    with pytest.raises(TypeError):
        PARAM_RULES["mass"] = PARAM_RULES["any"]  # read-only


def test_sensors_table_is_skipped(tmp_path):
    f = tmp_path / "with_sensors.toml"
    f.write_text('[sensors]\nacc_bias = [0.0, 0.0, 0.1]\n[body]\nMb = 17.0\n')
    assert load_params(f).Mb == 17.0
