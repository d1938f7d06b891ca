"""Reading back what the ``saved`` fixture (conftest.py) recorded of a figure."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from _snapshots import assert_pinned

#: Pinned looks of the study figures; ``BALLBOT_PIN_FIGURES=1`` rewrites them (review the diff).
GOLDEN = Path(__file__).parent / "figure_styles"


def line(axes: dict, label: str) -> tuple[np.ndarray, np.ndarray]:
    """The one line labelled ``label`` on these axes: (x, y)."""
    hits = [(x, y) for lab, x, y in axes["lines"] if lab == label]
    assert len(hits) == 1, [lab for lab, *_ in axes["lines"]]
    return hits[0]


def hlines(axes: dict) -> list[float]:
    """The y of each horizontal line across the axes (``axhline``), in drawing order."""
    return [float(y[0]) for _, x, y in axes["lines"]
            if x.size == 2 and y.size == 2 and y[0] == y[1] and list(x) == [0.0, 1.0]]


def vlines(axes: dict) -> list[float]:
    """The x of each vertical line across the axes (``axvline``), in drawing order."""
    return [float(x[0]) for _, x, y in axes["lines"]
            if x.size == 2 and y.size == 2 and x[0] == x[1] and list(y) == [0.0, 1.0]]


def assert_style(saved: dict, name: str) -> None:
    """The look of figure ``name`` (sizes, widths, markers, colours of patches, font sizes)
    equals its pinned copy ``figure_styles/<name>.json``: a changed line width or font size
    is a change a reader sees, made on purpose by re-pinning."""
    assert_pinned(GOLDEN / f"{name}.json", json.dumps(saved[name + ":style"], indent=1) + "\n",
                  "BALLBOT_PIN_FIGURES")
