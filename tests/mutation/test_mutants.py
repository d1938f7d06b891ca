"""The mutation harness mutates code only, one site at a time, reproducibly, and counts right."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
import mutants as M  # noqa: E402


def test_python_sites_skip_strings_comments_and_docstrings():
    text = '"""a < b and 3"""\nx = "c > d"  # e == 2\ny = a <= 7 and not b\n'
    sites = M.py_sites(text)
    assert [(s[0], s[2]) for s in sites] == [(3, "<="), (3, "7"), (3, "and")]
    assert sites[0][3] == ["<", ">="]


def test_python_star_in_a_signature_is_not_arithmetic_and_unary_minus_is_dropped():
    sites = M.py_sites("def f(*, a, **k):\n    return -a * 2\n")
    assert [(s[2], s[3]) for s in sites] == [("-", [""]), ("*", ["/"]), ("2", ["3", "1"])]


def test_c_sites_skip_comments_strings_includes_pointers_arrows_and_unary():
    text = ('#include <stdio.h>\n'
            '/* a < b */ int f(const double *p, S *s) { // x > 1\n'
            '  if (s->n >= 3 && p[0] < -1.5) return "a<b"[0] - 2;\n'
            '  return x1 / 4;\n}\n')
    got = [(s[0], s[2]) for s in M.c_sites(text)]
    assert got == [(3, ">="), (3, "3"), (3, "&&"), (3, "0"), (3, "<"), (3, "1.5"), (3, "0"),
                   (3, "-"), (3, "2"), (4, "/"), (4, "4")]


@pytest.mark.parametrize("lit, outs", [("0", ["1"]), ("1", ["0", "2"]), ("7", ["8", "6"]),
                                       ("1e-9", ["2e-09", "5e-10"]), ("0.0", ["1.0"]),
                                       ("1.0f", ["2.0f", "0.5f"]), ("3U", ["4U", "2U"]),
                                       ("0x10", []), ("1_000", [])])
def test_number_mutations(lit, outs):
    assert M._number_mutations(lit) == outs


def test_apply_replaces_exactly_the_site_and_refuses_a_moved_one():
    mut = {"id": 0, "path": "f.py", "line": 2, "col": 6, "old": "<", "new": "<="}
    assert M.apply_text("a = 1\nb = x < y < z\n", mut) == "a = 1\nb = x <= y < z\n"
    with pytest.raises(SystemExit, match="not at f.py:2:6"):
        M.apply_text("a = 1\nb = xx < y\n", mut)


def _repo(tmp_path: Path) -> Path:
    subprocess.run(["git", "init", "-q", str(tmp_path)], check=True)
    (tmp_path / "pkg").mkdir()
    (tmp_path / "pkg" / "a.py").write_text("def f(x):\n    return x + 1 if x > 0 else 2\nZ = 7\n")
    (tmp_path / "pkg" / "b.c").write_text("int g(int x) { return x > 3 ? x - 1 : 0; }\n")
    git = ["git", "-C", str(tmp_path), "-c", "user.name=t", "-c", "user.email=t@t"]
    subprocess.run(git + ["add", "."], check=True)
    subprocess.run(git + ["commit", "-qm", "a"], check=True)
    base = subprocess.run(git + ["rev-parse", "HEAD"], capture_output=True, text=True).stdout.strip()
    a = tmp_path / "pkg" / "a.py"
    a.write_text(a.read_text().replace("Z = 7", "Y = 5 * 3\nZ = 7"))
    (tmp_path / "pkg" / "c.py").write_text("W = 9\n")
    subprocess.run(git + ["add", "."], check=True)
    subprocess.run(git + ["commit", "-qm", "b"], check=True)
    return tmp_path, base


def test_generate_is_seeded_distinct_and_since_keeps_added_lines(tmp_path):
    root, base = _repo(tmp_path)
    a = M.generate(root, ["pkg"], seed=3, n=8, since=None)
    assert a == M.generate(root, ["pkg"], seed=3, n=8, since=None)
    assert a != M.generate(root, ["pkg"], seed=4, n=8, since=None)
    assert len({(m["path"], m["line"], m["col"]) for m in a}) == 8
    new = M.generate(root, ["pkg"], seed=3, n=6, since=base)  # only four sites are new
    assert sorted((m["path"], m["line"], m["old"]) for m in new) == [
        ("pkg/a.py", 3, "*"), ("pkg/a.py", 3, "3"), ("pkg/a.py", 3, "5"), ("pkg/c.py", 1, "9")]


def test_summary_counts_timeouts_as_caught_and_lists_survivors():
    recs = [{"id": 0, "status": "caught"}, {"id": 1, "status": "survived"},
            {"id": 2, "status": "timeout"}, {"id": 3, "status": "caught"}]
    assert M.summary(recs) == {"run": 4, "caught": 3, "survived": [1], "timeouts": 1, "rate": 0.75}


def test_area_folders():
    assert M.area_folder("ballbot_casadi/sim/guided.py") == "tests/sim"
    assert M.area_folder("fmu/layer/fmi2_common.c") == "tests/fmi"
    assert M.area_folder("studies/path.py") == "tests/studies"
    assert M.area_folder("ballbot_casadi/errors.py") == "tests"


def test_area_stage_adds_the_package_wide_checks(tmp_path):
    (tmp_path / "tests" / "sim").mkdir(parents=True)
    for name in ("test_b.py", "test_a.py", "conftest.py", "helper.py"):
        (tmp_path / "tests" / name).write_text("")
    (tmp_path / "tests" / "sim" / "test_c.py").write_text("")
    assert M.area_targets(tmp_path, "ballbot_casadi/sim/guided.py") == [
        "tests/sim", "tests/test_a.py", "tests/test_b.py"]
    assert M.area_targets(tmp_path, "ballbot_casadi/errors.py") == ["tests"]  # already all of them


def test_run_restores_the_file_and_records_the_verdict(tmp_path, monkeypatch):
    root, _ = _repo(tmp_path)
    (root / "tests").mkdir()
    (root / "tests" / "test_a.py").write_text("from pkg.a import f\n\ndef test_f():\n    assert f(1) == 2\n")
    muts = [{"id": 0, "path": "pkg/a.py", "line": 2, "col": 13, "old": "+", "new": "-"},
            {"id": 1, "path": "pkg/a.py", "line": 3, "col": 4, "old": "5", "new": "6"}]
    before = (root / "pkg" / "a.py").read_text()
    monkeypatch.setenv("PYTHONPATH", str(root))
    out = root / "r.jsonl"
    M.run(root, muts, out, timeout=120, ids=None)
    recs = [json.loads(l) for l in out.read_text().splitlines()]
    assert (root / "pkg" / "a.py").read_text() == before
    assert [r["status"] for r in recs] == ["caught", "survived"]
    assert recs[0]["near"] == ["tests/test_a.py"]
    assert recs[0]["near_said"].startswith("E ") and "1 failed" in recs[0]["near_said"]
    assert recs[1]["area_said"].endswith("1 passed") or "1 passed" in recs[1]["area_said"]


@pytest.mark.parametrize("files, refusal", [
    # tests that do not even load
    ({"test_a.py": "import not_installed_anywhere\n\ndef test_f():\n    pass\n"},
     "the tests do not collect before any mutant"),
    # a top-level test failing before any mutant: the second stage adds the top-level tests
    # to every area, so it would count every survivor of the first stage as caught
    ({"test_a.py": "from pkg.a import f\n\ndef test_f():\n    assert f(1) == 2\n",
      "test_register.py": "def test_stale():\n    assert 1 == 2\n"},
     "the package-wide tests fail before any mutant"),
])
def test_run_refuses_a_checkout_whose_tests_fail_unmutated(tmp_path, monkeypatch, files, refusal):
    root, _ = _repo(tmp_path)
    (root / "tests").mkdir()
    for name, text in files.items():
        (root / "tests" / name).write_text(text)
    monkeypatch.setenv("PYTHONPATH", str(root))
    muts = [{"id": 0, "path": "pkg/a.py", "line": 3, "col": 4, "old": "7", "new": "8"}]
    with pytest.raises(SystemExit, match=refusal):
        M.run(root, muts, root / "r.jsonl", timeout=120, ids=None)
    assert not (root / "r.jsonl").exists()


def test_a_survivor_of_both_stages_meets_every_other_test_file_naming_its_module(tmp_path, monkeypatch):
    """The first stage runs 15 of the files naming the module (its own area's first), the
    second the area's folder; a file naming it beyond those 15, in another area, runs third."""
    root = tmp_path
    (root / "ballbot_casadi" / "sub").mkdir(parents=True)
    (root / "ballbot_casadi" / "sub" / "mod.py").write_text("def f(x):\n    return x + 1\n")
    for init in ("ballbot_casadi", "ballbot_casadi/sub"):  # this package, not the installed one
        (root / init / "__init__.py").write_text("")
    for d in ("aa", "sub", "zz"):
        (root / "tests" / d).mkdir(parents=True)
    for i in range(15):  # name the module, test nothing
        (root / "tests" / "aa" / f"test_{i:02d}.py").write_text("# mod\ndef test_n():\n    pass\n")
    (root / "tests" / "sub" / "test_s.py").write_text("def test_s():\n    pass\n")
    (root / "tests" / "zz" / "test_real.py").write_text(
        "from ballbot_casadi.sub.mod import f\n\ndef test_f():\n    assert f(1) == 2\n")
    monkeypatch.setenv("PYTHONPATH", str(root))
    out = root / "r.jsonl"
    M.run(root, [{"id": 0, "path": "ballbot_casadi/sub/mod.py", "line": 2, "col": 13,
                  "old": "+", "new": "-"}], out, timeout=120, ids=None)
    (rec,) = [json.loads(l) for l in out.read_text().splitlines()]
    assert len(rec["near"]) == 15 and rec["near_status"] == "survived"
    assert rec["area"].split()[0] == "tests/sub" and rec["area_status"] == "survived"
    assert rec["wide"] == "tests/zz/test_real.py" and rec["status"] == "caught"
    assert "1 failed" in rec["wide_said"] and "assert" in rec["wide_said"]  # not an import error
