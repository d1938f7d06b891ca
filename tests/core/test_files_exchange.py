"""``_exchange`` (renameat2 RENAME_EXCHANGE) swaps two folders, says False only when the
kernel or file system cannot exchange, and raises any other error (issue 23: a mutant
that inverted the "unsupported" errno test went unnoticed: a missing folder looked like
an unsupported file system, and the staged folder fell back silently)."""

from __future__ import annotations

import errno

import pytest

from ballbot_casadi.core import files as F


def test_exchange_swaps_two_folders(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    (a / "x").write_text("in a")
    (b / "y").write_text("in b")
    if not F._exchange(a, b):
        pytest.skip("renameat2(RENAME_EXCHANGE) unsupported here")
    assert (a / "y").read_text() == "in b" and (b / "x").read_text() == "in a"


def test_exchange_raises_a_real_error_instead_of_reporting_unsupported(tmp_path):
    a = tmp_path / "a"
    a.mkdir()
    if not F._exchange(a, a):  # probe support: exchanging a folder with itself is allowed
        pytest.skip("renameat2(RENAME_EXCHANGE) unsupported here")
    with pytest.raises(OSError) as e:
        F._exchange(a, tmp_path / "missing")
    assert e.value.errno == errno.ENOENT and "missing" in str(e.value)
