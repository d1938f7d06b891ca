"""The BallbotPlant FMU as an :class:`~ballbot_casadi.fmi.spec.FmuSpec` (ME + CS).

:func:`plant_variables` is the one table of the plant's variables, :func:`plant_functions`
the CasADi Functions compiled into it, ``fmu/plant/plant_model.c`` its per-model C file and
:func:`plant_spec` puts them together.

The plant: the 12 model states of the 3D quaternion ballbot model plus the three wheel
(motor-shaft) angles ``phi0..2`` (integrated with the model by RK4 of
``ballbot_ode_wheel_angles``), wheel torques and disturbance torques in; attitude, wheel
speeds and the noise-free IMU and encoder signals out (continuous), and the robot's
sensor readings ``sensor_acc_*``, ``sensor_gyro_*``, ``sensor_enc*`` sampled every
``Ts_sensor`` and held (discrete), with noise from the counter-based generator
(``noise_on``, ``seed``); with ``heading_sensor`` on, the heading sensor's reading
``sensor_heading`` (:func:`~ballbot_casadi.model.sensors.make_heading_sensor`, the
yaw reading the heading-aided filter reads, thesis (4.30)) at the samples of its own
low rate ``heading_rate_yaw`` (:func:`~ballbot_casadi.model.sensors.heading_schedule`)
and NaN (no reading) at the others; and the sensor parameters under their
:data:`~ballbot_casadi.core.sensor_params.SENSOR_VECTOR_NAMES` names.  The sampling
conventions are in ``fmu/plant/plant_model.c`` and reproduced in Python by
:mod:`ballbot_casadi.fmi.plant.oracle`.
"""

from __future__ import annotations

import casadi as ca

from ballbot_casadi.core import quaternion as Q
from ballbot_casadi.core.constants import TS_CONTROL
from ballbot_casadi.core.layout import STATE, Layout
from ballbot_casadi.core.params import PARAM_INFO, PARAM_NAMES, load_params
from ballbot_casadi.core.rng import c_sources
from ballbot_casadi.core.sensor_params import (
    SENSOR_PARAM_INFO,
    SENSOR_VECTOR_NAMES,
    load_sensor_params,
)
from ballbot_casadi.core.validation import QUAT_TOL
from ballbot_casadi.fmi.spec import (
    INT32_MAX,
    FmuBlock,
    FmuSpec,
    FmuVar,
    VarTable,
    sparsity_dependencies,
)
from ballbot_casadi.model.dynamics import (
    INPUT_NAMES,
    NP,
    NU,
    NX,
    STATE_NAMES,
    make_model_functions,
)
from ballbot_casadi.model.integrators import make_rk4
from ballbot_casadi.model.numeric import make_state
from ballbot_casadi.model.sensors import (
    NOISE_STREAMS,
    make_encoders,
    HEADING_SCHEDULE_EPS,
    make_gyro_bias_step,
    make_heading_sensor,
    make_imu,
    make_sensors,
    make_wheel_angle_ode,
)
from ballbot_casadi.sim.embedded import MEAS

__all__ = [
    "MODEL_IDENTIFIER",
    "X0_PREFIX",
    "H_INTERNAL_DEFAULT",
    "TS_SENSOR_DEFAULT",
    "MAX_SUBSTEPS",
    "MAX_SAMPLES",
    "GRID_TOL",
    "NXW",
    "WHEEL_ANGLE_NAMES",
    "SENSOR_OUTPUT_NAMES",
    "HEADING_OUTPUT_NAME",
    "PLANT_STATE",
    "PLANT_OUTPUTS",
    "plant_variables",
    "plant_functions",
    "plant_spec",
]

