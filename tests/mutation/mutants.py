"""Blind mutation measurement of the test suite's strength (issue 23).

A *mutant* is one realistic single-point bug: a comparison, arithmetic or boolean operator
replaced by a neighbour, a number nudged, a constant flipped. This script draws a seeded,
blind set of them over given source paths, applies them one at a time to a checkout, runs
the tests nearest to each (the first 15 test files naming the module), then for the
survivors the area's test folder with the package-wide checks of ``tests/test_*.py``, then
every other test file naming the module (in another area), and always restores the file.

Run it on a *separate clone* (it edits files in place)::

    python tests/mutation/mutants.py gen ROOT --seed 7 -n 40 --out muts.json ballbot_casadi studies fmu
    python tests/mutation/mutants.py run ROOT muts.json --out muts.jsonl   # appends, resumable
    python tests/mutation/mutants.py show ROOT muts.json 12                 # one mutant's diff
    python tests/mutation/mutants.py summary muts.jsonl

Python sources are read as tokens, so strings, comments and docstrings are never mutated;
a mutant that does not compile is redrawn. C sources are read line by line with comments,
string literals and preprocessor includes blanked, and only operators whose binary use is
certain (comparisons, ``&&``/``||``, binary ``+``/``-``/``/``) and plain decimal numbers are
mutated. ``--since COMMIT`` keeps only lines added since that commit.

Only this harness's own code lives here: it is a test tool, not part of the package.
"""
from __future__ import annotations

import argparse
import io
import json
import os
import random
import re
import subprocess
import sys
import time
import tokenize
from pathlib import Path

PY_OPS = {
    "<": ["<=", ">"], "<=": ["<", ">="], ">": [">=", "<"], ">=": [">", "<="],
    "==": ["!="], "!=": ["=="], "+": ["-"], "-": ["+"], "*": ["/"], "/": ["*", "//"],
    "//": ["/"], "%": ["*"], "+=": ["-="], "-=": ["+="], "*=": ["/="],
}
PY_NAMES = {"True": ["False"], "False": ["True"], "and": ["or"], "or": ["and"],
            "is": ["is not"], "in": ["not in"]}
C_OPS = {
    "<": ["<=", ">"], "<=": ["<", ">="], ">": [">=", "<"], ">=": [">", "<="],
    "==": ["!="], "!=": ["=="], "&&": ["||"], "||": ["&&"], "+": ["-"], "-": ["+"],
    "/": ["*"],
}
C_TOKEN = re.compile(
    r"->|\+\+|--|<<=?|>>=?|&&|\|\||[<>=!]=|[-+*/%&|^]=|[<>+\-/]|"
    r"(?<![\w.])(\d+\.\d*(?:[eE][-+]?\d+)?|\.\d+(?:[eE][-+]?\d+)?|\d+[eE][-+]?\d+|\d+)[fFuUlL]*(?![\w.])"
)
SUFFIXES = (".py", ".c", ".h")


def _number_mutations(text: str) -> list[str]:
    """Nudged values of one numeric literal (the literal's own spelling kept in style)."""
    core = text.rstrip("fFuUlLjJ")
    suffix = text[len(core):]
    if "j" in suffix.lower() or core.lower().startswith(("0x", "0o", "0b")) or "_" in core:
        return []
    if re.fullmatch(r"\d+", core):
        v = int(core)
        outs = {0: ["1"], 1: ["0", "2"]}.get(v, [str(v + 1), str(v - 1)])
    else:
        v = float(core)
        outs = ["1.0"] if v == 0.0 else [repr(v * 2.0), repr(v / 2.0)]
        if "f" in suffix.lower() and "." not in outs[0] and "e" not in outs[0]:
            outs = [o + ".0" for o in outs]
    return [o + suffix for o in outs]


def _added_lines(root: Path, rel: str, since: str | None) -> set[int] | None:
    if since is None:
        return None
    out = subprocess.run(["git", "-C", str(root), "diff", "-U0", since, "--", rel],
                         capture_output=True, text=True, check=True).stdout
    lines: set[int] = set()
    for m in re.finditer(r"^@@ -\S+ \+(\d+)(?:,(\d+))? @@", out, re.M):
        start, count = int(m.group(1)), int(m.group(2) or 1)
        lines.update(range(start, start + count))
    tracked = subprocess.run(["git", "-C", str(root), "cat-file", "-e", f"{since}:{rel}"],
                             capture_output=True).returncode == 0
    if not tracked:
        return set(range(1, (root / rel).read_text().count("\n") + 2))
    return lines


