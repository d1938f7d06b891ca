"""Benchmarks of the native plant FMU (group ``fmu`` of ``make bench``).

* ``fmu_plant_step_us``: one 5 ms co-simulation step (fmi2SetReal of the torques,
  fmi2DoStep with five 1 ms RK4 sub-steps of the 15 states and the sensor sample at its
  end, fmi2GetReal of the 12 model states) in the C host ``fmu/tools/host.c``; best of several
  repetitions of 2000 steps.
* ``fmu_vs_pythonfmu_ratio``: wall time of the same fmpy co-simulation (2 s at 5 ms,
  constant torques, states recorded) of a PythonFMU export of the same CasADi model
  (RK4 Function called from Python, same 1 ms sub-steps) divided by that of the native
  FMU.  The PythonFMU is built only here, under ``<build>/bench/pythonfmu``, and never
  shipped.  Target: >= 20.
* ``fmu_controller_step_us``: one 5 ms step of ``BallbotController.fmu`` (fmi2SetReal of
  the nine readings, fmi2DoStep running one period of the embedded software, fmi2GetReal
  of the torques) in the C host ``fmu/tools/controller_host.c``; best of several repetitions of
  2000 steps.  Target: <= 15 us.
* ``sil_100s_s``: 100 s of the velocity-profile scenario (``full_velocity``: noise, QUKF +
  VUKF, FLC, velocity cascade) as the SSP system (plant + controller + reference FMUs)
  in libcosim (``CosimExecution.from_ssp_file`` + ``simulate_until``, no observers), best
  of two; ``sil_vs_mission_ratio`` divides it by the compiled mission of the same
  scenario (``run_scenario``, best of two): the cost of going through FMI and the engine.
* ``fmu3_vs_casadi_export_ratio`` and its companions: the FMI 3.0 plant beside CasADi's
  own FMU export of the same ODE (:mod:`ballbot_casadi.bench.fmu3`).
"""

from __future__ import annotations

import json
import subprocess
import time
from importlib import resources
from pathlib import Path

import numpy as np

from ballbot_casadi.bench.fmpy_timing import fmpy_best_time
from ballbot_casadi.bench.fmu3 import bench_fmu3_vs_casadi
from ballbot_casadi.core.toolchain import build_root
from ballbot_casadi.fmi.build import build_fmu, build_tool
from ballbot_casadi.fmi.controller.controller import controller_spec
from ballbot_casadi.fmi.package import build_fmu_from_spec
from ballbot_casadi.fmi.plant.plant import X0_PREFIX
from ballbot_casadi.fmi.system.sil import write_sil_ssp
from ballbot_casadi.model.dynamics import STATE_NAMES
from ballbot_casadi.model.numeric import make_state
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.sim.scenario import load_scenario_file

__all__ = ["bench_fmu", "build_pythonfmu", "bench_controller_fmu", "bench_sil",
           "FMU_RATIO_TARGET", "CONTROLLER_STEP_TARGET_US"]

FMU_RATIO_TARGET = 20.0
CONTROLLER_STEP_TARGET_US = 15.0
_SIL_SCENARIO = "full_velocity.toml"
_TAU = (0.02, -0.01, 0.005)
_ROLL0 = 0.002
_STOP = 2.0
_DT = 0.005

_SLAVE = '''"""PythonFMU baseline of the ballbot plant (benchmark only, never shipped)."""
import math

import numpy as np
from pythonfmu.fmi2slave import Fmi2Causality, Fmi2Slave, Real

from ballbot_casadi.model.integrators import make_rk4
from ballbot_casadi.model.dynamics import STATE_NAMES, make_model_functions
from ballbot_casadi.core.params import load_params

_RK4 = make_rk4(make_model_functions()["ode"])
_P = load_params().to_vector()


class BallbotPlantPy(Fmi2Slave):
    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.h_internal = 1e-3
        self.tau0 = 0.0
        self.tau1 = 0.0
        self.tau2 = 0.0
        x0 = [0.0] * 12
        x0[2], x0[3] = math.cos(ROLL0 / 2), math.sin(ROLL0 / 2)
        for name, value in zip(STATE_NAMES, x0):
            setattr(self, name, value)
        for i in range(3):
            self.register_variable(Real(f"tau{i}", causality=Fmi2Causality.input))
        for name in STATE_NAMES:
            self.register_variable(Real(name, causality=Fmi2Causality.output))

    def do_step(self, current_time, step_size):
        x = np.array([getattr(self, n) for n in STATE_NAMES])
        tau = np.array([self.tau0, self.tau1, self.tau2])
        n = max(1, math.ceil(step_size / self.h_internal * (1 - 1e-12)))
        for _ in range(n):
            x = np.asarray(_RK4(x, tau, _P, step_size / n)).ravel()
        for name, value in zip(STATE_NAMES, x):
            setattr(self, name, float(value))
        return True
'''


