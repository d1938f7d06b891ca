"""The robot's embedded software as an FMU: ``BallbotController.fmu`` (FMI 2.0 Co-Simulation).

The FMU runs the embedded software's period, the CasADi Function
``ballbot_embedded_<ctrl>_<est>`` of :func:`~ballbot_casadi.sim.embedded.make_embedded_step`
(attitude and velocity filters, velocity controller, balance controller, torque limit),
taken from the Functions the compiled mission exports
(:func:`~ballbot_casadi.sim.embedded.embedded_software`, built without any mission): the
FMU's C and the mission's C are generated from the same Function, so there is one
implementation.  The per-model C file is ``fmu/controller/controller_model.c``; the FMI
layer is the plant's (``fmu/layer/fmi2_common.c`` and its parts), the table below
generates ``modelDescription.xml`` and the C
headers.

Path following: :func:`controller_spec` with a scenario that has a ``[path]`` builds
``BallbotControllerPath`` (:mod:`~ballbot_casadi.fmi.controller.path`): the embedded
software with the path-following MPC in its guidance slot, the Function the compiled
guided mission calls (:func:`~ballbot_casadi.sim.guided.guided_software`); the path
table, the obstacles and ``path_s0`` are parameters, the guidance state ``c_guide_*``
starts at initialisation as the mission's (``GuidanceLaw.initial_function``), and the
outputs ``v_ref_used_x, v_ref_used_y, yaw_rate_ref_used`` give the references the
guidance handed the velocity controller.  The velocity inputs ``v_ref_x, v_ref_y`` are
then unused (``yaw_rate_ref`` still is).  The parameters the MPC's build-time prediction
matrices depend on (``Ts``, ``ctrl_*`` and ``k_vel_*`` entries of
:func:`~ballbot_casadi.fmi.controller.path.mpc_model_dependencies`) are fixed at the
build's values: another value is refused.  The same table builds the FMI 2.0 and the FMI 3.0 variant.

Variants: :func:`controller_spec` builds any balance controller with any estimator;
the FLC with the package's default estimator
(:data:`~ballbot_casadi.sim.embedded.DEFAULT_ESTIMATOR`) is ``BallbotController``, the
others are separate FMUs ``BallbotController_<ctrl>_<est>`` (e.g. the predecessor's SMC
with the EKFs, ``BallbotController_smc_ekf``) built from the same table and C file: the
filters' state and covariance sizes differ, so a run-time switch would need both
layouts in one FMU for no gain.

Timing (thesis §7.1, 200 Hz).  Period ``k`` runs at ``t_k = startTime + k Ts``.  At a
communication point ``t_k`` the inputs (readings, references, mode) are latched;
``fmi2DoStep(t_k, n Ts)`` runs the ``n`` periods ``k .. k+n-1``: the first on the
latched readings, the others predict only (their readings are missing: a held reading
is not a new sample), all with the latched references.  The outputs after the step are
those of the last period; the wheel torques ``tau0..2`` are the command the embedded
software sends at the end of its period.  A communication step that is not a whole
number of periods (within ``STEP_TOL Ts``) is refused (``fmi2Error``, logged, nothing
changed); a step within ``STEP_TOL Ts`` of zero (the rounding remainder an importer with a
running-sum clock issues at the end, 1e-17 .. 1e-13 s) runs no period and returns OK.  The encoder reading of period 0 is missing (there is no previous count to
difference), as in the compiled mission.  A NaN reading (Real inputs accept NaN as
"missing") makes its filter predict only for that sensor; the torque stays finite.

What this means for a master: stepping the controller first and the plant after it at
each ``t_k`` (Gauss-Seidel) gives the loop of the compiled mission exactly (torque of
period ``k`` computed from sample ``k`` and acting on ``[t_k, t_k+1)``); a master that
steps both at once and exchanges values afterwards (Jacobi, libcosim's fixed-step
algorithm, fmpy's containers) applies it one period later, on ``[t_k+1, t_k+2)``
(:mod:`ballbot_casadi.fmi.masters.ssp_run`).

Variable names (see :func:`controller_variables`):

* inputs: the readings as the plant FMU outputs them (``sensor_acc_x .. sensor_enc2``,
  NaN = missing), the attitude reference of the balance-only mode ``q_ref0..3``,
  ``dq_ref0..3``, ``ddq_ref0..3``, the velocity reference ``v_ref_x, v_ref_y`` and the
  heading-rate reference ``yaw_rate_ref``, and the Boolean ``balance_only`` (the
  attitude reference drives the balance controller alone, thesis Fig. 8.1; otherwise
  the velocity cascade, Fig. 7.1);
* outputs: ``tau0..2`` (limited command), ``tau_cmd0..2``, the estimate ``pos_hat_x/y,
  q_hat0..3, v_hat_x/y, dq_hat0..3``, ``roll_hat, pitch_hat, yaw_hat``, the body rate
  ``omega_hat_x/y/z``, the references used, ``diag_<name>``, ``nis_attitude``,
  ``nis_velocity``, ``repairs``, the innovation-gate rejections ``rejected_<filter>_<sensor>``
  (:data:`REJECTION_NAMES`; and ``com_hat_x/y`` with the COM observer);
* parameters: ``Ts``; the controllers' internal model ``ctrl_<name>`` and the filters'
  internal model ``est_<name>`` under the :data:`~ballbot_casadi.core.params.PARAM_NAMES`
  of ``load_params`` (both exist, hence the prefixes); the gains ``k_bal_<gain name>``
  and ``k_vel_K_<row>_<col>`` / ``k_vel_<limit name>``; ``feedforward``; the filter
  covariances ``Qa_<r>_<c>``, ``Ra_..``, ``Qv_..``, ``Rv_..``; the robot's state at
  power-on ``x0_<state name>`` (``x0_x .. x0_dq3``), from which the FMU computes the
  embedded software's state at power-on in its initialisation with the generated C of
  ``ballbot_initial_controller_state_<est>[_obs]``
  (:func:`~ballbot_casadi.sim.embedded.make_initial_controller_state`, the Function the
  compiled mission starts from: the filters aligned with that state as after the
  start-up calibration at rest); with the COM observer ``com_observer`` and
  ``k_obs_<gain name>``;
* locals: the embedded software's state ``c_<field>_<i>`` and the period counter
  ``period`` (so FMU states, serialisation and reset need no model code).

:func:`controller_values` gives every parameter's value for a
:class:`~ballbot_casadi.sim.scenario.Scenario` (the start values are those of a default
scenario); the SSP writes them into its parameter set.
"""

