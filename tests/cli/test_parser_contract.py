"""The command line's defaults and required arguments are what its help says (issue 23:
``fmu cosim --out`` made optional, or a default changed without its help, went unnoticed).

Every option whose help names a concrete default ("default 2", "default build/demo")
has exactly that default; the required arguments are refused when missing with one line,
exit 2, naming the argument."""

from __future__ import annotations

import argparse
import re

import pytest

from ballbot_casadi import cli
from ballbot_casadi.cli import build_parser


def _walk(parser, path=()):
    for a in parser._actions:
        if isinstance(a, argparse._SubParsersAction):
            for name, sp in a.choices.items():
                yield from _walk(sp, (*path, name))
        else:
            yield path, a


def _documented_default(text: str):
    m = re.search(r"\(default:? ([^;,)]+)|default:? ([^;,)\s]+)", text)
    if m is None:
        return None
    word = (m.group(1) or m.group(2)).strip().split(":")[0].split(" ")[0]
    try:
        return float(word)
    except ValueError:
        return word


def test_every_concrete_default_in_the_help_is_the_default():
    checked = []
    for path, a in _walk(build_parser()):
        doc = _documented_default(a.help or "")
        if doc is None or a.default is None:
            continue
        if isinstance(doc, float):
            assert isinstance(a.default, (int, float)) and float(a.default) == doc, (path, a.option_strings)
        else:
            assert str(a.default) == doc, (path, a.option_strings, a.default, doc)
        checked.append((" ".join(path), a.option_strings[0] if a.option_strings else a.dest))
    # the ones that matter most are among them
    for want in [("montecarlo", "--workers"), ("montecarlo", "--min-success"), ("simulate", "--log-every"),
                 ("animate", "--fps"), ("animate", "--max-frames"), ("fmu ssp", "--scenario"),
                 ("firmware", "--controller"), ("firmware", "--estimator"), ("analyze", "--out"),
                 ("demo", "--out"), ("bench", "--out"), ("study", "--controller")]:
        assert want in checked, want
    assert len(checked) >= 13


@pytest.mark.parametrize("argv, missing", [
    (["simulate"], "scenario"),
    (["montecarlo", "zero"], "--n"),
    (["montecarlo", "--n", "2"], "scenario"),
    (["animate"], "run"),
    (["fmu", "cosim", "x.ssp"], "--out"),
    (["fmu", "cosim", "--out", "o"], "ssp"),
])
def test_required_arguments_are_one_line_exit_2(tmp_path, monkeypatch, capsys, argv, missing):
    monkeypatch.chdir(tmp_path)  # nothing may be written anywhere that matters
    with pytest.raises(SystemExit) as e:
        cli.main(argv)
    assert e.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "required" in err and missing in err, err
    assert list(tmp_path.iterdir()) == []
