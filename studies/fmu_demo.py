"""``make demo`` step: build the plant FMU, co-simulate it in fmpy and compare with Python."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ballbot_casadi.core.params import load_params
from ballbot_casadi.fmi.build import build_fmu
from ballbot_casadi.fmi.masters.plant_loop import closed_loop_cosim, cosim_open_loop
from ballbot_casadi.fmi.plant.plant import X0_PREFIX
from ballbot_casadi.model.dynamics import STATE_NAMES, make_model_functions
from ballbot_casadi.model.integrators import make_rk4
from ballbot_casadi.model.numeric import make_state
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.studies.registry import study_scenarios

__all__ = ["demo_step"]


def demo_step(out: Path) -> int:
    """``make demo`` step: build the FMU, co-simulate it in fmpy, compare with Python."""

    b = build_fmu()
    print(f"built {b.fmu} (GUID {b.guid})")
    d = Path(out) / "fmu"
    d.mkdir(parents=True, exist_ok=True)
    tau = np.array([0.02, -0.01, 0.005])
    x0 = make_state(roll=0.002)
    start = {X0_PREFIX + n: float(v) for n, v in zip(STATE_NAMES, x0)}  # the start state
    res = cosim_open_loop(b.fmu, tau, 1.0, start_values=start)
    names = res.dtype.names
    np.savetxt(d / "cosim_open_loop.csv", np.column_stack([res[n] for n in names]),
               delimiter=",", header=",".join(names), comments="")
    # Python reference: the same RK4 with the same 1 ms internal step.
    rk4 = make_rk4(make_model_functions()["ode"])
    p = load_params().to_vector()
    x = x0.copy()
    for _ in range(1000):
        x = np.asarray(rk4(x, tau, p, 1e-3)).ravel()
    x_fmu = np.array([res[n][-1] for n in STATE_NAMES])
    err = float(np.max(np.abs(x_fmu - x)))
    msg = (f"fmpy co-simulation of BallbotPlant.fmu, 1 s, tau = {tau.tolist()} N.m, "
           f"start roll 0.002 rad: final roll {res['roll'][-1]:.6f} rad, "
           f"max |x_fmu - x_python| = {err:.3e}")
    # Closed loop: the FMU stepped at 5 ms by the FLC master (roll sine 3 deg, 0.5 Hz).

    sc = study_scenarios("sine", "flc")[0]
    co = closed_loop_cosim(sc)
    ref = run_scenario(sc, ClosedLoop(compiled=False))
    cl_err = float(np.max(np.abs(co["state"] - ref["state"])))
    np.savetxt(d / "cosim_closed_loop_sine.csv",
               np.column_stack([co["time"], co["state"], np.vstack([co["tau"], co["tau"][-1:]])]),
               delimiter=",", comments="",
               header=",".join(["time", *STATE_NAMES, "tau0", "tau1", "tau2"]))
    roll = 2 * np.arcsin(co["state"][:, 3])
    msg2 = (f"closed-loop co-simulation (FLC, roll sine 3 deg 0.5 Hz, 10 s, 5 ms): "
            f"max roll {np.degrees(roll.max()):.3f} deg, max |x_fmu - x_python| = {cl_err:.3e}")
    (d / "summary.txt").write_text(msg + "\n" + msg2 + "\n")
    print(msg)
    print(msg2)
    print(f"written to {d}")
    return 0 if err < 1e-9 and cl_err < 1e-9 else 1


