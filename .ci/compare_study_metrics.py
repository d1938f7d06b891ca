#!/usr/bin/env python3
"""Compare two ``ballbot study all --out DIR`` runs: every study's metrics, FLC and SMC.

Usage: python .ci/compare_study_metrics.py DIR_BEFORE DIR_AFTER [--rtol R] [--atol A]

Prints one line per metric that differs beyond the tolerances and exits 1 if any does;
used to show that a refactoring leaves every study's results unchanged.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path


def _flat(prefix: str, value, out: dict) -> None:
    if isinstance(value, dict):
        for k, v in value.items():
            _flat(f"{prefix}.{k}", v, out)
    elif isinstance(value, list):
        for i, v in enumerate(value):
            _flat(f"{prefix}[{i}]", v, out)
    else:
        out[prefix] = value


def compare(a: Path, b: Path, rtol: float, atol: float) -> list[str]:
    ta = json.loads((a / "summary.json").read_text())
    tb = json.loads((b / "summary.json").read_text())
    fa, fb = {}, {}
    for study, res in ta.items():
        for ctrl, r in res.items():
            _flat(f"{study}/{ctrl}", {"metrics": r["metrics"], "passed": r["passed"]}, fa)
    for study, res in tb.items():
        for ctrl, r in res.items():
            _flat(f"{study}/{ctrl}", {"metrics": r["metrics"], "passed": r["passed"]}, fb)
    diffs = []
    for key in sorted(set(fa) | set(fb)):
        if key not in fa or key not in fb:
            diffs.append(f"{key}: only in {'before' if key in fa else 'after'}")
            continue
        va, vb = fa[key], fb[key]
        if isinstance(va, (int, float)) and isinstance(vb, (int, float)) and not isinstance(va, bool):
            if not (va == vb or math.isclose(va, vb, rel_tol=rtol, abs_tol=atol)):
                diffs.append(f"{key}: {va!r} -> {vb!r}")
        elif va != vb:
            diffs.append(f"{key}: {va!r} -> {vb!r}")
    return diffs


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("before", type=Path)
    ap.add_argument("after", type=Path)
    ap.add_argument("--rtol", type=float, default=0.0)
    ap.add_argument("--atol", type=float, default=0.0)
    args = ap.parse_args()
    diffs = compare(args.before, args.after, args.rtol, args.atol)
    for d in diffs:
        print(d)
    print(f"{len(diffs)} metric(s) differ (rtol {args.rtol}, atol {args.atol})")
    return 1 if diffs else 0


if __name__ == "__main__":
    sys.exit(main())
