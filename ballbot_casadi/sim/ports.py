"""The ports of one control period, defined once: names, kinds, sizes and packed layouts.

Every backend of the closed loop (the compiled mission's step Functions of
:mod:`~ballbot_casadi.sim.steps`, the Python loop, the FMU masters, the controller FMU's
Python side, the log unpacking of :mod:`~ballbot_casadi.sim.closed_loop`) builds its
symbols and packs and unpacks its vectors through a :class:`PeriodPorts`, made by
:func:`period_ports` from the period's blocks (:class:`PeriodBlocks`), so the sizes come
from the CasADi Functions and every port has one name.

A port is one of three kinds:

``state``
    carried from period to period (the accumulated input ``xz`` of a mission; its
    :class:`~ballbot_casadi.core.layout.Layout` names every part: plant state ``x``,
    wheel angles ``phi``, controller state ``c`` with its fields, sensor state ``s``,
    held command ``u``);
``sequence``
    one value per period (references, disturbance, noise, sensor availability);
``constant``
    one value per mission (parameters, gains, ``Ts``, switches).

The blocks of a period, top to bottom (thesis Fig. 7.1): an optional **guidance** block
(e.g. a path-following MPC) that turns the period's ``v_ref`` into the velocity reference
the velocity controller follows; the **velocity** controller; the optional **COM
observer**; the **balance** controller.  Adding a block above the velocity controller:

1. give :class:`PeriodBlocks` the Function (``guidance`` is the slot: ``(x, v_ref, g, z, p,
   k_guid, Ts) -> (v_ref_out, g_next)``, ``z`` the velocity controller's state; a balance
   feed adds ``(q_ref, dq_ref, ddq_ref)``, which replace the velocity controller's);
2. its state becomes a field of the controller-state layout
   (:func:`controller_state`, field ``guide``), its gains a constant port
   (:data:`GUIDANCE_CONSTANTS`), its output a period output (:data:`GUIDANCE_OUTPUTS`);
3. :func:`~ballbot_casadi.sim.period.controller_part` calls it; every step builder,
   the packing of :meth:`ClosedLoop.simulate <ballbot_casadi.sim.closed_loop.ClosedLoop.simulate>`
   and the log follow from the ports.

A balance controller may carry a state of its own (the super-twisting controller's
integral term ``zb``, :mod:`ballbot_casadi.control.super_twisting`): it is then a
7-in / 3-out Function ``(x, q_ref, dq_ref, ddq_ref, p, k, zb) -> (tau, diag, zb_next)``
and its state is the last field ``bal`` of the controller-state layout, started at
zero and advanced every period (in balance-only mode too: it belongs to the balance
controller, not to the velocity loop).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import casadi as ca

from ballbot_casadi.core.layout import (
    DISTURBANCE,
    STATE,
    VELOCITY_CONTROLLER_STATE,
    Layout,
)
from ballbot_casadi.errors import ScenarioError

__all__ = [
    "SEQUENCE",
    "CONSTANT",
    "STATE_PORT",
    "Port",
    "PeriodBlocks",
    "PeriodPorts",
    "check_blocks",
    "controller_state",
    "controller_state_of",
    "mission_state",
    "period_ports",
    "embedded_ports",
    "sequence_positions",
    "REFERENCE_SEQUENCES",
    "PERIOD_SEQUENCES",
    "PERIOD_CONSTANTS",
    "PERIOD_OUTPUTS",
    "SENSOR_SEQUENCES",
    "SENSOR_CONSTANTS",
    "FILTER_CONSTANTS",
    "ESTIMATION_OUTPUTS",
    "OBSERVER_CONSTANTS",
    "OBSERVER_OUTPUTS",
    "GUIDANCE_CONSTANTS",
    "GUIDANCE_OUTPUTS",
    "EMBEDDED_INPUTS",
    "EMBEDDED_OUTPUTS",
    "MODEL_CONSTANTS",
    "GAIN_CONSTANTS",
    "N_WHEEL",
    "HELD_COMMAND",
]

SEQUENCE, CONSTANT, STATE_PORT = "sequence", "constant", "state"

# ------------------------------------------------------------------ the port list
#: The references of a period: attitude reference and derivatives (balance-only mode,
#: thesis Fig. 8.1) and the velocity reference ``[vx, vy, yaw rate]`` (cascade).
REFERENCE_SEQUENCES = ("q_ref", "dq_ref", "ddq_ref", "v_ref")
#: Per-period inputs of every period: the references and the disturbance ``w``.
PERIOD_SEQUENCES = (*REFERENCE_SEQUENCES, "w")
#: Inputs constant over a mission, in order.
PERIOD_CONSTANTS = ("p_plant", "p_ctrl", "k_bal", "k_vel", "Ts", "cascade", "feedforward")
#: Per-period outputs of every period besides the next state.
PERIOD_OUTPUTS = ("x", "tau_cmd", "tau", "q_ref_used", "dq_ref_used", "ddq_ref_used", "diag")
#: Per-period inputs of the sensors: standard-normal noise and availability.
SENSOR_SEQUENCES = ("noise", "valid")
#: Sensor parameters (constant).
SENSOR_CONSTANTS = ("s",)
#: The filters' model parameters and covariances (column-major), constant.
FILTER_CONSTANTS = ("p_est", "Qa", "Ra", "Qv", "Rv")
#: Outputs of a period with sensors and estimators.
ESTIMATION_OUTPUTS = ("x_hat", "meas", "nis", "repairs", "rejections")
#: Constants of the COM observer: the switch (controllers use the estimate) and gains.
OBSERVER_CONSTANTS = ("com_observer", "k_obs")
#: Output of the COM observer: the COM-offset estimate after the period's update.
OBSERVER_OUTPUTS = ("com_hat",)
#: Constants of the guidance block (its gains / weights).
GUIDANCE_CONSTANTS = ("k_guid",)
#: Output of the guidance block: the velocity reference the velocity controller followed.
GUIDANCE_OUTPUTS = ("v_ref_used",)
#: The model-parameter constants: the plant's, the controllers' and the filters' models.
MODEL_CONSTANTS = ("p_plant", "p_ctrl", "p_est")
#: The gain constants (balance, velocity, COM observer): a scenario file's ``[gains]`` keys.
GAIN_CONSTANTS = ("k_bal", "k_vel", "k_obs")
#: Inputs of the embedded software's period (its state ``c`` and the readings first).
EMBEDDED_INPUTS = ("c", "meas", *REFERENCE_SEQUENCES, "p_ctrl", "p_est", "k_bal", "k_vel", "Ts",
                   "cascade", "feedforward", "Qa", "Ra", "Qv", "Rv")
#: Outputs of the embedded software's period.
EMBEDDED_OUTPUTS = ("c_next", "tau_lim", "tau_cmd", "x_hat", "q_ref_used", "dq_ref_used",
                    "ddq_ref_used", "diag", "nis", "repairs", "rejections")
#: Wheel angles appended to the plant state of a period with sensors.
N_WHEEL = 3
#: The torque command held from the previous period (one-period actuation delay).
HELD_COMMAND = Layout("held torque command u", [("tau", 3)])

_SIZES = {"q_ref": 4, "dq_ref": 4, "ddq_ref": 4, "v_ref": 3, "w": DISTURBANCE.size, "Ts": 1,
          "cascade": 1, "feedforward": 1, "com_observer": 1}


@dataclass(frozen=True)
class Port:
    """One named input or output of a period: ``kind`` is :data:`SEQUENCE`,
    :data:`CONSTANT` or :data:`STATE_PORT`; ``size`` entries (a column)."""

    name: str
    kind: str
    size: int


@dataclass(frozen=True)
class PeriodBlocks:
    """The controller blocks of a period (CasADi Functions).

    Attributes
    ----------
    balance
        ``(x, q_ref, dq_ref, ddq_ref, p, k) -> (tau, diag)``, or with a state of its own
        ``(x, q_ref, dq_ref, ddq_ref, p, k, zb) -> (tau, diag, zb_next)``.
    velocity
        ``(x, v_ref, z, p, k, Ts) -> (q_ref, dq_ref, ddq_ref, z_next)``.
    observer
        Optional COM observer ``(x, v_ref, o, p, k_obs, Ts) -> (o_next, p_hat, com_hat,
        com_meas)`` (:mod:`ballbot_casadi.estimation.com_observer`).
    guidance
        Optional block above the velocity controller ``(x, v_ref, g, z, p, k_guid, Ts) ->
        (v_ref_out, g_next)`` (the slot of a path-following MPC; ``z`` is the velocity
        controller's state at the start of the period, read only).
    """

    balance: ca.Function
    velocity: ca.Function
    observer: ca.Function | None = None
    guidance: ca.Function | None = None

    @property
    def name(self) -> str:
        """The balance controller's name without the ``ballbot_`` prefix (``flc``, ``smc``)."""
        return self.balance.name().removeprefix("ballbot_")

    @property
    def balance_state(self) -> int:
        """Size of the balance controller's own state ``zb`` (0: stateless)."""
        b = self.balance
        return b.numel_in(6) if isinstance(b, ca.Function) and b.n_in() == 7 else 0


def check_blocks(blocks: PeriodBlocks, n_p: int) -> dict[str, int]:
    """Check the blocks' signatures and return the sizes ``nk, nd, nz, nkv`` (and
    ``n_obs, nko`` with an observer, ``ng, nkg`` with guidance, ``nb`` with a balance
    controller that has a state of its own)."""
    balance, velocity = blocks.balance, blocks.velocity
    stateless = isinstance(balance, ca.Function) and (balance.n_in(), balance.n_out()) == (6, 2)
    stateful = isinstance(balance, ca.Function) and (balance.n_in(), balance.n_out()) == (7, 3) \
        and balance.numel_in(6) == balance.numel_out(2) > 0
    if not (stateless or stateful):
        raise ScenarioError(
            "balance controller must be a CasADi Function "
            "(x, q_ref, dq_ref, ddq_ref, p, k) -> (tau, diag), or with a state "
            "(x, q_ref, dq_ref, ddq_ref, p, k, zb) -> (tau, diag, zb_next) of equal sizes"
        )
    if not isinstance(velocity, ca.Function) or velocity.n_in() != 6 or velocity.n_out() != 4:
        raise ScenarioError(
            "velocity controller must be a CasADi Function "
            "(x, v_ref, z, p, k, Ts) -> (q_ref, dq_ref, ddq_ref, z_next)"
        )
    want_b = [STATE.size, 4, 4, 4, n_p]
    got_b = [balance.numel_in(i) for i in range(5)]
    if got_b != want_b or balance.numel_out(0) != 3:
        raise ScenarioError(f"balance controller input sizes {got_b} (expected {want_b} + gains)")
    nz = velocity.numel_in(2)
    want_v = [STATE.size, 3, nz, n_p]
    got_v = [velocity.numel_in(i) for i in range(4)]
    if got_v != want_v or [velocity.numel_out(i) for i in range(4)] != [4, 4, 4, nz]:
        raise ScenarioError(f"velocity controller sizes {got_v} do not match {want_v}")
    sizes = {"nk": balance.numel_in(5), "nd": balance.numel_out(1), "nz": nz,
             "nkv": velocity.numel_in(4)}
    if stateful:
        sizes["nb"] = balance.numel_in(6)
    if blocks.observer is not None:
        sizes.update(n_obs=blocks.observer.numel_in(2), nko=blocks.observer.numel_in(4))
    g = blocks.guidance
    if g is not None:
        if not isinstance(g, ca.Function) or g.n_in() != 7 or g.n_out() not in (2, 5) or \
                [g.numel_in(i) for i in (0, 1, 3, 4)] != [STATE.size, 3, nz, n_p] or \
                g.numel_out(0) != 3 or g.numel_out(1) != g.numel_in(2) or \
                any(g.numel_out(i) != 4 for i in range(2, g.n_out())):
            raise ScenarioError("guidance must be a CasADi Function (x, v_ref, g, z, p, k_guid, "
                                "Ts) -> (v_ref_out (3), g_next[, q_ref (4), dq_ref (4), "
                                "ddq_ref (4)])")
        sizes.update(ng=g.numel_in(2), nkg=g.numel_in(5))
    return sizes


def controller_state(blocks: PeriodBlocks, n_p: int) -> Layout:
    """Layout of the controllers' state of a period without estimators (the blocks' sizes,
    :func:`controller_state_of`)."""
    s = check_blocks(blocks, n_p)
    return controller_state_of(s["nz"], s.get("n_obs", 0), s.get("ng", 0), s.get("nb", 0))


def controller_state_of(nz: int, n_obs: int = 0, n_guide: int = 0, n_bal: int = 0) -> Layout:
    """Layout of the controllers' state of a period without estimators: the velocity
    controller's ``z``, then the COM observer's ``obs``, then the guidance block's
    ``guide``, then the balance controller's ``bal``."""
    z = VELOCITY_CONTROLLER_STATE if nz == VELOCITY_CONTROLLER_STATE.size else nz
    return Layout("controller state", [("z", z), *((("obs", n_obs),) if n_obs else ()),
                                       *((("guide", n_guide),) if n_guide else ()),
                                       *((("bal", n_bal),) if n_bal else ())])


def mission_state(c: Layout, sensor_state: Layout | None = None,
                  actuation_delay: bool = False) -> Layout:
    """Layout of a mission's accumulated state ``xz``: the plant state ``x``; with sensors
    (``sensor_state`` given) the wheel angles ``phi``; the controller state ``c``; with
    sensors the sensor state ``s``; with the actuation delay the held command ``u``."""
    if sensor_state is None:
        if actuation_delay:
            raise ScenarioError("the actuation delay is an option of the period with sensors "
                                "and the embedded software (estimator 'ukf' or 'ekf')")
        return Layout("mission state xz", [("x", STATE), ("c", c)])
    return Layout("mission state xz", [("x", STATE), ("phi", N_WHEEL), ("c", c),
                                       ("s", sensor_state),
                                       *((("u", HELD_COMMAND),) if actuation_delay else ())])


class PeriodPorts:
    """The ports of one period: the packed state and the named inputs and outputs.

    Parameters
    ----------
    name
        What the period is (error messages).
    state
        Layout of the accumulated state ``xz`` (input ``xz``, output ``xz_next``).
    inputs
        The other inputs in Function order (sequences and constants).
    outputs
        The outputs after ``xz_next`` in Function order.
    state_names
        Names of the state input and output (``xz``, ``xz_next``; the embedded
        software's ``c``, ``c_next``).
    """

    def __init__(self, name: str, state: Layout, inputs: tuple[Port, ...],
                 outputs: tuple[Port, ...], state_names: tuple[str, str] = ("xz", "xz_next")
                 ) -> None:
        self.name = name
        self.state = state
        self.state_names = state_names
        self.inputs = tuple(inputs)
        self.outputs = tuple(outputs)
        self._in = {p.name: p for p in self.inputs}

    @property
    def names_in(self) -> tuple[str, ...]:
        """Input names of the step Function (``xz`` first)."""
        return (self.state_names[0], *(p.name for p in self.inputs))

    @property
    def names_out(self) -> tuple[str, ...]:
        """Output names of the step Function (``xz_next`` first)."""
        return (self.state_names[1], *(p.name for p in self.outputs))

    @property
    def sequences(self) -> tuple[str, ...]:
        """Names of the per-period inputs, in order."""
        return tuple(p.name for p in self.inputs if p.kind == SEQUENCE)

    @property
    def constants(self) -> tuple[str, ...]:
        """Names of the constant inputs, in order."""
        return tuple(p.name for p in self.inputs if p.kind == CONSTANT)

    def port(self, name: str) -> Port:
        """The input port ``name``."""
        try:
            return self._in[name]
        except KeyError:
            raise ScenarioError(f"{self.name} has no input {name!r}; inputs: "
                                f"{', '.join(self._in)}") from None

    def has(self, name: str) -> bool:
        """Whether the period has the input or output ``name``."""
        return name in self._in or name in (p.name for p in self.outputs)

    def symbols(self) -> dict[str, ca.MX]:
        """An MX symbol per input (``xz`` first), named and sized by the ports."""
        return {self.state_names[0]: ca.MX.sym(self.state_names[0], self.state.size),
                **{p.name: ca.MX.sym(p.name, p.size) for p in self.inputs}}

    def function(self, name: str, sym: Mapping[str, ca.MX], out: Mapping[str, Any]) -> ca.Function:
        """The step Function ``name`` from the symbols of :meth:`symbols` and the outputs
        ``out`` (``xz_next`` and every output port by name)."""
        return ca.Function(name, [sym[k] for k in self.names_in], [out[k] for k in self.names_out],
                           list(self.names_in), list(self.names_out))

    def sequence_positions(self) -> tuple[int, ...]:
        """Positions of the sequence inputs in the step Function's inputs."""
        return tuple(i for i, n in enumerate(self.names_in) if n in self.sequences)


def period_ports(blocks: PeriodBlocks, n_p: int, estimation: Mapping[str, Any] | None = None,
                 actuation_delay: bool = False) -> PeriodPorts:
    """The ports of a mission's period.

    Parameters
    ----------
    blocks
        The controller blocks (sizes of gains, controller state, observer, guidance).
    n_p
        Number of model parameters.
    estimation
        ``None``: the controllers read the true state.  Otherwise the sizes of the period
        with sensors and the embedded software: ``c`` (the controller-state
        :class:`~ballbot_casadi.core.layout.Layout`), ``s`` (number of sensor
        parameters), ``sensor_state``, ``noise``, ``valid`` (layouts) and ``embedded``
        (the embedded software's Function: sizes of its constants by name).
    actuation_delay
        The torque acting in period ``k`` is the command of period ``k-1`` (a Jacobi
        co-simulation master): the state ends with the held command ``u``.
    """
    s = check_blocks(blocks, n_p)
    sizes = {**_SIZES, "p_plant": n_p, "p_ctrl": n_p, "k_bal": s["nk"], "k_vel": s["nkv"]}
    seqs = list(PERIOD_SEQUENCES)
    consts = list(PERIOD_CONSTANTS)
    outs = list(PERIOD_OUTPUTS)
    if estimation is None:
        with_obs, with_guide = blocks.observer is not None, blocks.guidance is not None
        sizes.update(k_obs=s.get("nko", 0), k_guid=s.get("nkg", 0))
        state = mission_state(controller_state(blocks, n_p), None, actuation_delay)
        name = f"ballbot_cl_step_{blocks.name}"
    else:
        # the observer and the guidance block run inside the embedded software
        emb = estimation["embedded"]
        with_obs = OBSERVER_CONSTANTS[0] in emb.name_in()
        with_guide = GUIDANCE_CONSTANTS[0] in emb.name_in()
        seqs += SENSOR_SEQUENCES
        consts += [*SENSOR_CONSTANTS, *FILTER_CONSTANTS]
        outs += ESTIMATION_OUTPUTS
        sizes.update(noise=estimation["noise"].size, valid=estimation["valid"].size,
                     s=int(estimation["s"]), p_est=n_p,
                     **{k: emb.size1_in(emb.index_in(k)) for k in (
                         *FILTER_CONSTANTS[1:], *(OBSERVER_CONSTANTS if with_obs else ()),
                         *(GUIDANCE_CONSTANTS if with_guide else ()))})
        state = mission_state(estimation["c"], estimation["sensor_state"], actuation_delay)
        name = f"ballbot_cl_step_{blocks.name}_{estimation['name']}"
        if actuation_delay:
            name = name.replace("ballbot_cl_step_", "ballbot_cl_step_delayed_")
    if with_obs:
        consts += OBSERVER_CONSTANTS
        outs += OBSERVER_OUTPUTS
    if with_guide:
        consts += GUIDANCE_CONSTANTS
        outs += GUIDANCE_OUTPUTS
    inputs = tuple(Port(n, SEQUENCE, sizes[n]) for n in seqs) + tuple(
        Port(n, CONSTANT, sizes[n]) for n in consts)
    return PeriodPorts(name, state, inputs, tuple(Port(n, SEQUENCE, 0) for n in outs))


def embedded_ports(blocks: PeriodBlocks, n_p: int, c: Layout, n_meas: int,
                   filter_sizes: Mapping[str, int]) -> PeriodPorts:
    """The ports of the embedded software's period (:data:`EMBEDDED_INPUTS` ->
    :data:`EMBEDDED_OUTPUTS`, plus the observer's and the guidance block's): state ``c``,
    the readings ``meas`` (``n_meas``) and the constants; ``filter_sizes`` gives the
    sizes of ``Qa, Ra, Qv, Rv``."""
    s = check_blocks(blocks, n_p)
    sizes = {**_SIZES, "p_ctrl": n_p, "p_est": n_p, "k_bal": s["nk"], "k_vel": s["nkv"],
             "meas": n_meas, **filter_sizes}
    names = list(EMBEDDED_INPUTS[1:])
    outs = list(EMBEDDED_OUTPUTS[1:])
    if blocks.observer is not None:
        sizes["k_obs"] = s["nko"]
        names += OBSERVER_CONSTANTS
        outs += OBSERVER_OUTPUTS
    if blocks.guidance is not None:
        sizes["k_guid"] = s["nkg"]
        names += GUIDANCE_CONSTANTS
        outs += GUIDANCE_OUTPUTS
    kinds = {n: SEQUENCE for n in ("meas", *REFERENCE_SEQUENCES)}
    return PeriodPorts(f"ballbot_embedded_{blocks.name}", c,
                       tuple(Port(n, kinds.get(n, CONSTANT), sizes[n]) for n in names),
                       tuple(Port(n, SEQUENCE, 0) for n in outs), ("c", "c_next"))


def sequence_positions(step: ca.Function) -> tuple[int, ...]:
    """Positions of a step Function's per-period inputs (by port name; the others are
    the state and constants)."""
    names = {*PERIOD_SEQUENCES, *SENSOR_SEQUENCES}
    return tuple(i for i in range(step.n_in()) if step.name_in(i) in names)
