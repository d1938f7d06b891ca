"""How the studies' reports and summaries print a value: floats (numpy's too) to four
significant digits, anything else (bools, None, strings, ints) as ``str``; and text put in
one cell of a Markdown table."""

from __future__ import annotations

from typing import Any

__all__ = ["fmt", "md_cell"]


def fmt(v: Any) -> str:
    """``v`` for a report table or summary line."""
    return f"{v:.4g}" if isinstance(v, float) else str(v)


def md_cell(text: Any) -> str:
    """``text`` as one Markdown table cell: its pipes escaped (``|x|`` would split the cell),
    line breaks as spaces."""
    return str(text).replace("\\|", "|").replace("|", "\\|").replace("\n", " ")
