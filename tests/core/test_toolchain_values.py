"""The toolchain's small pure parts by hand (no compile): the compiler command and the
source of each of its refusals, a library's files and archives (linked libraries depth
first, nested), the C made strict (``(void)`` casts of unused parameters), a damaged or
never-built linked library refused before any generation, and a load failure's message."""

from __future__ import annotations

import shutil
from pathlib import Path

import casadi as ca
import pytest

from ballbot_casadi.core import toolchain as tc
from ballbot_casadi.errors import BuildError


def _lib(root: Path, name: str, links=()) -> tc.Library:
    folder = root / name
    return tc.Library(name, folder / f"{name}.c", folder / f"{name}.h", folder / f"lib{name}.so",
                      folder / f"lib{name}.a", "d" + name, links=tuple(links))


def test_archives_are_the_own_then_each_linked_librarys_depth_first(tmp_path):
    d = _lib(tmp_path, "d")
    b = _lib(tmp_path, "b", [d])
    c = _lib(tmp_path, "c")
    a = _lib(tmp_path, "a", [b, c])
    assert a.archives == (a.static, b.static, d.static, c.static)
    assert c.archives == (c.static,)
    assert a.files == (a.source, a.header, a.shared, a.static)
    assert a.folder == tmp_path / "a"
    assert a.static.name == "liba.a" and a.shared.name == "liba.so"
    # status and links are not part of equality
    assert a == _lib(tmp_path, "a") and a.status == "cached"


def test_compiler_command_sources_and_refusals(monkeypatch):
    gcc = shutil.which("gcc")
    if gcc is None:
        pytest.skip("gcc not installed")
    monkeypatch.delenv("CC", raising=False)
    assert tc.compiler_command() == ["gcc"]
    assert tc.compiler_command("gcc -O1 -g") == ["gcc", "-O1", "-g"]
    assert tc.compiler_command(["gcc", 3]) == ["gcc", "3"]
    monkeypatch.setenv("CC", "")
    assert tc.compiler_command() == ["gcc"]            # an empty $CC is the default
    monkeypatch.setenv("CC", "gcc -m64")
    assert tc.compiler_command() == ["gcc", "-m64"]
    assert tc.compiler_command("gcc") == ["gcc"]       # the argument wins over $CC
    monkeypatch.setenv("CC", "  ")
    with pytest.raises(BuildError, match=r"^C compiler \(\$CC\) is empty; set CC"):
        tc.compiler_command()
    with pytest.raises(BuildError, match=r"^C compiler \(the cc argument\) is empty"):
        tc.compiler_command("")
    monkeypatch.setenv("CC", "no-such-cc-q -O2")
    with pytest.raises(BuildError) as exc:
        tc.compiler_command()
    assert str(exc.value) == ("C compiler 'no-such-cc-q' ($CC: 'no-such-cc-q -O2') not found; "
                              "install gcc or set CC to an installed compiler")
    monkeypatch.delenv("CC")
    with pytest.raises(BuildError, match=r"^C compiler 'no-such-cc-q' \(the cc argument: "):
        tc.compiler_command("no-such-cc-q")
    with pytest.raises(BuildError, match=r"^C compiler \"'x\" \(the cc argument\) is not a valid command"):
        tc.compiler_command("'x")


def test_strict_c_casts_unused_parameters():
    head = ("static int casadi_f0(const casadi_real** arg, casadi_real** res, "
            "casadi_int* iw, casadi_real* w, int mem) {\n")
    out = tc._strict_c(head + "  return 0;\n}\n")
    assert out == head + "  (void)arg; (void)res; (void)iw; (void)w; (void)mem;\n  return 0;\n}\n"
    rel = "CASADI_SYMBOL_EXPORT void f_release(int mem) {\n}\n"
    assert tc._strict_c(rel) == "CASADI_SYMBOL_EXPORT void f_release(int mem) {\n  (void)mem;\n}\n"
    qp = "int casadi_qp_work(casadi_qp_prob* p, casadi_int* sz_iw, casadi_int *sz_w) {\n}\n"
    assert tc._strict_c(qp) == ("int casadi_qp_work(casadi_qp_prob* p, casadi_int* sz_iw, "
                                "casadi_int *sz_w) {\n  (void)p;\n  (void)sz_iw;\n  (void)sz_w;\n}\n")
    other = "static int other(int a) {\n}\n"
    assert tc._strict_c(other) == other


def _probe() -> ca.Function:
    x = ca.SX.sym("x")
    return ca.Function("ballbot_tc_probe", [x], [2 * x], ["x"], ["y"])


def test_a_linked_library_never_built_is_refused_before_generation(tmp_path, monkeypatch):
    if shutil.which("gcc") is None:
        pytest.skip("gcc not installed")
    monkeypatch.delenv("CC", raising=False)
    dep = _lib(tmp_path / "codegen", "ballbot_dep")

    def never(*_a, **_k):
        raise AssertionError("generated before the linked library was checked")

    monkeypatch.setattr(tc, "generate_sources", never)
    with pytest.raises(BuildError) as exc:
        tc.build_library("outer", [_probe()], root=tmp_path, links=[dep])
    msg = str(exc.value)
    assert msg.startswith(f"library 'outer' links ballbot_dep ({dep.folder}), which is damaged "
                          f"(no manifest {dep.folder / tc.MANIFEST}); build it again")
    assert "\n" not in msg
    assert not (tmp_path / "codegen").exists()


def test_loading_a_missing_library_is_a_build_error_naming_the_folder(tmp_path):
    lib = _lib(tmp_path, "ballbot_gone")
    with pytest.raises(BuildError) as exc:
        tc.load_library(lib, ["ballbot_gone"])
    msg = str(exc.value)
    assert msg.startswith(f"loading {lib.shared} failed (")
    assert msg.endswith(f"delete {lib.folder} to force a rebuild")
