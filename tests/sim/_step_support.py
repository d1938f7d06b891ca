"""Running an estimating step (ballbot_casadi.sim.steps) period by period, for the tests."""

from __future__ import annotations

import numpy as np

from ballbot_casadi.estimation.com_observer import com_observer_initial_state


def run_steps(step, inp: dict, n: int, keys: tuple[str, ...]) -> np.ndarray:
    """``n`` periods of the estimating ``step`` on the scenario inputs ``inp``, called by
    input name (with the COM observer's state and gains, observer off, when the step has
    them); one row a period: the outputs ``keys`` concatenated."""
    est = inp["estimation"]
    with_obs = "k_obs" in step.name_in()
    o0 = [com_observer_initial_state(inp["x0"], inp["p_ctrl"])] if with_obs else []
    xz = np.concatenate([inp["x0"], np.zeros(3), inp["z0"], est["e0"], *o0, est["s0"]])
    const = {"p_plant": inp["p_plant"], "p_ctrl": inp["p_ctrl"], "k_bal": inp["k_bal"],
             "k_vel": inp["k_vel"], "Ts": inp["Ts"], "cascade": 1.0, "feedforward": 1.0,
             **{k: np.ravel(est[k], order="F") for k in ("s", "p_est", "Qa", "Ra", "Qv", "Rv")},
             **({"com_observer": 0.0, "k_obs": inp["k_obs"]} if with_obs else {})}
    rows = []
    for k in range(n):
        seq = {key: inp[key][k] for key in ("q_ref", "dq_ref", "ddq_ref", "v_ref", "w")}
        seq.update({key: est[key][k] for key in ("noise", "valid")})
        out = step.call({"xz": xz, **seq, **const})
        xz = np.ravel(np.asarray(out["xz_next"]))
        rows.append(np.concatenate([np.ravel(np.asarray(out[key])) for key in keys]))
    return np.array(rows)