from __future__ import annotations

from typing import Any, Mapping

import casadi as ca
import numpy as np

from ballbot_casadi.control import BALANCE_DIAG_NAMES, BALANCE_GAIN_NAMES
from ballbot_casadi.control.velocity import (
    VELOCITY_LIMIT_NAMES,
    VELOCITY_NKV,
)
from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.constants import TS_CONTROL
from ballbot_casadi.core.layout import STATE, VELOCITY_FILTER_STATE, Layout
from ballbot_casadi.core.params import PARAM_INFO, PARAM_NAMES
from ballbot_casadi.core.validation import QUAT_TOL
from ballbot_casadi.errors import BuildError, ScenarioError
from ballbot_casadi.estimation.com_observer import COM_OBSERVER_GAIN_NAMES
from ballbot_casadi.fmi.controller.path import (
    FIXED_WHY,
    PATH_MODEL_IDENTIFIER,
    S0_NAME,
    path_c_defines,
    mpc_model_dependencies,
    path_law,
    path_parameter_descriptions,
    path_parameter_names,
    path_parameter_values,
)
from ballbot_casadi.fmi.plant.plant import HEADING_OUTPUT_NAME, SENSOR_OUTPUT_NAMES
from ballbot_casadi.fmi.package import fmu_source_dir
from ballbot_casadi.fmi.spec import INT32_MAX, FmuBlock, FmuSpec, FmuVar, VarTable
from ballbot_casadi.guidance.path_table import path_table_layout
from ballbot_casadi.sim.embedded import (
    ADAPTIVE_VELOCITY,
    DEFAULT_ESTIMATOR,
    ESTIMATOR_FILTERS,
    GATE_GROUPS,
    MATCHED_VELOCITY,
    MEAS_HEADING,
    embedded_software,
    initial_controller_state_function,
    readings_layout,
    software_layout,
)
from ballbot_casadi.sim.guided import GuidanceLaw, guided_software
from ballbot_casadi.sim.period import require_finite_controller_limit
from ballbot_casadi.sim.ports import (
    EMBEDDED_INPUTS,
    EMBEDDED_OUTPUTS,
    GUIDANCE_CONSTANTS,
    GUIDANCE_OUTPUTS,
    MODEL_CONSTANTS,
    OBSERVER_CONSTANTS,
    OBSERVER_OUTPUTS,
)
from ballbot_casadi.sim.scenario import Scenario

__all__ = [
    "MODEL_IDENTIFIER",
    "STEP_TOL",
    "MAX_PERIODS",
    "READING_NAMES",
    "HEADING_READING_NAME",
    "reading_names",
    "REFERENCE_NAMES",
    "XHAT_NAMES",
    "REJECTION_NAMES",
    "model_identifier",
    "embedded_function",
    "controller_state_layout",
    "initial_state_function",
    "X0_NAMES",
    "V_REF_USED_NAMES",
    "path_embedded_function",
    "controller_variables",
    "controller_values",
    "controller_spec",
    "default_scenario",
]

