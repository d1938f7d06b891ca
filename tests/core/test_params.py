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
