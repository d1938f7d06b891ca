/* What the C benchmarks share to print the outputs they timed (include after the
 * generated header, which defines casadi_real and casadi_int). */
#ifndef BALLBOT_BENCH_JSON_H
#define BALLBOT_BENCH_JSON_H
#include <math.h>
#include <stdio.h>

/* Number of nonzeros of a CasADi sparsity pattern: [nrow, ncol, colind[ncol + 1], row[nnz]],
 * or [nrow, ncol, 1] when dense (a compressed pattern always starts its colind with 0). */
static inline casadi_int bench_nnz(const casadi_int *sp) {
  return sp[2] == 1 ? sp[0] * sp[1] : sp[2 + sp[1]];
}

/* One JSON array of n numbers, full precision (NaN and +-Infinity as Python's json reads them). */
static inline void bench_print_array(const casadi_real *v, casadi_int n) {
  casadi_int i;
  putchar('[');
  for (i = 0; i < n; ++i) {
    if (i) fputs(", ", stdout);
    if (isnan(v[i])) fputs("NaN", stdout);
    else if (isinf(v[i])) fputs(v[i] > 0 ? "Infinity" : "-Infinity", stdout);
    else printf("%.17g", v[i]);
  }
  putchar(']');
}

#endif
