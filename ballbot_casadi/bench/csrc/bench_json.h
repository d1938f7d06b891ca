/* What the C benchmarks share to print the outputs they timed (include after the
 * generated header, which defines casadi_real and casadi_int). */
#ifndef BALLBOT_BENCH_JSON_H
#define BALLBOT_BENCH_JSON_H
#include <math.h>
#include <stddef.h>
#include <stdio.h>

/* Number of nonzeros of a CasADi sparsity pattern: [nrow, ncol, colind[ncol + 1], row[nnz]],
 * or [nrow, ncol, 1] when dense (a compressed pattern always starts its colind with 0). */
static inline casadi_int bench_nnz(const casadi_int *sp) {
  return sp[2] == 1 ? sp[0] * sp[1] : sp[2 + sp[1]];
}

/* Number of elements of an array (not of a pointer). */
#define BENCH_LEN(a) (sizeof(a) / sizeof((a)[0]))

/* 0 if the program hands n <= n_fn buffers to the first inputs (or outputs) of Function
 * `fn` and buffer i holds len[i] >= nnz(sp(i)) reals; else 1 and one line on stderr naming
 * the buffer that the generated code has outgrown (the buffers are sized by hand).  Inputs
 * past n are NULL pointers, which CasADi reads as zeros; outputs past n are not written. */
static inline int bench_sizes_fail(const char *fn, const char *kind, casadi_int n_fn,
                                   const casadi_int *(*sp)(casadi_int), const size_t *len,
                                   casadi_int n) {
  casadi_int i;
  if (n > n_fn) {
    fprintf(stderr, "%s has %ld %ss, the program hands it %ld\n", fn, (long)n_fn, kind, (long)n);
    return 1;
  }
  for (i = 0; i < n; ++i)
    if ((casadi_int)len[i] < bench_nnz(sp(i))) {
      fprintf(stderr, "%s %s %ld needs %ld reals, the program's buffer holds %lu\n", fn, kind,
              (long)i, (long)bench_nnz(sp(i)), (unsigned long)len[i]);
      return 1;
    }
  return 0;
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