def py_sites(text: str) -> list[tuple[int, int, str, list[str]]]:
    """(line, column, token, replacements) of every mutable Python token."""
    sites = []
    prev = None
    for tok in tokenize.generate_tokens(io.StringIO(text).readline):
        s = tok.string
        line, col = tok.start
        if tok.type == tokenize.OP and s in PY_OPS:
            # a star in a signature or an unpacking is not arithmetic
            if s in ("*", "-", "+") and (prev is None or prev.string in ("(", ",", "[", "=", ":", "{", "lambda", "return")):
                if s == "-":
                    sites.append((line, col, s, [""]))
            else:
                sites.append((line, col, s, PY_OPS[s]))
        elif tok.type == tokenize.NAME and s in PY_NAMES:
            if s == "in" and prev is not None and prev.string == "not":
                pass
            elif s == "is" and prev is not None and prev.string == "not":
                pass
            else:
                sites.append((line, col, s, PY_NAMES[s]))
        elif tok.type == tokenize.NUMBER:
            reps = _number_mutations(s)
            if reps:
                sites.append((line, col, s, reps))
        if tok.type not in (tokenize.NL, tokenize.NEWLINE, tokenize.COMMENT, tokenize.INDENT, tokenize.DEDENT):
            prev = tok
    return sites


def _blank_c(text: str) -> list[str]:
    """The C source's lines with comments, string/char literals and #include lines blanked."""
    out = []
    in_block = False
    for raw in text.split("\n"):
        chars = list(raw)
        i = 0
        while i < len(chars):
            if in_block:
                if raw.startswith("*/", i):
                    chars[i] = chars[i + 1] = " "
                    in_block = False
                    i += 2
                    continue
                chars[i] = " "
                i += 1
                continue
            if raw.startswith("/*", i):
                in_block = True
                chars[i] = chars[i + 1] = " "
                i += 2
                continue
            if raw.startswith("//", i):
                for j in range(i, len(chars)):
                    chars[j] = " "
                break
            if chars[i] in "\"'":
                q = chars[i]
                j = i + 1
                while j < len(chars) and chars[j] != q:
                    j += 2 if chars[j] == "\\" else 1
                for k in range(i, min(j + 1, len(chars))):
                    chars[k] = " "
                i = j + 1
                continue
            i += 1
        line = "".join(chars)
        if re.match(r"\s*#\s*(include|pragma|error)", line):
            line = " " * len(line)
        out.append(line)
    return out


def c_sites(text: str) -> list[tuple[int, int, str, list[str]]]:
    sites = []
    for n, line in enumerate(_blank_c(text), start=1):
        for m in C_TOKEN.finditer(line):
            s = m.group(0)
            col = m.start()
            if m.group(1) is not None:
                reps = _number_mutations(s)
                if reps:
                    sites.append((n, col, s, reps))
                continue
            if s not in C_OPS:
                continue
            before = line[:col].rstrip()
            binary = bool(before) and (before[-1].isalnum() or before[-1] in "_)]")
            if s in ("+", "-", "/") and not binary:
                continue
            if s in ("<", ">") and re.search(r"#\s*include", line):
                continue
            sites.append((n, col, s, C_OPS[s]))
    return sites


def apply_text(text: str, mut: dict) -> str:
    lines = text.split("\n")
    line = lines[mut["line"] - 1]
    col, old = mut["col"], mut["old"]
    if line[col:col + len(old)] != old:
        raise SystemExit(f"mutant {mut['id']}: {old!r} not at {mut['path']}:{mut['line']}:{col}")
    lines[mut["line"] - 1] = line[:col] + mut["new"] + line[col + len(old):]
    return "\n".join(lines)