def build_pythonfmu(out: Path) -> Path:
    """Build the PythonFMU baseline ``BallbotPlantPy.fmu`` into ``out`` (benchmark only)."""
    from pythonfmu import FmuBuilder

    out.mkdir(parents=True, exist_ok=True)
    script = out / "ballbot_plant_py.py"
    script.write_text(_SLAVE.replace("ROLL0", repr(_ROLL0)))
    return Path(FmuBuilder.build_FMU(script, dest=out, needsExecutionTool="false"))


def _fmpy_time(fmu: Path, start_values: dict, reps: int = 3) -> tuple[float, np.ndarray]:
    best, res = fmpy_best_time(fmu, reps, fmi_type="CoSimulation", stop_time=_STOP,
                               output_interval=_DT, start_values=start_values,
                               output=list(STATE_NAMES))
    return best, np.column_stack([res[n] for n in STATE_NAMES])


def bench_controller_fmu() -> dict[str, float]:
    """``fmu_controller_step_us``: one 5 ms controller step in the C host."""
    b = build_fmu_from_spec(controller_spec())
    host = build_tool(b, "controller_host")
    run = subprocess.run([str(host), str(b.binary), b.guid, "2000", "5"], capture_output=True,
                         text=True, check=True)
    return {"fmu_controller_step_us": float(json.loads(run.stdout)["step_us"]),
            "fmu_controller_step_target_us": CONTROLLER_STEP_TARGET_US}


def bench_sil(reps: int = 2) -> dict[str, float]:
    """``sil_100s_s``: 100 s of plant + controller FMUs in libcosim, and the ratio to the
    compiled mission of the same scenario."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

    path = Path(str(resources.files("ballbot_casadi.studies") / "scenarios" / _SIL_SCENARIO))
    sc = load_scenario_file(path).scenario.replace(duration=100.0)
    ssp = write_sil_ssp(sc, build_root() / "bench" / "sil" / "BallbotSIL_100s.ssp")
    log_output_level(CosimLogLevel.ERROR)
    t_sil = float("inf")
    for _ in range(reps):
        ex = CosimExecution.from_ssp_file(str(ssp))
        t0 = time.perf_counter()
        ok = ex.simulate_until(int(round(sc.duration * 1e9)))
        t_sil = min(t_sil, time.perf_counter() - t0)
        if not ok:
            raise RuntimeError("libcosim stopped before the end of the 100 s SIL run")
        del ex
    sim = ClosedLoop()
    run_scenario(sc.replace(duration=1.0), sim)  # build and load the library first
    t_mission = float("inf")
    for _ in range(reps):
        t0 = time.perf_counter()
        run_scenario(sc, sim)
        t_mission = min(t_mission, time.perf_counter() - t0)
    return {"sil_100s_s": t_sil, "sil_mission_100s_s": t_mission,
            "sil_vs_mission_ratio": t_sil / t_mission}


def bench_fmu() -> dict[str, float]:
    """Run the FMU benchmarks; returns a flat dict for ``build/bench.json``."""

    b = build_fmu()
    host = build_tool(b, "host")
    run = subprocess.run([str(host), str(b.binary), b.guid, "2000", repr(_DT),
                          *map(repr, _TAU), repr(_ROLL0), "5"],
                         capture_output=True, text=True, check=True)
    step_us = float(json.loads(run.stdout)["step_us"])

    py_fmu = build_pythonfmu(build_root() / "bench" / "pythonfmu")
    taus = {f"tau{i}": t for i, t in enumerate(_TAU)}
    x0 = make_state(roll=_ROLL0)
    t_native, x_native = _fmpy_time(b.fmu, {**taus, **dict(zip((X0_PREFIX + n for n in STATE_NAMES),
                                                          x0.tolist()))})
    t_python, x_python = _fmpy_time(py_fmu, taus, reps=2)
    agree = float(np.max(np.abs(x_native - x_python)))
    return {
        "fmu_plant_step_us": step_us,
        "fmu_native_cosim_s": t_native,
        "fmu_pythonfmu_cosim_s": t_python,
        "fmu_vs_pythonfmu_ratio": t_python / t_native,
        "fmu_vs_pythonfmu_ratio_target": FMU_RATIO_TARGET,
        "fmu_vs_pythonfmu_state_diff": agree,
        **bench_controller_fmu(),
        **bench_sil(),
        **bench_fmu3_vs_casadi(),
    }
