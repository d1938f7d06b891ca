"""Faults and hostile input of runs: no silent pass, no hang, one line and exit 2.

* a NaN run or a fall fails whatever the specs say (``ballbot simulate`` exit 1 with the
  reason; a Monte Carlo run is not a success);
* absurd torque disturbances, too many control periods and deeply nested TOML are
  refused with one line (exit 2);
* ``ballbot montecarlo`` exits 1 when runs miss their specs;
* ``--scheduler``: malformed strings, nothing listening, a silent peer and an HTTP
  server are one line, exit 2, within the connect timeout;
* a Dask cluster that lost all its workers fails the run (ClusterError), never waits.
"""

from __future__ import annotations

import http.server
import json
import math
import socket
import threading
import time

import pytest

from ballbot_casadi import cli
from ballbot_casadi.studies import dask_cluster as cluster
from ballbot_casadi.studies.montecarlo_runner import evaluate_run, run_dask
from ballbot_casadi.core.specs import FALL_TILT_DEG, run_failure
from ballbot_casadi.errors import ArgumentError, ClusterError, ScenarioFileError
from ballbot_casadi.sim.closed_loop import ClosedLoop
from ballbot_casadi.sim.scenario import load_scenario_file, parse_scenario
from ballbot_casadi.sim.scenario.file import MAX_PERIODS, TORQUE_DISTURBANCE_MAX_NM
from ballbot_casadi.studies import study as study_mod


def _err_line(capsys, command: str) -> str:
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith(f"ballbot {command}: error:"), err
    assert "Traceback" not in err
    return err


@pytest.fixture(scope="module")
def sim():
    return ClosedLoop()


# ------------------------------------------------------------------ NaN and falls


@pytest.mark.parametrize("metrics, needle", [
    ({"finite": False, "peak_tilt_deg": 0.0}, "NaN"),
    ({"finite": True, "peak_tilt_deg": FALL_TILT_DEG}, "fell"),
    ({"finite": True, "peak_tilt_deg": 179.0}, "fell"),
    ({"finite": True, "peak_tilt_deg": math.nan}, "peak tilt"),
])
def test_run_failure_names_the_reason(metrics, needle):
    assert needle in run_failure(metrics)


def test_run_failure_leaves_a_standing_run_alone():
    assert run_failure({"finite": True, "peak_tilt_deg": FALL_TILT_DEG - 0.01}) is None


def test_a_fall_fails_simulate_without_specs(tmp_path, capsys):
    scen = tmp_path / "fall.toml"
    scen.write_text("duration_s = 0.2\n[initial]\nroll_deg = 179\n")
    code = cli.main(["simulate", str(scen), "--out", str(tmp_path / "o"), "--no-plot"])
    out = capsys.readouterr().out
    assert code == 1 and "FAIL" in out and "fell" in out, out
    doc = json.loads((tmp_path / "o" / "metrics.json").read_text())
    assert doc["passed"] is False and "fell" in doc["failure"]


def test_a_nan_run_fails_simulate_whatever_the_specs(tmp_path, capsys, monkeypatch):
    real = study_mod.run_metrics

    def nan_metrics(log):
        m = real(log)
        return {**m, "finite": False, "peak_tilt_deg": 0.0}

    monkeypatch.setattr(study_mod, "run_metrics", nan_metrics)
    scen = tmp_path / "nan.toml"
    scen.write_text("duration_s = 0.1\n[[spec]]\nmetric = 'peak_tilt_deg'\nop = '<'\nthreshold = 5\n")
    code = cli.main(["simulate", str(scen), "--out", str(tmp_path / "o"), "--no-plot"])
    out = capsys.readouterr().out
    assert code == 1 and "NaN" in out, out


def test_a_fall_is_not_a_monte_carlo_success(sim):
    table = {"name": "fall", "duration_s": 0.2, "initial": {"roll_deg": 179.0}}
    res = evaluate_run(table, [{"metric": "finite", "op": "==", "threshold": True}], sim)
    assert res["ok"] is False and "fell" in res["failure"]
    res = evaluate_run({"name": "ok", "duration_s": 0.2}, [], sim)
    assert res["ok"] is True and res["failure"] is None


# ------------------------------------------------------------------ refused up front


def test_absurd_torque_disturbance_is_refused_with_the_range():
    row = "[[torque_disturbance]]\nt_start_s = 0.1\nt_end_s = 0.2\ntau_nm = [{}, 0, 0]\n"
    with pytest.raises(ScenarioFileError, match=r"torque_disturbance\[0\].tau_nm.*within \+-20 N m"):
        parse_scenario(__import__("tomllib").loads("duration_s = 1\n" + row.format(1e9)), "f")
    ok = parse_scenario(__import__("tomllib").loads("duration_s = 1\n" + row.format(TORQUE_DISTURBANCE_MAX_NM)), "f")
    assert ok.scenario.torque_disturbances[0][2] == TORQUE_DISTURBANCE_MAX_NM


