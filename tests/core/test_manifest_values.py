"""The cache manifest read back by hand: its JSON against ``os.stat`` and ``hashlib``
(computed here, not by the module), the ``extra`` record, each refusal's exact reason, and
a file larger than one read block hashed whole."""

from __future__ import annotations

import hashlib
import json
import os

from ballbot_casadi.core import files as F


def test_manifest_records_size_and_sha256_of_each_named_file(tmp_path):
    blobs = {"a.so": os.urandom(3 * 65536 + 17), "b.h": b"header\n", "c.txt": b"not recorded"}
    for name, data in blobs.items():
        (tmp_path / name).write_bytes(data)
    path = F.write_manifest(tmp_path, ["b.h", "a.so"], "M.json", extra={"key": "flags -O2"})
    assert path == tmp_path / "M.json"
    doc = json.loads(path.read_text())
    assert doc == {"format": 1, "extra": {"key": "flags -O2"}, "files": {
        n: {"size": len(blobs[n]), "sha256": hashlib.sha256(blobs[n]).hexdigest()}
        for n in ("a.so", "b.h")}}
    assert F.sha256_file(tmp_path / "a.so") == hashlib.sha256(blobs["a.so"]).hexdigest()
    # the text does not depend on the order the files are named in: keys sorted, indent 1
    again = F.write_manifest(tmp_path, ["a.so", "b.h"], "M2.json", extra={"key": "flags -O2"})
    assert again.read_bytes() == path.read_bytes()
    assert path.read_text().startswith('{\n "extra": {\n  "key": "flags -O2"\n },\n "files": {\n  "a.so": {')
    # without extra: no "extra" key at all
    doc2 = json.loads(F.write_manifest(tmp_path, ["b.h"], "N.json").read_text())
    assert set(doc2) == {"format", "files"}
    assert F.check_manifest(tmp_path, None, "M.json") is None
    assert F.check_manifest(tmp_path, ["a.so"], "M.json") is None
    # the unrecorded file may change freely
    (tmp_path / "c.txt").write_bytes(b"changed")
    assert F.check_manifest(tmp_path, ["a.so", "b.h"], "M.json") is None


def test_each_refusal_names_the_file_and_the_numbers(tmp_path):
    (tmp_path / "x.a").write_bytes(b"0123456789")
    F.write_manifest(tmp_path, ["x.a"])
    m = tmp_path / "MANIFEST.json"
    assert F.check_manifest(tmp_path, ["x.a", "y.a"]) == f"y.a is not recorded in {m}"
    (tmp_path / "x.a").write_bytes(b"0123")
    assert F.check_manifest(tmp_path) == f"{tmp_path / 'x.a'} has 4 bytes, 10 were built"
    (tmp_path / "x.a").write_bytes(b"0123456780")
    assert F.check_manifest(tmp_path) == (f"{tmp_path / 'x.a'} content differs from the build "
                                          "(SHA-256 mismatch)")
    (tmp_path / "x.a").unlink()
    assert F.check_manifest(tmp_path) == f"{tmp_path / 'x.a'} is missing"
    m.write_text('{"files": [1, 2]}')
    assert F.check_manifest(tmp_path) == f"unreadable manifest {m}"
    m.write_text('{"format": 1}')
    assert F.check_manifest(tmp_path) == f"unreadable manifest {m}"
    m.unlink()
    assert F.check_manifest(tmp_path) == f"no manifest {m}"
