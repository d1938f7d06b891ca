"""The C library's array draws by counter (``ballbot_rng_uniform`` / ``ballbot_rng_normal``,
public in ``ballbot_rng.h`` beside the element draws): ``out[i]`` is the element of row
``counter + i``, column 0, for every i from the first, equal to the numpy reference; a
count of zero writes nothing."""

from __future__ import annotations

import ctypes

import numpy as np
import pytest

from ballbot_casadi.core import rng

pytestmark = pytest.mark.needs_cc


@pytest.fixture(scope="module")
def dll():
    lib = ctypes.CDLL(str(rng.build_rng_library()))
    dbl = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
    for name in ("ballbot_rng_uniform", "ballbot_rng_normal"):
        fn = getattr(lib, name)
        fn.argtypes = [ctypes.c_uint32, ctypes.c_uint32, ctypes.c_uint64, dbl, ctypes.c_size_t]
        fn.restype = None
    return lib


@pytest.mark.parametrize("kind, reference", [("uniform", rng.reference_uniform),
                                             ("normal", rng.reference_normal)])
@pytest.mark.parametrize("counter", [0, 5, 2**40 + 3])
def test_each_entry_is_its_rows_element(dll, kind, reference, counter):
    seed, stream, n = 12345, 7, 9
    out = np.full(n + 2, np.pi)                 # two guard entries past the count
    getattr(dll, f"ballbot_rng_{kind}")(seed, stream, counter, out, n)
    want = reference(seed, stream, n, 1, start=counter)[:, 0]
    np.testing.assert_array_equal(out[:n], want)
    assert np.all(out[n:] == np.pi)
    assert len(set(out[:n])) == n               # distinct rows, not one element repeated


def test_a_count_of_zero_writes_nothing(dll):
    out = np.full(3, np.pi)
    dll.ballbot_rng_uniform(1, 2, 3, out, 0)
    dll.ballbot_rng_normal(1, 2, 3, out, 0)
    assert np.all(out == np.pi)