MODEL_IDENTIFIER = "BallbotPlant"
#: The state ``<name>`` starts from the parameter ``x0_<name>`` (bound by an SSP parameter
#: set or set by an importer before initialisation; the state itself is calculated).
X0_PREFIX = "x0_"
#: Default internal RK4 step of fmi2DoStep (s).
H_INTERNAL_DEFAULT = 1e-3
#: Default sensor sample period (s): the robot's 200 Hz.
TS_SENSOR_DEFAULT = TS_CONTROL
#: Largest number of RK4 sub-steps / sensor samples one fmi2DoStep may take.
MAX_SUBSTEPS = 1_000_000
MAX_SAMPLES = 1_000_000
#: A time within GRID_TOL * Ts_sensor of a sample instant is at the instant.
GRID_TOL = 1e-6
#: Wheel angles: continuous states after the 12 model states.
WHEEL_ANGLE_NAMES = ("phi0", "phi1", "phi2")
NXW = NX + len(WHEEL_ANGLE_NAMES)
#: The held sensor readings (discrete outputs), in order: acc (3), gyro (3), enc (3).
SENSOR_OUTPUT_NAMES = (*(f"sensor_acc_{c}" for c in "xyz"), *(f"sensor_gyro_{c}" for c in "xyz"),
                       *(f"sensor_enc{i}" for i in range(3)))
#: The held heading-sensor reading (discrete output; NaN at samples without a reading):
#: the controller FMU's heading input of the same name.
HEADING_OUTPUT_NAME = "sensor_heading"

#: The plant FMU's continuous state: the model state (:data:`~ballbot_casadi.core.layout.STATE`)
#: and the wheel angles.
PLANT_STATE = Layout("plant state with wheel angles",
                     [*((f, STATE[f].stop - STATE[f].start) for f in STATE.fields),
                      ("phi", len(WHEEL_ANGLE_NAMES))])
#: The continuous outputs ``y`` of ``bbp_out``: ZYX angles, wheel speeds, noise-free IMU
#: and encoder signals.
PLANT_OUTPUTS = Layout("plant outputs y", [("rpy", 3), ("dphi", 3), ("acc", 3), ("gyro", 3),
                                           ("enc", 3)])

_STATE_UNITS = ("m", "m", "1", "1", "1", "1", "m/s", "m/s", "1/s", "1/s", "1/s", "1/s")
_STATE_DESC = (
    "ball position x in the inertial frame",
    "ball position y in the inertial frame",
    "attitude quaternion q0 (scalar part) of body B in ball frame K",
    "attitude quaternion q1",
    "attitude quaternion q2",
    "attitude quaternion q3",
    "ball velocity x",
    "ball velocity y",
    "quaternion rate dq0",
    "quaternion rate dq1",
    "quaternion rate dq2",
    "quaternion rate dq3",
)
_OUTPUTS = (
    ("roll", "rad", "ZYX roll angle of the body"),
    ("pitch", "rad", "ZYX pitch angle of the body"),
    ("yaw", "rad", "ZYX yaw angle of the body"),
    ("dphi0", "rad/s", "wheel 0 motor-shaft speed (inverse kinematics B.47)"),
    ("dphi1", "rad/s", "wheel 1 motor-shaft speed (inverse kinematics B.47)"),
    ("dphi2", "rad/s", "wheel 2 motor-shaft speed (inverse kinematics B.47)"),
    ("acc_x", "m/s2", "accelerometer, specific force along body x at the IMU (ball centre)"),
    ("acc_y", "m/s2", "accelerometer, specific force along body y at the IMU (ball centre)"),
    ("acc_z", "m/s2", "accelerometer, specific force along body z at the IMU (ball centre)"),
    ("gyro_x", "rad/s", "gyroscope, body angular velocity about body x (B.16)"),
    ("gyro_y", "rad/s", "gyroscope, body angular velocity about body y (B.16)"),
    ("gyro_z", "rad/s", "gyroscope, body angular velocity about body z (B.16)"),
    ("enc0", "1/s", "wheel 0 encoder rate in ticks per second"),
    ("enc1", "1/s", "wheel 1 encoder rate in ticks per second"),
    ("enc2", "1/s", "wheel 2 encoder rate in ticks per second"),
)
_HELD = "sampled at t_k = startTime + k Ts_sensor and held until the next sample"
_SENSOR_DESC = {
    "acc": ("m/s2", "accelerometer reading along IMU axis {c} (thesis 3.3): scale, "
                    "misalignment, bias, lever arm and, with noise_on, white noise; " + _HELD),
    "gyro": ("rad/s", "gyroscope reading about IMU axis {c} (thesis 3.7): scale, "
                      "misalignment, random-walk bias and, with noise_on, white noise; " + _HELD),
    "enc": ("1/s", "wheel {c} encoder reading in ticks per second: change of the quantised "
                   "count (thesis 3.11-3.14) over the last sensor period divided by Ts_sensor; "
                   + _HELD),
}


