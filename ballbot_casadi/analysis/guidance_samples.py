"""Per-sample figures of the guidance block in a logged path run (issue 18).

A path run (:func:`~ballbot_casadi.sim.guided.run_path_scenario`) logs the guidance
block's state ``guide`` (N+1 rows: ``guide[k]`` before period ``k``; the block samples at
the periods ``0, every, 2 every, ...`` and holds in between).  From it:

* :func:`sample_periods`: the periods at which the law sampled;
* :func:`sample_residuals`: the MPC's ADMM primal residual ``r_prim`` of each sample (the
  ADMM runs a fixed number of iterations, :data:`~ballbot_casadi.guidance.qp_admm`, so its
  iteration count is constant and the residual is what varies);
* :func:`time_samples`: the wall-clock and CPU time of each sample, by calling the
  compiled guidance block (:func:`guidance_library`, the period's ``ballbot_guidance_<law>``
  generated to C) from Python on the logged inputs of each sample period.  The calls
  reproduce the logged next state (checked: :attr:`SampleTiming.g_next`), so what is timed
  is the computation the mission ran.  Times include the ``casadi.external`` call overhead;
  they are measurements of this machine (reports, never tests).

The MPC's predicted horizons come from
:func:`~ballbot_casadi.sim.guided.predictions`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Mapping

import casadi as ca
import numpy as np

from ballbot_casadi.core.toolchain import build_library, load_library
from ballbot_casadi.errors import ScenarioError
from ballbot_casadi.sim.guided import GUIDANCE_EVERY, GuidanceLaw

__all__ = ["sample_periods", "sample_residuals", "guidance_library", "time_samples",
           "SampleTiming", "timing_summary", "sample_inputs"]


def sample_periods(n_periods: int, every: int = GUIDANCE_EVERY) -> np.ndarray:
    """The control periods ``0, every, 2 every, ... < n_periods`` at which the guidance
    block samples (its counter starts at 0, :func:`~ballbot_casadi.sim.guided.make_guidance`)."""
    if not (isinstance(every, (int, np.integer)) and every >= 1):
        raise ScenarioError(f"every must be an int >= 1 periods, got {every!r}")
    return np.arange(0, max(int(n_periods), 0), every)


def sample_residuals(law: GuidanceLaw, guide: np.ndarray, every: int = GUIDANCE_EVERY) -> np.ndarray:
    """The ADMM primal residual ``r_prim`` of each MPC sample: the field of the law's
    state after each sample period (``guide[k + 1]`` for a sample at period ``k``)."""
    if law.mpc_layout is None:
        raise ScenarioError("sample_residuals: only the MPC has a QP residual")
    guide = np.asarray(guide, float)
    col = 1 + law.state["r_prim"].start  # after the period counter
    return guide[sample_periods(guide.shape[0] - 1, every) + 1, col]


def guidance_library(law: GuidanceLaw) -> ca.Function:
    """The law's period block ``ballbot_guidance_<law>`` generated to C99, compiled
    (strict flags, cached by hash under build/) and loaded."""
    f = law.function
    lib = build_library(f.name(), [f])
    return load_library(lib, [f.name()])[f.name()]


def sample_inputs(log: Mapping[str, np.ndarray], k: int) -> tuple[np.ndarray, ...]:
    """The guidance block's logged inputs at period ``k``: what the controllers read
    (``x_hat`` with an estimator, else the true ``state``), ``v_ref``, ``guide`` and the
    velocity controller's state ``z``."""
    x = log["x_hat"][k] if "x_hat" in log else log["state"][k]
    return x, log["v_ref"][k], log["guide"][k], log["z"][k]


@dataclass(frozen=True)
class SampleTiming:
    """Per-sample timing of a guidance block (see :func:`time_samples`).

    Attributes
    ----------
    periods
        Control periods of the samples.
    wall_s, cpu_s
        Wall-clock (``time.perf_counter``) and CPU time of the calling thread
        (``time.thread_time``) of each call, s.
    g_next
        The block's next state of each call (to compare with the logged one).
    """

    periods: np.ndarray
    wall_s: np.ndarray
    cpu_s: np.ndarray
    g_next: np.ndarray


def time_samples(f: ca.Function, log: Mapping[str, np.ndarray], p_ctrl: np.ndarray,
                 k_guid: np.ndarray, Ts: float, every: int = GUIDANCE_EVERY) -> SampleTiming:
    """Call the guidance block ``f`` (``(x, v_ref, g, z, p, k_guid, Ts) -> (v_ref_out,
    g_next)``, e.g. :func:`guidance_library`) once at each sample period of ``log`` on
    that period's logged inputs, timing each call (a log without a control period has no
    sample: :class:`~ballbot_casadi.errors.ScenarioError`)."""
    n = np.asarray(log["guide"]).shape[0] - 1
    periods = sample_periods(n, every)
    if periods.size == 0:
        raise ScenarioError("time_samples: the log has no control period, so no guidance sample")
    p = ca.DM(np.asarray(p_ctrl, float))
    kg = ca.DM(np.asarray(k_guid, float))
    wall, cpu, g_next = [], [], []
    for k in periods:
        args = [ca.DM(np.asarray(a, float)) for a in sample_inputs(log, int(k))]
        x, v, g, z = args
        c0, t0 = time.thread_time(), time.perf_counter()
        out = f(x, v, g, z, p, kg, Ts)
        wall.append(time.perf_counter() - t0)
        cpu.append(time.thread_time() - c0)
        g_next.append(np.asarray(out[1], float).ravel())
    return SampleTiming(periods, np.array(wall), np.array(cpu),
                        np.array(g_next).reshape(len(periods), -1))


def timing_summary(seconds: np.ndarray) -> dict[str, float]:
    """Median, 99th percentile (numpy's linear interpolation) and maximum of per-sample
    times given in s, as ``median_us``, ``p99_us``, ``max_us``."""
    us = 1e6 * np.asarray(seconds, float).ravel()
    if us.size == 0:
        raise ScenarioError("timing_summary: no samples")
    return {"median_us": float(np.median(us)), "p99_us": float(np.percentile(us, 99)),
            "max_us": float(us.max())}
