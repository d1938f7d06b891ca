"""Replay a recorded sensor log through the firmware: in QEMU (Cortex-M7) and on the host.

The log comes from a compiled mission (:func:`~ballbot_casadi.sim.closed_loop.run_scenario`)
with noisy sensors and the default estimator in the loop (:func:`replay_scenario`: the roll sine of
the ``full`` study, with a gyroscope drop-out so the predict-only path runs too).  Its
readings, the scenario's references, parameters and power-on state go into one binary
input file (layout in ``csrc/replay_main.c``); the replay program steps the library and
writes the torques back.  It runs in ``qemu-system-arm -M mps2-an500 -cpu cortex-m7`` with
semihosting and ``-icount shift=0`` (one instruction = 1 ns of virtual time, read with
SysTick: :mod:`~ballbot_casadi.firmware.cost`) and, built for this PC, as the host reference.

A build with a guidance block replays a guided mission instead (:func:`record_guided_log`:
the figure-eight of the path study, 4 m x 2 m at 0.5 m/s, with noise and the default estimator, the
MPC in the compiled mission's period); the replay then also returns the velocity
references the block gave.  With ``latency >= 1`` the log is the guided mission with that
latency and the build the split one: the replay program runs the background sample
right after the step that took its snapshot (the main loop of a board runs it while the
next steps interrupt it; the result is applied at its due period either way) and returns
its instructions apart (:attr:`ReplayResult.bg_ticks`).
"""

from __future__ import annotations

import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ballbot_casadi.core.constants import TS_CONTROL
from ballbot_casadi.errors import BuildError, ScenarioError
from ballbot_casadi.firmware.build import FirmwareBuild
from ballbot_casadi.firmware.sources import (
    FirmwareValues,
    default_guidance_path,
    firmware_function,
    scenario_values,
)
from ballbot_casadi.firmware.toolchain import require
from ballbot_casadi.guidance.paths import Path as GuidancePath
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.sim.embedded import DEFAULT_ESTIMATOR, embedded_readings
from ballbot_casadi.sim.guided import run_guided, scenario_law
from ballbot_casadi.sim.path_following import path_scenario
from ballbot_casadi.sim.scenario import Scenario

__all__ = ["REPLAY_ATOL", "GUIDED_REPLAY_ATOL", "OUT_HEADER", "CALIB_LOOPS", "QEMU_COMMAND",
           "RecordedLog", "ReplayResult", "replay_scenario", "record_log", "record_guided_log",
           "write_replay_input", "run_qemu", "run_host"]

#: Largest torque difference (N m) of the QEMU replay from the host's double-precision
#: torques: double, rounding differences of newlib's libm against glibc's carried through
#: the filters; single, float rounding (the measured differences are in the README's
#: firmware section).
REPLAY_ATOL = {"double": 1e-12, "single": 2e-3}
#: The same for a double build with the MPC (torque N m, velocity reference m/s): the
#: fixed-iteration ADMM carries libm's last-bit differences (path table interpolation,
#: filters) through 60 iterations a sample (the measured differences: README, firmware).
GUIDED_REPLAY_ATOL = 1e-10
#: Values in the output header of the replay program (csrc/replay_main.c).
OUT_HEADER = 9
#: Iterations of the instruction-count calibration loop (1 + 2 n instructions).
CALIB_LOOPS = 100_000
#: The emulator: Cortex-M7 board, semihosting, one instruction per ns of virtual time.
QEMU_COMMAND = ("qemu-system-arm", "-M", "mps2-an500", "-cpu", "cortex-m7", "-nographic",
                "-monitor", "none", "-serial", "none", "-semihosting-config",
                "enable=on,target=native", "-icount", "shift=0")
_ROW = 5  # tau (3), ticks, return code (then the header's ROW_EXTRA values: v_ref_used)


def replay_scenario(n_periods: int = 200, seed: int = 1,
                    estimator: str = DEFAULT_ESTIMATOR) -> Scenario:
    """The recorded mission: roll sine 3 deg at 0.5 Hz (study ``full``), noisy sensors,
    the filters of ``estimator`` (default: the firmware's,
    :data:`~ballbot_casadi.sim.embedded.DEFAULT_ESTIMATOR`), FLC in the thesis mode, the
    gyroscope missing for 50 ms at 0.3 s."""
    if not isinstance(n_periods, int) or n_periods < 1:
        raise ScenarioError(f"n_periods must be an int >= 1, got {n_periods!r}")
    return Scenario(name="firmware_replay", controller="flc", estimator=estimator,
                    duration=n_periods * TS_CONTROL, feedforward="none", seed=seed,
                    attitude={"roll": {"type": "sine", "amplitude_deg": 3.0, "frequency_hz": 0.5}},
                    estimator_tuning={"rate_process_var": 3e-5, "acc_bias_process_var": 2e-8},
                    sensor_dropouts=((0.3, 0.35, "gyro"),))


