/*
 * ballbot_rng: Philox4x32-10 counter-based random numbers (see ballbot_rng.h).
 *
 * Philox4x32 round (Salmon et al. 2011, Random123 philox.h):
 *   (hi0, lo0) = M0 * c0,  (hi1, lo1) = M1 * c2          (32x32 -> 64-bit products)
 *   c' = { hi1 ^ c1 ^ k0, lo1, hi0 ^ c3 ^ k1, lo0 }
 * with M0 = 0xD2511F53, M1 = 0xCD9E8D57; between rounds the key is bumped by the
 * Weyl constants W0 = 0x9E3779B9, W1 = 0xBB67AE85 (mod 2^32).  Ten rounds.
 */
#include "ballbot_rng.h"

#include <math.h>

#define PHILOX_M0 UINT32_C(0xD2511F53)
#define PHILOX_M1 UINT32_C(0xCD9E8D57)
#define PHILOX_W0 UINT32_C(0x9E3779B9)
#define PHILOX_W1 UINT32_C(0xBB67AE85)
#define PHILOX_ROUNDS 10

/* 2^-52 and 2*pi as exactly representable / correctly rounded doubles. */
#define BALLBOT_RNG_2M52 (1.0 / 4503599627370496.0)
#define BALLBOT_RNG_TWO_PI 6.283185307179586

void ballbot_philox4x32_10(const uint32_t ctr[4], const uint32_t key[2], uint32_t out[4])
{
    uint32_t c0 = ctr[0], c1 = ctr[1], c2 = ctr[2], c3 = ctr[3];
    uint32_t k0 = key[0], k1 = key[1];
    int r;
    for (r = 0; r < PHILOX_ROUNDS; ++r) {
        uint64_t p0 = (uint64_t)PHILOX_M0 * (uint64_t)c0;
        uint64_t p1 = (uint64_t)PHILOX_M1 * (uint64_t)c2;
        uint32_t hi0 = (uint32_t)(p0 >> 32), lo0 = (uint32_t)p0;
        uint32_t hi1 = (uint32_t)(p1 >> 32), lo1 = (uint32_t)p1;
        if (r > 0) {
            k0 += PHILOX_W0;
            k1 += PHILOX_W1;
        }
        c0 = hi1 ^ c1 ^ k0;
        c1 = lo1;
        c2 = hi0 ^ c3 ^ k1;
        c3 = lo0;
    }
    out[0] = c0;
    out[1] = c1;
    out[2] = c2;
    out[3] = c3;
}

double ballbot_rng_u01(uint32_t hi, uint32_t lo)
{
    uint64_t m = ((uint64_t)hi << 20) | (uint64_t)(lo >> 12);
    return ((double)m + 0.5) * BALLBOT_RNG_2M52;
}

void ballbot_rng_block(uint32_t seed, uint32_t stream, uint64_t row, uint32_t col,
                       uint32_t kind, uint32_t out[4])
{
    uint32_t ctr[4];
    uint32_t key[2];
    ctr[0] = (uint32_t)row;
    ctr[1] = (uint32_t)(row >> 32);
    ctr[2] = col;
    ctr[3] = kind;
    key[0] = seed;
    key[1] = stream;
    ballbot_philox4x32_10(ctr, key, out);
}

double ballbot_rng_uniform_at(uint32_t seed, uint32_t stream, uint64_t row, uint32_t col)
{
    uint32_t w[4];
    ballbot_rng_block(seed, stream, row, col, BALLBOT_RNG_KIND_UNIFORM, w);
    return ballbot_rng_u01(w[0], w[1]);
}

double ballbot_rng_normal_at(uint32_t seed, uint32_t stream, uint64_t row, uint32_t col)
{
    uint32_t w[4];
    double u1, u2;
    ballbot_rng_block(seed, stream, row, col, BALLBOT_RNG_KIND_NORMAL, w);
    u1 = ballbot_rng_u01(w[0], w[1]);
    u2 = ballbot_rng_u01(w[2], w[3]);
    return sqrt(-2.0 * log(u1)) * cos(BALLBOT_RNG_TWO_PI * u2);
}

void ballbot_rng_uniform(uint32_t seed, uint32_t stream, uint64_t counter, double *out, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i) {
        out[i] = ballbot_rng_uniform_at(seed, stream, counter + (uint64_t)i, 0u);
    }
}

void ballbot_rng_normal(uint32_t seed, uint32_t stream, uint64_t counter, double *out, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i) {
        out[i] = ballbot_rng_normal_at(seed, stream, counter + (uint64_t)i, 0u);
    }
}

/* Rows row0 .. row0 + n_rows - 1 of `dim` draws each of the generator `at`, row-major. */
static void fill_rows(double (*at)(uint32_t, uint32_t, uint64_t, uint32_t), uint32_t seed,
                      uint32_t stream, uint64_t row0, size_t n_rows, uint32_t dim, double *out)
{
    size_t i;
    uint32_t j;
    for (i = 0; i < n_rows; ++i) {
        for (j = 0; j < dim; ++j) {
            out[i * dim + j] = at(seed, stream, row0 + (uint64_t)i, j);
        }
    }
}

void ballbot_rng_fill_uniform(uint32_t seed, uint32_t stream, uint64_t row0, size_t n_rows,
                              uint32_t dim, double *out)
{
    fill_rows(ballbot_rng_uniform_at, seed, stream, row0, n_rows, dim, out);
}

void ballbot_rng_fill_normal(uint32_t seed, uint32_t stream, uint64_t row0, size_t n_rows,
                             uint32_t dim, double *out)
{
    fill_rows(ballbot_rng_normal_at, seed, stream, row0, n_rows, dim, out);
}

void ballbot_rng_fill_bits(uint32_t seed, uint32_t stream, uint64_t row0, size_t n_rows,
                           uint32_t dim, uint32_t kind, uint32_t *out)
{
    size_t i;
    uint32_t j;
    for (i = 0; i < n_rows; ++i) {
        for (j = 0; j < dim; ++j) {
            ballbot_rng_block(seed, stream, row0 + (uint64_t)i, j, kind, out + (i * dim + j) * 4u);
        }
    }
}
