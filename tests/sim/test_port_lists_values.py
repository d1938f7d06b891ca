"""The period's port lists (sim.ports) on toy blocks of distinct sizes: every port's
name, kind, size and position, the controller-state and mission-state layouts in their
documented order, and each signature refusal (issue 23: a wrong index in a size check, a
port in the wrong list or order, a field swapped must show)."""

from __future__ import annotations

import casadi as ca
import pytest

from ballbot_casadi.core.layout import STATE, VELOCITY_CONTROLLER_STATE, Layout
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.ports import (
    CONSTANT,
    SEQUENCE,
    PeriodBlocks,
    check_blocks,
    controller_state_of,
    embedded_ports,
    mission_state,
    period_ports,
    sequence_positions,
)

NPAR, NK, ND, NZ, NKV = 21, 7, 5, 8, 26


def _fn(name, ins, outs):
    syms = [ca.MX.sym(n, m) for n, m in ins]
    res = [ca.MX.zeros(m) + ca.sum1(ca.vertcat(*[ca.sum1(s) for s in syms])) for _, m in outs]
    return ca.Function(name, syms, res, [n for n, _ in ins], [n for n, _ in outs])


def _balance(nb=0):
    ins = [("x", 12), ("q_ref", 4), ("dq_ref", 4), ("ddq_ref", 4), ("p", NPAR), ("k", NK)]
    outs = [("tau", 3), ("diag", ND)]
    if nb:
        ins, outs = ins + [("zb", nb)], outs + [("zb_next", nb)]
    return _fn("ballbot_toy", ins, outs)


def _velocity(nz=NZ):
    return _fn("ballbot_velocity", [("x", 12), ("v_ref", 3), ("z", nz), ("p", NPAR), ("k", NKV), ("Ts", 1)],
               [("q_ref", 4), ("dq_ref", 4), ("ddq_ref", 4), ("z_next", nz)])


def _observer():
    return _fn("ballbot_obs", [("x", 12), ("v_ref", 3), ("o", 6), ("p", NPAR), ("k_obs", 4), ("Ts", 1)],
               [("o_next", 6), ("p_hat", NPAR), ("com_hat", 2), ("com_meas", 2)])


def _guidance(ng=9, nkg=11, feed=False):
    outs = [("v_ref_out", 3), ("g_next", ng)] + ([("q", 4), ("dq", 4), ("ddq", 4)] if feed else [])
    return _fn("ballbot_guide", [("x", 12), ("v_ref", 3), ("g", ng), ("z", NZ), ("p", NPAR),
                                 ("k_guid", nkg), ("Ts", 1)], outs)


def test_sizes_of_every_block():
    blocks = PeriodBlocks(_balance(2), _velocity(), _observer(), _guidance())
    assert check_blocks(blocks, NPAR) == {"nk": NK, "nd": ND, "nz": NZ, "nkv": NKV, "nb": 2,
                                          "n_obs": 6, "nko": 4, "ng": 9, "nkg": 11}
    assert check_blocks(PeriodBlocks(_balance(), _velocity()), NPAR) == {
        "nk": NK, "nd": ND, "nz": NZ, "nkv": NKV}
    assert blocks.name == "toy" and blocks.balance_state == 2
    assert PeriodBlocks(_balance(), _velocity()).balance_state == 0
    check_blocks(PeriodBlocks(_balance(), _velocity(), guidance=_guidance(feed=True)), NPAR)


