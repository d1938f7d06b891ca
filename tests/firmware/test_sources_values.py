"""The generated library's configuration and defaults read back against the Function and
the scenario they come from (every index, size, field order and value), the guidance
block's options, the default path, and the replay's refusals (no cross toolchain)."""

from __future__ import annotations

import re

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.errors import BuildError, ScenarioError
from ballbot_casadi.firmware import replay as R
from ballbot_casadi.firmware.build import default_scenario
from ballbot_casadi.firmware.sources import (
    COVARIANCE_INPUTS,
    SPLIT_LATENCY,
    codegen_work,
    default_guidance_path,
    firmware_function,
    firmware_guidance,
    generate_sources,
    generated_work,
    param_inputs,
    scenario_values,
)
from ballbot_casadi.sim.embedded import DEFAULT_ESTIMATOR, embedded_readings


@pytest.fixture(scope="module")
def generated():
    f = firmware_function()
    vals = scenario_values(f, default_scenario())
    return f, vals, generate_sources(f, "double", vals)


def test_generated_work_is_what_the_firmware_c_declares(generated):
    """The work sizes the firmware's cost report uses (the Function generated alone) are
    those the firmware's own C declares for it, in either precision, and at most CasADi's
    counts of the Function (the C can need less)."""
    f, _, files = generated
    assert generated_work(f) == codegen_work(f, files["ballbot_fw_cg.c"])
    x = ca.MX.sym("x", 3)
    g = ca.Function("fw_probe", [x], [ca.sin(x) * ca.sum1(x)])
    got = generated_work(g)
    assert got == generated_work(g, "single") and got[:2] == (g.sz_arg(), g.sz_res())
    assert 0 < got[3] <= g.sz_w() and got[2] <= g.sz_iw()


def test_single_precision_constants_are_clamped_into_floats_range_and_zero_stays_zero():
    """Generated C for single precision: math calls become their float versions, literals
    beyond FLT_MAX or below FLT_MIN (the model's guards DBL_MAX and 1e-300) are clamped to
    them with their sign, zero and in-range literals are left as written."""
    from ballbot_casadi.firmware.sources import _float_math

    src = ("a = 0.0e+00; b = 1.0e-300; c = -1.0e-300; d = 1.0e+300; e = 2.5e-03; "
           "f = sqrt(x) + cos(y); g = 1.2e-38; h = 3.5e+38; i = 3.4e+38;")
    assert _float_math(src) == (
        "a = 0.0e+00; b = 1.1754943508222875e-38; c = -1.1754943508222875e-38; "
        "d = 3.4028234663852886e+38; e = 2.5e-03; f = sqrtf(x) + cosf(y); g = 1.2e-38; "
        "h = 3.4028234663852886e+38; i = 3.4e+38;")


def _reshaped(f: ca.Function, name: str, shape: tuple[int, int]) -> ca.Function:
    """``f`` with input ``name`` declared as ``shape``: column-major, its first entries used."""
    ins = [ca.MX.sym(n, *(shape if n == name else f.size_in(i))) for i, n in enumerate(f.name_in())]
    args = [ca.vec(a)[:f.numel_in(i)] if n == name else a
            for i, (a, n) in enumerate(zip(ins, f.name_in()))]
    return ca.Function(f.name(), ins, f.call(args), f.name_in(), f.name_out())


def test_parameter_inputs_are_matched_by_their_number_of_entries(generated):
    """A parameter input declared as a matrix (a covariance 6 x 6) takes the scenario's
    values column-major, as the flat layout; an input of another number of entries is
    refused naming it and both counts."""
    f, vals, _ = generated
    sc = default_scenario()
    m = scenario_values(_reshaped(f, "Qa", (6, 6)), sc)
    assert m.params.keys() == vals.params.keys()
    for n, v in vals.params.items():
        np.testing.assert_array_equal(m.params[n], v, err_msg=n)
    np.testing.assert_array_equal(m.c0, vals.c0)
    with pytest.raises(BuildError, match=rf"^{f.name()}: input Qv has 50 entries, the scenario "
                                         r"gives 49$"):
        scenario_values(_reshaped(f, "Qv", (50, 1)), sc)