@dataclass(frozen=True)
class RecordedLog:
    """What the replay needs: readings (N, 9, NaN = missing), references (N, 15: q_ref,
    dq_ref, ddq_ref, v_ref), the mode, parameters, power-on state, and the torques the
    compiled mission applied (N, 3)."""

    meas: np.ndarray
    refs: np.ndarray
    balance_only: bool
    values: FirmwareValues
    tau_mission: np.ndarray
    v_ref_mission: np.ndarray | None = None

    @property
    def n(self) -> int:
        return self.meas.shape[0]


def record_log(scenario: Scenario, sim: ClosedLoop | None = None) -> RecordedLog:
    """Run ``scenario`` as a compiled mission and keep what the embedded software saw."""
    if scenario.torque_disturbances or scenario.pushes:
        raise ScenarioError("the replay compares torques: the scenario must have no pushes or "
                            "torque disturbances")
    log = run_scenario(scenario, sim)
    inp = scenario.inputs()
    refs = np.hstack([inp["q_ref"], inp["dq_ref"], inp["ddq_ref"], inp["v_ref"]])
    f = firmware_function(scenario.controller, scenario.estimator)
    return RecordedLog(np.asarray(log["meas"], float), refs, not scenario.cascade,
                       scenario_values(f, scenario), np.asarray(log["tau"], float))


def record_guided_log(n_periods: int = 400, seed: int = 1, guidance: str = "mpc",
                      path: GuidancePath | None = None, latency: int = 0,
                      estimator: str = DEFAULT_ESTIMATOR) -> RecordedLog:
    """Run ``path`` (default: :func:`~ballbot_casadi.firmware.sources.default_guidance_path`,
    the figure-eight at 0.5 m/s from its start) for ``n_periods`` as the compiled guided
    mission with noisy sensors and the filters of ``estimator`` (seed ``seed``;
    ``latency``: the mission's guidance latency, replayed by the split build of that
    latency) and keep what the
    embedded software saw, the torques and the velocity references the guidance gave."""
    if not isinstance(n_periods, int) or n_periods < 1:
        raise ScenarioError(f"n_periods must be an int >= 1, got {n_periods!r}")
    path = default_guidance_path() if path is None else path
    sc = path_scenario(path, n_periods * TS_CONTROL).replace(estimator=estimator, seed=seed,
                                                              guidance=guidance)
    law = scenario_law(sc, latency)  # the mission's own law for this scenario
    log = run_guided(path, law, sc.duration, scenario=sc)
    inp = sc.inputs()
    refs = np.hstack([inp["q_ref"], inp["dq_ref"], inp["ddq_ref"], inp["v_ref"]])
    f = firmware_function(sc.controller, sc.estimator, guidance, latency)
    fw_law = scenario_law(sc, latency, split=True) if latency else law  # the interrupt step's
    return RecordedLog(np.asarray(log["meas"], float), refs, not sc.cascade,
                       scenario_values(f, sc, fw_law, path), np.asarray(log["tau"], float),
                       np.asarray(log["v_ref_used"], float))


def write_replay_input(path: Path, rec: RecordedLog, build: FirmwareBuild,
                       bg_delay: int = 0) -> Path:
    """The binary input file of the replay program (little-endian doubles); ``bg_delay``
    (split guidance): periods from a snapshot's step to the step after which the replay
    runs its background sample (0: right after it; ``>= latency``: too late)."""
    if not (isinstance(bg_delay, int) and bg_delay >= 0):
        raise ScenarioError(f"bg_delay must be an int >= 0 periods, got {bg_delay!r}")
    f = firmware_function(build.controller, build.estimator, build.guidance, build.latency)
    flat = rec.values.flat_params(f)
    n_meas = embedded_readings(f).size
    if rec.meas.shape[1] != n_meas or rec.refs.shape != (rec.n, 15):
        raise BuildError(f"replay log has readings {rec.meas.shape} and references "
                         f"{rec.refs.shape}; expected (N, {n_meas}) and (N, 15)")
    guid = np.zeros(0) if build.guidance is None else rec.values.guidance
    if guid is None:
        raise BuildError("the firmware has a guidance block; the replay log has no guidance data")
    hdr = [rec.n, flat.size, rec.values.c0.size, float(rec.balance_only), CALIB_LOOPS, guid.size,
           bg_delay]
    data = np.concatenate([hdr, flat, rec.values.c0, guid, np.hstack([rec.meas, rec.refs]).ravel()])
    path.write_bytes(data.astype("<f8").tobytes())
    return path