def plant_variables() -> tuple[FmuVar, ...]:
    """The variable table of BallbotPlant, ordered by value reference (0, 1, 2, ...)."""
    x0 = make_state()
    params = load_params()
    sensors = load_sensor_params().to_vector()
    t = VarTable()
    for i, name in enumerate(STATE_NAMES):
        t.add(name, "state", f"{_STATE_DESC[i]} (starts from {X0_PREFIX}{name})",
              start_from=X0_PREFIX + name, unit=_STATE_UNITS[i])
    for i, name in enumerate(WHEEL_ANGLE_NAMES):
        t.add(name, "state", f"wheel {i} motor-shaft angle, the integral of dphi{i} (B.47) "
              f"that the encoder counts (starts from {X0_PREFIX}{name})",
              start_from=X0_PREFIX + name, unit="rad")
    for name in (*STATE_NAMES, *WHEEL_ANGLE_NAMES):
        t.add(f"der({name})", "derivative", f"time derivative of {name}", derivative_of=name)
    for i, name in enumerate(INPUT_NAMES):
        t.add(name, "input", f"wheel {i} torque (thesis wheel order), saturated at +-tau_max",
              start=0.0, unit="N.m")
    for i in range(NU):
        t.add(f"tau_dist{i}", "input", f"wheel {i} disturbance torque, added after the "
              "saturation", start=0.0, unit="N.m")
    for name, unit, desc in _OUTPUTS:
        t.add(name, "output", desc, unit=unit)
    for name in SENSOR_OUTPUT_NAMES:
        group = name.removeprefix("sensor_").rstrip("xyz012_")
        unit, desc = _SENSOR_DESC[group]
        t.add(name, "discrete_output", desc.format(c=name[-1]), unit=unit)
    t.add(HEADING_OUTPUT_NAME, "discrete_output", "heading-sensor reading (ZYX yaw of the "
          "body, wrapped to (-pi, pi]) with heading_bias_yaw and, with noise_on, white noise "
          "of variance heading_noise_var_yaw; taken at the samples the sensor's rate "
          "heading_rate_yaw falls on, NaN (no reading) at the others and always NaN with "
          "heading_sensor off; " + _HELD, unit="rad", missing=True)
    for name in PARAM_NAMES:
        unit, desc, rule = PARAM_INFO[name]
        t.add(name, "parameter", desc, start=float(getattr(params, name)), unit=unit, rule=rule)
    t.add("h_internal", "parameter", "internal RK4 step of fmi2DoStep (each segment between "
          "sample instants and step ends is split into ceil(length / h_internal) equal "
          "sub-steps)", start=H_INTERNAL_DEFAULT, unit="s", rule="pos")
    t.add("Ts_sensor", "parameter", "sensor sample period: readings are taken at "
          "startTime + k Ts_sensor", start=TS_SENSOR_DEFAULT, unit="s", rule="pos")
    for j, name in enumerate(SENSOR_VECTOR_NAMES):
        base = next(n for n in SENSOR_PARAM_INFO if name.startswith(n + "_"))
        unit, desc, rule, _ = SENSOR_PARAM_INFO[base]
        t.add(name, "parameter", f"{desc}, component {name[len(base) + 1:]}",
              start=float(sensors[j]), unit=unit, rule=rule)
    x0w = (*(float(v) for v in x0), *(0.0 for _ in WHEEL_ANGLE_NAMES))
    for name, unit, desc, start in zip((*STATE_NAMES, *WHEEL_ANGLE_NAMES),
                                       (*_STATE_UNITS, *("rad" for _ in WHEEL_ANGLE_NAMES)),
                                       (*_STATE_DESC, *(f"wheel {i} motor-shaft angle"
                                                        for i in range(NU))), x0w):
        t.add(X0_PREFIX + name, "parameter", f"initial value of the state {name}: {desc}",
              start=start, unit=unit)
    t.add("noise_on", "parameter", "sensor noise on: white IMU noise and the gyroscope bias "
          "random walk drawn from the counter-based generator (off: zero noise; bias, scale "
          "and misalignment still apply)", type="Boolean", start=False)
    t.add("heading_sensor", "parameter", "the robot carries the heading sensor (off: "
          "sensor_heading is always NaN)", type="Boolean", start=False)
    t.add("seed", "parameter", "noise seed (Philox key word 0): the same seed gives the same "
          "noise in Python, in the compiled mission and in the FMU", type="Integer", start=0,
          bounds=(0, INT32_MAX))
    for c in "xyz":
        t.add(f"sensor_gyro_bias_{c}", "local", f"gyroscope bias b_k about IMU axis {c} in "
              "the held reading (random walk, thesis 3.9)", unit="rad/s")
    for i in range(NU):
        t.add(f"sensor_tau_prev{i}", "local", f"wheel {i} torque acting on the plant just "
              "before the last sample instant (used by the accelerometer)", unit="N.m")
    for i in range(NU):
        t.add(f"sensor_phi_prev{i}", "local", f"wheel {i} angle at the last sample instant "
              "(the encoder count difference starts there)", unit="rad")
    t.add("sensor_sample", "local", "index k of the held sensor sample", type="Integer",
          bounds=(0, INT32_MAX))
    return t.rows()