def test_too_many_periods_are_refused_not_memoryerror(tmp_path, capsys):
    scen = tmp_path / "many.toml"
    scen.write_text("duration_s = 3600\ncontrol_period_s = 1e-5\n")
    t0 = time.perf_counter()
    assert cli.main(["simulate", str(scen), "--out", str(tmp_path / "o")]) == 2
    err = _err_line(capsys, "simulate")
    assert "duration_s" in err and str(MAX_PERIODS) in err and "periods" in err
    assert time.perf_counter() - t0 < 10.0


def test_deeply_nested_toml_is_one_line_exit_2(tmp_path, capsys):
    scen = tmp_path / "deep.toml"
    scen.write_text("duration_s = 1\nx = " + "[" * 5000 + "]" * 5000 + "\n")
    assert cli.main(["simulate", str(scen), "--out", str(tmp_path / "o")]) == 2
    assert "nested too deeply" in _err_line(capsys, "simulate")
    with pytest.raises(ScenarioFileError):
        load_scenario_file(scen)


def test_montecarlo_exits_1_when_specs_are_missed(tmp_path, capsys):
    scen = tmp_path / "never.toml"
    scen.write_text("duration_s = 0.05\n[[spec]]\nmetric = 'peak_tilt_deg'\nop = '<'\nthreshold = -1\n")
    code = cli.main(["montecarlo", str(scen), "--n", "2", "--workers", "0", "--quiet",
                     "--out", str(tmp_path / "o")])
    assert code == 1
    doc = json.loads((tmp_path / "o" / "montecarlo.json").read_text())
    assert doc["success_rate"] == 0.0
    code = cli.main(["montecarlo", str(scen), "--n", "2", "--workers", "0", "--quiet",
                     "--out", str(tmp_path / "o"), "--min-success", "0"])
    assert code == 0


# ------------------------------------------------------------------ --scheduler


@pytest.mark.parametrize("address", ["localhost", "tcp://", "tcp://host", "tcp://host:0",
                                     "tcp://host:99999", "http://host:80", "tcp://ho st:1",
                                     "tcp://host:80/x", ""])
def test_malformed_scheduler_strings_are_exit_2(tmp_path, capsys, address):
    assert cli.main(["montecarlo", "zero", "--n", "1", "--scheduler", address,
                     "--out", str(tmp_path / "o")]) == 2
    assert "PROTOCOL://HOST:PORT" in _err_line(capsys, "montecarlo")


@pytest.mark.parametrize("address, ok", [
    ("tcp://host:1", True), ("tcp://host:65535", True), ("tcp://host:0", False),
    ("tcp://host:65536", False), ("tls://10.0.0.2:8786", True), ("ws://a-b.c_d:8786", True),
    ("wss://[::1]:8786", True), ("udp://host:8786", False), ("tcp://-host:8786", False),
    ("TCP://host:8786", False), ("tcp://host:123456", False), (8786, False), (None, False),
])
def test_scheduler_addresses_at_the_edges(address, ok):
    """Ports 1..65535, the four protocols, a host name, IPv4 or bracketed IPv6."""
    if ok:
        assert cluster.check_scheduler_address(address) == address
    else:
        with pytest.raises(ArgumentError, match=r"^--scheduler .*: expected PROTOCOL://HOST:PORT "
                                                 r"with protocol tcp, tls, ws, wss and port "
                                                 r"1\.\.65535, e\.g\. tcp://127\.0\.0\.1:8786$"):
            cluster.check_scheduler_address(address)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture()
def silent_server():
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)  # accepts connections (the kernel does) and never answers
    yield srv.getsockname()[1]
    srv.close()


@pytest.fixture()
def http_server():
    class Handler(http.server.SimpleHTTPRequestHandler):
        timeout = 1.0  # a dask client never finishes its "request": do not block shutdown

        def log_message(self, *_a):  # keep stderr for the command's one line
            pass

    srv = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    srv.daemon_threads = True
    threading.Thread(target=srv.serve_forever, daemon=True).start()
    yield srv.server_address[1]
    srv.shutdown()
    srv.server_close()