@dataclass(frozen=True)
class ReplayResult:
    """Output of one replay: torques (N, 3), SysTick ticks per step (N), return codes (N),
    the stack high-water mark of one step (bytes), the calibration (ticks, instructions),
    ``sizeof(ballbot_fw_ctx)``, ``sizeof(ballbot_fw_real)``, with a guidance block the
    velocity references it gave (N, 3; else N x 0) and, with split guidance, the ticks of
    the background sample run after each step (N, 0 where none ran), its stack bytes and
    the results that were not ready at their due period (``guidance_late``)."""

    tau: np.ndarray
    ticks: np.ndarray
    rc: np.ndarray
    stack_bytes: int
    calib_ticks: float
    calib_instructions: float
    ctx_bytes: int
    real_bytes: int
    v_ref: np.ndarray
    bg_ticks: np.ndarray
    bg_stack_bytes: int = 0
    guidance_late: int = 0

    @property
    def instructions_per_tick(self) -> float:
        """Instructions per SysTick tick, measured by the calibration loop."""
        return self.calib_instructions / self.calib_ticks


def _read_output(path: Path, n: int) -> ReplayResult:
    data = np.frombuffer(path.read_bytes(), "<f8")
    row = _ROW + (int(data[6]) if data.size >= OUT_HEADER else 0)
    if data.size != OUT_HEADER + row * n or int(data[0]) != n:
        raise BuildError(f"replay output {path} has {data.size} values, expected "
                         f"{OUT_HEADER + row * n} (the program stopped early)")
    h, rows = data[:OUT_HEADER], data[OUT_HEADER:].reshape(n, row)
    extra = rows[:, _ROW:]
    bg = extra[:, 3].copy() if extra.shape[1] > 3 else np.zeros(n)
    return ReplayResult(rows[:, :3].copy(), rows[:, 3].copy(), rows[:, 4].astype(int), int(h[1]),
                        float(h[2]), float(h[3]), int(h[4]), int(h[5]), extra[:, :3].copy(), bg,
                        int(h[7]), int(h[8]))


def _run(cmd: list[str], cwd: Path, what: str, timeout: float) -> None:
    try:
        res = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        raise BuildError(f"{what} did not finish within {timeout:g} s") from None
    if res.returncode != 0:
        raise BuildError(f"{what} failed (exit {res.returncode}): {res.stderr.strip()[-2000:]}")


def run_qemu(build: FirmwareBuild, rec: RecordedLog, timeout: float = 600.0,
             bg_delay: int = 0) -> ReplayResult:
    """Replay ``rec`` with the library in QEMU (Cortex-M7, semihosting files in a temp dir;
    ``bg_delay``: :func:`write_replay_input`)."""
    require(qemu=True)
    with tempfile.TemporaryDirectory(prefix="ballbot-fw-") as tmp:
        d = Path(tmp)
        write_replay_input(d / "fw_replay_in.bin", rec, build, bg_delay)
        _run([*QEMU_COMMAND, "-kernel", str(build.replay_elf)], d, "the QEMU replay", timeout)
        return _read_output(d / "fw_replay_out.bin", rec.n)


def run_host(build: FirmwareBuild, rec: RecordedLog, timeout: float = 600.0,
             bg_delay: int = 0) -> ReplayResult:
    """Replay ``rec`` with the same library sources compiled for this PC (the reference;
    ``bg_delay``: :func:`write_replay_input`)."""
    with tempfile.TemporaryDirectory(prefix="ballbot-fw-") as tmp:
        d = Path(tmp)
        write_replay_input(d / "in.bin", rec, build, bg_delay)
        _run([str(build.host_replay), "in.bin", "out.bin"], d, "the host replay", timeout)
        return _read_output(d / "out.bin", rec.n)
