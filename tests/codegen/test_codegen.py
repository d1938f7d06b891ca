"""Generated C: strict compilation, determinism, equality with the symbolic Functions."""

import numpy as np
import pytest

from ballbot_casadi.codegen import libraries
from ballbot_casadi.core import toolchain as codegen
from ballbot_casadi.model.numeric import BallbotModel, make_state


@pytest.fixture(scope="module")
def compiled():
    return libraries.load_model_library()


def test_library_built_and_cached():
    lib1 = libraries.model_library()
    mtime = lib1.shared.stat().st_mtime_ns
    lib2 = libraries.model_library()
    assert lib1 == lib2 and lib2.shared.stat().st_mtime_ns == mtime  # no recompilation
    assert lib1.static.is_file() and lib1.header.is_file()
    assert "-Werror" in codegen.CFLAGS and "-std=c99" in codegen.CFLAGS


def test_generation_is_deterministic(model_functions):
    a = codegen.generate_sources("ballbot_model", model_functions.values())
    b = codegen.generate_sources("ballbot_model", list(libraries.model_functions_list()))
    assert a == b
    assert libraries.model_library().source.read_text() == a[0]


def test_compiled_equals_symbolic(compiled, model_functions, default_params, rng):
    p = default_params.replace(Bvk=0.1, Bvm=0.01, Bvb=0.02, com_x=0.01, com_y=-0.02).to_vector()
    for _ in range(10):
        x = make_state(roll=rng.uniform(-0.5, 0.5), pitch=rng.uniform(-0.5, 0.5),
                       yaw=rng.uniform(-3, 3), dx=rng.normal(), dy=rng.normal(),
                       omega_body=rng.normal(size=3))
        tau = rng.normal(size=3)
        for name, args in [("ode", (x, tau, p)), ("jac", (x, tau, p)), ("affine", (x, p)),
                           ("energy", (x, p)), ("wheel_speeds", (x, p)),
                           ("forward_kinematics", (x[2:6], x[8:12], x[9:12], p))]:
            sym = model_functions[name](*args)
            cmp = compiled[name](*args)
            sym = sym if isinstance(sym, tuple) else (sym,)
            cmp = cmp if isinstance(cmp, tuple) else (cmp,)
            for s, c in zip(sym, cmp):
                s, c = np.array(s), np.array(c)
                np.testing.assert_allclose(c, s, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(s).max()),
                                           err_msg=name)


def test_model_runs_on_compiled_functions(compiled):
    m_sym, m_c = BallbotModel(), BallbotModel(functions=compiled)
    x = make_state(roll=0.1)
    np.testing.assert_allclose(m_c.ode(x, [0.1, 0.2, 0.3]), m_sym.ode(x, [0.1, 0.2, 0.3]),
                               rtol=1e-12, atol=1e-13)


def test_bad_build_reports_compiler_error(tmp_path):
    import casadi as ca

    from ballbot_casadi.errors import BuildError

    x = ca.SX.sym("x")
    f = ca.Function("ballbot_tiny", [x], [2 * x], ["x"], ["y"])
    lib = codegen.build_library("tiny", [f], root=tmp_path)
    assert float(codegen.load_library(lib, ["ballbot_tiny"])["ballbot_tiny"](3.0)) == 6.0
    with pytest.raises(BuildError, match="not found"):
        codegen.build_library("tiny2", [f], root=tmp_path, cc="no-such-compiler-xyz")
    with pytest.raises(BuildError, match="no functions"):
        codegen.generate_sources("empty", [])