@pytest.mark.parametrize("kind", ["nothing", "silent", "http"])
def test_scheduler_that_does_not_answer_is_exit_2_in_time(tmp_path, capsys, monkeypatch, kind,
                                                          request):
    port = {"nothing": _free_port, "silent": lambda: request.getfixturevalue("silent_server"),
            "http": lambda: request.getfixturevalue("http_server")}[kind]()
    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT_S", 2.0)
    t0 = time.perf_counter()
    code = cli.main(["montecarlo", "zero", "--n", "1", "--set", "duration_s=0.05", "--quiet",
                     "--scheduler", f"tcp://127.0.0.1:{port}", "--out", str(tmp_path / "o")])
    took = time.perf_counter() - t0
    assert code == 2
    assert "no Dask scheduler answered within 2 s" in _err_line(capsys, "montecarlo")
    assert took < 2.0 + 5.0 + 20.0  # the connect timeout plus the thread's grace, not for ever


def test_connect_refuses_a_malformed_address():
    with pytest.raises(ArgumentError, match="PROTOCOL://HOST:PORT"):
        cluster.connect("not an address")


# ------------------------------------------------------------------ lost workers


def test_a_cluster_without_workers_fails_the_run_instead_of_waiting():
    from distributed import Client, LocalCluster

    source = parse_scenario({"name": "z", "duration_s": 0.05}, "z")
    runs = [{"table": dict(source.table), "index": i} for i in range(3)]
    with LocalCluster(n_workers=1, processes=False, dashboard_address=":0") as lc, Client(lc) as client:
        lc.scale(0)
        deadline = time.monotonic() + 30
        while client.scheduler_info().get("workers") and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not client.scheduler_info().get("workers")
        t0 = time.perf_counter()
        with pytest.raises(ClusterError, match=r"no worker for 2 s; 0 of \d+ batches \(0 runs\)"):
            run_dask(source, runs, client, lost_timeout_s=2.0)
        assert time.perf_counter() - t0 < 20.0


# ------------------------------------------------------------------ long runs on the command line


def test_simulate_duration_beyond_an_hour_needs_decimated_logging(tmp_path, capsys, monkeypatch):
    scen = tmp_path / "s.toml"
    scen.write_text("duration_s = 1\n")
    assert cli.main(["simulate", str(scen), "--duration", "36000", "--out", str(tmp_path / "o")]) == 2
    assert "add --log-every 10" in _err_line(capsys, "simulate")
    for bad in ("0", "-5", "nan", "1e9"):
        assert cli.main(["simulate", str(scen), "--duration", bad, "--out", str(tmp_path / "o")]) == 2
        assert "--duration" in _err_line(capsys, "simulate")
    seen = {}

    def fake_run(sc, sim, log_every=1):
        seen.update(duration=sc.duration, n=sc.n_periods, log_every=log_every)
        raise KeyboardInterrupt  # stop before simulating ten hours

    monkeypatch.setattr(study_mod, "run_scenario", fake_run)
    assert cli.main(["simulate", str(scen), "--duration", "36000", "--log-every", "10",
                     "--out", str(tmp_path / "o")]) == 130
    assert seen == {"duration": 36000.0, "n": 7_200_000, "log_every": 10}


def test_simulate_duration_overrides_the_file(tmp_path):
    scen = tmp_path / "s.toml"
    scen.write_text("duration_s = 1\n")
    assert cli.main(["simulate", str(scen), "--duration", "0.25", "--log-every", "5", "--no-plot",
                     "--quiet", "--out", str(tmp_path / "o")]) == 0
    from ballbot_casadi.sim.log import load_log

    log = load_log(tmp_path / "o" / "run.npz")
    assert log["time"][-1] == pytest.approx(0.25, abs=1e-12) and log["time"].size == 50 // 5 + 1
    assert "duration_s = 0.25" in (tmp_path / "o" / "scenario.toml").read_text()


@pytest.mark.parametrize("delay_s, answers", [(0.0, True), (0.4, True), (30.0, False)])
def test_connect_waits_the_timeout_plus_a_grace_for_the_client(monkeypatch, delay_s, answers):
    """A scheduler that answers after the client's own timeout but within the 5 s grace is
    used (its handshake may lag); one that never answers in time is one line, after the
    timeout plus the grace and not for ever."""
    import distributed

    made = []

    class SlowClient:
        def __init__(self, address, timeout):
            made.append((address, timeout))
            time.sleep(delay_s)

    monkeypatch.setattr(distributed, "Client", SlowClient)
    t0 = time.perf_counter()
    if answers:
        assert isinstance(cluster.connect("tcp://127.0.0.1:8786", timeout_s=0.1), SlowClient)
    else:
        with pytest.raises(ArgumentError, match=r"^--scheduler tcp://127.0.0.1:8786: no Dask "
                                                 r"scheduler answered within 0.1 s \(no answer\)"):
            cluster.connect("tcp://127.0.0.1:8786", timeout_s=0.1)
        assert 5.0 <= time.perf_counter() - t0 < 10.0
    assert made == [("tcp://127.0.0.1:8786", "0.1s")]
