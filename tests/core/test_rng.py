"""Counter-based Philox4x32-10 noise: known answers, C == numpy, layout, statistics."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from ballbot_casadi.core import rng
from ballbot_casadi.errors import BallbotTypeError, ParameterError, ShapeError

# Random123 kat_vectors (Salmon et al. 2011): counter (4 words), key (2 words) -> output.
KAT = {
    7: [
        ((0, 0, 0, 0), (0, 0), (0x5F6FB709, 0x0D893F64, 0x4F121F81, 0x4F730A48)),
        ((0xFFFFFFFF,) * 4, (0xFFFFFFFF,) * 2, (0x5207DDC2, 0x45165E59, 0x4D8EE751, 0x8C52F662)),
        ((0x243F6A88, 0x85A308D3, 0x13198A2E, 0x03707344), (0xA4093822, 0x299F31D0),
         (0x4DFCCABA, 0x190A87F0, 0xC47362BA, 0xB6B5242A)),
    ],
    10: [
        ((0, 0, 0, 0), (0, 0), (0x6627E8D5, 0xE169C58D, 0xBC57AC4C, 0x9B00DBD8)),
        ((0xFFFFFFFF,) * 4, (0xFFFFFFFF,) * 2, (0x408F276D, 0x41C83B0E, 0xA20BC7C6, 0x6D5451FD)),
        ((0x243F6A88, 0x85A308D3, 0x13198A2E, 0x03707344), (0xA4093822, 0x299F31D0),
         (0xD16CFE09, 0x94FDCCEB, 0x5001E420, 0x24126EA1)),
    ],
}
U32MAX = 0xFFFFFFFF


@pytest.fixture(scope="module")
def noise():
    return rng.NoiseStream(20201122)


@pytest.mark.parametrize("rounds", [7, 10])
def test_numpy_reference_known_answers(rounds):
    for ctr, key, expected in KAT[rounds]:
        out = rng.philox4x32(np.array(ctr), np.array(key), rounds=rounds)
        assert out.dtype == np.uint32
        assert out.tolist() == list(expected)
    # vectorised over a batch of counters gives the same blocks
    ctrs = np.array([c for c, _, _ in KAT[rounds]])
    keys = np.array([k for _, k, _ in KAT[rounds]])
    assert rng.philox4x32(ctrs, keys, rounds).tolist() == [list(e) for _, _, e in KAT[rounds]]


@pytest.mark.needs_cc
def test_c_known_answers(noise):
    for ctr, key, expected in KAT[10]:
        assert noise.philox_block(ctr, key).tolist() == list(expected)


@pytest.mark.needs_cc
@pytest.mark.parametrize(
    "seed, stream, start, n, dim",
    [
        (0, 0, 0, 50, 3),
        (1, 7, 123, 40, 1),
        (U32MAX, U32MAX, 0, 10, 5),
        (20201122, 3, (1 << 32) - 5, 10, 2),  # row crosses the low/high counter word
        (42, 1, (1 << 64) - 8, 8, 3),  # last rows of the 64-bit counter
    ],
)
def test_c_words_equal_numpy_reference(seed, stream, start, n, dim):
    c = rng.NoiseStream(seed)
    for kind in (rng.KIND_NORMAL, rng.KIND_UNIFORM):
        np.testing.assert_array_equal(c.bits(stream, n, dim, start, kind),
                                      rng.reference_bits(seed, stream, n, dim, start, kind))


@pytest.mark.needs_cc
def test_c_words_equal_numpy_for_many_random_keys():
    g = np.random.default_rng(7)
    for seed, stream, start in zip(g.integers(0, 1 << 32, 6), g.integers(0, 1 << 32, 6),
                                   g.integers(0, 1 << 63, 6)):
        c = rng.NoiseStream(int(seed))
        np.testing.assert_array_equal(
            c.bits(int(stream), 20, 3, int(start)),
            rng.reference_bits(int(seed), int(stream), 20, 3, int(start)))


@pytest.mark.needs_cc
def test_defaults_are_row_zero_and_the_normal_kind(noise):
    """Without ``start`` and ``kind``: rows from 0, the words of the normal variates, in the
    C library and its numpy reference alike."""
    seed = noise.seed
    explicit = rng.reference_bits(seed, 3, 4, 2, 0, rng.KIND_NORMAL)
    np.testing.assert_array_equal(noise.bits(3, 4, 2), explicit)
    np.testing.assert_array_equal(rng.reference_bits(seed, 3, 4, 2), explicit)
    assert not np.array_equal(explicit, rng.reference_bits(seed, 3, 4, 2, 1, rng.KIND_NORMAL))
    assert not np.array_equal(explicit, rng.reference_bits(seed, 3, 4, 2, 0, rng.KIND_UNIFORM))
    np.testing.assert_array_equal(noise.uniform(3, 4, 2), rng.reference_uniform(seed, 3, 4, 2, 0))
    np.testing.assert_array_equal(rng.reference_uniform(seed, 3, 4, 2), rng.reference_uniform(seed, 3, 4, 2, 0))
    np.testing.assert_allclose(noise.normal(3, 4, 2), rng.reference_normal(seed, 3, 4, 2, 0), rtol=1e-14, atol=1e-15)
    np.testing.assert_array_equal(rng.reference_normal(seed, 3, 4, 2), rng.reference_normal(seed, 3, 4, 2, 0))


def test_counter_layout_of_reference():
    """Element (row, col) is philox(ctr=(row lo, row hi, col, kind), key=(seed, stream))."""
    seed, stream, row, col = 99, 4, (5 << 32) + 17, 2
    w = rng.reference_bits(seed, stream, 1, 3, start=row, kind=rng.KIND_UNIFORM)[0, col]
    direct = rng.philox4x32(np.array([17, 5, col, 1]), np.array([seed, stream]))
    np.testing.assert_array_equal(w, direct)


def test_u01_mapping_exact_and_open_interval():
    assert rng.u01(0, 0) == 2.0**-53
    assert rng.u01(U32MAX, U32MAX) == 1.0 - 2.0**-53
    assert rng.u01(1, 0) == (2**20 + 0.5) * 2.0**-52
    assert rng.u01(0, 0xFFF) == rng.u01(0, 0)  # low 12 bits of the second word unused
    assert rng.u01(0, 0x1000) == 1.5 * 2.0**-52
    g = np.random.default_rng(1)
    hi, lo = g.integers(0, 1 << 32, 1000), g.integers(0, 1 << 32, 1000)
    expected = [((int(h) << 20 | int(lo_) >> 12) + 0.5) / 2**52 for h, lo_ in zip(hi, lo)]
    np.testing.assert_array_equal(rng.u01(hi, lo), expected)


@pytest.mark.needs_cc
def test_c_u01_equals_numpy(noise):
    for hi, lo in [(0, 0), (U32MAX, U32MAX), (1, 0), (0x80000000, 0x12345678), (7, 0xFFF)]:
        assert noise.u01(hi, lo) == rng.u01(hi, lo)


@pytest.mark.needs_cc
def test_c_variates_equal_numpy_reference(noise):
    seed = noise.seed
    np.testing.assert_array_equal(noise.uniform(2, 3000, 3),
                                  rng.reference_uniform(seed, 2, 3000, 3))  # bit for bit
    # normals: same words and uniforms; libm vs numpy log/cos agree to a few ulp
    np.testing.assert_allclose(noise.normal(2, 3000, 3), rng.reference_normal(seed, 2, 3000, 3),
                               rtol=1e-14, atol=1e-15)


@pytest.mark.needs_cc
def test_chunking_dim_and_single_element_access(noise):
    whole = noise.normal(5, 1000, 3)
    chunks = np.vstack([noise.normal(5, 400, 3), noise.normal(5, 1, 3, start=400),
                        noise.normal(5, 599, 3, start=401)])
    np.testing.assert_array_equal(whole, chunks)
    np.testing.assert_array_equal(noise.normal(5, 1000, 5)[:, :3], whole)  # columns by index
    for row, col in [(0, 0), (17, 2), (999, 1)]:
        assert noise.normal_at(5, row, col) == whole[row, col]
    u = noise.uniform(5, 300, 2)
    np.testing.assert_array_equal(u[100:], noise.uniform(5, 200, 2, start=100))
    assert noise.normal(5, 0, 3).shape == (0, 3)


@pytest.mark.needs_cc
def test_same_seed_bit_identical_other_seed_or_stream_different(noise):
    again = rng.NoiseStream(noise.seed)
    a = noise.normal(1, 500, 3)
    assert a.tobytes() == again.normal(1, 500, 3).tobytes()
    assert again.library == noise.library  # cached build, not recompiled
    assert not np.any(a == rng.NoiseStream(noise.seed + 1).normal(1, 500, 3))
    assert not np.any(a == noise.normal(2, 500, 3))


def _z(n):
    return 4.5 / math.sqrt(n)  # 4.5-sigma bound of a sample correlation / standardised mean


@pytest.mark.needs_cc
def test_normal_moments_and_distribution(noise):
    n = 200_000
    z = noise.normal(0, n // 2, 2).ravel()
    assert abs(z.mean()) < _z(n)
    assert abs(z.var() - 1.0) < 4.5 * math.sqrt(2.0 / n)
    assert abs(stats.skew(z)) < 4.5 * math.sqrt(6.0 / n)
    assert abs(stats.kurtosis(z)) < 4.5 * math.sqrt(24.0 / n)
    assert stats.kstest(z, "norm").pvalue > 1e-4
    assert np.all(np.isfinite(z))


@pytest.mark.needs_cc
def test_uniform_moments_and_distribution(noise):
    n = 200_000
    u = noise.uniform(0, n, 1).ravel()
    assert u.min() > 0.0 and u.max() < 1.0
    assert abs(u.mean() - 0.5) < 4.5 * math.sqrt(1 / 12 / n)
    assert abs(u.var() - 1 / 12) < 4.5 * math.sqrt(1 / 180 / n)  # Var(s^2) of U(0,1) ~ 1/(180 n)
    assert stats.kstest(u, "uniform").pvalue > 1e-4


@pytest.mark.needs_cc
def test_no_correlation_between_streams_counters_columns_seeds_kinds(noise):
    n = 100_000
    a = noise.normal(0, n, 2)
    pairs = {
        "stream 0 vs 1": (a[:, 0], noise.normal(1, n, 1)[:, 0]),
        "column 0 vs 1": (a[:, 0], a[:, 1]),
        "row k vs k+1": (a[:-1, 0], a[1:, 0]),
        "seed vs seed+1": (a[:, 0], rng.NoiseStream(noise.seed + 1).normal(0, n, 1)[:, 0]),
        # z^2 = -2 ln(u1) cos^2: would be strongly correlated with u1 if the kind word
        # did not separate normal and uniform draws of the same element
        "normal^2 vs uniform": (a[:, 0] ** 2, noise.uniform(0, n, 1)[:, 0]),
        "squares, stream 0 vs 1": (a[:, 0] ** 2, noise.normal(1, n, 1)[:, 0] ** 2),
    }
    for what, (x, y) in pairs.items():
        r = np.corrcoef(x, y)[0, 1]
        assert abs(r) < _z(len(x)), f"{what}: correlation {r:.2e}"


def test_bad_arguments():
    with pytest.raises(ParameterError, match="seed must be an int in"):
        rng.reference_normal(-1, 0, 1, 1)
    with pytest.raises(ParameterError, match="stream"):
        rng.reference_normal(0, 1 << 32, 1, 1)
    with pytest.raises(BallbotTypeError, match="seed"):
        rng.reference_normal(1.5, 0, 1, 1)
    with pytest.raises(BallbotTypeError, match="seed"):
        rng.reference_normal(True, 0, 1, 1)
    with pytest.raises(ShapeError, match="dim"):
        rng.reference_normal(0, 0, 1, 0)
    with pytest.raises(ShapeError, match="2\\^64"):
        rng.reference_normal(0, 0, 10, 1, start=(1 << 64) - 5)
    with pytest.raises(ShapeError):
        rng.philox4x32(np.zeros(3), np.zeros(2))


@pytest.mark.needs_cc
def test_noise_stream_validates(noise):
    with pytest.raises(ParameterError):
        rng.NoiseStream(1 << 32)
    with pytest.raises(ShapeError):
        noise.normal(0, -1, 3)
    with pytest.raises(BallbotTypeError):
        noise.uniform(0, 10, 2.0)


@pytest.mark.needs_cc
def test_library_is_built_once_per_source_and_compiler(tmp_path):
    lib = rng.build_rng_library(tmp_path)
    stamp = lib.stat().st_mtime_ns
    assert rng.build_rng_library(tmp_path) == lib and lib.stat().st_mtime_ns == stamp
    src, hdr = rng.c_sources()
    assert src.is_file() and hdr.is_file() and lib.parent.parent == tmp_path / "rng"