def _defines(text: str) -> dict[str, str]:
    return {m.group(1): m.group(2).strip() for m in re.finditer(r"^#define (\w+)(?:\(X\))? (.*)$",
                                                                text, re.M)}


def _arrays(text: str) -> list[np.ndarray]:
    return [np.array([float(v) for v in m.split(",")]) for m in re.findall(r"\{([^{}]+)\}", text)]


def test_config_indices_and_sizes_are_the_functions(generated):
    f, vals, files = generated
    cfg = files["ballbot_fw_config.h"]
    d = _defines(cfg)
    assert d["BALLBOT_FW_EMBEDDED"] == f.name() == f"ballbot_embedded_flc_{DEFAULT_ESTIMATOR}"
    assert int(d["BALLBOT_FW_NC"]) == f.numel_in(0) == vals.c0.size
    for i, n in enumerate(f.name_in()):
        assert int(d[f"BALLBOT_FW_ARG_{n}"]) == i
    for i, n in enumerate(f.name_out()):
        assert int(d[f"BALLBOT_FW_RES_{n}"]) == i
    M = embedded_readings(f)
    assert int(d["BALLBOT_FW_N_READINGS"]) == M.size
    for k in M.fields:
        assert int(d[f"BALLBOT_FW_READING_{k.upper()}"]) == M[k].start
    assert int(d["BALLBOT_FW_N_ENC"]) == M["enc"].stop - M["enc"].start == 3
    work = codegen_work(f, files["ballbot_fw_cg.c"])
    assert [int(d[f"BALLBOT_FW_SZ_{n}"]) for n in ("ARG", "RES", "IW", "W")] == list(work)
    assert work[0] >= f.n_in() and work[1] >= f.n_out()
    assert (d["BALLBOT_FW_GUIDANCE"], d["BALLBOT_FW_N_GUIDANCE"], d["BALLBOT_FW_GUIDANCE_EVERY"],
            d["BALLBOT_FW_GUIDANCE_SPLIT"]) == ("0", "0", "0", "0")
    params = param_inputs(f)
    size = {n: f.numel_in(f.index_in(n)) for n in f.name_in()}
    assert d["BALLBOT_FW_PARAM_FIELDS"] == " ".join(f"X({n}, {size[n]})" for n in params)
    assert d["BALLBOT_FW_REFERENCE_FIELDS"] == "X(q_ref, 4) X(dq_ref, 4) X(ddq_ref, 4) X(v_ref, 3)"
    outs = [n for n in f.name_out() if n != "c_next"]
    assert d["BALLBOT_FW_OUTPUT_FIELDS"] == " ".join(
        f"X({n}, {f.numel_out(f.index_out(n))})" for n in outs)
    cov = d["BALLBOT_FW_COV_FIELDS"]
    assert cov == " ".join(f"X({n}, {int(round(np.sqrt(size[n])))})" for n in COVARIANCE_INPUTS)
    assert "X(Qa, 6)" in cov or "X(Qa, 7)" in cov  # the attitude filter's square matrix
    # the structs: the fields in the Function's order with its sizes
    struct = re.search(r"typedef struct ballbot_fw_params \{(.*?)\}", cfg, re.S).group(1)
    assert re.findall(r"ballbot_fw_real (\w+)\[(\d+)\];", struct) == [(n, str(size[n])) for n in params]
    out_struct = re.search(r"typedef struct ballbot_fw_outputs \{(.*?)\}", cfg, re.S).group(1)
    assert [n for n, _ in re.findall(r"ballbot_fw_real (\w+)\[(\d+)\];", out_struct)] == outs
    assert f"extern const ballbot_fw_real ballbot_fw_default_c0[{f.numel_in(0)}];" in cfg
    assert "typedef double ballbot_fw_real;" in cfg and "BALLBOT_FW_PRECISION_DOUBLE 1" in cfg
    assert "ballbot_fw_default_guidance_data" not in cfg


