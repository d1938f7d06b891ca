"""The C fuzzer of the FMI API (fmu/tools/fuzz.c) fails an FMU that breaks the rules, each
rule with its own exit status and message.

The plant FMU keeps every rule, so the other fuzz tests only ever see exit 0. Here the
plant's binary behind a library that breaks one rule (``_broken_fmu``), chosen by
``BROKEN_RULE``:

- ``guid``: instantiates whatever GUID it is given (exit 10, "instantiated with a wrong GUID");
- ``state``: reports a serialised state of ``STATE_SIZE`` bytes: one more than the fuzzer's
  64 KiB buffer fails the FMU (exit 11), exactly the buffer does not;
- ``null``: ``fmi2GetDerivatives`` on a NULL instance returns fmi2OK (exit 12 when the
  fuzzer's NULL-instance probe finds it, 13 when a random call on an empty slot does);
- ``silent``: ``fmi2Terminate`` refuses without a log message (counted as ``silent``, the
  first five printed, exit 0)."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest
from _broken_fmu import build_broken
from _fmu_support import plant_build, run_fuzz

pytestmark = pytest.mark.needs_cc


@pytest.fixture(scope="module")
def broken(tmp_path_factory) -> Path:
    """The rule-breaking library in front of the plant FMU's binary."""
    return build_broken(tmp_path_factory.mktemp("broken_fmu"))


def _fuzz(lib: Path, rule: str, n: int, seed: int, **extra: str) -> subprocess.CompletedProcess:
    build = plant_build()
    env = {"BROKEN_RULE": rule, "PLANT_GUID": build.guid, "PATH": "/usr/bin:/bin", **extra}
    return run_fuzz(build, str(lib), "{guid}", str(n), str(seed), env=env)


def test_the_wrapper_alone_keeps_every_rule(broken):
    res = _fuzz(broken, "none", 3000, 5)
    assert res.returncode == 0, res.stderr[-2000:]
    s = json.loads(res.stdout)
    assert s["silent"] == 0 and s["bad_guid"] > 0 and s["steps_ok"] > 0, s


def test_an_instance_made_with_a_wrong_guid_fails_the_fmu(broken):
    res = _fuzz(broken, "guid", 3000, 5)
    assert (res.returncode, res.stderr, res.stdout) == (10, "instantiated with a wrong GUID\n", "")


def test_a_serialised_state_beyond_the_buffer_fails_the_fmu(broken):
    res = _fuzz(broken, "state", 3000, 5, STATE_SIZE=str(65536 + 1))
    assert (res.returncode, res.stdout) == (11, "")
    res = _fuzz(broken, "state", 3000, 5, STATE_SIZE=str(65536))  # fits: refused by the FMU
    assert res.returncode == 0, res.stderr[-2000:]
    assert json.loads(res.stdout)["silent"] == 0


# The fuzzer draws from its own generator, so a seed replays on any host: seed 1 meets the
# NULL-instance probe first, seed 24 an fmi2GetDerivatives (op 27) drawn on an empty slot.
@pytest.mark.parametrize(("seed", "code", "message"), [
    (1, 12, "a call on a NULL instance returned fmi2OK\n"),
    (24, 13, "op 27 on a NULL instance returned fmi2OK\n"),
])
def test_ok_on_a_null_instance_fails_the_fmu(broken, seed, code, message):
    res = _fuzz(broken, "null", 3000, seed)
    assert (res.returncode, res.stderr, res.stdout) == (code, message, "")


def test_a_refusal_without_a_message_is_counted_silent(broken):
    res = _fuzz(broken, "silent", 3000, 5)
    assert res.returncode == 0, res.stderr[-2000:]
    s = json.loads(res.stdout)
    lines = res.stderr.splitlines()
    assert s["silent"] > 5, s
    assert lines == ["silent non-OK status 3 in op 5"] * 5