MODEL_IDENTIFIER = "BallbotController"
#: A communication step within STEP_TOL * Ts of n * Ts runs n periods (n = 0 included).
STEP_TOL = 1e-6
#: Largest number of periods one fmi2DoStep may run.
MAX_PERIODS = 1_000_000
#: Quaternion norm tolerance of a restored FMU state (far above rounding, far below damage).
QUAT_TOL_RESTORED = 1e-3
#: The readings (inputs), named as the plant FMU's outputs: acc (3), gyro (3), enc (3).
READING_NAMES = SENSOR_OUTPUT_NAMES
#: The heading reading of an estimator that reads the heading sensor (``ukf_heading``,
#: ``ekf_heading``): the last reading input, named as the plant FMU's heading output (NaN
#: = no reading this period; the sensor samples at a low rate).
HEADING_READING_NAME = HEADING_OUTPUT_NAME
#: Reference inputs in the order the per-model C reads them: q_ref, dq_ref, ddq_ref (4
#: each, balance-only mode), then the velocity reference and the heading-rate reference.
REFERENCE_NAMES = (*(f"q_ref{i}" for i in range(4)), *(f"dq_ref{i}" for i in range(4)),
                   *(f"ddq_ref{i}" for i in range(4)), "v_ref_x", "v_ref_y", "yaw_rate_ref")
#: The reference inputs by field (the embedded Function's q_ref, dq_ref, ddq_ref, v_ref).
REFERENCE = Layout("references", [("q_ref", 4), ("dq_ref", 4), ("ddq_ref", 4), ("v_ref", 3)],
                   REFERENCE_NAMES)
#: The references the balance controller used (outputs q_ref_used, dq_ref_used, ddq_ref_used).
REFERENCE_USED = Layout("references used", [("q", 4), ("dq", 4), ("ddq", 4)])
#: The estimate x_hat the controllers read (output block, the order of the Function's output).
XHAT_NAMES = ("pos_hat_x", "pos_hat_y", "q_hat0", "q_hat1", "q_hat2", "q_hat3", "v_hat_x",
              "v_hat_y", "dq_hat0", "dq_hat1", "dq_hat2", "dq_hat3")
#: The innovation-gate rejections of the last period (outputs, 1 = rejected), one per
#: measurement group of :data:`~ballbot_casadi.sim.embedded.GATE_GROUPS`.
REJECTION_NAMES = tuple(f"rejected_{g}" for g in GATE_GROUPS.fields)
#: The velocity reference the guidance block gave the velocity controller (path variant outputs).
V_REF_USED_NAMES = ("v_ref_used_x", "v_ref_used_y", "yaw_rate_ref_used")
#: The robot's state at power-on (parameters): ``x0_<state name>``.
X0_NAMES = tuple(f"x0_{n}" for n in STATE.names)
_XHAT_UNITS = ("m", "m", "1", "1", "1", "1", "m/s", "m/s", "1/s", "1/s", "1/s", "1/s")
_STATE_UNITS = _XHAT_UNITS
_READING_DESC = {
    "acc": ("m/s2", "accelerometer reading along IMU axis {c} (the plant FMU's output of that "
                    "name); NaN = missing (the filters predict only)"),
    "gyro": ("rad/s", "gyroscope reading about IMU axis {c} (the plant FMU's output of that "
                      "name); NaN = missing (the attitude filter predicts only)"),
    "enc": ("1/s", "wheel {c} encoder reading in ticks per second (the plant FMU's output of "
                   "that name); NaN = missing (the velocity filter predicts only); the reading "
                   "of period 0 is always taken as missing"),
    "heading": ("rad", "heading-sensor reading (ZYX yaw of the body, wrapped to (-pi, pi]); NaN "
                       "= no reading this period (the sensor samples at a low rate)"),
}


def reading_names(estimator: str) -> tuple[str, ...]:
    """The reading inputs of the controller FMU of ``estimator``, in the order of its
    readings layout (:func:`~ballbot_casadi.sim.embedded.readings_layout`): the plant
    FMU's sensor outputs, then the heading reading if the estimator reads it."""
    heading = readings_layout(estimator) is MEAS_HEADING
    return (*READING_NAMES, *((HEADING_READING_NAME,) if heading else ()))


def model_identifier(controller: str, estimator: str) -> str:
    """``BallbotController`` for the FLC with
    :data:`~ballbot_casadi.sim.embedded.DEFAULT_ESTIMATOR`, else
    ``BallbotController_<controller>_<estimator>``."""
    if (controller, estimator) == ("flc", DEFAULT_ESTIMATOR):
        return MODEL_IDENTIFIER
    return f"{MODEL_IDENTIFIER}_{controller}_{estimator}"


def filters_title(estimator: str) -> str:
    """The filters of ``estimator`` as the FMU's description names them, e.g. ``QUKF +
    VUKF`` (the thesis's), ``QUKF + VUKF (matched, adaptive walk)`` (``ukf_adaptive``)."""
    att, vel = ESTIMATOR_FILTERS[estimator]
    how = ", ".join(w for w, on in (("matched", estimator in MATCHED_VELOCITY),
                                   ("adaptive walk", estimator in ADAPTIVE_VELOCITY)) if on)
    return f"{att.upper()} + {vel.upper()}" + (f" ({how})" if how else "")


