"""How the studies' reports and summaries print a value: floats (numpy's too) to four
significant digits, anything else (bools, None, strings, ints) as ``str``."""

from __future__ import annotations

from typing import Any

__all__ = ["fmt"]


def fmt(v: Any) -> str:
    """``v`` for a report table or summary line."""
    return f"{v:.4g}" if isinstance(v, float) else str(v)
