"""CasADi 3.8's implicit numpy-on-CasADi conversion (issue #2959) is an error in this suite.

A numpy function applied to a CasADi value uses a deprecated conversion whose result a
later CasADi changes; the code converts explicitly instead.  pyproject's
``filterwarnings`` turns exactly that FutureWarning into an error.
"""

from __future__ import annotations

import warnings

import casadi as ca
import numpy as np
import pytest


def test_numpy_function_on_a_casadi_value_fails_the_suite():
    with pytest.raises(FutureWarning, match="issue #2959"):
        np.squeeze(ca.DM([1.0, 2.0]))


def test_explicit_conversions_do_not_warn():
    d = ca.DM([[1.0], [2.0]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        np.testing.assert_array_equal(d.full().ravel(), [1.0, 2.0])
        np.testing.assert_array_equal(np.asarray(d).ravel(), [1.0, 2.0])
        x = ca.SX.sym("x", 2)
        f = ca.Function("f", [x], [ca.sin(x)])
        np.testing.assert_allclose(f(np.array([0.0, np.pi / 2])).full().ravel(), [0.0, 1.0], rtol=0, atol=1e-15)