def test_defaults_are_the_scenarios_values_in_order(generated):
    f, vals, files = generated
    src = files["ballbot_fw_defaults.c"]
    head, c0_part = src.split("ballbot_fw_default_c0", 1)
    arrays = _arrays(head)
    params = param_inputs(f)
    assert len(arrays) == len(params)
    for n, a in zip(params, arrays):
        np.testing.assert_array_equal(a, vals.params[n], err_msg=n)
    assert f"ballbot_fw_default_c0[{vals.c0.size}]" in "ballbot_fw_default_c0" + c0_part
    np.testing.assert_array_equal(_arrays(c0_part)[0], vals.c0)
    np.testing.assert_array_equal(vals.flat_params(f), np.concatenate(arrays))
    inp = default_scenario().inputs()
    np.testing.assert_array_equal(vals.params["Ts"], [inp["Ts"]])
    np.testing.assert_array_equal(vals.params["k_vel"], np.asarray(inp["k_vel"], float).ravel("F"))
    assert vals.params["feedforward"][0] == (1.0 if inp["feedforward"] else 0.0)
    assert vals.params["com_observer"][0] == (1.0 if inp["com_observer"] else 0.0)
    # the hand-written files are shipped as they are
    assert set(files) == {"ballbot_fw_cg.c", "ballbot_fw_cg.h", "ballbot_fw_config.h",
                          "ballbot_fw_defaults.c", "ballbot_fw.h", "ballbot_fw.c"}
    with pytest.raises(ScenarioError, match="unknown precision 'half'; allowed: double, single"):
        generate_sources(f, "half", vals)


def test_default_scenario_is_the_upright_cascade():
    sc = default_scenario("smc", "ukf")
    assert (sc.controller, sc.estimator, sc.cascade) == ("smc", "ukf", True)
    assert sc.duration == pytest.approx(0.005, rel=1e-12)
    assert default_scenario().estimator == DEFAULT_ESTIMATOR


@pytest.mark.parametrize("latency, split", [(0, False), (1, True), (SPLIT_LATENCY, True)])
def test_guidance_latency_makes_the_split_law(latency, split):
    law = firmware_guidance("mpc", latency=latency)
    assert law.split == split and law.latency == latency and law.name == "mpc"


def test_guidance_defaults_to_no_latency():
    """Without a latency the guided period is the unsplit mission's (the MPC applied in its
    own period), for the period and the law alike."""
    plain = firmware_function("flc", "ukf", "mpc").serialize()
    assert plain == firmware_function("flc", "ukf", "mpc", 0).serialize()
    assert plain != firmware_function("flc", "ukf", "mpc", 1).serialize()
    law = firmware_guidance("mpc")
    assert (law.latency, law.split) == (0, False)


def test_the_firmware_guidance_is_the_missions_law():
    """The firmware's MPC predicts the loop the mission runs it on: the FLC cascade with the
    shipped velocity gains (the same cached law as a guided cascade scenario's, not one
    built for a robot without the velocity loop)."""
    from ballbot_casadi.core.constants import TS_CONTROL
    from ballbot_casadi.sim.guided import scenario_law
    from ballbot_casadi.sim.scenario import Scenario

    mission = Scenario(name="m", controller="flc", cascade=True, duration=TS_CONTROL, guidance="mpc")
    assert firmware_guidance("mpc") is scenario_law(mission)
    assert firmware_guidance("pursuit") is scenario_law(mission.replace(guidance="pursuit"))


def test_guidance_refusals_name_what_is_allowed():
    assert firmware_guidance(None) is None
    with pytest.raises(ScenarioError, match=r"unknown guidance 'warp'; allowed: .*mpc"):
        firmware_guidance("warp")
    with pytest.raises(ScenarioError, match=r"controller 'flc'\), got controller 'smc'"):
        firmware_guidance("mpc", "smc")
    for bad in (-1, 1.0, "2"):
        with pytest.raises(ScenarioError, match=r"latency must be an int >= 0 periods, got"):
            firmware_guidance("mpc", latency=bad)
    with pytest.raises(ScenarioError, match=r"firmware needs an estimator .* got 'true'"):
        firmware_function("flc", "true")


def test_default_path_is_the_studys_figure_eight():
    p = default_guidance_path()
    pts = np.array([p.point(s) for s in np.linspace(0.0, p.length, 801)])
    assert np.ptp(pts[:, 0]) == pytest.approx(4.0, rel=0.02)
    assert np.ptp(pts[:, 1]) == pytest.approx(2.0, rel=0.02)
    assert p.speed == pytest.approx(0.5, rel=1e-12)


