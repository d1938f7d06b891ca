"""A library that links another (``build_library(..., links=...)``): the linked Function is
generated and compiled once, the linking library's C calls it by name and carries none of
its code, the shared library needs nothing else, the hash covers what is linked, and the
result equals CasADi's own evaluation of the whole (inlined) Function.

Tiny Functions in a private build root; the "heavy" inner Function has a marker constant
(``HEAVY``) that shows which generated file carries its code.
"""

from __future__ import annotations

import ctypes

import casadi as ca
import numpy as np
import pytest

from ballbot_casadi.core import toolchain as tc
from ballbot_casadi.errors import BuildError

pytestmark = pytest.mark.needs_cc

#: A constant only the inner Function's code holds (its literal shows where it is generated).
HEAVY = 1.2345678912345


def _inner(scale: float = HEAVY) -> ca.Function:
    x, k = ca.SX.sym("x", 3), ca.SX.sym("k")
    return ca.Function("ballbot_link_inner", [x, k], [ca.sin(x) * k * scale, ca.sumsqr(x)],
                       ["x", "k"], ["y", "s"])


def _outer(inner: ca.Function) -> ca.Function:
    """Calls ``inner`` behind a switch (as the guidance block calls the MPC sample)."""
    c, x, k = ca.MX.sym("c"), ca.MX.sym("x", 3), ca.MX.sym("k")
    hold = ca.Function("ballbot_link_hold", [x, k], [x, ca.MX(0.0)], ["x", "k"], ["y", "s"])
    y, s = ca.Function.conditional("ballbot_link_branch", [inner], hold)(c, x, k)
    return ca.Function("ballbot_link_outer", [c, x, k], [2.0 * y + s, s * k], ["c", "x", "k"],
                       ["y", "s"])


def _args(rng: np.random.Generator) -> list[np.ndarray]:
    return [np.array([0.0]), rng.normal(size=3), np.array([rng.normal()])]


def test_the_linked_library_equals_casadis_evaluation_of_the_whole_function(tmp_path, rng):
    inner_lib, inner_ext = tc.linked_function(_inner(), root=tmp_path)
    assert inner_lib.status == "built" and inner_ext.name() == "ballbot_link_inner"
    lib = tc.build_library("link_outer", [_outer(inner_ext)], root=tmp_path, links=[inner_lib])
    assert lib.links == (inner_lib,)
    assert lib.archives == (lib.static, inner_lib.static)
    # the inner code is generated once, in its own library; the outer calls it by name
    marker = repr(HEAVY)[:10]
    assert marker in inner_lib.source.read_text()
    src = lib.source.read_text()
    assert marker not in src
    assert "int ballbot_link_inner(const casadi_real** arg" in src
    # the shared library carries the inner code (no run-time dependency on the inner .so)
    assert hasattr(ctypes.CDLL(str(lib.shared)), "ballbot_link_inner")
    compiled = tc.load_library(lib, ["ballbot_link_outer"])["ballbot_link_outer"]
    whole = _outer(_inner())  # CasADi's own evaluation, the inner Function inlined
    for c in (0.0, 1.0):
        args = _args(rng)
        args[0][0] = c
        for a, b in zip(compiled(*args), whole(*args)):
            np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=0, atol=1e-15)


def test_the_hash_covers_the_linked_library(tmp_path, rng):
    """Another inner Function with the same name and ports: the outer's generated C is the
    same text, but its library is another one (hash) and computes the other inner."""
    libs, outs = [], []
    for scale in (HEAVY, 2.0):
        inner_lib, ext = tc.linked_function(_inner(scale), root=tmp_path)
        libs.append(tc.build_library("link_outer", [_outer(ext)], root=tmp_path, links=[inner_lib]))
        outs.append(tc.load_library(libs[-1], ["ballbot_link_outer"])["ballbot_link_outer"])
    assert libs[0].source.read_text() == libs[1].source.read_text()
    assert libs[0].digest != libs[1].digest
    args = _args(rng)
    for f, scale in zip(outs, (HEAVY, 2.0)):
        np.testing.assert_allclose(np.asarray(f(*args)[0]),
                                   np.asarray(_outer(_inner(scale))(*args)[0]), rtol=0, atol=1e-15)
    # cached: the same library again, both links verified
    again = tc.build_library("link_outer", [_outer(tc.linked_function(_inner(2.0), root=tmp_path)[1])],
                             root=tmp_path, links=[libs[1].links[0]])
    assert again == libs[1] and again.status == "cached"


def test_a_damaged_linked_library_is_refused_by_name(tmp_path):
    inner_lib, ext = tc.linked_function(_inner(), root=tmp_path)
    inner_lib.static.write_bytes(b"")
    with pytest.raises(BuildError, match=r"links ballbot_link_inner .*damaged") as exc:
        tc.build_library("link_outer", [_outer(ext)], root=tmp_path, links=[inner_lib])
    assert len(str(exc.value).splitlines()) == 1
    # building the linked library again heals it, then the link works
    inner_lib = tc.build_library("ballbot_link_inner", [_inner()], root=tmp_path)
    assert inner_lib.status.startswith("rebuilt")
    tc.build_library("link_outer", [_outer(ext)], root=tmp_path, links=[inner_lib])
