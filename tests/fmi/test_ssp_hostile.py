"""Hostile and malformed SSPs: refused with one line and exit 2 before any engine runs.

Zip slip (members with ``..`` or absolute paths) is refused before anything is
extracted; a truncated FMU binary is refused before it is loaded (it used to kill the
process with SIGBUS, so the command line is run in a subprocess here); a non-unit start
quaternion before libcosim sees it (it used to abort); two connections into one input
under every master, the container builder and the writer; malformed XML values; a huge
stop time without ``--duration``.
"""

from __future__ import annotations

import subprocess
import sys
import uuid
import zipfile
from pathlib import Path
from typing import Callable

import pytest

from ballbot_casadi.cli import main
from ballbot_casadi.errors import BuildError, FileFormatError, ScenarioError, StateError
from ballbot_casadi.fmi.archive import shared_object_problem, verify_fmu
from ballbot_casadi.fmi.system.container import build_container
from ballbot_casadi.fmi.masters.ssp_run import MASTERS, run_ssp
from ballbot_casadi.fmi.system.sil import write_sil_ssp
from ballbot_casadi.fmi.system.ssp import SSD_NAME, SspComponent, SspConnection, read_ssp, write_ssp
from ballbot_casadi.sim.scenario import load_scenario_file
from ballbot_casadi.studies.registry import resolve_scenario

pytestmark = [pytest.mark.needs_cc, pytest.mark.fmi_extra]

DURATION = 0.1


@pytest.fixture(scope="module")
def good_ssp(tmp_path_factory) -> Path:
    source = load_scenario_file(resolve_scenario("full_sine"))
    sc = source.scenario.replace(duration=DURATION)
    return write_sil_ssp(sc, tmp_path_factory.mktemp("ssp") / "good.ssp", specs=source.specs)


def _rewrite(src: Path, dst: Path, edit: Callable[[str, bytes], bytes | None] = lambda n, b: b,
             extra: dict[str, bytes] | None = None) -> Path:
    """Copy an archive member by member; ``edit(name, data)`` returns new data (None drops)."""
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for name in zin.namelist():
            data = edit(name, zin.read(name))
            if data is not None:
                zout.writestr(zipfile.ZipInfo(name, (1980, 1, 1, 0, 0, 0)), data)
        for name, data in (extra or {}).items():
            zout.writestr(zipfile.ZipInfo(name, (1980, 1, 1, 0, 0, 0)), data)
    return dst


def _ssd(edit: Callable[[str], str]) -> Callable[[str, bytes], bytes]:
    return lambda n, b: edit(b.decode()).encode() if n == SSD_NAME else b


def _cli(*argv: str) -> subprocess.CompletedProcess:
    """``ballbot`` in a subprocess: a crash (SIGBUS, abort) shows as its signal, not ours."""
    return subprocess.run([sys.executable, "-m", "ballbot_casadi.cli", *argv],
                          capture_output=True, text=True, timeout=300)


def _one_line_exit_2(proc: subprocess.CompletedProcess, *needles: str) -> None:
    err = proc.stderr.strip()
    assert proc.returncode == 2, (proc.returncode, proc.stderr[-2000:])
    assert err.count("\n") == 0 and "error:" in err and "Traceback" not in err, err
    for n in needles:
        assert n in err, (n, err)


# ------------------------------------------------------------------ zip slip


@pytest.mark.parametrize("member", ["../../../../{u}", "/tmp/{u}", "resources/../../{u}"])
def test_zip_slip_is_refused_before_anything_is_extracted(good_ssp, tmp_path, member):
    u = f"ballbot-zipslip-{uuid.uuid4().hex}"
    name = member.format(u=u)
    bad = _rewrite(good_ssp, tmp_path / "slip.ssp", extra={name: b"pwned"})
    with pytest.raises(FileFormatError, match="unsafe archive"):
        read_ssp(bad)
    for master in MASTERS:
        with pytest.raises(FileFormatError, match="unsafe archive"):
            run_ssp(bad, master=master)
    with pytest.raises(FileFormatError, match="unsafe archive"):
        build_container(bad, tmp_path / "c.fmu")
    proc = _cli("fmu", "cosim", str(bad), "--out", str(tmp_path / "out"), "--no-plot")
    _one_line_exit_2(proc, "unsafe archive", name)
    hits = [p for p in (Path("/tmp"), Path("/"), tmp_path.parent, tmp_path.parents[1], Path.cwd().parent)
            if (p / u).exists()]
    assert not hits and not (tmp_path / "out").exists()


# ------------------------------------------------------------------ truncated binary


