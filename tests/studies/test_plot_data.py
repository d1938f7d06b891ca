"""What the study plots draw, read back from the figures when they are saved (issue 23:
plot mutants -- axes swapped, a wrong grid, points of the wrong runs -- changed no number
a test looked at).  ``Figure.savefig`` is wrapped to record each figure's lines and
scatter collections; the data are compared with values computed here independently."""

from __future__ import annotations

import numpy as np
import pytest
from _figures import assert_style, hlines, line, vlines

from ballbot_casadi.analysis import linear as an
from ballbot_casadi.core.params import load_params
from ballbot_casadi.core.specs import specs_or_default
from ballbot_casadi.sim.scenario import load_scenario_file
from ballbot_casadi.sim.scenario.dispersions import draw_runs
from ballbot_casadi.studies import analysis_report
from ballbot_casadi.studies import montecarlo_report as mr
from ballbot_casadi.studies.registry import shipped_scenarios


def test_pole_zero_and_singular_value_plots_draw_the_analysis(saved, tmp_path):
    lin, result = an.analyze_plant(load_params())
    fr = {"inner": {"omega": [1.0, 10.0, 100.0], "mag": [1.0, 0.5, 0.01]},
          "outer": {"omega": [0.5, 5.0], "mag": [0.9, 0.1]}}
    result = {**result, "closed_loop": {"frequency_response": fr}, "bandwidth_sensitivity_inner_hz": 1.7,
              "bandwidth_sensitivity_outer_hz": 0.4}
    files = analysis_report.write_plots(lin, result, tmp_path)
    assert [f.name for f in files] == ["pole_zero.png", "singular_values.png", "closed_loop.png"]
    cl, = saved["closed_loop.png"]
    for key, label in (("inner", "inner loop: q_ref -> tilt"), ("outer", "outer loop: v_ref -> ball velocity")):
        x, y = line(cl, label)
        np.testing.assert_allclose(x, np.array(fr[key]["omega"]) / (2 * np.pi), rtol=1e-15)
        np.testing.assert_allclose(y, 20 * np.log10(fr[key]["mag"]), rtol=1e-15, atol=1e-15)
    assert vlines(cl) == [1.7, 0.4] and hlines(cl) == [-3.01]
    assert cl["ylim"] == (-60.0, 10.0) and cl["xscale"] == "log"
    assert (cl["xlabel"], cl["ylabel"]) == ("frequency (Hz)", "|T| (dB)")
    assert_style(saved, "closed_loop.png")
    pz = saved["pole_zero.png"][0]
    er = np.array([complex(*z) for z in result["eigenvalues_reduced"]])
    x, y = line(pz, "poles (reduced 10-state model)")
    np.testing.assert_allclose(x, er.real, rtol=0, atol=0)  # Re on x, Im on y
    np.testing.assert_allclose(y, er.imag, rtol=0, atol=0)
    assert np.any(x > 0)  # the balancing robot is open-loop unstable: a pole on the right
    cons = np.array([complex(*z) for z in result["constraint_eigenvalues"]])
    x, y = line(pz, "constraint poles (12-state only)")
    np.testing.assert_allclose(x + 1j * y, cons, rtol=0, atol=0)
    assert pz["xlabel"].startswith("Re") and pz["ylabel"].startswith("Im")
    # the imaginary axis shown from -2 to 2 rad/s, the real and imaginary axes drawn at 0
    assert pz["ylim"] == (-2.0, 2.0)
    assert hlines(pz) == [0.0] and vlines(pz) == [0.0]
    assert pz["title"] == "Pole-zero map at the operating point (shaded: right half-plane)"
    # the shade starts at Re s = 0 and reaches past the mirror image of every point drawn, and
    # the right half-plane is shown at least as wide as the left
    (_, x0, x1), = pz["xspans"]
    ef = np.array([complex(*z) for z in result["eigenvalues_full"]])
    zeros = [complex(*v) for ch in result["channels"].values() for v in ch["zeros"]]
    reach = np.max(np.abs(np.concatenate([ef, zeros]).real))
    assert x0 == 0.0 and x1 > reach > 5.0
    assert pz["xlim"][1] >= -pz["xlim"][0] > 0

    sv_axes = saved["singular_values.png"]
    assert len(sv_axes) == 3
    # the shared frequency axis is labelled once, under the bottom panel
    assert [ax["xlabel"] for ax in sv_axes] == [
        "", "", "omega (rad/s)   [dotted: unstable poles, dash-dot: RHP zeros]"]
    for ax, channel in zip(sv_axes, ("position", "tilt", "heading")):
        w, db = line(ax, "sigma_1")
        assert w[0] == pytest.approx(1e-2, rel=1e-12) and w[-1] == pytest.approx(1e2, rel=1e-12)
        assert np.all(np.diff(np.log10(w)) > 0) and np.allclose(np.diff(np.log10(w)), np.diff(np.log10(w))[0])
        sv = an.singular_values(lin, w[[0, len(w) // 2, -1]], channel)
        np.testing.assert_allclose(db[[0, len(w) // 2, -1]], 20 * np.log10(sv[:, 0]), rtol=1e-12, atol=1e-12)
    assert_style(saved, "pole_zero.png")
    assert_style(saved, "singular_values.png")


def test_monte_carlo_scatter_draws_each_run_at_its_drawn_value_and_metric(saved, tmp_path):
    path = shipped_scenarios()["zero"]
    source = load_scenario_file(path)
    specs = specs_or_default(source.specs)
    runs = draw_runs(source, 5, 3)
    tilts = [0.3, 1.5, 0.2, 40.0, 0.9]
    results = [{"ok": t < 1.0, "spec_ok": [t < 1.0] * len(specs), "metrics": {"peak_tilt_deg": t},
                "error": None, "failure": None} for t in tilts]
    summary = {"specs": [{"metric": "peak_tilt_deg", "op": "<", "threshold": 1.0}], "n": 5, "success_rate": 0.6}
    mr._plots(summary, runs, results, tmp_path)
    params = list(runs[0]["values"])
    sc = saved["scatter.png"]
    assert [a["xlabel"] for a in sc[:len(params)]] == params
    ok = np.array([t < 1.0 for t in tilts])
    for ax, p in zip(sc, params):
        assert ax["ylabel"] == "peak_tilt_deg"
        got = dict(ax["scatter"])
        xs = np.array([r["values"][p] for r in runs])
        np.testing.assert_array_equal(got["pass"], np.column_stack([xs[ok], np.array(tilts)[ok]]))
        np.testing.assert_array_equal(got["fail"], np.column_stack([xs[~ok], np.array(tilts)[~ok]]))
    hist = saved["histograms.png"]
    tilt_ax = next(a for a in hist if any(lab.startswith("spec") for lab, *_ in a["lines"]))
    x, _ = line(tilt_ax, "spec < 1.0")
    assert np.all(x == 1.0)  # the spec threshold, in the metric's units
    x, _ = next((x, y) for lab, x, y in tilt_ax["lines"] if lab.startswith("§7.1 limit"))
    assert np.allclose(x, 5.0, rtol=1e-12, atol=0)  # 5 deg (thesis §7.1 tilt limit), in degrees
    assert_style(saved, "scatter.png")
    assert_style(saved, "histograms.png")


@pytest.mark.parametrize("runs", [[], [{"values": {}}] * 2], ids=["no runs", "nothing dispersed"])
def test_monte_carlo_scatter_without_dispersed_parameters_is_one_empty_row(saved, tmp_path, runs):
    """Only the noise seeds vary (or nothing ran): the scatter figure is one row of three
    switched-off axes, not an error."""
    results = [{"ok": True, "spec_ok": [True], "metrics": {"peak_tilt_deg": 0.5}, "error": None,
                "failure": None} for _ in runs]
    summary = {"specs": [{"metric": "peak_tilt_deg", "op": "<", "threshold": 1.0}], "n": len(runs),
               "success_rate": 1.0}
    assert mr._plots(summary, runs, results, tmp_path) == ["histograms.png", "scatter.png"]
    assert saved["scatter.png:style"]["figsize"] == [11.0, 3.0]
    assert len(saved["scatter.png"]) == 3
    assert all(ax["scatter"] == [] and ax["xlabel"] == "" for ax in saved["scatter.png"])
    assert (tmp_path / "scatter.png").is_file()


@pytest.mark.parametrize("n_finite, n_bins", [(4, 5), (12, 6), (59, 29), (60, 30), (100, 30)])
def test_monte_carlo_histogram_bins_half_the_finite_runs_between_5_and_30(saved, tmp_path, n_finite, n_bins):
    """The histogram of a metric has n // 2 bins of its finite values, at least 5 and at most
    30; non-finite values (a failed run's NaN, a fall's inf) are left out of the counts."""
    vals = np.linspace(0.1, 0.9, n_finite)
    results = [{"ok": True, "spec_ok": [True], "metrics": {"peak_tilt_deg": float(v)}, "error": None,
                "failure": None} for v in [*vals, np.nan, np.inf]]
    summary = {"specs": [{"metric": "peak_tilt_deg", "op": "<", "threshold": 1.0}], "n": n_finite + 2,
               "success_rate": 1.0}
    mr._plots(summary, [], results, tmp_path)
    ax = next(a for a in saved["histograms.png"] if a["title"] == "peak_tilt_deg")
    heights = [hi - lo for _, lo, hi in ax["spans"]]
    assert len(heights) == n_bins
    np.testing.assert_array_equal(heights, np.histogram(vals, n_bins)[0])