@pytest.mark.parametrize("blocks, needle", [
    (lambda: PeriodBlocks(_velocity(), _velocity()), "balance controller must be"),
    (lambda: PeriodBlocks(_balance(), _balance()), "velocity controller must be"),
    (lambda: PeriodBlocks(_fn("b", [("x", 12), ("q_ref", 4), ("dq_ref", 4), ("ddq_ref", 4), ("p", NPAR),
                                    ("k", NK), ("zb", 2)], [("tau", 3), ("diag", ND), ("zb_next", 3)]),
                          _velocity()), "balance controller must be"),
    (lambda: PeriodBlocks(_fn("b", [("x", 12), ("q_ref", 4), ("dq_ref", 3), ("ddq_ref", 4), ("p", NPAR),
                                    ("k", NK)], [("tau", 3), ("diag", ND)]), _velocity()),
     "balance controller input sizes"),
    (lambda: PeriodBlocks(_fn("b", [("x", 12), ("q_ref", 4), ("dq_ref", 4), ("ddq_ref", 4), ("p", NPAR),
                                    ("k", NK)], [("tau", 2), ("diag", ND)]), _velocity()),
     "balance controller input sizes"),
    (lambda: PeriodBlocks(_balance(), _fn("v", [("x", 12), ("v_ref", 2), ("z", NZ), ("p", NPAR), ("k", NKV),
                                                ("Ts", 1)], [("q", 4), ("dq", 4), ("ddq", 4), ("z_next", NZ)])),
     "velocity controller sizes"),
    (lambda: PeriodBlocks(_balance(), _fn("v", [("x", 12), ("v_ref", 3), ("z", NZ), ("p", NPAR), ("k", NKV),
                                                ("Ts", 1)], [("q", 4), ("dq", 4), ("ddq", 4), ("z_next", 7)])),
     "velocity controller sizes"),
    (lambda: PeriodBlocks(_balance(), _velocity(), guidance=_fn(
        "g", [("x", 12), ("v_ref", 3), ("g", 9), ("z", NZ), ("p", NPAR), ("k_guid", 1), ("Ts", 1)],
        [("v", 3), ("g_next", 8)])), "guidance must be"),
    (lambda: PeriodBlocks(_balance(), _velocity(), guidance=_fn(
        "g", [("x", 12), ("v_ref", 3), ("g", 9), ("z", NZ), ("p", NPAR), ("k_guid", 1), ("Ts", 1)],
        [("v", 2), ("g_next", 9)])), "guidance must be"),
    (lambda: PeriodBlocks(_balance(), _velocity(), guidance=_fn(
        "g", [("x", 12), ("v_ref", 3), ("g", 9), ("z", 7), ("p", NPAR), ("k_guid", 1), ("Ts", 1)],
        [("v", 3), ("g_next", 9)])), "guidance must be"),
    (lambda: PeriodBlocks(_balance(), _velocity(), guidance=_fn(
        "g", [("x", 12), ("v_ref", 3), ("g", 9), ("z", NZ), ("p", NPAR), ("k_guid", 1), ("Ts", 1)],
        [("v", 3), ("g_next", 9), ("q", 4), ("dq", 3), ("ddq", 4)])), "guidance must be"),
])
def test_each_signature_refusal(blocks, needle):
    with pytest.raises(ScenarioError, match=needle):
        check_blocks(blocks(), NPAR)


def test_controller_and_mission_state_layouts_in_order():
    c = controller_state_of(NZ, 6, 9, 2)
    assert c.fields == ("z", "obs", "guide", "bal")
    assert (c["obs"], c["guide"], c["bal"]) == (slice(8, 14), slice(14, 23), slice(23, 25))
    assert c.size_of("z") == VELOCITY_CONTROLLER_STATE.size and c["z.theta_r"] == slice(0, 2)
    assert controller_state_of(5).fields == ("z",) and controller_state_of(5).size == 5
    assert controller_state_of(NZ, 0, 3).fields == ("z", "guide")
    m = mission_state(c)
    assert m.fields == ("x", "c") and m.size == STATE.size + 25
    s = Layout("sensor state", [("b", 4)])
    m = mission_state(c, s)
    assert m.fields == ("x", "phi", "c", "s") and m["phi"] == slice(12, 15) and m["s"] == slice(40, 44)
    m = mission_state(c, s, actuation_delay=True)
    assert m.fields == ("x", "phi", "c", "s", "u") and m["u"] == slice(44, 47)
    with pytest.raises(ScenarioError, match="actuation delay"):
        mission_state(c, None, actuation_delay=True)


