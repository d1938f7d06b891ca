/* Micro-benchmark of one CasADi-generated function: us per call, JSON on stdout.
 * Usage: bench_function N_CALLS INPUT_FILE
 * The function is selected at compile time: -DBENCH_FN=<name> (the name of a function of
 * the linked static library).  INPUT_FILE holds the numbers of every input in input
 * order, each input dense column-major (as many as its sparsity pattern's nonzeros).
 * Work vectors are allocated before timing; the best of 5 repetitions is reported, with
 * the outputs of the timed call (the inputs do not change) for the caller to verify. */
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include BENCH_HEADER
#include "bench_json.h"

#define CAT2(a, b) a##b
#define CAT(a, b) CAT2(a, b)
#define FN BENCH_FN
#define FN_WORK CAT(BENCH_FN, _work)
#define FN_N_IN CAT(BENCH_FN, _n_in)
#define FN_N_OUT CAT(BENCH_FN, _n_out)
#define FN_SP_IN CAT(BENCH_FN, _sparsity_in)
#define FN_SP_OUT CAT(BENCH_FN, _sparsity_out)

static volatile double sink;

static double now_ns(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}

int main(int argc, char **argv) {
  casadi_int n_arg, n_res, n_iw, n_w, i, j;
  const casadi_real **arg;
  casadi_real **res, *w, **in, **out;
  casadi_int *iw;
  long n, k;
  int rep;
  double best = 1e300;
  FILE *fh;
  if (argc != 3) {
    fprintf(stderr, "usage: bench_function N_CALLS INPUT_FILE\n");
    return 2;
  }
  n = atol(argv[1]);
  fh = fopen(argv[2], "r");
  if (!fh || n < 1) {
    fprintf(stderr, "bench_function: cannot read %s\n", argv[2]);
    return 2;
  }
  FN_WORK(&n_arg, &n_res, &n_iw, &n_w);
  arg = (const casadi_real **)calloc((size_t)n_arg + 1, sizeof(casadi_real *));
  res = (casadi_real **)calloc((size_t)n_res + 1, sizeof(casadi_real *));
  iw = (casadi_int *)calloc((size_t)n_iw + 1, sizeof(casadi_int));
  w = (casadi_real *)calloc((size_t)n_w + 1, sizeof(casadi_real));
  in = (casadi_real **)calloc((size_t)FN_N_IN() + 1, sizeof(casadi_real *));
  out = (casadi_real **)calloc((size_t)FN_N_OUT() + 1, sizeof(casadi_real *));
  if (!arg || !res || !iw || !w || !in || !out) return 3;
  for (i = 0; i < FN_N_IN(); ++i) {
    casadi_int m = bench_nnz(FN_SP_IN(i));
    in[i] = (casadi_real *)calloc((size_t)m + 1, sizeof(casadi_real));
    for (j = 0; j < m; ++j) {
      if (fscanf(fh, "%lf", &in[i][j]) != 1) {
        fprintf(stderr, "bench_function: input %ld needs %ld numbers\n", (long)i, (long)m);
        return 2;
      }
    }
    arg[i] = in[i];
  }
  fclose(fh);
  for (i = 0; i < FN_N_OUT(); ++i) {
    out[i] = (casadi_real *)calloc((size_t)bench_nnz(FN_SP_OUT(i)) + 1, sizeof(casadi_real));
    res[i] = out[i];
  }
  for (rep = 0; rep < 5; ++rep) {
    double t0 = now_ns(), t;
    for (k = 0; k < n; ++k) {
      if (FN(arg, res, iw, w, 0)) return 4;
      sink += out[0][0];
    }
    t = (now_ns() - t0) / (double)n / 1000.0;
    if (t < best) best = t;
  }
  printf("{\"us_per_call\": %.4f, \"finite\": %d, \"outputs\": [", best, sink == sink ? 1 : 0);
  for (i = 0; i < FN_N_OUT(); ++i) {
    if (i) fputs(", ", stdout);
    bench_print_array(out[i], bench_nnz(FN_SP_OUT(i)));
  }
  puts("]}");
  return 0;
}
