"""The ``flc_smc`` study: thesis §8.3, the FLC against the predecessor's sliding mode, side by side.

The thesis (§8.3, Fig. 8.8) compares its FLC (V2020) with the predecessor's SMC (V2019) on
the roll sine: roll errors "quite similar", pitch "one order of magnitude lower" with the
SMC.  Here both (and the FLC with the disturbance observer, the super-twisting controller
and the balance LQR, for reference) run the ``sine_asym`` scenario - the 3 deg / 0.5 Hz
roll sine on a robot whose COM is 5 mm off-axis, unknown to the controllers, so that the
pitch error is not zero by construction - in two set-ups:

* the thesis's: ``feedforward = none`` (its FLC (8.44) and the V2019 SMC took the
  reference's second derivative as zero);
* ours: ``feedforward = exact``.

Why the ratio is what it is: inside its boundary layer the V2019 law
``v = -K dy - eta sat(S / eps)``, ``S = dy + K y`` (:mod:`ballbot_casadi.control.smc`) is
the linear PD ``v = -(K + eta/eps) dy - (eta/eps) K y``.  The COM offset is a slowly varying
error acceleration ``delta``; a PD leaves ``y = delta / K_p`` of it, so the pitch errors
stand in the ratio of the stiffnesses, :func:`stiffness_ratio` = ``(eta/eps) K / K_p`` =
12 x 15 / 100 = 1.8 with the defaults, not 10.  A law with integral action (the
super-twisting controller's ``z``, the FLC + disturbance observer) removes the static part.

Specs (``metrics["specs"]``): the thesis's claim (pitch ratio >= 10, in the thesis's
set-up; a *thesis* row: it may differ without failing the study) and ours: the measured
ratio is the stiffness ratio within 15 % (the explanation above, which fails if the
error is not the static PD error), and the roll errors "quite similar" (within 3x).
Writes ``metrics.json`` and ``report.md``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ballbot_casadi.analysis.metrics import run_metrics
from ballbot_casadi.control import default_balance_gains
from ballbot_casadi.control.flc import FLC_GAIN_NAMES
from ballbot_casadi.control.smc import SMC_GAIN_NAMES
from ballbot_casadi.core.specs import spec_ok
from ballbot_casadi.sim.closed_loop import ClosedLoop, run_scenario
from ballbot_casadi.studies.registry import get_study
from ballbot_casadi.studies.formatting import write_metrics

__all__ = ["FLC_SMC_CONTROLLERS", "SETUPS", "stiffness_ratio", "run_flc_smc_study",
           "flc_smc_report_lines"]

#: Controllers of the study (the first two are the thesis's comparison).
FLC_SMC_CONTROLLERS = ("flc", "smc", "flc_dob", "sta", "lqr")
#: The set-ups: name -> the feed-forward switch.
SETUPS = {"thesis": "none", "ours": "exact"}
_ERRORS = ("roll_error_max_deg", "pitch_error_max_deg", "yaw_error_max_deg")
_THESIS_RATIO, _EXPLAIN_RTOL, _ROLL_SIMILAR = 10.0, 0.15, 3.0


def stiffness_ratio(k_smc: Sequence[float] | None = None, k_flc: Sequence[float] | None = None,
                    axis: int = 1) -> float:
    """SMC / FLC proportional stiffness on ``axis`` (1: pitch): ``(eta/eps) K / K_p``
    (module docstring); defaults the controllers' default gains."""
    s = np.asarray(default_balance_gains("smc") if k_smc is None else k_smc, float)
    f = np.asarray(default_balance_gains("flc") if k_flc is None else k_flc, float)
    i = str(axis + 1)
    K, eta, eps = (s[SMC_GAIN_NAMES.index(n + i)] for n in ("K", "eta", "eps"))
    return float(eta / eps * K / f[FLC_GAIN_NAMES.index("Kp" + i)])