def generate(root: Path, paths: list[str], seed: int, n: int, since: str | None) -> list[dict]:
    files = []
    for p in paths:
        q = root / p
        cand = [q] if q.is_file() else sorted(q.rglob("*"))
        files += [f for f in cand if f.suffix in SUFFIXES and "__pycache__" not in f.parts]
    sites = []
    for f in files:
        rel = str(f.relative_to(root))
        tracked = subprocess.run(["git", "-C", str(root), "ls-files", "--error-unmatch", rel],
                                 capture_output=True).returncode == 0
        if not tracked:
            continue
        text = f.read_text()
        keep = _added_lines(root, rel, since)
        found = py_sites(text) if f.suffix == ".py" else c_sites(text)
        sites += [(rel, *s) for s in found if keep is None or s[0] in keep]
    rng = random.Random(seed)
    muts: list[dict] = []
    chosen: set[tuple] = set()
    tries = 0
    while len(muts) < n and tries < 50 * n:
        tries += 1
        rel, line, col, old, reps = rng.choice(sites)
        if (rel, line, col) in chosen:
            continue
        mut = {"id": len(muts), "path": rel, "line": line, "col": col, "old": old,
               "new": rng.choice(reps)}
        text = (root / rel).read_text()
        new_text = apply_text(text, mut)
        if rel.endswith(".py"):
            try:
                compile(new_text, rel, "exec")
            except SyntaxError:
                continue
        chosen.add((rel, line, col))
        mut["context"] = text.split("\n")[line - 1].strip()
        muts.append(mut)
    print(f"{len(sites)} sites in {len(files)} files; {len(muts)} mutants drawn (seed {seed})",
          file=sys.stderr)
    return muts


def nearest_tests(root: Path, rel: str, limit: int | None = 15) -> list[str]:
    """Test files naming the module (or the C file), those of the module's own area first;
    the first ``limit`` of them (all with ``None``)."""
    stem = Path(rel).stem
    if stem == "__init__":
        stem = Path(rel).parent.name
    area = area_folder(rel)
    hits = []
    pattern = re.compile(rf"\b{re.escape(stem)}\b")
    for t in sorted((root / "tests").rglob("test_*.py")):
        if pattern.search(t.read_text(errors="ignore")) or stem in t.name:
            hits.append(str(t.relative_to(root)))
    hits.sort(key=lambda h: (not h.startswith(area), h))
    return hits[:limit]


def area_folder(rel: str) -> str:
    parts = Path(rel).parts
    if parts[0] == "ballbot_casadi" and len(parts) > 2:
        return f"tests/{parts[1]}"
    if parts[0] == "fmu":
        return "tests/fmi"
    if parts[0] == "studies":
        return "tests/studies"
    return "tests"


def area_targets(root: Path, rel: str) -> list[str]:
    """The second stage's tests: the area's folder and the package-wide checks at the top of
    ``tests/`` (architecture, packaging: conventions every module is held to)."""
    area = area_folder(rel)
    if area == "tests":
        return [area]
    return [area, *sorted(str(t.relative_to(root)) for t in (root / "tests").glob("test_*.py"))]


