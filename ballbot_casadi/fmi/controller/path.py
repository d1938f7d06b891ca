"""The path-following controller FMU's path: the guidance block's parameter table as FMU parameters.

The path-following variant of the controller FMU (``BallbotControllerPath``,
:func:`~ballbot_casadi.fmi.controller.controller.controller_spec` with a scenario that has
a ``[path]``) runs the embedded software with the path-following MPC in its guidance
slot: the Function :func:`~ballbot_casadi.sim.guided.guided_software` that the compiled
guided mission calls.  Its path and obstacles are the guidance block's parameter vector
``k_guid`` (:func:`~ballbot_casadi.guidance.path_table.path_table_layout`: a path of any
kind, waypoints, line, arc or figure-eight, resolved to a table of
:data:`~ballbot_casadi.guidance.path_table.PATH_SAMPLES` points and unit tangents at
equal arc-length steps), one FMU parameter per entry (:func:`path_parameter_names`):

* ``path_length`` (m), ``path_closed`` (0 or 1), ``path_speed`` (m/s, ``0 < speed <=
  v_max`` of thesis §7.1);
* ``path_p<i>_x``, ``path_p<i>_y`` (m): table point ``i`` (``s_i = i L / (n - 1)``);
* ``path_t<i>_x``, ``path_t<i>_y``: the unit tangent there;
* ``obstacle<j>_x``, ``obstacle<j>_y``, ``obstacle<j>_r`` (m): circular obstacle ``j``
  (radius 0: an empty slot);
* ``path_s0`` (m): the arc length of the path point nearest the robot's position at
  power-on (``x0_x``, ``x0_y``), where the MPC's progress starts (the mission computes it
  with :meth:`Path.project <ballbot_casadi.guidance.paths.Path.project>`; the FMU checks
  it is no farther from the start than the nearest table point plus
  :data:`S0_TOL`).

:func:`path_parameter_values` gives their values for a scenario (the SSP's parameter set
and the FMU's start values).  The FMU refuses (logged, ``fmi2Error``) a NaN or Inf
entry, a non-positive length, ``closed`` not 0 or 1, a speed outside ``(0, v_max]``, a
tangent that is not a unit vector (within :data:`TANGENT_TOL`), a negative radius, an
obstacle covering the path's start, its end or the robot's start, and a ``path_s0``
that is not the start's projection.

The MPC's condensed prediction matrices are build-time constants: they come from the
velocity loop of the scenario's controller model and velocity gain
(:func:`~ballbot_casadi.sim.path_following.velocity_loop_model`) at the period ``Ts``.
The parameters they are built from, as their builder declares them (``Ts`` and the
``ctrl_*`` and ``k_vel_*`` entries of :func:`mpc_model_dependencies`: the body's mass,
inertia about x and y and centre of mass, the ball's, the friction, ``g``, the velocity
gain) are therefore fixed at their
build values: setting one to another value is refused (logged, the set call returns
``fmi2Error`` / ``fmi3Error``) instead of running a loop the MPC does not predict.  The
others (``ctrl_tau_max``, the wheel geometry the FLC cancels, the velocity limits, ...)
stay settable.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ballbot_casadi.core.constants import THESIS_LIMITS
from ballbot_casadi.core.layout import Layout
from ballbot_casadi.control.velocity import VELOCITY_NKV
from ballbot_casadi.errors import ScenarioError, ShapeError
from ballbot_casadi.guidance.path_table import PATH_SAMPLES, path_table_layout
from ballbot_casadi.core.params import PARAM_NAMES
from ballbot_casadi.guidance.prediction import NXL
from ballbot_casadi.sim.closed_loop import power_on_inputs
from ballbot_casadi.sim.embedded import ESTIMATOR_FILTERS
from ballbot_casadi.sim.guided import GuidanceLaw, make_loop_state, scenario_law
from ballbot_casadi.sim.path_following import velocity_loop_dependencies
from ballbot_casadi.sim.period import require_finite_controller_limit
from ballbot_casadi.sim.scenario import Scenario

__all__ = ["PATH_MODEL_IDENTIFIER", "S0_NAME", "S0_TOL", "TANGENT_TOL", "V_MAX", "FIXED_WHY",
           "mpc_model_dependencies", "path_law", "path_parameter_names", "path_parameter_descriptions",
           "path_parameter_values"]

#: Model identifier of the path-following controller FMU (QUKF + VUKF; ``_ekf`` with the EKFs).
PATH_MODEL_IDENTIFIER = "BallbotControllerPath"
#: The parameter giving the arc length where the progress starts.
S0_NAME = "path_s0"
#: ``path_s0`` may put the start at most this much (m) farther from the robot than the
#: nearest table point (the table's spacing is ~1 cm; the projection is exact on the spline).
S0_TOL = 0.01
#: Largest deviation of a tangent's norm from 1.
TANGENT_TOL = 1e-6
#: Highest reference speed (m/s), thesis §7.1.
V_MAX = THESIS_LIMITS["v_max"]
#: Why the parameters of :func:`mpc_model_dependencies` are fixed (the FMU's refusal says it).
FIXED_WHY = ("the path-following MPC's prediction matrices were computed from it when the "
             "FMU was built; build the FMU of a scenario with the value you want "
             "(ballbot fmu build-controller --scenario)")


def path_law(scenario: Scenario) -> GuidanceLaw:
    """The guidance law of a path scenario the FMU can run (the MPC).

    Raises
    ------
    ScenarioError
        No ``[path]``, guidance other than the MPC, a controller other than the FLC
        cascade, a guidance latency, the per-wheel torque limit (whose controller limit
        is ``+inf``, :func:`~ballbot_casadi.sim.period.controller_torque_limit`, not a
        value of the FMU's ``ctrl_tau_max``), or no estimator (one line naming the key).
    """
    if scenario.route.build() is None:
        raise ScenarioError(f"scenario {scenario.name!r} has no [path]: the path-following "
                            "controller FMU needs one", key="path")
    if scenario.guidance != "mpc":
        raise ScenarioError(f"scenario {scenario.name!r}: the path-following controller FMU runs "
                            f"the MPC guidance, got guidance = {scenario.guidance!r}; allowed: mpc",
                            key="guidance")
    if scenario.controller != "flc" or not scenario.cascade:
        raise ScenarioError(f"scenario {scenario.name!r}: path following runs the FLC cascade "
                            f"(controller 'flc', cascade = true), got {scenario.controller!r}",
                            key="controller")
    require_finite_controller_limit(scenario.torque_limit, scenario.name, "the controller FMU")
    if scenario.guidance_latency:
        raise ScenarioError(f"scenario {scenario.name!r}: the path-following controller FMU "
                            "applies each guidance sample in its own period, got "
                            f"guidance_latency = {scenario.guidance_latency}; allowed: 0",
                            key="guidance_latency")
    if scenario.estimator not in ESTIMATOR_FILTERS:
        raise ScenarioError(f"scenario {scenario.name!r}: the controller FMU needs an estimator "
                            f"({', '.join(ESTIMATOR_FILTERS)}), got {scenario.estimator!r}",
                            key="estimator")
    return scenario_law(scenario)


def mpc_model_dependencies(p_ctrl: Any, k_vel: Any, dt: float
                           ) -> tuple[tuple[str, ...], tuple[int, ...]]:
    """What the MPC's prediction model is built from: the model parameters (``load_params``
    names) and the indices into ``k_vel``.

    The prediction model is the velocity loop closed by ``k_vel``'s gain around the
    linearisation of the controllers' model ``p_ctrl`` at the upright equilibrium, with
    the balance controller's FLC in it, discretised at the MPC step ``dt``
    (:func:`~ballbot_casadi.sim.path_following.velocity_loop_model`); its builder declares
    what it reads (:func:`~ballbot_casadi.sim.path_following.velocity_loop_dependencies`:
    the parameters the model's Jacobians depend on structurally there, less those the
    FLC's inversion cancels, and the gain entries).  The set is the same for every value;
    the arguments are checked for their sizes.

    Raises
    ------
    ShapeError
        ``p_ctrl`` or ``k_vel`` of the wrong size, or ``dt`` not positive.
    """
    p = np.asarray(p_ctrl, float).ravel()
    k = np.asarray(k_vel, float).ravel()
    if p.size != len(PARAM_NAMES) or k.size != VELOCITY_NKV or not float(dt) > 0.0:
        raise ShapeError(f"p_ctrl must have {len(PARAM_NAMES)} entries and k_vel "
                         f"{VELOCITY_NKV}, dt > 0; got {p.size}, {k.size}, dt = {dt!r}")
    dep = velocity_loop_dependencies()
    return dep.params, dep.gains


def _table(law: GuidanceLaw) -> Layout:
    return path_table_layout(law.config.n_obstacles, PATH_SAMPLES)


def path_parameter_names(law: GuidanceLaw) -> tuple[str, ...]:
    """The FMU parameters of ``k_guid`` in its element order (module docstring)."""
    L = _table(law)
    n = L.size_of("points") // 2
    m = L.size_of("obstacles") // 3
    names = ["path_length", "path_closed", "path_speed"]
    names += [f"path_p{i}_{c}" for i in range(n) for c in "xy"]
    names += [f"path_t{i}_{c}" for i in range(n) for c in "xy"]
    names += [f"obstacle{j}_{c}" for j in range(m) for c in ("x", "y", "r")]
    if len(names) != L.size:
        raise ScenarioError(f"path table of {L.size} entries, {len(names)} names")
    return tuple(names)


def path_parameter_descriptions(law: GuidanceLaw) -> dict[str, tuple[str, str | None]]:
    """``name -> (description, unit)`` of the path parameters and ``path_s0``."""
    L = _table(law)
    n = L.size_of("points") // 2
    out: dict[str, tuple[str, str | None]] = {
        "path_length": ("length L of the path (arc length of the table's last point)", "m"),
        "path_closed": ("1: a closed path (progress modulo L), 0: an open one (stops at its end)",
                        "1"),
        "path_speed": (f"reference progress speed, 0 < speed <= {V_MAX} (thesis 7.1 v_max)",
                       "m/s"),
        S0_NAME: ("arc length of the path point nearest the robot's position at power-on "
                  "(x0_x, x0_y): where the MPC's progress starts", "m"),
    }
    for name in path_parameter_names(law)[3:]:
        kind, c = name.rsplit("_", 1)
        if kind.startswith("path_p"):
            out[name] = (f"path table point {kind[6:]} of {n} (equal arc-length steps), {c}", "m")
        elif kind.startswith("path_t"):
            out[name] = (f"unit tangent of the path at table point {kind[6:]}, {c}", "1")
        else:
            what = {"x": "centre x", "y": "centre y", "r": "radius (0: no obstacle)"}[c]
            out[name] = (f"circular obstacle {kind[8:]}: {what}", "m")
    return out


def path_parameter_values(scenario: Scenario, law: GuidanceLaw | None = None
                          ) -> dict[str, float]:
    """The path parameters' values for ``scenario`` (its ``k_guid`` and ``path_s0``, as the
    compiled guided mission starts)."""
    law = path_law(scenario) if law is None else law
    path = scenario.route.build()
    k = law.parameters(path)
    inp = power_on_inputs(scenario.estimator, scenario.inputs(periods=(0, 1)))
    X0 = np.asarray(make_loop_state()(inp["x0"], inp["z0"]), float).reshape(NXL)
    out = {n: float(v) for n, v in zip(path_parameter_names(law), k, strict=True)}
    out[S0_NAME] = float(path.project(X0[12:14]))
    return out


def path_c_defines(law: GuidanceLaw) -> dict[str, Any]:
    """The constants the per-model C checks the path with."""
    L = _table(law)
    return {"PATH_SAMPLES": L.size_of("points") // 2, "PATH_OBSTACLES": L.size_of("obstacles") // 3,
            "V_MAX": repr(float(V_MAX)), "S0_TOL": repr(S0_TOL), "TANGENT_TOL": repr(TANGENT_TOL)}
