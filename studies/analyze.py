"""``ballbot analyze``: linearisation, controllability, zeros and bandwidth report.

Writes ``analysis.json``, ``analysis.md`` and PNG plots (pole-zero map, singular values of
the wheel-torque channels and, once the controllers exist, the closed-loop magnitude) to
``--out``.  The computation is :mod:`ballbot_casadi.analysis.linear` (plant) and
:mod:`ballbot_casadi.analysis.closed_loop` (cascade); the report text and plots
are :mod:`ballbot_casadi.studies.analysis_report`.

Operating point (``--at``)
--------------------------
``key=value`` pairs (``x, y`` in m, ``dx, dy`` in m/s, ``roll, pitch, yaw`` in degrees,
ZYX), e.g. ``--at yaw=30`` or ``--at yaw=45,dx=0.2``; or the full 12-state as 12
comma-separated numbers.  The attitude must be at rest and the state an equilibrium (a
trim torque must cancel every acceleration); otherwise the command stops with exit
code 2.  Default: the balanced attitude at rest (upright for a centred COM).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
from ballbot_casadi.studies.analysis_report import write_markdown, write_plots

from ballbot_casadi.analysis import closed_loop as cla
from ballbot_casadi.analysis import linear as an
from ballbot_casadi.codegen.libraries import load_model_library
from ballbot_casadi.core.files import staged_dir
from ballbot_casadi.core.params import load_params
from ballbot_casadi.errors import BallbotError, StateError
from ballbot_casadi.model import linearization as lz

__all__ = ["run_analysis", "summary_text", "demo_step", "OWNED_OUTPUTS"]

#: Files an existing output folder may hold and still be replaced (earlier outputs).
OWNED_OUTPUTS = ("analysis.json", "analysis.md", "*.png")


def _jsonable(obj: Any) -> Any:
    """Replace non-finite floats by None so the JSON is standard."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    return obj


def run_analysis(
    out: str | Path,
    params_path: str | None = None,
    at: str | None = None,
    plots: bool = True,
    compiled: bool = False,
) -> dict[str, Any]:
    """Analyse one robot at one operating point and write the report files.

    Parameters
    ----------
    out
        Output directory.  It is replaced as a whole when the analysis is complete
        (:func:`~ballbot_casadi.core.files.staged_dir`), so it never holds a mix of old
        and new files; it must be new, empty or hold only earlier outputs
        (:data:`OWNED_OUTPUTS`).
    params_path
        Parameter TOML file; ``None`` = thesis App. A defaults.
    at
        Operating-point text (see the module docstring); ``None`` = balanced at rest.
    plots
        Also write the PNG plots.
    compiled
        Take the plant Jacobians and trim from the compiled C library
        (:func:`ballbot_casadi.codegen.libraries.load_model_library`) instead of the CasADi
        Functions in memory (same expressions; the closed loop always differentiates the
        symbolic controller graph).

    Returns
    -------
    dict
        The content of ``analysis.json`` plus ``files`` (written paths).
    """

    params = load_params(params_path)
    x0 = _operating_point(at, params) if at is not None else None
    funcs = None
    if compiled:
        funcs = load_model_library()
    lin, result = an.analyze_plant(params, x0, funcs)
    result["jacobians"] = "compiled C library" if compiled else "CasADi Functions (symbolic)"
    result.update(cla.analyze_closed_loop(params, lin))
    result["parameters"] = params.as_dict()
    result["parameters_source"] = str(params_path) if params_path else "thesis App. A defaults"

    out = Path(out)
    # all files appear together: written into a fresh folder that replaces `out` at the end
    with staged_dir(out, owned=OWNED_OUTPUTS) as tmp:
        files = write_plots(lin, result, tmp) if plots else []
        md = write_markdown(result, tmp, result["parameters_source"], files)
        js = tmp / "analysis.json"
        js.write_text(json.dumps(_jsonable(result), indent=2) + "\n", encoding="utf-8")
    result["files"] = [str(out / f.name) for f in (js, md, *files)]
    return result


def _operating_point(at: str, params: Any) -> Any:
    """Parse ``--at``; a state where the model overflows is a clear :class:`StateError`."""
    try:
        with np.errstate(all="ignore"):
            return lz.parse_state_spec(at, params)
    except BallbotError:
        raise
    except (ValueError, ArithmeticError) as exc:  # e.g. dx=1e300: the model is Inf there
        raise StateError(f"operating point {at!r}: the model is not finite there ({exc}); "
                         "give values it can represent (speeds of m/s, angles in deg)") from None


def summary_text(result: dict[str, Any]) -> str:
    """A few lines summarising an analysis result."""
    w = result["controllability"]["weakest_mode"]
    lines = [
        f"operating point rpy = {[round(v, 3) for v in result['operating_point']['rpy_deg']]} deg",
        f"reduced model: {result['n_states_reduced']} states, controllability rank "
        f"{result['controllability_rank']}",
        f"unstable poles (rad/s): {[round(p, 4) for p in result['unstable_poles']]}",
        f"RHP zeros torques->position (rad/s): {[round(z, 4) for z in result['rhp_zeros_position']]}"
        + ("  (non-minimum phase)" if result["rhp_zeros_position"] else ""),
        f"weakest controllable modes: {', '.join(w['weakest_direction'])} "
        f"(energy {w['energy']:.3g} tau_max^2 s in {result['controllability']['gramian_horizon_s']:g} s)",
    ]
    if result.get("bandwidth_inner_hz") is None and result.get("bandwidth_outer_hz") is None:
        msg = (result.get("closed_loop") or {}).get("message", "controllers not available")
        lines.append(f"closed loop: not analysed ({msg}); plant only")
    else:
        bi, bo = result.get("bandwidth_inner_hz"), result.get("bandwidth_outer_hz")
        si, so = result.get("bandwidth_sensitivity_inner_hz"), result.get("bandwidth_sensitivity_outer_hz")
        ok = result.get("cascade_rule_ok")
        lines.append(f"-3 dB bandwidth |T|: inner (FLC) {_f(bi)} Hz, outer (velocity) {_f(bo)} Hz")
        lines.append(f"tracking bandwidth |1-T| = -3 dB: inner {_f(si)} Hz, outer {_f(so)} Hz, "
                     f"ratio {_f(result.get('bandwidth_sensitivity_ratio'))}; 3x rule (thesis 7.1): "
                     + ("n/a" if ok is None else "satisfied" if ok else "NOT satisfied"))
    return "\n".join(lines)


def _f(v: float | None) -> str:
    return "n/a" if v is None else f"{v:.3f}"


def demo_step(out: Path) -> int:
    """``make demo`` step: analyse the default robot into ``out/analysis`` and print a summary."""
    result = run_analysis(Path(out) / "analysis")
    print(summary_text(result))
    print(f"report: {Path(out) / 'analysis' / 'analysis.md'}")
    return 0