def embedded_function(controller: str = "flc", estimator: str = DEFAULT_ESTIMATOR
                      ) -> ca.Function:
    """The embedded software's period ``ballbot_embedded_<controller>_<estimator>``
    (:func:`~ballbot_casadi.sim.embedded.embedded_software`, the Function the compiled
    mission calls), checked against what the per-model C reads.  Builds no mission.

    Raises
    ------
    ScenarioError
        Unknown controller or estimator (the message lists the allowed ones).
    BuildError
        The Function's inputs or outputs are not the ones the per-model C reads.
    """
    if estimator == "true":
        raise ScenarioError(f"the controller FMU needs an estimator (one of "
                            f"{', '.join(ESTIMATOR_FILTERS)}); the true state is not available "
                            "to the embedded software")
    f = embedded_software(controller, estimator)
    name = f.name()
    ins, outs = tuple(f.name_in()), tuple(f.name_out())
    if ins not in (EMBEDDED_INPUTS, (*EMBEDDED_INPUTS, *OBSERVER_CONSTANTS)) or outs not in (
            EMBEDDED_OUTPUTS, (*EMBEDDED_OUTPUTS, *OBSERVER_OUTPUTS)):
        raise BuildError(f"{name} has inputs {ins} and outputs {outs}; the controller FMU reads "
                         f"{EMBEDDED_INPUTS} (+ {OBSERVER_CONSTANTS}) -> {EMBEDDED_OUTPUTS} "
                         f"(+ {OBSERVER_OUTPUTS})")
    return f


def path_embedded_function(law: GuidanceLaw, estimator: str = DEFAULT_ESTIMATOR
                           ) -> ca.Function:
    """The embedded software with the guidance ``law`` in its slot
    (:func:`~ballbot_casadi.sim.guided.guided_software`: the Function the compiled guided
    mission calls), checked against what the per-model C reads.

    Raises
    ------
    BuildError
        The Function's inputs or outputs are not the ones the per-model C reads.
    """
    f = guided_software(law, estimator)
    ins, outs = tuple(f.name_in()), tuple(f.name_out())
    want_in = (*EMBEDDED_INPUTS, *OBSERVER_CONSTANTS, *GUIDANCE_CONSTANTS)
    want_out = (*EMBEDDED_OUTPUTS, *OBSERVER_OUTPUTS, *GUIDANCE_OUTPUTS)
    if ins != want_in or outs != want_out:
        raise BuildError(f"{f.name()} has inputs {ins} and outputs {outs}; the path-following "
                         f"controller FMU reads {want_in} -> {want_out}")
    return f


def _has_observer(embedded: ca.Function) -> bool:
    return OBSERVER_CONSTANTS[0] in embedded.name_in()


def _has_guidance(embedded: ca.Function) -> bool:
    return GUIDANCE_CONSTANTS[0] in embedded.name_in()


def controller_state_layout(embedded: ca.Function, estimator: str,
                            law: GuidanceLaw | None = None) -> Layout:
    """Layout of the embedded software's state ``c``
    (:func:`~ballbot_casadi.sim.embedded.software_layout`; with the guidance ``law`` its
    state ``guide``)."""
    return software_layout(embedded, estimator,
                           law.function.numel_in(2) if law is not None else 0)


def default_scenario(controller: str = "flc", estimator: str = DEFAULT_ESTIMATOR) -> Scenario:
    """The scenario whose values are the FMU's start values: the robot upright at rest,
    the velocity cascade on, the package's default gains and the thesis's filter tuning."""
    return Scenario(name="controller_fmu_default", controller=controller, estimator=estimator,
                    cascade=True, duration=TS_CONTROL)


def _element_names(field: str, n: int) -> list[str]:
    return [f"{field}_{i}" for i in range(n)]


def _matrix_names(name: str, n: int) -> list[str]:
    """Names of an n x n matrix's entries in column-major order (how the Function reads it)."""
    return [f"{name}_{r}_{c}" for c in range(n) for r in range(n)]


def _kvel_names() -> list[str]:
    """``k_vel``: the 2 x n LQR gain row by row (``K_<row>_<col>``), then the limits."""
    n_lqr = (VELOCITY_NKV - len(VELOCITY_LIMIT_NAMES)) // 2
    return ([f"k_vel_K_{r}_{c}" for r in range(2) for c in range(n_lqr)]
            + [f"k_vel_{n}" for n in VELOCITY_LIMIT_NAMES])


def _side(embedded: ca.Function, arg: str) -> int:
    """Side of the square covariance input ``arg`` (column-major vector)."""
    return int(round(np.sqrt(embedded.size1_in(embedded.index_in(arg)))))


