"""Reproducible counter-based noise: Philox4x32-10 in C, called through ctypes.

The generator is Philox4x32-10 (J. K. Salmon, M. A. Moraes, R. O. Dror, D. E. Shaw,
"Parallel random numbers: as easy as 1, 2, 3", SC'11, 2011; Random123).  It is a pure
function ``block = philox(counter, key)`` of a 128-bit counter and a 64-bit key, so
every number is addressed directly by ``(seed, stream, row, col)``: chunking a run,
re-running it, or drawing the same numbers inside a compiled FMU gives identical
values.  The implementation is the C file ``csrc/ballbot_rng.c`` (C99, no 128-bit
integers; its header documents the same layout), compiled once into a small shared
library cached by hash under the build root; an FMU compiles the same file
(:func:`c_sources`).  :func:`philox4x32` and the ``reference_*`` functions are a
pure-numpy implementation used to check the C stream.

Layout of element ``(row, col)`` of stream ``stream`` under ``seed``::

    key = (seed, stream)                                   two 32-bit words
    ctr = (row mod 2^32, row div 2^32, col, kind)          kind 0 normal, 1 uniform

one Philox block ``(w0, w1, w2, w3)`` per element.  ``seed`` and ``stream`` are in
``[0, 2^32)``, ``row`` in ``[0, 2^64)`` (the sample index), ``col`` in ``[0, 2^32)``.

Words to doubles (exact)::

    u01(hi, lo) = (((hi << 20) | (lo >> 12)) + 0.5) * 2^-52     in [2^-53, 1 - 2^-53]
    uniform     = u01(w0, w1)
    normal      = sqrt(-2 ln u01(w0, w1)) * cos(2 pi u01(w2, w3))   (Box-Muller, cosine)

The integer words and the uniforms are bit-identical between C and numpy; normals
agree to a few ulp (``log``/``cos`` of the C library versus numpy's) and are
bit-identical between every user of the same compiled C code.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import shutil
import tempfile
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from ballbot_casadi.core.toolchain import CFLAGS, build_root, run_tool
from ballbot_casadi.errors import BallbotTypeError, ParameterError, ShapeError

__all__ = [
    "NoiseStream",
    "philox4x32",
    "u01",
    "reference_bits",
    "reference_uniform",
    "reference_normal",
    "c_sources",
    "build_rng_library",
    "KIND_NORMAL",
    "KIND_UNIFORM",
    "PHILOX_M",
    "PHILOX_W",
]

#: Philox4x32 multipliers and Weyl key increments (Salmon et al. 2011).
PHILOX_M = (0xD2511F53, 0xCD9E8D57)
PHILOX_W = (0x9E3779B9, 0xBB67AE85)
#: Fourth counter word: which kind of variate an element is.
KIND_NORMAL = 0
KIND_UNIFORM = 1

_U32 = 1 << 32
_TWO_PI = 6.283185307179586  # the double nearest 2 pi, as in the C source
_LIB = "ballbot_rng"


# --------------------------------------------------------------------------- numpy reference
def philox4x32(ctr: Any, key: Any, rounds: int = 10) -> np.ndarray:
    """Philox4x32-``rounds`` on arrays of counters ``(..., 4)`` and keys ``(..., 2)``.

    Pure numpy reference (uint32 arithmetic modulo 2^32, the 32x32 -> 64-bit products
    in uint64).  Returns the output blocks as uint32 of the broadcast shape ``(..., 4)``.
    """
    c = np.asarray(ctr, dtype=np.uint64)
    k = np.asarray(key, dtype=np.uint64)
    if c.shape[-1:] != (4,) or k.shape[-1:] != (2,):
        raise ShapeError(f"counter must end in 4 words and key in 2, got {c.shape}, {k.shape}")
    shape = np.broadcast_shapes(c.shape[:-1], k.shape[:-1])
    c0, c1, c2, c3 = (np.broadcast_to(c[..., i], shape).copy() for i in range(4))
    k0, k1 = (np.broadcast_to(k[..., i], shape).copy() for i in range(2))
    mask = np.uint64(0xFFFFFFFF)
    m0, m1 = np.uint64(PHILOX_M[0]), np.uint64(PHILOX_M[1])
    w0, w1 = np.uint64(PHILOX_W[0]), np.uint64(PHILOX_W[1])
    s32 = np.uint64(32)
    for r in range(rounds):
        if r > 0:
            k0 = (k0 + w0) & mask
            k1 = (k1 + w1) & mask
        p0, p1 = m0 * c0, m1 * c2
        c0, c1, c2, c3 = (p1 >> s32) ^ c1 ^ k0, p1 & mask, (p0 >> s32) ^ c3 ^ k1, p0 & mask
    return np.stack([c0, c1, c2, c3], axis=-1).astype(np.uint32)


def u01(hi: Any, lo: Any) -> np.ndarray:
    """Map two uint32 words to doubles in (0, 1): ``(((hi << 20) | (lo >> 12)) + 0.5) 2^-52``."""
    m = (np.asarray(hi, dtype=np.uint64) << np.uint64(20)) | (
        np.asarray(lo, dtype=np.uint64) >> np.uint64(12))
    return (m.astype(np.float64) + 0.5) * 2.0**-52


def _check_int(name: str, v: Any) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
        raise BallbotTypeError(f"{name} must be an int, got {type(v).__name__} {v!r}")
    return int(v)


def _check_u32(name: str, v: Any) -> int:
    v = _check_int(name, v)
    if not 0 <= v < _U32:
        raise ParameterError(f"{name} must be an int in [0, 2^32), got {v}")
    return v


def _check_rows(start: Any, n_samples: Any, dim: Any) -> tuple[int, int, int]:
    start, n_samples = _check_int("start", start), _check_int("n_samples", n_samples)
    dim = _check_int("dim", dim)
    if start < 0 or n_samples < 0:
        raise ShapeError(f"start and n_samples must be >= 0, got {start}, {n_samples}")
    if not 1 <= dim < _U32:
        raise ShapeError(f"dim must be in [1, 2^32), got {dim}")
    if start + n_samples > 1 << 64:
        raise ShapeError(
            f"rows start={start} .. start+n_samples={start + n_samples} exceed the 2^64 counter"
        )
    return start, n_samples, dim


def reference_bits(seed: int, stream: int, n_samples: int, dim: int, start: int = 0,
                   kind: int = KIND_NORMAL) -> np.ndarray:
    """Raw Philox words of elements (start + k, j): uint32 array ``(n_samples, dim, 4)``."""
    seed, stream = _check_u32("seed", seed), _check_u32("stream", stream)
    start, n_samples, dim = _check_rows(start, n_samples, dim)
    rows = np.arange(n_samples, dtype=np.uint64) + np.uint64(start)
    cols = np.arange(dim, dtype=np.uint64)
    ctr = np.empty((n_samples, dim, 4), dtype=np.uint64)
    ctr[..., 0] = (rows & np.uint64(0xFFFFFFFF))[:, None]
    ctr[..., 1] = (rows >> np.uint64(32))[:, None]
    ctr[..., 2] = cols[None, :]
    ctr[..., 3] = kind
    return philox4x32(ctr, np.array([seed, stream], dtype=np.uint64))


def reference_uniform(seed: int, stream: int, n_samples: int, dim: int,
                      start: int = 0) -> np.ndarray:
    """Numpy reference of :meth:`NoiseStream.uniform` (bit-identical)."""
    w = reference_bits(seed, stream, n_samples, dim, start, KIND_UNIFORM)
    return u01(w[..., 0], w[..., 1])


def reference_normal(seed: int, stream: int, n_samples: int, dim: int,
                     start: int = 0) -> np.ndarray:
    """Numpy reference of :meth:`NoiseStream.normal` (equal to a few ulp)."""
    w = reference_bits(seed, stream, n_samples, dim, start, KIND_NORMAL)
    u1, u2 = u01(w[..., 0], w[..., 1]), u01(w[..., 2], w[..., 3])
    return np.sqrt(-2.0 * np.log(u1)) * np.cos(_TWO_PI * u2)


# --------------------------------------------------------------------------- C library
def c_sources() -> tuple[Path, Path]:
    """Paths of ``ballbot_rng.c`` and ``ballbot_rng.h`` shipped with the package."""
    d = Path(str(resources.files("ballbot_casadi.core") / "csrc"))
    return d / f"{_LIB}.c", d / f"{_LIB}.h"


def build_rng_library(root: Path | None = None, cc: str | None = None) -> Path:
    """Compile ``ballbot_rng.c`` into a shared library (cached by hash) and return its path.

    The library goes to ``<root>/rng/<hash>/libballbot_rng.so``, ``<hash>`` being the
    SHA-256 of the C source, header, compiler and :data:`~ballbot_casadi.core.toolchain.CFLAGS`,
    so an unchanged source is never recompiled.

    Raises
    ------
    BuildError
        The compiler is missing or the source does not compile.
    """
    root = build_root() if root is None else Path(root)
    cc = cc or os.environ.get("CC", "gcc")
    src, hdr = c_sources()
    c_text, h_text = src.read_text(), hdr.read_text()
    digest = hashlib.sha256("\0".join([c_text, h_text, cc, *CFLAGS]).encode()).hexdigest()[:16]
    lib = root / "rng" / digest / f"lib{_LIB}.so"
    if lib.is_file():
        return lib
    lib.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{_LIB}-", dir=lib.parent))
    try:
        (tmp / src.name).write_text(c_text)
        (tmp / hdr.name).write_text(h_text)
        run_tool([cc, *CFLAGS, "-shared", "-o", str(tmp / lib.name), str(tmp / src.name), "-lm"],
                 f"compiling {_LIB} (shared)")
        os.replace(tmp / lib.name, lib)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return lib


def _load(path: Path) -> ctypes.CDLL:
    dll = ctypes.CDLL(str(path))
    u32, u64, sz = ctypes.c_uint32, ctypes.c_uint64, ctypes.c_size_t
    dbl = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
    words = np.ctypeslib.ndpointer(dtype=np.uint32, flags="C_CONTIGUOUS")
    for name in ("ballbot_rng_fill_uniform", "ballbot_rng_fill_normal"):
        fn = getattr(dll, name)
        fn.argtypes = [u32, u32, u64, sz, u32, dbl]
        fn.restype = None
    dll.ballbot_rng_fill_bits.argtypes = [u32, u32, u64, sz, u32, u32, words]
    dll.ballbot_rng_fill_bits.restype = None
    dll.ballbot_philox4x32_10.argtypes = [words, words, words]
    dll.ballbot_philox4x32_10.restype = None
    dll.ballbot_rng_u01.argtypes = [u32, u32]
    dll.ballbot_rng_u01.restype = ctypes.c_double
    for name in ("ballbot_rng_uniform_at", "ballbot_rng_normal_at"):
        fn = getattr(dll, name)
        fn.argtypes = [u32, u32, u64, u32]
        fn.restype = ctypes.c_double
    return dll


class NoiseStream:
    """Reproducible Gaussian / uniform noise of one seed, drawn by the C Philox library.

    Parameters
    ----------
    seed
        Int in ``[0, 2^32)``, the first Philox key word.
    root, cc
        Build root and C compiler for the (cached) library, see :func:`build_rng_library`.

    Notes
    -----
    ``normal(stream, n, dim, start)[k, j]`` is element ``(start + k, j)`` of the stream,
    a function of ``(seed, stream, start + k, j)`` only, so drawing rows 0..999 at once
    or in chunks gives the same array bit for bit.  Use one stream per noise source
    (e.g. accelerometer, gyroscope, bias random walk).
    """

    def __init__(self, seed: int, root: Path | None = None, cc: str | None = None) -> None:
        self._seed = _check_u32("seed", seed)
        self._lib_path = build_rng_library(root, cc)
        self._dll = _load(self._lib_path)

    @property
    def seed(self) -> int:
        """The seed (first key word)."""
        return self._seed

    @property
    def library(self) -> Path:
        """Path of the compiled shared library in use."""
        return self._lib_path

    def _fill(self, fn: Any, stream: int, n_samples: int, dim: int, start: int) -> np.ndarray:
        stream = _check_u32("stream", stream)
        start, n_samples, dim = _check_rows(start, n_samples, dim)
        out = np.empty((n_samples, dim), dtype=np.float64)
        if n_samples:
            fn(self._seed, stream, start, n_samples, dim, out)
        return out

    def normal(self, stream: int, n_samples: int, dim: int, start: int = 0) -> np.ndarray:
        """Standard normal array ``(n_samples, dim)``: row k, column j is element (start + k, j)."""
        return self._fill(self._dll.ballbot_rng_fill_normal, stream, n_samples, dim, start)

    def uniform(self, stream: int, n_samples: int, dim: int, start: int = 0) -> np.ndarray:
        """Uniform (0, 1) array ``(n_samples, dim)``: row k, column j is element (start + k, j)."""
        return self._fill(self._dll.ballbot_rng_fill_uniform, stream, n_samples, dim, start)

    def bits(self, stream: int, n_samples: int, dim: int, start: int = 0,
             kind: int = KIND_NORMAL) -> np.ndarray:
        """Raw Philox words ``(n_samples, dim, 4)`` (uint32) of the C library."""
        stream = _check_u32("stream", stream)
        kind = _check_u32("kind", kind)
        start, n_samples, dim = _check_rows(start, n_samples, dim)
        out = np.empty((n_samples, dim, 4), dtype=np.uint32)
        if n_samples:
            self._dll.ballbot_rng_fill_bits(self._seed, stream, start, n_samples, dim, kind, out)
        return out

    def philox_block(self, ctr: Any, key: Any) -> np.ndarray:
        """One Philox4x32-10 block of the C library (for known-answer tests)."""
        c = np.ascontiguousarray(ctr, dtype=np.uint32).reshape(4)
        k = np.ascontiguousarray(key, dtype=np.uint32).reshape(2)
        out = np.empty(4, dtype=np.uint32)
        self._dll.ballbot_philox4x32_10(c, k, out)
        return out

    def u01(self, hi: int, lo: int) -> float:
        """The C word-to-double map ``ballbot_rng_u01``."""
        return float(self._dll.ballbot_rng_u01(_check_u32("hi", hi), _check_u32("lo", lo)))

    def normal_at(self, stream: int, row: int, col: int) -> float:
        """One normal element, as an FMU would draw it (``ballbot_rng_normal_at``)."""
        start, _, _ = _check_rows(row, 1, 1)
        return float(self._dll.ballbot_rng_normal_at(
            self._seed, _check_u32("stream", stream), start, _check_u32("col", col)))