def plant_functions() -> list[ca.Function]:
    """The CasADi Functions compiled into the FMU (see ``fmu/plant/plant_model.c``):
    ``bbp_ode``, ``bbp_rk4``, ``bbp_out``, ``bbp_dd`` and the sensor Functions
    ``ballbot_imu``, ``ballbot_encoders``, ``ballbot_gyro_bias_step``,
    ``ballbot_heading``."""
    f = make_model_functions()
    ode, jac, ws = f["ode"], f["jac"], f["wheel_speeds"]
    ode_w = make_wheel_angle_ode(ode, ws)
    xs, taus, ps = ca.SX.sym("xw", NXW), ca.SX.sym("tau", NU), ca.SX.sym("p", NP)
    bbp_ode = ca.Function("bbp_ode", [xs, taus, ps], [ode_w(xs, taus, ps)], ["xw", "tau", "p"],
                          ["xwdot"])
    rk4 = make_rk4(bbp_ode)
    bbp_rk4 = ca.Function("bbp_rk4", rk4.mx_in(), rk4.call(rk4.mx_in()), ["xw", "tau", "p", "h"],
                          rk4.name_out())
    x, tau, p = ca.MX.sym("x", NX), ca.MX.sym("tau", NU), ca.MX.sym("p", NP)
    acc, gyro, enc = make_sensors(ode)(x, tau, p)
    y = ca.vertcat(Q.to_rpy(x[2:6]), ws(x, p), acc, gyro, enc)
    out = ca.Function("bbp_out", [x, tau, p], [y], ["x", "tau", "p"], ["y"]).expand()
    xw, tau_s, p_s = ca.SX.sym("xw", NXW), ca.SX.sym("tau", NU), ca.SX.sym("p", NP)
    xm = xw[:NX]
    yw = out(xm, tau_s, p_s)
    A, B = jac(xm, tau_s, p_s)
    Z = ca.SX.zeros
    J = ca.vertcat(
        ca.horzcat(A, Z(NX, NXW - NX), B),
        ca.horzcat(ca.jacobian(ws(xm, p_s), xm), Z(NXW - NX, NXW - NX), Z(NXW - NX, NU)),
        ca.horzcat(ca.jacobian(yw, xm), Z(yw.numel(), NXW - NX), ca.jacobian(yw, tau_s)))
    dd = ca.Function("bbp_dd", [xw, tau_s, p_s], [ca.densify(J)], ["xw", "tau", "p"], ["J"])
    return [bbp_ode, bbp_rk4, out, dd, make_imu(ode).expand(), make_encoders(NP),
            make_gyro_bias_step(), make_heading_sensor()]


