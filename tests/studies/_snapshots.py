"""Pinned copies of report text (``report_snapshots/<name>.md``): a report written from
hand-built inputs is compared whole with its copy.  Re-pin after a deliberate change with
``BALLBOT_PIN_REPORTS=1`` and review the difference."""

from __future__ import annotations

import os
from pathlib import Path

SNAPSHOTS = Path(__file__).parent / "report_snapshots"


def assert_snapshot(name: str, text: str) -> None:
    """``text`` equals the pinned copy ``report_snapshots/<name>.md``."""
    pinned = SNAPSHOTS / f"{name}.md"
    if os.environ.get("BALLBOT_PIN_REPORTS") == "1":
        SNAPSHOTS.mkdir(exist_ok=True)
        pinned.write_text(text, encoding="utf-8")
    assert pinned.is_file(), f"no pinned copy {pinned}: run with BALLBOT_PIN_REPORTS=1 and review"
    assert text == pinned.read_text(encoding="utf-8"), f"{name} differs from {pinned}"


def snapshot_text(name: str) -> str:
    return (SNAPSHOTS / f"{name}.md").read_text(encoding="utf-8")