def _controller_member(ssp: Path) -> str:
    """The controller FMU's member of the SIL archive (its name follows its estimator)."""
    with zipfile.ZipFile(ssp) as zf:
        return next(n for n in zf.namelist()
                    if n.startswith("resources/BallbotController") and n.endswith(".fmu"))


def _truncate_controller(good_ssp: Path, tmp_path: Path) -> Path:
    fmu_name = _controller_member(good_ssp)
    with zipfile.ZipFile(good_ssp) as zf:
        inner = zf.read(fmu_name)
    inner_path = tmp_path / "inner.fmu"
    inner_path.write_bytes(inner)
    short = _rewrite(inner_path, tmp_path / "short.fmu",
                     lambda n, b: b[: len(b) // 2] if n.endswith(".so") else b)
    return _rewrite(good_ssp, tmp_path / "truncated.ssp",
                    lambda n, b: short.read_bytes() if n == fmu_name else b)


def test_shared_object_check_sees_truncation(good_ssp, tmp_path):
    with zipfile.ZipFile(good_ssp) as zf:
        fmu = tmp_path / "c.fmu"
        fmu.write_bytes(zf.read(_controller_member(good_ssp)))
    with zipfile.ZipFile(fmu) as zf:
        so = zf.read(next(n for n in zf.namelist() if n.endswith(".so")))
    assert shared_object_problem(so) is None
    verify_fmu(fmu)
    for cut in (len(so) - 1, len(so) // 2, 100, 10):
        assert shared_object_problem(so[:cut]) is not None, cut
    assert "not an ELF" in shared_object_problem(b"MZ" + so[2:])


def test_truncated_fmu_binary_in_the_ssp_is_refused_not_sigbus(good_ssp, tmp_path):
    bad = _truncate_controller(good_ssp, tmp_path)
    for master in MASTERS:
        with pytest.raises(FileFormatError, match="truncated"):
            run_ssp(bad, master=master)
    with pytest.raises(FileFormatError, match="truncated"):
        build_container(bad, tmp_path / "c.fmu")
    for master in MASTERS:
        proc = _cli("fmu", "cosim", str(bad), "--out", str(tmp_path / f"o-{master}"),
                    "--master", master, "--no-plot", "--no-compare")
        _one_line_exit_2(proc, "controller", "truncated")
    proc = _cli("fmu", "container", str(bad), "--out", str(tmp_path / "c.fmu"))
    _one_line_exit_2(proc, "truncated")
    assert not (tmp_path / "c.fmu").exists()


# ------------------------------------------------------------------ start values, connections


def _set_param(xml: str, name: str, value: str) -> str:
    marker = f'name="{name}">'
    i = xml.index(marker)
    j = xml.index('value="', i) + len('value="')
    k = xml.index('"', j)
    return xml[:j] + value + xml[k:]


def _param_edit(name: str, value: str) -> Callable[[str, bytes], bytes]:
    """Edit a plant parameter wherever the SSP keeps it (inline or in an .ssv)."""
    def edit(n: str, b: bytes) -> bytes:
        text = b.decode(errors="replace")
        if (n == SSD_NAME or n.endswith(".ssv")) and f'name="{name}">' in text:
            return _set_param(text, name, value).encode()
        return b
    return edit


def test_non_unit_start_quaternion_is_refused_before_the_engine(good_ssp, tmp_path):
    bad = _rewrite(good_ssp, tmp_path / "q.ssp", _param_edit("x0_q0", "3.0"))
    assert read_ssp(bad).parameters["plant"]["x0_q0"] == 3.0
    for master in MASTERS:
        with pytest.raises(StateError, match="quaternion"):
            run_ssp(bad, master=master)
    proc = _cli("fmu", "cosim", str(bad), "--out", str(tmp_path / "o"), "--no-plot")
    _one_line_exit_2(proc, "start state of plant", "quaternion")


def _duplicate_input(xml: str) -> str:
    """A second connection into controller.sensor_acc_x (from plant.sensor_acc_y)."""
    first = ('<ssd:Connection startElement="plant" startConnector="sensor_acc_x" '
             'endElement="controller" endConnector="sensor_acc_x"/>')
    assert first in xml
    return xml.replace(first, first + "\n" + first.replace('startConnector="sensor_acc_x"',
                                                           'startConnector="sensor_acc_y"'))


def test_two_connections_into_one_input_are_refused_everywhere(good_ssp, tmp_path):
    with zipfile.ZipFile(good_ssp) as zf:
        xml = zf.read(SSD_NAME).decode()
    doubled = _duplicate_input(xml)
    assert doubled.count("<ssd:Connection ") == xml.count("<ssd:Connection ") + 1
    bad = _rewrite(good_ssp, tmp_path / "two.ssp", _ssd(lambda _x: doubled))
    for master in MASTERS:
        with pytest.raises(FileFormatError, match="more than one connection"):
            run_ssp(bad, master=master)
    with pytest.raises(FileFormatError, match="more than one connection"):
        build_container(bad, tmp_path / "c.fmu")
    # the writer too
    with zipfile.ZipFile(good_ssp) as zf:
        for n in ("BallbotPlant", "BallbotReference"):
            (tmp_path / f"{n}.fmu").write_bytes(zf.read(f"resources/{n}.fmu"))
    comps = [SspComponent("plant", tmp_path / "BallbotPlant.fmu"),
             SspComponent("reference", tmp_path / "BallbotReference.fmu")]
    cons = [SspConnection("reference", "tau_dist0", "plant", "tau_dist0"),
            SspConnection("reference", "tau_dist1", "plant", "tau_dist0")]
    with pytest.raises(BuildError, match="more than one connection"):
        write_ssp(tmp_path / "w.ssp", comps, cons, name="x", stop=1.0, step=0.005)
    write_ssp(tmp_path / "w.ssp", comps, cons[:1], name="x", stop=1.0, step=0.005)


# ------------------------------------------------------------------ malformed values


@pytest.mark.parametrize("edit, needle", [
    (_ssd(lambda x: x.replace('stopTime="', 'stopTime="abc', 1)), "stopTime"),
    (_ssd(lambda x: x.replace('stopTime="', 'stopTime="-', 1)), "positive multiple"),
    (_ssd(lambda x: x.replace('baseStepSize="0.005"', 'baseStepSize="0"')), "baseStepSize"),
    (_ssd(lambda x: x.replace('baseStepSize="0.005"', 'baseStepSize="nan"')), "baseStepSize"),
    (_ssd(lambda x: x.replace("<ssd:System ", "<ssd:Sistem ").replace("</ssd:System>", "</ssd:Sistem>")),
     "ssd:System"),
    (_ssd(lambda x: x.replace('endConnector="tau0"', 'endConnector="tau9"', 1)), "no variable 'tau9'"),
    (_ssd(lambda x: x.replace('endElement="plant"', 'endElement="nobody"', 1)), "no component 'nobody'"),
    (_ssd(lambda x: x.replace('source="resources/BallbotPlant.fmu"', 'source="resources/Nope.fmu"')),
     "not in the archive"),
    (_ssd(lambda x: x[: len(x) // 2]), "not valid XML"),
    (_param_edit("x0_q1", "zero"), "malformed"),
    (_param_edit("seed", "1.5"), "malformed"),
    (lambda n, b: None if n == "resources/BallbotReference.fmu" else b, "not in the archive"),
    (lambda n, b: b"{not json" if n.endswith("scenario.json") else b, "not valid JSON"),
])
def test_malformed_ssps_are_one_line_exit_2(good_ssp, tmp_path, edit, needle):
    bad = _rewrite(good_ssp, tmp_path / "bad.ssp", edit)
    proc = _cli("fmu", "cosim", str(bad), "--out", str(tmp_path / "o"), "--no-plot")
    _one_line_exit_2(proc, needle)


def test_huge_stop_time_needs_duration_or_allow_long(good_ssp, tmp_path, monkeypatch):
    bad = _rewrite(good_ssp, tmp_path / "long.ssp",
                   _ssd(lambda x: x.replace(f'stopTime="{DURATION!r}"', 'stopTime="1000000000.0"')))
    assert read_ssp(bad).stop_time == 1e9
    with pytest.raises(ScenarioError, match="--duration, or --allow-long"):
        run_ssp(bad)
    assert run_ssp(bad, duration=DURATION).time.size == round(DURATION / 0.005) + 1
    assert main(["fmu", "cosim", str(bad), "--out", str(tmp_path / "o"), "--no-plot"]) == 2


def test_fmu_ssp_refuses_what_the_ssp_cannot_express(tmp_path, capsys):
    scen = tmp_path / "drop.toml"
    text = resolve_scenario("full_sine").read_text()
    scen.write_text(text.split("[[spec]]")[0] + "\n[[sensor_dropout]]\nsensor = 'gyro'\nt_start_s = 0.5\n"
                    "t_end_s = 0.6\n")
    load_scenario_file(scen)  # a valid scenario file for the compiled mission
    code = main(["fmu", "ssp", "--scenario", str(scen), "--duration", "1", "--out", str(tmp_path / "x.ssp")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "sensor_dropout" in err and err.count("\n") == 0, err
    assert not (tmp_path / "x.ssp").exists()