def plant_spec() -> FmuSpec:
    """BallbotPlant: Model Exchange + Co-Simulation, directional derivatives."""
    rows = plant_variables()
    xw_names = (*STATE_NAMES, *WHEEL_ANGLE_NAMES)
    y_names = tuple(n for n, _, _ in _OUTPUTS)
    blocks = (
        FmuBlock("xw", PLANT_STATE, xw_names),
        FmuBlock("der", PLANT_STATE, tuple(f"der({n})" for n in xw_names)),
        FmuBlock("tau", None, INPUT_NAMES),
        FmuBlock("tau_dist", None, tuple(f"tau_dist{i}" for i in range(NU))),
        FmuBlock("y", PLANT_OUTPUTS, y_names),
        FmuBlock("sensor", MEAS, SENSOR_OUTPUT_NAMES),
        FmuBlock("heading_out", None, (HEADING_OUTPUT_NAME,)),
        FmuBlock("bias", None, tuple(f"sensor_gyro_bias_{c}" for c in "xyz")),
        FmuBlock("tau_prev", None, tuple(f"sensor_tau_prev{i}" for i in range(NU))),
        FmuBlock("phi_prev", None, tuple(f"sensor_phi_prev{i}" for i in range(NU))),
        FmuBlock("p", Layout("model parameters p", [(n, 1) for n in PARAM_NAMES]), PARAM_NAMES),
        FmuBlock("s", Layout("sensor parameters s", [(n, 1) for n in SENSOR_VECTOR_NAMES]),
                 SENSOR_VECTOR_NAMES),
    )
    defines = {
        "QUAT_TOL": repr(QUAT_TOL),
        "MAX_SUBSTEPS": repr(float(MAX_SUBSTEPS)),
        "MAX_SAMPLES": repr(float(MAX_SAMPLES)),
        "GRID_TOL": repr(GRID_TOL),
        "HEADING_EPS": repr(HEADING_SCHEDULE_EPS),
        **{f"STREAM_{k.upper()}": f"{v}u" for k, v in NOISE_STREAMS.items()},
    }
    functions = plant_functions()
    by_name = {f.name(): f for f in functions}
    # the knowns: the states and the inputs (a torque and its disturbance enter as one sum)
    tau_knowns = [(n, f"tau_dist{i}") for i, n in enumerate(INPUT_NAMES)]
    dependencies = {
        **sparsity_dependencies(by_name["bbp_ode"], "xwdot", [f"der({n})" for n in xw_names],
                                {"xw": [(n,) for n in xw_names], "tau": tau_knowns}),
        **sparsity_dependencies(by_name["bbp_out"], "y", y_names,
                                {"x": [(n,) for n in STATE_NAMES], "tau": tau_knowns}),
    }
    rng_c, rng_h = c_sources()
    return FmuSpec(
        model_identifier=MODEL_IDENTIFIER,
        description="3D quaternion Euler-Lagrange ballbot plant (Roche and Borja, AAU 2020) "
        "generated with CasADi; wheel torques in, state, attitude, wheel speeds, noise-free "
        "IMU and encoder signals and the robot's sampled sensor readings (optional noise) out",
        prefix="plant",
        variables=rows,
        functions=tuple(functions),
        model_source="plant/plant_model.c",
        cg_name="ballbot_plant_cg",
        extra_sources=(rng_c, rng_h),
        interfaces=("me", "cs"),
        defines=tuple((k, str(v)) for k, v in defines.items()),
        blocks=blocks,
        dependencies=tuple(dependencies.items()),
        directional_derivatives=True,
        default_experiment=(0.0, 5.0, TS_SENSOR_DEFAULT),
    )