def run_flc_smc_study(out: Path, plot: bool = True,
                      controllers: Sequence[str] = FLC_SMC_CONTROLLERS,
                      sim: ClosedLoop | None = None) -> dict[str, Any]:
    """Run the study into ``out`` (no plot); returns the metrics."""
    out.mkdir(parents=True, exist_ok=True)
    sim = ClosedLoop() if sim is None else sim
    study = get_study("sine_asym")
    table: dict[str, dict[str, dict[str, float]]] = {}
    for setup, ff in SETUPS.items():
        table[setup] = {}
        for c in controllers:
            log = run_scenario(study.scenarios(c, [("feedforward", ff)])[-1], sim)
            m = run_metrics(log)
            table[setup][c] = {k: float(m[k]) for k in _ERRORS}
    ratio = {s: {e.split("_")[0]: table[s]["flc"][e] / table[s]["smc"][e] for e in _ERRORS}
             for s in SETUPS}
    predicted = stiffness_ratio()
    specs = [
        {"name": "thesis: pitch error FLC / SMC (thesis's set-up)", "thesis": True,
         "value": ratio["thesis"]["pitch"], "op": ">=", "threshold": _THESIS_RATIO,
         "source": "thesis §8.3: SMC one order of magnitude lower in pitch (Fig. 8.8)"},
        {"name": "thesis: roll error FLC / SMC within 3x (thesis's set-up)", "thesis": True,
         "value": max(ratio["thesis"]["roll"], 1 / ratio["thesis"]["roll"]), "op": "<=",
         "threshold": _ROLL_SIMILAR, "source": "thesis §8.3: roll 'quite similar'"},
        *({"name": f"ours: pitch ratio / stiffness ratio {predicted:.2f} ({s} set-up)",
           "thesis": False, "value": ratio[s]["pitch"] / predicted - 1, "op": "abs<=",
           "threshold": _EXPLAIN_RTOL,
           "source": "inside the boundary layer the SMC is a PD of stiffness (eta/eps) K"}
          for s in SETUPS),
    ]
    for sp in specs:
        sp["ok"] = spec_ok(sp["value"], sp["op"], sp["threshold"])
    m = {"table": table, "ratio_flc_over_smc": ratio, "stiffness_ratio": predicted,
         "integral_action_ratio": {c: table["ours"]["flc"]["pitch_error_max_deg"]
                                   / table["ours"][c]["pitch_error_max_deg"]
                                   for c in controllers if c in ("flc_dob", "sta")},
         "specs": specs, "passed": all(sp["ok"] for sp in specs if not sp["thesis"])}
    write_metrics(out, m)
    (out / "report.md").write_text("\n".join(flc_smc_report_lines(m)) + "\n")
    return m


def flc_smc_report_lines(m: dict[str, Any]) -> list[str]:
    """``report.md``: the thesis's claim, ours in its set-up and in ours, the ratio, why."""
    r = m["ratio_flc_over_smc"]
    lines = ["# §8.3 FLC against the predecessor's SMC, side by side", "",
             "Roll sine 3 deg / 0.5 Hz, COM 5 mm off-axis unknown to the controllers "
             "(`sine_asym`); largest errors (deg).  Thesis's set-up: `feedforward = none`; ours: "
             "`exact`.", "",
             "| controller | set-up | roll | pitch | yaw |", "|---|---|---|---|---|"]
    for setup, rows in m["table"].items():
        for c, e in rows.items():
            lines.append(f"| {c} | {setup} | {e['roll_error_max_deg']:.4f} | "
                         f"{e['pitch_error_max_deg']:.4f} | {e['yaw_error_max_deg']:.4f} |")
    lines += ["", "| | thesis (§8.3, Fig. 8.8) | ours, thesis's set-up | ours, our set-up |",
              "|---|---|---|---|",
              f"| pitch error FLC / SMC | ≥ 10 ('one order of magnitude') | {r['thesis']['pitch']:.2f} "
              f"| {r['ours']['pitch']:.2f} |",
              f"| roll error FLC / SMC | ≈ 1 ('quite similar') | {r['thesis']['roll']:.2f} | "
              f"{r['ours']['roll']:.2f} |", "", "Specs:", ""]
    for sp in m["specs"]:
        verdict = ("PASS" if sp["ok"] else "FAIL") if not sp["thesis"] else \
            ("pass" if sp["ok"] else "differs")
        lines.append(f"- {sp['name']}: {sp['value']:.3g} {sp['op']} {sp['threshold']:g} -> "
                     f"**{verdict}** ({sp['source']})")
    ia = ", ".join(f"{c} {v:.1f}" for c, v in m["integral_action_ratio"].items())
    lines += ["", f"Why we differ: inside its boundary layer the V2019 SMC is the PD "
              f"`v = -(K + eta/eps) dy - (eta/eps) K y`, stiffness (eta/eps) K = "
              f"{m['stiffness_ratio']:.2f}x the FLC's K_p.  The COM offset acts as a slowly "
              "varying error acceleration that a PD leaves as `y = delta / K_p`, so the pitch "
              "errors stand in the ratio of the stiffnesses - measured "
              f"{r['ours']['pitch']:.2f}, predicted {m['stiffness_ratio']:.2f}; the feed-forward "
              "switch changes the roll (the sine's own tracking), not the pitch.  The thesis's "
              "factor 10 came from the predecessor's model and implementation, which we "
              "do not have (§8.3 ran the predecessor's own system); with the V2019 gains on our "
              "model the factor is the stiffness ratio.  An order of magnitude needs integral action, not a sliding surface: "
              f"FLC / controller pitch ratio with it: {ia} (our set-up)."]
    return lines