def _parameter_groups(embedded: ca.Function, controller: str, estimator: str,
                      law: GuidanceLaw | None = None) -> list[tuple[str, list[str]]]:
    """``(Function input, [FMU parameter names])`` of every vector parameter, in the
    Function's element order."""
    nv = int(round(np.sqrt(embedded.size1_in(EMBEDDED_INPUTS.index("Qv")))))
    groups = [
        ("p_ctrl", [f"ctrl_{n}" for n in PARAM_NAMES]),
        ("p_est", [f"est_{n}" for n in PARAM_NAMES]),
        ("k_bal", [f"k_bal_{n}" for n in BALANCE_GAIN_NAMES[controller]]),
        ("k_vel", _kvel_names()),
        ("Qa", _matrix_names("Qa", _side(embedded, "Qa"))),
        ("Ra", _matrix_names("Ra", _side(embedded, "Ra"))),
        ("Qv", _matrix_names("Qv", nv)),
        ("Rv", _matrix_names("Rv", 6)),
    ]
    if _has_observer(embedded):
        groups.append(("k_obs", [f"k_obs_{n}" for n in COM_OBSERVER_GAIN_NAMES]))
    if _has_guidance(embedded):
        if law is None:
            raise BuildError(f"{embedded.name()} has a guidance block: give its law")
        groups.append(("k_guid", list(path_parameter_names(law))))
    for arg, names in groups:
        if len(names) != embedded.size1_in(embedded.index_in(arg)):
            raise BuildError(f"{embedded.name()}: input {arg} has "
                             f"{embedded.size1_in(embedded.index_in(arg))} entries, the FMU "
                             f"names {len(names)}")
    return groups


def initial_state_function(embedded: ca.Function, estimator: str,
                           law: GuidanceLaw | None = None) -> ca.Function:
    """The power-on state Function of the embedded software ``embedded``
    (:func:`~ballbot_casadi.sim.embedded.initial_controller_state_function`, with the COM
    observer's part when ``embedded`` has the observer), checked against its state (with
    the guidance ``law``: all but the guidance state ``guide``, which the FMU starts with
    the law's own initial Function).

    Raises
    ------
    BuildError
        The Function's output is not the embedded software's state.
    """
    n_guide = law.function.numel_in(2) if law is not None else 0
    layout = software_layout(embedded, estimator, n_guide)
    n_bal = layout.size_of("bal") if "bal" in layout.fields else 0
    f = initial_controller_state_function(estimator, _has_observer(embedded), n_bal)
    if f.size1_out(0) + n_guide != embedded.size1_in(0):
        raise BuildError(f"{f.name()} gives {f.size1_out(0)} entries, {embedded.name()}'s state "
                         f"has {embedded.size1_in(0)}")
    return f


def controller_values(scenario: Scenario, embedded: ca.Function | None = None,
                      law: GuidanceLaw | None = None) -> dict[str, float | bool]:
    """Values of the controller FMU's parameters for ``scenario`` (FMU name -> value).

    The scenario's controller model (``ctrl_*``), filter model (``est_*``), gains,
    feed-forward mode, filter tuning, COM observer and the robot's state at power-on
    (``x0_*``, from which the FMU starts the velocity controller, filters and observer as
    the compiled mission starts them); with the guidance ``law`` (the path-following
    variant, ``embedded`` from :func:`path_embedded_function`) the path table and
    ``path_s0`` (:func:`~ballbot_casadi.fmi.controller.path.path_parameter_values`).
    Booleans are Python ``bool``.

    Raises
    ------
    ScenarioError
        The scenario has no estimator in the loop, or the per-wheel torque limit
        (:func:`~ballbot_casadi.sim.period.require_finite_controller_limit`).
    """
    if scenario.estimator == "true":
        raise ScenarioError(f"scenario {scenario.name!r}: the controller FMU needs an estimator "
                            f"(estimator = one of {', '.join(ESTIMATOR_FILTERS)})")
    require_finite_controller_limit(scenario.torque_limit, scenario.name, "the controller FMU")
    embedded = embedded_function(scenario.controller, scenario.estimator) if embedded is None \
        else embedded
    inp = scenario.inputs()
    est = inp["estimation"]
    vectors = {"p_ctrl": inp["p_ctrl"], "p_est": est["p_est"], "k_bal": inp["k_bal"],
               "k_vel": inp["k_vel"], "Qa": est["Qa"], "Ra": est["Ra"], "Qv": est["Qv"],
               "Rv": est["Rv"], "k_obs": inp.get("k_obs")}
    out: dict[str, float | bool] = {"Ts": float(inp["Ts"]), "feedforward": bool(inp["feedforward"])}
    path_values = path_parameter_values(scenario, law) if law is not None else {}
    for arg, names in _parameter_groups(embedded, scenario.controller, scenario.estimator, law):
        if arg == "k_guid":
            out.update({n: path_values[n] for n in names})
            continue
        vals = np.asarray(vectors[arg], float).ravel(order="F")
        out.update({n: float(v) for n, v in zip(names, vals, strict=True)})
    if _has_observer(embedded):
        out["com_observer"] = bool(inp["com_observer"])
    out.update({n: float(v) for n, v in zip(X0_NAMES, np.asarray(inp["x0"], float).ravel(),
                                            strict=True)})
    if law is not None:
        out[S0_NAME] = path_values[S0_NAME]
    return out


