#!/usr/bin/env python3
"""Snapshot every shipped scenario (and every study's scenarios) for a refactoring check.

Usage: python .ci/scenario_inputs_snapshot.py save OUT.npz
       python .ci/scenario_inputs_snapshot.py compare OUT.npz

For each shipped scenario file and each study scenario (FLC and SMC) it records the
arrays of ``Scenario.inputs()`` (the estimation inputs included), ``to_dict()`` as JSON
and the TOML text written back by ``dump_toml``; ``compare`` reports every difference
(bit for bit) and exits 1 if there is one.
"""

from __future__ import annotations

import json
import sys

import numpy as np

from ballbot_casadi.sim.scenario import dump_toml, load_scenario_file
from ballbot_casadi.studies.registry import STUDIES, shipped_scenarios, study_scenarios


def _flatten(prefix: str, value, out: dict) -> None:
    if isinstance(value, dict):
        for k, v in value.items():
            _flatten(f"{prefix}.{k}", v, out)
    else:
        out[prefix] = np.asarray(value)


def snapshot() -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    scenarios = []
    for name, path in sorted(shipped_scenarios().items()):
        sf = load_scenario_file(path)
        out[f"file:{name}.toml"] = np.asarray(dump_toml(sf.table))
        scenarios.append((f"file:{name}", sf.scenario))
    for study in sorted(STUDIES):
        for ctrl in ("flc", "smc"):
            for i, sc in enumerate(study_scenarios(study, ctrl)):
                scenarios.append((f"study:{study}:{ctrl}:{i}", sc))
    for key, sc in scenarios:
        out[f"{key}.dict"] = np.asarray(json.dumps(sc.to_dict(), sort_keys=False))
        _flatten(f"{key}.inputs", sc.inputs(), out)
    return out


def main() -> int:
    mode, path = sys.argv[1], sys.argv[2]
    now = snapshot()
    if mode == "save":
        np.savez(path, **now)
        print(f"{len(now)} arrays saved to {path}")
        return 0
    before = dict(np.load(path))
    diff = sorted(set(before) ^ set(now))
    for k in sorted(set(before) & set(now)):
        a, b = before[k], now[k]
        if a.dtype != b.dtype or a.shape != b.shape or a.tobytes() != b.tobytes():
            diff.append(k)
    for k in diff:
        print("differs:", k)
    print(f"{len(before)} arrays before, {len(now)} now, {len(diff)} differ")
    return 1 if diff else 0


if __name__ == "__main__":
    sys.exit(main())
