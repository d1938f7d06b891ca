"""sim/driver.py: the generated mission glue matches the step Functions it chains.

(The compiled driver's cache and a tiny mission run are tests/sim/test_driver_cache.py.)
"""

from __future__ import annotations

import re

import casadi as ca
import pytest

from ballbot_casadi.errors import BuildError
from ballbot_casadi.sim.driver import glue_source


def _step(name: str, nx: int = 3, nseq: int = 2) -> ca.Function:
    xz, s, k = ca.MX.sym("xz", nx), ca.MX.sym("s", nseq), ca.MX.sym("k")
    return ca.Function(f"ballbot_cl_step_{name}", [xz, s, k], [xz * k, ca.sum1(s)], ["xz", "s", "k"],
                       ["xz_next", "y"])


def test_glue_lists_every_controller_with_its_row_counts():
    src = glue_source("lib.h", {"flc": _step("flc"), "smc": _step("smc")}, chunk=64, seq_inputs=(1,))
    for ctrl in ("flc", "smc"):
        assert f"int ballbot_mission_{ctrl}(long n," in src
        assert re.search(rf"ROWS_IN_{ctrl}\[3\] = \{{3, 2, 1\}};", src)
        assert re.search(rf"ROWS_OUT_{ctrl}\[2\] = \{{3, 1\}};", src)
    assert '#include "lib.h"' in src
    assert "SEQ_IN[3] = {0, 1, 0};" in src                   # only input 1 is a sequence
    assert "xz[3]" in src and ">= 64" in src


def test_misnamed_or_mismatched_steps_are_refused():
    with pytest.raises(BuildError, match="not named ballbot_cl_step_flc"):
        glue_source("lib.h", {"flc": _step("smc")}, 64, (1,))
    renamed = ca.Function("ballbot_cl_step_smc", [ca.MX.sym("xz", 3), ca.MX.sym("seq", 2), ca.MX.sym("k")],
                          [ca.MX.sym("xz", 3) * 0, ca.MX(0)], ["xz", "seq", "k"], ["xz_next", "y"])
    with pytest.raises(BuildError, match="same inputs and outputs"):
        glue_source("lib.h", {"flc": _step("flc"), "smc": renamed}, 64, (1,))
    # a controller with its own state (super-twisting) may have a larger xz: its own row counts
    src = glue_source("lib.h", {"flc": _step("flc"), "sta": _step("sta", nx=4)}, 64, (1,))
    assert re.search(r"ROWS_IN_sta\[3\] = \{4, 2, 1\};", src)