def controller_variables(embedded: ca.Function, controller: str, estimator: str,
                         start: Mapping[str, float | bool] | None = None,
                         law: GuidanceLaw | None = None) -> tuple[FmuVar, ...]:
    """The variable table of the controller FMU (module docstring), ordered by VR.

    ``start`` gives the parameters' start values (default :func:`controller_values` of
    :func:`default_scenario`; the path-following variant, with ``law``, needs them).
    """
    if start is None and law is not None:
        raise BuildError("the path-following controller FMU's start values come from a path "
                         "scenario: give start")
    start = controller_values(default_scenario(controller, estimator), embedded) \
        if start is None else start
    layout = controller_state_layout(embedded, estimator, law)
    t = VarTable()
    for name in reading_names(estimator):
        group = name.removeprefix("sensor_").rstrip("xyz012_")
        unit, desc = _READING_DESC[group]
        t.add(name, "discrete_input", desc.format(c=name[-1]), start=0.0, unit=unit, missing=True)
    for i in range(4):
        t.add(f"q_ref{i}", "discrete_input", f"attitude reference quaternion q{i} (balance-only "
              "mode)", start=1.0 if i == 0 else 0.0, unit="1")
    for i in range(4):
        t.add(f"dq_ref{i}", "discrete_input", f"rate of the attitude reference dq{i} "
              "(balance-only mode)", start=0.0, unit="1/s")
    for i in range(4):
        t.add(f"ddq_ref{i}", "discrete_input", f"second derivative of the attitude reference "
              f"ddq{i} (balance-only mode; used with feedforward)", start=0.0, unit="1/s2")
    t.add("v_ref_x", "discrete_input", "ball velocity reference along x (velocity cascade)",
          start=0.0, unit="m/s")
    t.add("v_ref_y", "discrete_input", "ball velocity reference along y (velocity cascade)",
          start=0.0, unit="m/s")
    t.add("yaw_rate_ref", "discrete_input", "heading-rate reference (velocity cascade)",
          start=0.0, unit="rad/s")
    for i in range(3):
        t.add(f"tau{i}", "discrete_output", f"wheel {i} torque command after the "
              "direction-preserving limit at ctrl_tau_max (connect to the plant's tau{i})",
              unit="N.m")
    for i in range(3):
        t.add(f"tau_cmd{i}", "discrete_output", f"wheel {i} torque of the balance controller "
              "before the limit", unit="N.m")
    for name, unit in zip(XHAT_NAMES, _XHAT_UNITS):
        t.add(name, "discrete_output", f"estimate the controllers read: {name.replace('_hat', '')}",
              unit=unit)
    for name in ("roll", "pitch", "yaw"):
        t.add(f"{name}_hat", "discrete_output", f"ZYX {name} angle of the estimated attitude",
              unit="rad")
    for c in "xyz":
        t.add(f"omega_hat_{c}", "discrete_output", f"estimated body angular velocity about "
              f"body {c}", unit="rad/s")
    for what, unit in (("q", "1"), ("dq", "1/s"), ("ddq", "1/s2")):
        for i in range(4):
            t.add(f"{what}_ref_used{i}", "discrete_output", f"attitude reference {what}{i} the "
                  "balance controller used (the velocity controller's in the cascade)",
                  unit=unit)
    for name in BALANCE_DIAG_NAMES:
        t.add(f"diag_{name}", "discrete_output", f"balance controller diagnostic {name}")
    t.add("nis_attitude", "discrete_output", "normalised innovation squared of the attitude "
          "filter")
    t.add("nis_velocity", "discrete_output", "normalised innovation squared of the velocity "
          "filter")
    t.add("repairs", "discrete_output", "covariance repairs of the filters in the last period")
    for name, g in zip(REJECTION_NAMES, GATE_GROUPS.fields, strict=True):
        filt, sensor = g.split("_", 1)
        t.add(name, "discrete_output", f"1 when the {filt} filter's innovation gate rejected the "
              f"{sensor} reading in the last period (chi-square test), else 0")
    if _has_observer(embedded):
        for c in "xy":
            t.add(f"com_hat_{c}", "discrete_output", f"COM offset estimate along body {c}",
                  unit="m")
    if law is not None:
        for name, what, unit in zip(V_REF_USED_NAMES, ("ball velocity reference along x",
                                                       "ball velocity reference along y",
                                                       "heading-rate reference"),
                                    ("m/s", "m/s", "rad/s"), strict=True):
            t.add(name, "discrete_output", f"{what} the path-following guidance gave the "
                  "velocity controller in the last period", unit=unit)
    # the path variant's MPC was built from these (module path): fixed at their build values
    fixed: set[str] = set()
    if law is not None:
        kv = _kvel_names()
        names, gains = mpc_model_dependencies([start[f"ctrl_{n}"] for n in PARAM_NAMES],
                                              [start[n] for n in kv], law.config.dt)
        fixed = {"Ts", *(f"ctrl_{n}" for n in names), *(kv[i] for i in gains)}

    def why(name: str) -> str | None:
        return FIXED_WHY if name in fixed else None

    t.add("Ts", "parameter", "period of the embedded software; a communication step must be a "
          "whole number of periods", start=float(start["Ts"]), unit="s", rule="pos",
          fixed=why("Ts"))
    path_desc = path_parameter_descriptions(law) if law is not None else {}
    for arg, names in _parameter_groups(embedded, controller, estimator, law):
        for n in names:
            unit, rule, desc = None, None, f"{arg} entry {n}"
            if n in path_desc:
                desc, unit = path_desc[n]
            if arg in MODEL_CONSTANTS:
                base = n.split("_", 1)[1]
                unit, pdesc, rule = PARAM_INFO[base]
                who = "controllers'" if arg == "p_ctrl" else "filters'"
                desc = f"{pdesc} (the {who} internal model, load_params name {base})"
            t.add(n, "parameter", desc, start=float(start[n]), unit=unit, rule=rule,
                  fixed=why(n))
    t.add("feedforward", "parameter", "the balance controller gets the reference's second "
          "derivative (false: zero, the thesis's mode)", type="Boolean",
          start=bool(start["feedforward"]))
    if _has_observer(embedded):
        t.add("com_observer", "parameter", "the controllers use the COM observer's estimate as "
              "their internal model", type="Boolean", start=bool(start["com_observer"]))
    for name, unit in zip(X0_NAMES, _STATE_UNITS, strict=True):
        t.add(name, "parameter", f"robot state {name[3:]} at power-on: the embedded software "
              "starts aligned with it (start-up calibration at rest)", start=float(start[name]),
              unit=unit)
    if law is not None:
        desc, unit = path_desc[S0_NAME]
        t.add(S0_NAME, "parameter", desc, start=float(start[S0_NAME]), unit=unit)
    for f in layout.fields:
        n = layout.size_of(f)
        for name in _element_names(f"c_{f}", n):
            t.add(name, "local", f"state of the embedded software, field {f}")
    t.add("balance_only", "discrete_input", "mode: true = the balance controller follows the "
          "attitude reference q_ref alone (thesis Fig. 8.1); false = the velocity cascade "
          "(Fig. 7.1) follows v_ref_x, v_ref_y, yaw_rate_ref", type="Boolean", start=False)
    t.add("period", "local", "index k of the next period (t_k = startTime + k Ts)",
          type="Integer", bounds=(0, INT32_MAX))
    return t.rows()


