"""The compiled mission driver is verified before it is loaded and rebuilt when damaged."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest

pytestmark = pytest.mark.needs_cc

CHILD = textwrap.dedent("""
    import casadi as ca, numpy as np
    from ballbot_casadi.sim.closed_loop import ClosedLoop
    from ballbot_casadi.sim.ports import PERIOD_CONSTANTS, PERIOD_SEQUENCES

    # a tiny step with the mission signature: xz accumulates Ts, the rest passes through
    xz = ca.MX.sym("xz", 2)
    seq = [ca.MX.sym(n, k) for n, k in zip(PERIOD_SEQUENCES, (4, 4, 4, 3, 6))]
    const = [ca.MX.sym(n) for n in PERIOD_CONSTANTS]
    step = ca.Function("ballbot_cl_step_tiny", [xz, *seq, *const],
                       [xz + const[4], xz[0], seq[3][0]],
                       ["xz", *PERIOD_SEQUENCES, *PERIOD_CONSTANTS], ["xz_next", "x", "v"])
    sim = ClosedLoop(compiled=True, steps={"tiny": step})
    n = 450
    args = [np.zeros(2)] + [np.zeros((n, k)) for k in (4, 4, 4, 3, 6)] + [0.0] * 4 + [0.005, 1.0, 1.0]
    out = sim._variant(sim.n_sub).driver.run("tiny", n, args)
    assert abs(out[0][-1, 0] - n * 0.005) < 1e-12, out[0][-1]
    print("ok")
""")


def _run(root) -> subprocess.CompletedProcess:
    env = {**os.environ, "BALLBOT_BUILD_DIR": str(root)}
    return subprocess.run([sys.executable, "-c", CHILD], env=env, capture_output=True, text=True,
                          timeout=300)


def test_damaged_mission_driver_is_rebuilt(tmp_path):
    first = _run(tmp_path)
    assert first.returncode == 0 and first.stdout.strip() == "ok", first.stderr
    (so,) = [p for p in tmp_path.rglob("lib*_mission_*.so")]
    size = so.stat().st_size
    for damage in ("truncate", "zero", "delete"):
        if damage == "truncate":
            with open(so, "r+b") as fh:
                fh.truncate(size // 3)
        elif damage == "zero":
            so.write_bytes(b"")
        else:
            so.unlink()
        again = _run(tmp_path)  # a child: a SIGBUS would show as a negative return code
        assert again.returncode == 0 and again.stdout.strip() == "ok", (damage, again.returncode,
                                                                        again.stderr[-500:])
        assert so.stat().st_size == size