def _pytest(root: Path, targets: list[str], timeout: float) -> tuple[str, float, str]:
    cmd = [sys.executable, "-m", "pytest", "-x", "-q", "-m", "not slow", "-p", "no:cacheprovider",
           "-p", "no:randomly", *targets]
    t0 = time.monotonic()
    try:
        r = subprocess.run(cmd, cwd=root, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return "timeout", time.monotonic() - t0, ""
    status = {0: "survived", 5: "no-tests"}.get(r.returncode, "caught")
    # pytest's last line (and the first error) show a mutant "caught" by a broken set-up
    lines = r.stdout.strip().splitlines() or [""]
    first_error = next((l for l in lines if l.startswith("E ")), "")
    return status, time.monotonic() - t0, (first_error + " | " + lines[-1])[:300]


def run(root: Path, muts: list[dict], out: Path, timeout: float, ids: set[int] | None) -> None:
    status, _, said = _pytest(root, ["--collect-only", "tests"], timeout)
    if status != "survived":  # an unmutated checkout whose tests do not even load
        raise SystemExit(f"{root}: the tests do not collect before any mutant ({said}); fix the set-up")
    wide_checks = sorted(str(t.relative_to(root)) for t in (root / "tests").glob("test_*.py"))
    if wide_checks:  # every second stage runs them: one failing unmutated would "catch" anything
        status, _, said = _pytest(root, wide_checks, timeout)
        if status != "survived":
            raise SystemExit(f"{root}: the package-wide tests fail before any mutant ({said}); "
                             "fix them first")
    done = set()
    if out.exists():
        done = {json.loads(l)["id"] for l in out.read_text().splitlines() if l.strip()}
    for mut in muts:
        if mut["id"] in done or (ids is not None and mut["id"] not in ids):
            continue
        path = root / mut["path"]
        original = path.read_text()
        rec = dict(mut)
        try:
            path.write_text(apply_text(original, mut))
            near = nearest_tests(root, mut["path"])
            rec["near"] = near
            status, dt, said = _pytest(root, near, timeout) if near else ("no-tests", 0.0, "")
            rec["near_status"], rec["near_s"], rec["near_said"] = status, round(dt, 1), said
            if status in ("survived", "no-tests"):
                area = area_targets(root, mut["path"])
                status, dt, said = _pytest(root, area, timeout)
                rec["area"], rec["area_status"], rec["area_s"] = " ".join(area), status, round(dt, 1)
                rec["area_said"] = said
            if status in ("survived", "no-tests"):
                area_set = set(rec.get("area", "").split())
                wide = [t for t in nearest_tests(root, mut["path"], None)
                        if t not in near and not any(t == a or t.startswith(a + "/")
                                                     for a in area_set)]
                if wide:
                    status, dt, said = _pytest(root, wide, timeout)
                    rec["wide"], rec["wide_status"], rec["wide_s"] = " ".join(wide), status, round(dt, 1)
                    rec["wide_said"] = said
            rec["status"] = status
        finally:
            path.write_text(original)
        with out.open("a") as fh:
            fh.write(json.dumps(rec) + "\n")
        print(f"#{mut['id']} {rec['status']:8s} {mut['path']}:{mut['line']} "
              f"{mut['old']!r} -> {mut['new']!r}", flush=True)


def summary(records: list[dict]) -> dict:
    """Counts by final status; timeouts count as caught (an infinite loop is seen)."""
    caught = sum(r["status"] in ("caught", "timeout") for r in records)
    survived = [r["id"] for r in records if r["status"] == "survived"]
    return {"run": len(records), "caught": caught, "survived": survived,
            "timeouts": sum(r["status"] == "timeout" for r in records),
            "rate": caught / len(records) if records else float("nan")}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    g = sub.add_parser("gen")
    g.add_argument("root", type=Path)
    g.add_argument("paths", nargs="+")
    g.add_argument("--seed", type=int, required=True)
    g.add_argument("-n", type=int, default=40)
    g.add_argument("--since")
    g.add_argument("--out", type=Path, required=True)
    r = sub.add_parser("run")
    r.add_argument("root", type=Path)
    r.add_argument("muts", type=Path)
    r.add_argument("--out", type=Path, required=True)
    r.add_argument("--timeout", type=float, default=900.0)
    r.add_argument("--ids", type=lambda s: {int(x) for x in s.split(",")})
    s = sub.add_parser("show")
    s.add_argument("root", type=Path)
    s.add_argument("muts", type=Path)
    s.add_argument("id", type=int)
    a = sub.add_parser("apply")
    a.add_argument("root", type=Path)
    a.add_argument("muts", type=Path)
    a.add_argument("id", type=int)
    m = sub.add_parser("summary")
    m.add_argument("records", type=Path)
    args = ap.parse_args(argv)
    if args.cmd == "gen":
        muts = generate(args.root, args.paths, args.seed, args.n, args.since)
        args.out.write_text(json.dumps(muts, indent=1))
    elif args.cmd == "run":
        run(args.root, json.loads(args.muts.read_text()), args.out, args.timeout, args.ids)
    elif args.cmd in ("show", "apply"):
        mut = json.loads(args.muts.read_text())[args.id]
        path = args.root / mut["path"]
        text = path.read_text()
        new = apply_text(text, mut)
        if args.cmd == "apply":
            path.write_text(new)
        print(f"{mut['path']}:{mut['line']}: {mut['old']!r} -> {mut['new']!r}")
        print("- " + text.split("\n")[mut["line"] - 1])
        print("+ " + new.split("\n")[mut["line"] - 1])
    else:
        recs = [json.loads(l) for l in args.records.read_text().splitlines() if l.strip()]
        print(json.dumps(summary(recs), indent=1))
    return 0


if __name__ == "__main__":
    os.environ.setdefault("PYTHONHASHSEED", "0")
    sys.exit(main())
