"""The scenario an SIL SSP carries (``resources/scenario.json``, written by
:func:`~ballbot_casadi.fmi.system.sil.write_sil_ssp`) read back by ``read_scenario``: the
scenario and its specs round trip; an archive without the resource has none; a resource
that is not JSON, lacks the scenario or holds an invalid one is refused with one line
naming the archive and the member (a user's file: exit 2, never a traceback)."""

from __future__ import annotations

import json
import zipfile

import pytest

from ballbot_casadi.errors import FileFormatError
from ballbot_casadi.fmi.system.sil import SCENARIO_RESOURCE, read_scenario
from ballbot_casadi.sim.scenario import Scenario

MEMBER = f"resources/{SCENARIO_RESOURCE}"


def _ssp(tmp_path, text: str | None):
    p = tmp_path / "sil.ssp"
    with zipfile.ZipFile(p, "w") as zf:
        zf.writestr("SystemStructure.ssd", "<x/>")
        if text is not None:
            zf.writestr(MEMBER, text)
    return p


def test_the_scenario_and_its_specs_round_trip(tmp_path):
    sc = Scenario(name="carried", duration=0.5, controller="smc", seed=7)
    specs = [{"metric": "peak_tilt_deg", "op": "<=", "threshold": 5.0}]
    back, got = read_scenario(_ssp(tmp_path, json.dumps({"scenario": sc.to_dict(),
                                                          "specs": specs})))
    assert back == sc and got == tuple(specs)
    assert read_scenario(_ssp(tmp_path, json.dumps({"scenario": sc.to_dict()}))) == (sc, ())


def test_an_archive_without_the_resource_carries_no_scenario(tmp_path):
    assert read_scenario(_ssp(tmp_path, None)) == (None, ())


@pytest.mark.parametrize("text, why", [
    ("{not json", f"{MEMBER} is not valid JSON ("),
    (json.dumps({"specs": []}), f"{MEMBER} is malformed (KeyError: 'scenario')"),
    (json.dumps({"scenario": 5}), f"{MEMBER} is malformed (TypeError: "),
    (json.dumps({"scenario": {"duration": 1.0}}), f"{MEMBER} is malformed (TypeError: Scenario() "
                                                  "needs a name)"),
    (json.dumps({"scenario": {"name": "x", "duration": -1.0}}), f"{MEMBER}: scenario 'x'"),
    (json.dumps({"scenario": {"name": "x", "duration": 1.0, "wind": 3}}),
     f"{MEMBER}: unknown scenario field(s) ['wind']"),
])
def test_a_damaged_resource_is_refused_in_one_line(tmp_path, text, why):
    p = _ssp(tmp_path, text)
    with pytest.raises(FileFormatError) as ei:
        read_scenario(p)
    msg = str(ei.value)
    assert msg.startswith(f"{p}: ") and why in msg and "\n" not in msg
