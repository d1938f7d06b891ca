"""The host build of the firmware period goes to ``<root>/firmware/host`` (made with its
parents in a fresh root), named by controller, estimator, precision and the hash of what
generated it.  The compile itself is replaced by a recorder here."""

from __future__ import annotations

import re

from ballbot_casadi.firmware import closed_loop as fcl


def test_a_fresh_root_gets_the_host_folder_and_a_hashed_name(tmp_path, monkeypatch):
    seen = []
    monkeypatch.setattr(fcl, "cached_file", lambda path, make, digest: seen.append((path, digest)) or path)
    root = tmp_path / "fresh" / "build"  # nothing of it exists yet
    path = fcl.host_period_library("flc", precision="single", root=root)
    ((got, digest),) = seen
    assert got == path and path.parent == root / "firmware" / "host" and path.parent.is_dir()
    assert re.fullmatch(rf"flc_{fcl.DEFAULT_ESTIMATOR}_single-{digest}\.so", path.name)
    assert re.fullmatch(r"[0-9a-f]{16}", digest)
