"""Shared fixtures: reference data, default parameters, model Functions (built once), a
forked child for loads that may kill the process, a stand-in for ``subprocess.run``."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path
from types import SimpleNamespace
from typing import Callable

import numpy as np
import pytest

REFERENCE = Path(__file__).resolve().parent.parent.parent / "shared" / "reference"
#: Where this run's lines of ``$BALLBOT_BUILD_LOG`` start (path, byte offset).
_BUILD_LOG_START = pytest.StashKey[tuple]()


def pytest_configure(config: pytest.Config) -> None:
    log = os.environ.get("BALLBOT_BUILD_LOG")
    if log:
        config.stash[_BUILD_LOG_START] = (Path(log), Path(log).stat().st_size
                                          if Path(log).is_file() else 0)


def pytest_terminal_summary(terminalreporter, exitstatus, config: pytest.Config) -> None:
    """With ``$BALLBOT_BUILD_LOG`` (``make test`` sets it): this run's C compiles, their
    compiler CPU seconds and the sources compiled more than once, so a CI log shows
    when a change starts building the same C twice."""
    from ballbot_casadi.core.toolchain import build_log_summary

    start = config.stash.get(_BUILD_LOG_START, None)
    if start is None or not start[0].is_file():
        return
    s = build_log_summary(*start)
    terminalreporter.write_sep("=", f"C compiles: {s['compiles']}, {s['cpu_s']:.0f} s compiler CPU "
                                    f"(log {start[0]})")
    for what, times, cpu in s["repeated"]:
        terminalreporter.write_line(f"same sources compiled {times}x: {what} ({cpu:.1f} s CPU)")


@pytest.fixture(scope="session")
def kugle_reference() -> dict:
    """The predecessor robot's independently derived model (shared/reference)."""
    path = Path(os.environ.get("BALLBOT_REFERENCE_DIR", REFERENCE)) / "kugle-model-reference.json"
    if not path.is_file():
        if os.environ.get("CI"):
            pytest.fail(f"reference data not found at {path} (CI must have shared/ beside the clone)")
        pytest.skip(f"reference data not found at {path}")
    return json.loads(path.read_text())


@pytest.fixture(scope="session")
def model_functions():
    from ballbot_casadi.model.dynamics import make_model_functions

    return make_model_functions()


@pytest.fixture(scope="session")
def default_params():
    from ballbot_casadi import load_params

    return load_params()


@pytest.fixture()
def rng() -> np.random.Generator:
    return np.random.default_rng(20201122)


def _run_in_fork(fn: Callable[[], object]) -> tuple[int, str]:
    """Run ``fn()`` in a forked child; (its exit code, or -signal, and ``str(fn())``).

    Loading a truncated shared library kills the process with SIGBUS, so such loads run
    in a child whose exit status the test checks.
    """
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:  # child: a SIGBUS here must not take the test run with it
        code = 1
        try:
            os.close(r)
            os.write(w, str(fn()).encode())
            code = 0
        finally:
            os._exit(code)
    os.close(w)
    with os.fdopen(r) as f:
        out = f.read()
    _, status = os.waitpid(pid, 0)
    return os.waitstatus_to_exitcode(status), out


@pytest.fixture()
def in_fork() -> Callable[[Callable[[], object]], tuple[int, str]]:
    """:func:`_run_in_fork`: ``in_fork(fn) -> (exit code or -signal, str(fn()))``."""
    return _run_in_fork


def _fake_run(reply: Callable[[list[str]], str], calls: list, returncode: int = 0):
    """A stand-in for ``subprocess.run`` answering ``reply(cmd)``, as the real one would:
    the output reaches the caller only when captured (``str`` with ``text=True``, else
    ``bytes``), ``check=True`` raises on a non-zero code; each call appends ``(cmd, kw)``."""
    def run(cmd, capture_output=False, text=False, check=False, **kw):
        calls.append((list(cmd), {"capture_output": capture_output, "text": text,
                                  "check": check, **kw}))
        out = reply(list(cmd))
        if check and returncode != 0:
            raise subprocess.CalledProcessError(returncode, cmd, out)
        stdout, stderr = ((out, "") if text else (out.encode(), b"")) if capture_output else (None, None)
        return SimpleNamespace(stdout=stdout, stderr=stderr, returncode=returncode)
    return run


@pytest.fixture()
def fake_run() -> Callable[..., object]:
    """:func:`_fake_run`: ``fake_run(reply, calls, returncode=0) -> run``."""
    return _fake_run


@pytest.fixture(scope="session")
def guided_path():
    """A short waypoint path for the guidance-slot tests (tests/sim, tests/analysis)."""
    from ballbot_casadi.guidance.paths import waypoint_path

    return waypoint_path([[0.0, 0.0], [1.0, 0.3], [2.0, 0.0]])


@pytest.fixture(scope="session")
def guided_inputs(guided_path):
    """The path scenario's mission inputs along :func:`guided_path` (1 s)."""
    from ballbot_casadi.sim.path_following import path_scenario

    return path_scenario(guided_path, 1.0).inputs()


@pytest.fixture(scope="session")
def guided_law(guided_inputs):
    """The MPC guidance law for :func:`guided_inputs`' robot (built once per session)."""
    from ballbot_casadi.sim.guided import mpc_law

    return mpc_law(guided_inputs["p_ctrl"], guided_inputs["k_vel"])
