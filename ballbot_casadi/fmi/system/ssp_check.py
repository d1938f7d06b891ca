"""An SSP from elsewhere, opened and checked before any engine sees it.

:func:`open_ssp` is the one way the co-simulation masters (:func:`~ballbot_casadi.fmi.masters.ssp_run.run_ssp`)
and the container builder (:func:`~ballbot_casadi.fmi.system.container.build_container`) unpack
an SSP.  Before it returns, in this order:

1. the archive's members are checked (no absolute paths, no ``..``) before the first
   is extracted (:func:`~ballbot_casadi.fmi.archive.safe_extract`);
2. every component's FMU is in the archive and verified as the FMU cache verifies its
   own (CRCs, ``modelDescription.xml``, this platform's binary, a complete shared object:
   :func:`~ballbot_casadi.fmi.archive.verify_fmu`), so a truncated binary is one line
   instead of a SIGBUS when it is loaded;
3. the connections join existing outputs to existing inputs, one connection per input,
   and the parameter sets name existing variables with finite values of their type
   (:func:`~ballbot_casadi.fmi.system.ssp.check_connections`,
   :func:`~ballbot_casadi.fmi.system.ssp.check_parameters`);
4. a component whose parameter set holds the whole robot state (the plant) starts on
   the unit-quaternion manifold (:func:`~ballbot_casadi.core.validation.check_state`),
   which libcosim would otherwise abort on.

Every refusal is a :class:`~ballbot_casadi.errors.FileFormatError` or
:class:`~ballbot_casadi.errors.StateError` naming the SSP (a user mistake, exit 2).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from fmpy import read_model_description

from ballbot_casadi.core.layout import STATE
from ballbot_casadi.core.safe_paths import member_problem
from ballbot_casadi.core.validation import check_state
from ballbot_casadi.errors import FileFormatError
from ballbot_casadi.fmi.archive import safe_extract, verify_fmu
from ballbot_casadi.fmi.plant.plant import X0_PREFIX
from ballbot_casadi.fmi.system.ssp import SspSystem, check_connections, check_parameters, read_ssp

__all__ = ["open_ssp", "MAX_STEPS"]

#: Most fixed steps a co-simulation runs without being asked explicitly (one hour at the
#: thesis's 5 ms period); a longer run needs ``--duration`` or ``allow_long``.
MAX_STEPS = 720_000


def open_ssp(ssp: str | Path, dest: str | Path) -> tuple[SspSystem, dict[str, Path], dict[str, dict[str, Any]]]:
    """Read, unpack into ``dest`` and check an SSP (see the module docstring).

    Returns
    -------
    system, fmus, variables
        The system (:func:`~ballbot_casadi.fmi.system.ssp.read_ssp`), ``{component: FMU file
        under dest}`` and ``{component: {name: fmpy ModelVariable}}``.
    """
    ssp, dest = Path(ssp), Path(dest)
    system = read_ssp(ssp)  # refuses unsafe members and malformed XML before extracting
    safe_extract(ssp, dest)
    fmus: dict[str, Path] = {}
    variables: dict[str, dict[str, Any]] = {}
    for comp, src in system.components.items():
        path = dest / src
        if not src or member_problem(src) is not None or not path.is_file():
            raise FileFormatError(f"{ssp}: component {comp!r}: its FMU {src!r} is not in the archive")
        verify_fmu(path, f"{ssp}: component {comp} ({src})")
        try:
            md = read_model_description(str(path))
        except Exception as exc:  # noqa: BLE001 - fmpy raises plain exceptions
            raise FileFormatError(f"{ssp}: component {comp}: unreadable modelDescription.xml "
                                  f"({type(exc).__name__}: {exc})") from None
        if md.coSimulation is None:
            raise FileFormatError(f"{ssp}: component {comp}: the FMU has no Co-Simulation interface")
        fmus[comp] = path
        variables[comp] = {v.name: v for v in md.modelVariables}
    kinds = {c: {n: (v.type, v.causality) for n, v in vs.items()} for c, vs in variables.items()}
    try:
        check_connections(system.connections, kinds)
        check_parameters(system.parameters, kinds)
    except FileFormatError as exc:
        raise FileFormatError(f"{ssp}: {exc}") from None
    for comp, values in system.parameters.items():
        for names in ([X0_PREFIX + n for n in STATE.names], list(STATE.names)):  # parameters, or start values
            if all(n in values for n in names):
                check_state([float(values[n]) for n in names], f"{ssp}: start state of {comp}")
    return system, fmus, variables
