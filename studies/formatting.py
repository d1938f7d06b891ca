"""How the studies' reports and summaries print a value: floats (numpy's too) to four
significant digits, anything else (bools, None, strings, ints) as ``str``; text put in
one cell of a Markdown table; and the ``metrics.json`` every study writes."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

__all__ = ["fmt", "md_cell", "write_metrics"]


def fmt(v: Any) -> str:
    """``v`` for a report table or summary line."""
    return f"{v:.4g}" if isinstance(v, float) else str(v)


def md_cell(text: Any) -> str:
    """``text`` as one Markdown table cell: its pipes escaped (``|x|`` would split the cell),
    line breaks as spaces."""
    return str(text).replace("\\|", "|").replace("|", "\\|").replace("\n", " ")


def write_metrics(folder: Path, metrics: Any) -> Path:
    """Write ``metrics`` (JSON-able) to ``folder / "metrics.json"``, indented by 2 with a final
    newline, as every study does; returns the file."""
    path = Path(folder) / "metrics.json"
    path.write_text(json.dumps(metrics, indent=2) + "\n")
    return path
