"""The studies' Python entry points draw their figures unless asked not to, as ``ballbot
study`` does without ``--no-plot``: every ``run_*`` function of ``studies/`` that takes
``plot`` (or ``plots``) defaults to drawing.  The one exception, ``run_thesis``, draws
nothing of its own: its ``plot`` is passed to the studies it has to run again, which it
runs without figures unless asked (the table reads their metrics only)."""

from __future__ import annotations

import importlib
import inspect
from pathlib import Path

STUDIES = Path(__file__).resolve().parents[2] / "studies"
NOT_DRAWING_BY_DEFAULT = {"studies.study.run_thesis"}


def _runners():
    for path in sorted(STUDIES.glob("*.py")):
        if path.stem == "__init__":
            continue
        mod = importlib.import_module(f"studies.{path.stem}")
        for name, fn in inspect.getmembers(mod, inspect.isfunction):
            if name.startswith("run_") and fn.__module__ == mod.__name__:
                yield f"{mod.__name__}.{name}", inspect.signature(fn)


def test_every_study_runner_draws_by_default():
    defaults = {name: sig.parameters[p].default for name, sig in _runners()
                for p in ("plot", "plots") if p in sig.parameters}
    assert len(defaults) >= 9  # the studies and the analysis that draw
    drawing = {n for n, d in defaults.items() if d is True}
    assert {n for n, d in defaults.items() if d is False} == NOT_DRAWING_BY_DEFAULT
    assert drawing | NOT_DRAWING_BY_DEFAULT == set(defaults)
    assert {"studies.heading.run_heading_study", "studies.study.run_all", "studies.analyze.run_analysis",
            "studies.sta_noise.run_sta_noise_study"} <= drawing
