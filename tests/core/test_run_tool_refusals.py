"""A build tool that cannot run is a BuildError naming the step and the program (not a
bare OSError), and a tool that fails carries its command and the end of its stderr."""

from __future__ import annotations

import sys

import pytest

from ballbot_casadi.core.toolchain import run_tool
from ballbot_casadi.errors import BuildError


def test_a_missing_program(tmp_path):
    prog = str(tmp_path / "no-such-cc")
    with pytest.raises(BuildError, match=rf"^compiling x\.c: program '{prog}' not found; install "
                                         r"gcc/binutils or set CC$"):
        run_tool([prog, "x.c"], "compiling x.c")


def test_a_program_that_cannot_be_executed(tmp_path):
    prog = tmp_path / "cc"
    prog.write_text("not a program")
    prog.chmod(0o644)   # no execute bit: even root cannot run it
    with pytest.raises(BuildError, match=rf"^linking y: cannot run '{prog}': .*Permission denied"):
        run_tool([str(prog)], "linking y")


def test_a_failing_tool_carries_its_command_and_stderr():
    cmd = [sys.executable, "-c", "import sys; sys.stderr.write('A' * 5000 + 'the end'); sys.exit(4)"]
    with pytest.raises(BuildError) as exc:
        run_tool(cmd, "archiving z")
    head, tail = str(exc.value).split("\n", 1)
    assert head == f"archiving z failed ({' '.join(cmd)}):"
    assert tail.endswith("the end") and len(tail) == 4000
    run_tool([sys.executable, "-c", "pass"], "a step that works")   # returns quietly
