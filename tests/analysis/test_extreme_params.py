"""Legal but extreme parameters: a clear result or a clear refusal, never a LinAlgError.

``g = 0`` leaves nothing for the velocity loop to act through (no stabilising discrete
LQR gain exists): the closed-loop part is skipped with that message; a 10 t body on a
1e-3 kg.m2 inertia has a 240 rad/s tilt mode whose Gramian over 1 s would overflow (the
horizon is shortened and reported); ``l = 1e-9``, ``Mb = 1e6`` or ``Mb = 1e308`` are
outside the physical ranges the model supports and refused with the reason.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from ballbot_casadi import cli, load_params
from ballbot_casadi.analysis import closed_loop as cla
from ballbot_casadi.analysis import linear as an
from ballbot_casadi.control import design_velocity_lqr
from ballbot_casadi.core.layout import STATE
from ballbot_casadi.errors import ParameterError
from ballbot_casadi.model.dynamics import make_model_functions

NO_GAIN = "no stabilising velocity gain exists for these parameters"


@pytest.fixture(scope="module")
def funcs():
    return make_model_functions()


@pytest.mark.parametrize("override", [{"g": 0.0}])
def test_no_stabilising_velocity_gain_is_a_result(funcs, override):
    params = load_params(**override)
    with pytest.raises(ParameterError, match=NO_GAIN):
        design_velocity_lqr(funcs["jac"], params.to_vector())
    lin, plant = an.analyze_plant(params, functions=funcs)
    assert plant["controllability_rank"] <= 10 and plant["n_states_reduced"] == 10
    cl = cla.analyze_closed_loop(params, lin, funcs)
    assert cl["closed_loop"]["status"] == "skipped"
    assert cl["closed_loop"]["message"].startswith(NO_GAIN)
    assert cl["bandwidth_inner_hz"] is None and cl["cascade_rule_ok"] is None


def test_without_gravity_nothing_is_unstable(funcs):
    _, plant = an.analyze_plant(load_params(g=0.0), functions=funcs)
    assert plant["unstable_poles"] == []  # the pendulum needs gravity to fall


@pytest.mark.parametrize("override, reason", [
    ({"l": 1e-9}, "between 1 mm and 10 m"), ({"Mb": 1e6}, "<= 10000 kg"), ({"Mb": 1e308}, "<= 10000 kg")])
def test_unsupported_parameters_are_refused_with_the_physical_range(override, reason):
    with pytest.raises(ParameterError, match=reason):
        load_params(**override)


def _fastest_mode(lin):
    """max |Re lambda| of the scaled state matrix, the rate the Gramian horizon is limited by."""
    return max(abs(np.linalg.eigvals(an.state_scaling(lin)[0]).real))


def test_fast_modes_shorten_the_gramian_horizon(funcs):
    params = load_params(Mb=1e4, Jbx=1e-3, Jby=1e-3)
    lin, plant = an.analyze_plant(params, functions=funcs)
    T = plant["controllability"]["gramian_horizon_s"]
    lam = _fastest_mode(lin)
    assert lam > 200  # the heavy body falls fast
    assert T == pytest.approx(an._MAX_GRAMIAN_EXPONENT / lam, rel=1e-12) and T < 1.0
    energies = [m["energy"] for m in plant["controllability"]["modes"]]
    assert all(not np.isnan(e) and e > 0 for e in energies)  # inf: out of reach in T
    # the default robot keeps the requested 1 s horizon
    _, default = an.analyze_plant(load_params(), functions=funcs)
    assert default["controllability"]["gramian_horizon_s"] == 1.0


def test_a_requested_horizon_is_kept_when_short_enough_and_shortened_when_not(funcs):
    """The limit is on max|Re lambda| * T: with the 240 rad/s tilt mode, T = 0.05 s
    (exponent 12) is kept and T = 0.5 s (exponent 120) is cut to 30 / max|Re lambda|."""
    params = load_params(Mb=1e4, Jbx=1e-3, Jby=1e-3)
    lin, short = an.analyze_plant(params, functions=funcs, horizon=0.05)
    lam = _fastest_mode(lin)
    assert 0.05 * lam < an._MAX_GRAMIAN_EXPONENT < 0.5 * lam
    assert short["controllability"]["gramian_horizon_s"] == 0.05
    _, long = an.analyze_plant(params, functions=funcs, horizon=0.5)
    assert long["controllability"]["gramian_horizon_s"] == pytest.approx(
        an._MAX_GRAMIAN_EXPONENT / lam, rel=1e-12)


def test_cli_reports_the_skipped_closed_loop(tmp_path, capsys):
    pfile = tmp_path / "robot.toml"
    pfile.write_text("[environment]\ng = 0.0\n")
    out = tmp_path / "out"
    assert cli.main(["analyze", "--params", str(pfile), "--out", str(out), "--no-plots"]) == 0
    data = json.loads((out / "analysis.json").read_text())
    assert data["closed_loop"]["status"] == "skipped"
    assert NO_GAIN in (out / "analysis.md").read_text()
    assert NO_GAIN in capsys.readouterr().out


def test_cli_refuses_overflowing_parameters_in_one_line(tmp_path, capsys):
    pfile = tmp_path / "robot.toml"
    pfile.write_text("[body]\nMb = 1e308\n")
    rc = cli.main(["analyze", "--params", str(pfile), "--out", str(tmp_path / "o"), "--no-plots"])
    assert rc == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "'Mb'" in err and "10000 kg" in err and "Traceback" not in err
    assert not (tmp_path / "o").exists()


def test_an_operating_point_where_the_model_overflows_names_the_largest_parameters(funcs):
    """The refusal names the three parameters of largest magnitude, largest first, with
    their values (API path: the command line bounds the operating point before)."""
    params = load_params()
    vals = params.as_dict()
    top = sorted(vals, key=lambda k: -abs(float(vals[k])))[:3]
    x = np.zeros(len(STATE))
    x[STATE.offset("q")], x[STATE.index("dx")] = 1.0, 1e200  # upright, absurd ball speed
    with pytest.raises(ParameterError) as e:
        an.analyze_plant(params, x0=x, functions=funcs)
    assert ("(largest: " + ", ".join(f"{k} = {float(vals[k]):g}" for k in top) + "):") in str(e.value)
    assert str(e.value).startswith("the model evaluates to Inf/NaN at the operating point with these parameters")