def test_period_ports_true_state_with_observer_and_guidance():
    ports = period_ports(PeriodBlocks(_balance(), _velocity(), _observer(), _guidance()), NPAR)
    assert ports.name == "ballbot_cl_step_toy"
    assert ports.names_in == ("xz", "q_ref", "dq_ref", "ddq_ref", "v_ref", "w", "p_plant", "p_ctrl",
                              "k_bal", "k_vel", "Ts", "cascade", "feedforward", "com_observer",
                              "k_obs", "k_guid")
    assert ports.names_out == ("xz_next", "x", "tau_cmd", "tau", "q_ref_used", "dq_ref_used",
                               "ddq_ref_used", "diag", "com_hat", "v_ref_used")
    sizes = {p.name: p.size for p in ports.inputs}
    assert sizes == {"q_ref": 4, "dq_ref": 4, "ddq_ref": 4, "v_ref": 3, "w": 6, "p_plant": NPAR,
                     "p_ctrl": NPAR, "k_bal": NK, "k_vel": NKV, "Ts": 1, "cascade": 1,
                     "feedforward": 1, "com_observer": 1, "k_obs": 4, "k_guid": 11}
    assert ports.sequences == ("q_ref", "dq_ref", "ddq_ref", "v_ref", "w")
    assert ports.constants[0] == "p_plant" and ports.port("k_vel").kind == CONSTANT
    assert ports.port("w").kind == SEQUENCE
    assert ports.sequence_positions() == (1, 2, 3, 4, 5)
    assert ports.state.fields == ("x", "c") and ports.state["c.guide"] == slice(12 + 8 + 6, 12 + 8 + 6 + 9)
    assert ports.has("com_hat") and ports.has("k_guid") and not ports.has("noise")
    with pytest.raises(ScenarioError, match="has no input 'noise'"):
        ports.port("noise")
    sym = ports.symbols()
    assert sym["xz"].numel() == ports.state.size and sym["k_guid"].numel() == 11
    plain = period_ports(PeriodBlocks(_balance(), _velocity()), NPAR)
    assert plain.names_in[-1] == "feedforward" and plain.names_out[-1] == "diag"


def test_embedded_ports_and_sequence_positions():
    c = controller_state_of(NZ, 6, 9)
    ports = embedded_ports(PeriodBlocks(_balance(), _velocity(), _observer(), _guidance()), NPAR, c, 13,
                           {"Qa": 36, "Ra": 9, "Qv": 49, "Rv": 16})
    assert ports.name == "ballbot_embedded_toy" and ports.state_names == ("c", "c_next")
    assert ports.names_in == ("c", "meas", "q_ref", "dq_ref", "ddq_ref", "v_ref", "p_ctrl", "p_est",
                              "k_bal", "k_vel", "Ts", "cascade", "feedforward", "Qa", "Ra", "Qv", "Rv",
                              "com_observer", "k_obs", "k_guid")
    assert ports.names_out == ("c_next", "tau_lim", "tau_cmd", "x_hat", "q_ref_used", "dq_ref_used",
                               "ddq_ref_used", "diag", "nis", "repairs", "rejections", "com_hat",
                               "v_ref_used")
    sizes = {p.name: (p.kind, p.size) for p in ports.inputs}
    assert sizes["meas"] == (SEQUENCE, 13) and sizes["v_ref"] == (SEQUENCE, 3)
    assert sizes["Qv"] == (CONSTANT, 49) and sizes["Rv"] == (CONSTANT, 16) and sizes["Ra"] == (CONSTANT, 9)
    assert sizes["k_obs"] == (CONSTANT, 4) and sizes["k_guid"] == (CONSTANT, 11)
    assert sizes["p_est"] == (CONSTANT, NPAR)
    step = _fn("s", [("xz", 3), ("noise", 2), ("q_ref", 4), ("p_plant", 1), ("w", 6), ("valid", 4),
                     ("Ts", 1)], [("xz_next", 3)])
    assert sequence_positions(step) == (1, 2, 4, 5)