def _rpy_function() -> ca.Function:
    q = ca.SX.sym("q", 4)
    return ca.Function("bbc_rpy", [q], [Q.to_rpy(q)], ["q"], ["rpy"])


def controller_spec(controller: str = "flc", estimator: str = DEFAULT_ESTIMATOR,
                    path: Scenario | None = None) -> FmuSpec:
    """The controller FMU of ``controller`` with ``estimator`` (Co-Simulation only).

    With ``path`` (a scenario with a ``[path]``; its controller and estimator replace the
    arguments) the path-following variant ``BallbotControllerPath[_<est>]`` (no suffix with
    :data:`~ballbot_casadi.sim.embedded.DEFAULT_ESTIMATOR`): the embedded
    software with the scenario's MPC guidance (:func:`path_embedded_function`), the path
    table and ``path_s0`` as parameters (start values from the scenario,
    :mod:`~ballbot_casadi.fmi.controller.path`), the outputs :data:`V_REF_USED_NAMES`,
    and the guidance state started at initialisation by the Function the compiled guided
    mission starts from (:meth:`GuidanceLaw.initial_function
    <ballbot_casadi.sim.guided.GuidanceLaw.initial_function>`).  The MPC predicts with
    the scenario's controller model and velocity gains (built in).

    Raises
    ------
    ScenarioError
        ``path`` cannot run in the FMU (:func:`~ballbot_casadi.fmi.controller.path.path_law`).
    """
    law = path_law(path) if path is not None else None
    if law is not None:
        controller, estimator = path.controller, path.estimator
        embedded = path_embedded_function(law, estimator)
        rows = controller_variables(embedded, controller, estimator,
                                    controller_values(path, embedded, law), law)
    else:
        embedded = embedded_function(controller, estimator)
        rows = controller_variables(embedded, controller, estimator)
    initial = initial_state_function(embedded, estimator, law)
    layout = controller_state_layout(embedded, estimator, law)
    has_obs = _has_observer(embedded)

    def field_names(prefix: str) -> tuple[str, ...]:
        return tuple(n for f in layout.fields
                     for n in _element_names(f"{prefix}_{f}", layout.size_of(f)))

    xa = layout.part("xa")  # the heading-aided filter's ends with the z gyro bias
    for f, sub in (("xa", xa), ("xv", VELOCITY_FILTER_STATE)):
        if layout[f].stop - layout[f].start != sub.size:
            raise BuildError(f"{embedded.name()}: field {f} of the controller state has "
                             f"{layout[f].stop - layout[f].start} entries, the {sub.name} {sub.size}")
    groups = dict(_parameter_groups(embedded, controller, estimator, law))
    blocks = [
        FmuBlock("c", layout, field_names("c")),
        FmuBlock("x0", STATE, X0_NAMES),
        FmuBlock("xa", xa),
        FmuBlock("xv", VELOCITY_FILTER_STATE),
        FmuBlock("meas", readings_layout(estimator), reading_names(estimator)),
        FmuBlock("ref", REFERENCE, REFERENCE_NAMES),
        FmuBlock("tau", None, tuple(f"tau{i}" for i in range(3))),
        FmuBlock("tau_cmd", None, tuple(f"tau_cmd{i}" for i in range(3))),
        FmuBlock("x_hat", STATE, XHAT_NAMES),
        FmuBlock("rpy", None, ("roll_hat", "pitch_hat", "yaw_hat")),
        FmuBlock("omega", None, tuple(f"omega_hat_{c}" for c in "xyz")),
        FmuBlock("ref_used", REFERENCE_USED,
                 tuple(f"{w}_ref_used{i}" for w in ("q", "dq", "ddq") for i in range(4))),
        FmuBlock("diag", None, tuple(f"diag_{n}" for n in BALANCE_DIAG_NAMES)),
        FmuBlock("nis", None, ("nis_attitude", "nis_velocity")),
        FmuBlock("rejections", None, REJECTION_NAMES),
        *(FmuBlock(a, path_table_layout(law.config.n_obstacles) if a == "k_guid" else None,
                   tuple(n)) for a, n in groups.items()),
    ]
    if has_obs:
        blocks.append(FmuBlock("com_hat", None, ("com_hat_x", "com_hat_y")))
    functions = [embedded, initial, _rpy_function()]
    aliases = [(embedded.name(), "EMBEDDED"), (initial.name(), "INITIAL")]
    if law is not None:
        blocks.append(FmuBlock("v_ref_used", None, V_REF_USED_NAMES))
        guide0 = law.initial_function()
        functions.append(guide0)
        aliases.append((guide0.name(), "GUIDE_INITIAL"))
    defines: dict[str, Any] = {
        "NQV": int(round(np.sqrt(len(groups["Qv"])))),
        "NQA": int(round(np.sqrt(len(groups["Qa"])))),
        "NRA": int(round(np.sqrt(len(groups["Ra"])))),
        "HAS_OBSERVER": int(has_obs),
        "STEP_TOL": repr(STEP_TOL),
        "MAX_PERIODS": repr(float(MAX_PERIODS)),
        "PERIOD_MAX": repr(float(INT32_MAX)),
        "QUAT_TOL": repr(QUAT_TOL),
        "QUAT_TOL_RESTORED": repr(QUAT_TOL_RESTORED),
        "HAS_GUIDANCE": int(law is not None),
        **(path_c_defines(law) if law is not None else {}),
    }
    title = f"{controller.upper()} with the {filters_title(estimator)}"
    ident = model_identifier(controller, estimator)
    what = "velocity LQR cascade"
    if law is not None:
        ident = PATH_MODEL_IDENTIFIER + ("" if estimator == DEFAULT_ESTIMATOR else f"_{estimator}")
        what = "path-following MPC guidance at 10 Hz above the velocity LQR cascade"
    return FmuSpec(
        model_identifier=ident,
        description=f"ballbot embedded software at 200 Hz ({title}, {what}, "
        "torque limit; Roche and Borja, AAU 2020) generated with CasADi from the compiled "
        "mission's Function: sensor readings in, wheel torques, estimate and diagnostics out",
        prefix="ctrl",
        variables=rows,
        functions=tuple(functions),
        model_source="controller/controller_model.c",
        cg_name="ballbot_controller_cg",
        extra_sources=tuple(fmu_source_dir() / "controller" / f"controller_path.{x}"
                            for x in ("c", "h")) if law is not None else (),
        interfaces=("cs",),
        defines=tuple((k, str(v)) for k, v in defines.items()),
        blocks=tuple(blocks),
        function_aliases=tuple(aliases),
        default_experiment=(0.0, 5.0, TS_CONTROL),
    )