def test_replay_log_refuses_pushes_and_torque_disturbances():
    sc = R.replay_scenario(10)
    with pytest.raises(ScenarioError, match="no pushes or torque disturbances"):
        R.record_log(sc.replace(pushes=((0.01, 1.0, 0.0, 0.0),)))
    with pytest.raises(ScenarioError, match="no pushes or torque disturbances"):
        R.record_log(sc.replace(torque_disturbances=((0.0, 0.01, 0.1, 0.0, 0.0),)))
    for bad in (0, 1.5):
        with pytest.raises(ScenarioError, match=r"n_periods must be an int >= 1"):
            R.record_guided_log(bad)


def test_write_replay_input_refuses_a_bad_delay(tmp_path):
    for bad in (-1, 1.5):
        with pytest.raises(ScenarioError, match=r"bg_delay must be an int >= 0 periods"):
            R.write_replay_input(tmp_path / "in.bin", None, None, bad)


def test_guidance_every_is_the_law_period_in_control_periods():
    from types import SimpleNamespace

    from ballbot_casadi.core.constants import TS_CONTROL
    from ballbot_casadi.firmware.sources import guidance_every
    from ballbot_casadi.sim.guided import GUIDANCE_EVERY
    assert TS_CONTROL == pytest.approx(0.005, rel=0, abs=1e-15) and GUIDANCE_EVERY == 20
    assert guidance_every(SimpleNamespace(config=SimpleNamespace(dt=0.035))) == 7  # 35 ms / 5 ms
    # the nearest whole number of periods: 0.03 / 0.005 is 5.999... in floating point
    for dt, want in ((0.03, 6), (0.015, 3), (0.1, 20), (0.0374, 7), (0.0376, 8)):
        assert guidance_every(SimpleNamespace(config=SimpleNamespace(dt=dt))) == want, dt
    assert guidance_every(SimpleNamespace(config=None)) == 20


def test_write_replay_input_lays_out_header_parameters_state_guidance_and_rows(tmp_path, monkeypatch):
    """Little-endian doubles: [N, n_params, n_c0, balance_only, CALIB_LOOPS, n_guidance,
    bg_delay], the parameters, the power-on state, the guidance data (with a guidance block
    only), then per period the 9 readings and 15 references; bg_delay 0 by default."""
    from types import SimpleNamespace

    seen = []
    monkeypatch.setattr(R, "firmware_function", lambda *a: seen.append(a) or "f")
    monkeypatch.setattr(R, "embedded_readings", lambda f: np.zeros(9))
    values = SimpleNamespace(flat_params=lambda f: np.array([1.0, 2.0, 3.0]), c0=np.array([4.0, 5.0]),
                             guidance=np.array([6.0, 7.0, 8.0, 9.0]))
    meas = np.arange(18.0).reshape(2, 9) + 100
    refs = np.arange(30.0).reshape(2, 15) + 200
    rec = R.RecordedLog(meas, refs, True, values, np.zeros((2, 3)))
    plain = SimpleNamespace(controller="flc", estimator="ukf", guidance=None, latency=0)
    data = np.frombuffer(R.write_replay_input(tmp_path / "a.bin", rec, plain).read_bytes(), "<f8")
    rows = np.hstack([meas, refs]).ravel()
    np.testing.assert_array_equal(data, [2, 3, 2, 1.0, R.CALIB_LOOPS, 0, 0, 1, 2, 3, 4, 5, *rows])
    assert seen == [("flc", "ukf", None, 0)]
    guided = SimpleNamespace(controller="flc", estimator="ukf", guidance="mpc", latency=4)
    rec_v = R.RecordedLog(meas, refs, False, values, np.zeros((2, 3)))
    data = np.frombuffer(R.write_replay_input(tmp_path / "b.bin", rec_v, guided, 3).read_bytes(), "<f8")
    np.testing.assert_array_equal(data, [2, 3, 2, 0.0, R.CALIB_LOOPS, 4, 3, 1, 2, 3, 4, 5, 6, 7, 8, 9, *rows])
    assert seen[-1] == ("flc", "ukf", "mpc", 4)
