"""``ballbot simulate``, ``study --list/--set/--axis``, ``animate``: in-process, short runs."""

from __future__ import annotations

import json

import pytest

from ballbot_casadi.cli import main
from ballbot_casadi.sim.log import load_log
from ballbot_casadi.studies.registry import shipped_scenarios

PNG = b"\x89PNG\r\n\x1a\n"


def _short_copy(tmp_path, name: str, duration: float) -> str:
    text = shipped_scenarios()[name].read_text()
    text = "\n".join(f"duration_s = {duration}" if line.startswith("duration_s") else line
                     for line in text.splitlines())
    path = tmp_path / f"{name}_short.toml"
    path.write_text(text + "\n")
    return str(path)


def test_simulate_writes_every_output(tmp_path, capsys):
    path = _short_copy(tmp_path, "sine", 2.0)
    out = tmp_path / "run"
    rc = main(["simulate", path, "--out", str(out)])
    text = capsys.readouterr().out
    data = json.loads((out / "metrics.json").read_text())
    assert rc == (0 if data["passed"] else 1) and "scenario sine" in text
    assert {r["metric"] for r in data["limits"]} == {"peak_tilt_deg", "peak_tilt_rate_deg_s", "peak_torque_nm"}
    png = (out / "plot.png").read_bytes()
    assert png[:8] == PNG and len(png) > 10000
    report = (out / "report.md").read_text()
    assert "![plot.png](plot.png)" in report and "< 0.1 s" in report  # the thesis's value beside ours
    log = load_log(out / "run.npz")
    assert log.scenario["duration"] == 2.0 and log["tau"].shape == (400, 3)
    assert (out / "scenario.toml").is_file()


@pytest.mark.parametrize("text,key", [
    ("duration_s = 1.0\nspeed = 3\n", "speed"),
    ("duration_s = 1.0\n[attitude.roll]\ntype = 'sine'\namplitude_deg = 3\n", "attitude.roll.frequency_hz"),
    ("duration_s = 'x'\n", "duration_s"),
])
def test_simulate_malformed_file_exit_2_one_line(tmp_path, capsys, text, key):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    assert main(["simulate", str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(path) in err[0] and f"key '{key}'" in err[0]
    assert not (tmp_path / "o").exists()


def test_study_list_and_set(tmp_path, capsys):
    assert main(["study", "--list"]) == 0
    text = capsys.readouterr().out
    assert "chirp" in text and "sine_asym.toml" in text
    out = tmp_path / "zero"
    rc = main(["study", "zero", "--set", "duration_s=3", "--out", str(out), "--no-plot", "--quiet"])
    data = json.loads((out / "metrics.json").read_text())
    assert rc == 0 and data["metrics"]["duration_s"] == pytest.approx(3.0, abs=1e-12)
    tilt = next(r for r in data["limits"] if r["metric"] == "peak_tilt_deg")
    assert tilt["exceeded"] and tilt["by_scenario"]            # starts at 7.07 deg > 5 deg
    rate = next(r for r in data["limits"] if r["metric"] == "peak_tilt_rate_deg_s")
    assert rate["exceeded"] and not rate["by_scenario"]        # ~24 deg/s: the loop's response
    assert main(["study", "zero", "--set", "nonsense"]) == 2
    assert main(["study", "zero", "--amplitude", "2"]) == 2


def test_chirp_pitch_short(tmp_path):
    out = tmp_path / "chirp"
    rc = main(["study", "chirp", "--axis", "pitch", "--amplitude", "3", "--set", "duration_s=30",
               "--set", "attitude.roll.sweep_s=29.7", "--out", str(out), "--quiet"])
    data = json.loads((out / "metrics.json").read_text())
    m = data["metrics"]
    assert rc in (0, 1) and m["chirp_axis"] == "pitch"
    for key in ("bandwidth_hz", "bandwidth_criterion", "first_saturation_hz", "first_saturation_s",
                "fell_at_s", "linear_bandwidth_hz"):
        assert key in m
    assert set(m["by_feedforward"]) == {"exact", "none"}
    assert m["linear_bandwidth_hz"] == pytest.approx(1.03, abs=0.05)
    for f in ("chirp_bode.png", "chirp_time.png", "plot.png"):
        assert (out / f).read_bytes()[:8] == PNG
    assert "Why the numbers differ" in (out / "report.md").read_text()


def test_animate_gif(tmp_path, capsys):
    path = _short_copy(tmp_path, "push", 1.5)
    main(["simulate", path, "--out", str(tmp_path / "p"), "--no-plot", "--quiet"])
    gif = tmp_path / "p.gif"
    assert main(["animate", str(tmp_path / "p" / "run.npz"), "-o", str(gif), "--max-frames", "4", "--quiet"]) == 0
    data = gif.read_bytes()
    assert data[:6] in (b"GIF89a", b"GIF87a") and len(data) > 2000
    assert main(["animate", str(tmp_path / "p" / "run.npz"), "-o", str(tmp_path / "x.avi")]) == 2
