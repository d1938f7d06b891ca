"""Pinned copies: a text compared whole with a reviewed copy in the tests' tree, rewritten
only on purpose (an environment variable) and then reviewed as a diff.  Reports written from
hand-built inputs live in ``report_snapshots/<name>.md`` (``BALLBOT_PIN_REPORTS=1``); the
figures' looks use the same mechanism (``_figures.assert_style``)."""

from __future__ import annotations

import os
from pathlib import Path

SNAPSHOTS = Path(__file__).parent / "report_snapshots"


def assert_pinned(path: Path, text: str, env: str) -> None:
    """``text`` equals the pinned copy ``path``; with ``env=1`` set, it becomes the copy."""
    if os.environ.get(env) == "1":
        path.parent.mkdir(exist_ok=True)
        path.write_text(text, encoding="utf-8")
    assert path.is_file(), f"no pinned copy {path}: run with {env}=1 and review"
    assert text == path.read_text(encoding="utf-8"), f"differs from the pinned copy {path}"


def assert_snapshot(name: str, text: str) -> None:
    """``text`` equals the pinned report ``report_snapshots/<name>.md``."""
    assert_pinned(SNAPSHOTS / f"{name}.md", text, "BALLBOT_PIN_REPORTS")


def snapshot_text(name: str) -> str:
    return (SNAPSHOTS / f"{name}.md").read_text(encoding="utf-8")
