/*
 * ballbot_rng: counter-based random numbers for reproducible sensor noise.
 *
 * Generator: Philox4x32-10 (J. K. Salmon, M. A. Moraes, R. O. Dror, D. E. Shaw,
 * "Parallel random numbers: as easy as 1, 2, 3", SC'11, 2011; the Random123 library).
 * A pure function of a 128-bit counter and a 64-bit key: any element of any stream
 * is computed directly, so a run split into chunks, a Python run and an FMU draw
 * identical numbers.
 *
 * Layout of element (row, col) of stream `stream` under `seed`:
 *   key = { seed, stream }
 *   ctr = { row & 0xffffffff, row >> 32, col, kind }   kind: 0 normal, 1 uniform
 * One Philox block (4 words w0..w3) per element.
 *
 * 32-bit words -> double in (0, 1):
 *   m = (hi << 20) | (lo >> 12)          52 bits: all of hi, the top 20 bits of lo
 *   u = (m + 0.5) * 2^-52                exact; u in [2^-53, 1 - 2^-53]
 * uniform element: u = u01(w0, w1).
 * normal element (Box-Muller, cosine branch):
 *   u1 = u01(w0, w1), u2 = u01(w2, w3), z = sqrt(-2 log(u1)) * cos(2 pi u2)
 *   with 2 pi the double 6.283185307179586.  The integer stream and the uniforms are
 *   bit-exact everywhere; normals are bit-exact wherever log, cos and sqrt are the
 *   same (sqrt is correctly rounded by IEEE 754; log and cos come from the C library).
 *
 * C99, no allocation, no global state, thread-safe.
 */
#ifndef BALLBOT_RNG_H
#define BALLBOT_RNG_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define BALLBOT_RNG_KIND_NORMAL 0u
#define BALLBOT_RNG_KIND_UNIFORM 1u

/* One Philox4x32-10 block: out = philox(ctr, key). */
void ballbot_philox4x32_10(const uint32_t ctr[4], const uint32_t key[2], uint32_t out[4]);

/* Two 32-bit words -> double in (0, 1), see above. */
double ballbot_rng_u01(uint32_t hi, uint32_t lo);

/* The four raw words of element (row, col) of a stream, for the given kind. */
void ballbot_rng_block(uint32_t seed, uint32_t stream, uint64_t row, uint32_t col,
                       uint32_t kind, uint32_t out[4]);

/* One element: uniform in (0, 1) / standard normal. */
double ballbot_rng_uniform_at(uint32_t seed, uint32_t stream, uint64_t row, uint32_t col);
double ballbot_rng_normal_at(uint32_t seed, uint32_t stream, uint64_t row, uint32_t col);

/* n consecutive elements of column 0: out[i] = element (counter + i, 0). */
void ballbot_rng_uniform(uint32_t seed, uint32_t stream, uint64_t counter, double *out, size_t n);
void ballbot_rng_normal(uint32_t seed, uint32_t stream, uint64_t counter, double *out, size_t n);

/* A whole (n_rows, dim) row-major array: out[i * dim + j] = element (row0 + i, j). */
void ballbot_rng_fill_uniform(uint32_t seed, uint32_t stream, uint64_t row0, size_t n_rows,
                              uint32_t dim, double *out);
void ballbot_rng_fill_normal(uint32_t seed, uint32_t stream, uint64_t row0, size_t n_rows,
                             uint32_t dim, double *out);

/* Raw words of a (n_rows, dim) array: out[(i * dim + j) * 4 + w] (for tests). */
void ballbot_rng_fill_bits(uint32_t seed, uint32_t stream, uint64_t row0, size_t n_rows,
                           uint32_t dim, uint32_t kind, uint32_t *out);

#ifdef __cplusplus
}
#endif

#endif /* BALLBOT_RNG_H */
