"""``ballbot fmu build|info|validate``: build and check the native plant FMU.

Also provides the ``make demo`` step :func:`demo_step` (build the FMU and run one fmpy
co-simulation of it).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

__all__ = ["add_parser", "demo_step", "cosim_open_loop", "closed_loop_cosim"]


def _default_fmu() -> Path:
    from .codegen import build_root

    return build_root() / "fmu" / "BallbotPlant.fmu"


def _cmd_build(args: argparse.Namespace) -> int:
    from .fmu_build import build_fmu

    b = build_fmu(args.out)
    print(f"{b.fmu}  (GUID {b.guid}, cache {b.digest})")
    return 0


def _cmd_info(args: argparse.Namespace) -> int:
    from fmpy import dump

    path = Path(args.fmu) if args.fmu else _default_fmu()
    if not path.is_file():
        print(f"{path} does not exist; run 'ballbot fmu build' first")
        return 1
    dump(str(path))
    return 0


def _cmd_validate(args: argparse.Namespace) -> int:
    from fmpy.validation import validate_fmu

    path = Path(args.fmu) if args.fmu else _default_fmu()
    if not path.is_file():
        print(f"{path} does not exist; run 'ballbot fmu build' first")
        return 1
    problems = validate_fmu(str(path))
    for p in problems:
        print(f"problem: {p}")
    print(f"{path}: {'valid' if not problems else f'{len(problems)} problem(s)'}")
    return 1 if problems else 0


def cosim_open_loop(fmu: str | Path, tau: np.ndarray, stop_time: float, step: float = 5e-3,
                    start_values: dict | None = None):
    """One fmpy co-simulation of the plant with constant wheel torques.

    Returns the fmpy result record array (time, states, outputs).
    """
    from fmpy import simulate_fmu

    sv = {f"tau{i}": float(t) for i, t in enumerate(tau)}
    sv.update(start_values or {})
    return simulate_fmu(str(fmu), fmi_type="CoSimulation", stop_time=stop_time,
                        output_interval=step, start_values=sv)


def closed_loop_cosim(scenario, fmu: str | Path | None = None, n_sub: int | None = None,
                      controllers: tuple | None = None) -> dict[str, np.ndarray]:
    """Closed-loop co-simulation: the plant FMU stepped by a Python master that runs the
    package's controllers once per control period (zero-order hold, as in
    :mod:`ballbot_casadi.simulation`).

    Per period ``k`` the master reads the plant state from the FMU, runs the velocity
    controller (cascade scenarios) and the balance controller on the controller's
    internal-model parameters, sets the wheel torques (the FMU saturates them at the
    plant's ``tau_max``) and calls ``fmi2DoStep(t_k, Ts)``; the FMU integrates with RK4
    sub-steps of ``Ts / n_sub`` (parameter ``h_internal``).  The plant FMU gets every
    plant parameter of the scenario.

    Parameters
    ----------
    scenario
        A :class:`~ballbot_casadi.scenarios.Scenario` without attitude pushes.
    fmu
        The plant FMU (default: build it).
    n_sub
        RK4 sub-steps per period (default that of :mod:`ballbot_casadi.simulation`).
    controllers
        Optional ``(balance, velocity)`` CasADi Functions (default: built from the
        symbolic model).

    Returns
    -------
    dict
        ``time`` (N+1), ``state`` (N+1, 12; row k the state at ``t_k``), ``tau_cmd``
        (N, 3) and ``tau`` (N, 3, as saturated inside the FMU).
    """
    from fmpy import read_model_description
    from fmpy.fmi2 import FMU2Slave

    from .controllers import BALANCE_CONTROLLERS, make_velocity_controller, saturate_torques
    from .errors import ScenarioError
    from .fmu_build import MODEL_IDENTIFIER, build_fmu
    from .model import STATE_NAMES, make_affine
    from .params import PARAM_NAMES
    from .simulation import N_SUB_DEFAULT

    n_sub = N_SUB_DEFAULT if n_sub is None else int(n_sub)
    if controllers is None:
        controllers = (BALANCE_CONTROLLERS[scenario.controller](make_affine()),
                       make_velocity_controller())
    balance, velocity = controllers
    inp = scenario.inputs()
    w = np.asarray(inp["w"], float)
    if np.any(w[:, :3] != 0.0):
        raise ScenarioError("closed_loop_cosim: attitude pushes cannot be applied through the "
                            "FMU's inputs; use a scenario without pushes")
    if fmu is None:
        unzipped = build_fmu().unzipped
    else:
        from fmpy import extract

        unzipped = Path(extract(str(fmu)))
    md = read_model_description(str(unzipped))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    sx = [vr[n] for n in STATE_NAMES]
    su = [vr[f"tau{i}"] for i in range(3)]
    Ts, cascade = float(inp["Ts"]), bool(inp["cascade"])
    n = w.shape[0]
    plant = FMU2Slave(guid=md.guid, unzipDirectory=str(unzipped),
                      modelIdentifier=MODEL_IDENTIFIER, instanceName="plant")
    plant.instantiate()
    try:
        plant.setupExperiment(startTime=0.0)
        plant.enterInitializationMode()
        plant.setReal([vr[p] for p in PARAM_NAMES], [float(v) for v in inp["p_plant"]])
        plant.setReal([vr["h_internal"]], [Ts / n_sub])
        plant.setReal(sx, [float(v) for v in inp["x0"]])
        plant.exitInitializationMode()
        z = np.asarray(inp["z0"], float)
        p_ctrl, k_bal, k_vel = inp["p_ctrl"], inp["k_bal"], inp["k_vel"]
        states = np.zeros((n + 1, len(sx)))
        tau_cmd = np.zeros((n, 3))
        tau = np.zeros((n, 3))
        for k in range(n):
            x = np.array(plant.getReal(sx))
            states[k] = x
            if cascade:
                qr, dqr, ddqr, z_next = velocity(x, inp["v_ref"][k], z, p_ctrl, k_vel, Ts)
                z = np.asarray(z_next, float).ravel()
            else:
                qr, dqr, ddqr = inp["q_ref"][k], inp["dq_ref"][k], inp["ddq_ref"][k]
            u, _ = balance(x, qr, dqr, ddqr, p_ctrl, k_bal)
            tau_cmd[k] = np.asarray(u, float).ravel()
            u_lim = saturate_torques(tau_cmd[k], p_ctrl[PARAM_NAMES.index("tau_max")])
            plant.setReal(su, (u_lim + w[k, 3:6]).tolist())
            plant.doStep(k * Ts, Ts)
            tmax = float(inp["p_plant"][PARAM_NAMES.index("tau_max")])
            tau[k] = np.clip(u_lim + w[k, 3:6], -tmax, tmax)
        states[n] = plant.getReal(sx)
        plant.terminate()
    finally:
        plant.freeInstance()
    return {"time": np.arange(n + 1) * Ts, "state": states, "tau_cmd": tau_cmd, "tau": tau}


def demo_step(out: Path) -> int:
    """``make demo`` step: build the FMU, co-simulate it in fmpy, compare with Python."""
    from .fmu_build import build_fmu
    from .integrators import make_rk4
    from .model import STATE_NAMES, make_model_functions
    from .params import load_params
    from .robot import make_state

    b = build_fmu()
    print(f"built {b.fmu} (GUID {b.guid})")
    d = Path(out) / "fmu"
    d.mkdir(parents=True, exist_ok=True)
    tau = np.array([0.02, -0.01, 0.005])
    x0 = make_state(roll=0.002)
    res = cosim_open_loop(b.fmu, tau, 1.0, start_values=dict(zip(STATE_NAMES, x0.tolist())))
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
    from .scenarios import study_scenarios
    from .simulation import ClosedLoop, run_scenario

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


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register ``ballbot fmu build|info|validate``."""
    p = sub.add_parser("fmu", help="build, describe and validate the native plant FMU")
    fsub = p.add_subparsers(dest="fmu_command", required=True, metavar="ACTION")
    b = fsub.add_parser("build", help="build BallbotPlant.fmu (gcc)")
    b.add_argument("--out", default=None, help="output directory (default build/fmu)")
    b.set_defaults(func=_cmd_build)
    i = fsub.add_parser("info", help="print the FMU's model description")
    i.add_argument("fmu", nargs="?", help="FMU file (default build/fmu/BallbotPlant.fmu)")
    i.set_defaults(func=_cmd_info)
    v = fsub.add_parser("validate", help="validate the FMU with fmpy")
    v.add_argument("fmu", nargs="?", help="FMU file (default build/fmu/BallbotPlant.fmu)")
    v.set_defaults(func=_cmd_validate)
