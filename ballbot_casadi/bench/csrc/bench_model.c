/* Micro-benchmark of generated CasADi functions: ns per call, printed as JSON.
 * Usage: bench_model N_CALLS x[12] tau[3] p[...]   (p: exactly the model's parameters)
 * Each entry point is called with the state, torques and parameters given; the work
 * vectors are allocated once, before timing (no malloc in the timed loop).  The outputs
 * of the timed calls (the inputs do not change) are printed for the caller to verify. */
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "ballbot_model.h"
#include "bench_json.h"

typedef int (*entry_fn)(const casadi_real **, casadi_real **, casadi_int *, casadi_real *, int);
typedef int (*work_fn)(casadi_int *, casadi_int *, casadi_int *, casadi_int *);

static double now_ns(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}

static volatile double sink;

#define OUT_STRIDE 256

/* `"key": [output 0, output 1, ...]`, output i's nonzeros at out + OUT_STRIDE i. */
static void print_outputs(const char *key, casadi_int n_out, const casadi_int *(*sp)(casadi_int),
                          const casadi_real *out) {
  casadi_int k;
  printf(", \"%s\": [", key);
  for (k = 0; k < n_out; ++k) {
    if (k) fputs(", ", stdout);
    bench_print_array(out + OUT_STRIDE * k, bench_nnz(sp(k)));
  }
  putchar(']');
}

/* Best of 5 timings of n calls (ns per call); output i of the calls in out + OUT_STRIDE i. */
static double bench(entry_fn f, work_fn wf, const casadi_real **arg, long n, casadi_real *out) {
  casadi_int sz_arg, sz_res, sz_iw, sz_w;
  casadi_real *res[8];
  casadi_int *iw;
  casadi_real *w;
  double best = 1e300;
  int rep;
  long i;
  wf(&sz_arg, &sz_res, &sz_iw, &sz_w);
  iw = (casadi_int *)malloc(sizeof(casadi_int) * (size_t)(sz_iw + 1));
  w = (casadi_real *)malloc(sizeof(casadi_real) * (size_t)(sz_w + 1));
  for (i = 0; i < 8; ++i) res[i] = out + OUT_STRIDE * (i % 4);
  for (rep = 0; rep < 5; ++rep) {
    double t0 = now_ns(), t;
    for (i = 0; i < n; ++i) {
      f(arg, res, iw, w, 0);
      sink += out[0];
    }
    t = (now_ns() - t0) / (double)n;
    if (t < best) best = t;
  }
  free(iw);
  free(w);
  return best;
}

int main(int argc, char **argv) {
  long n = argc > 1 ? atol(argv[1]) : 100000;
  static casadi_real x[12], tau[3], p[64], ode_out[4 * OUT_STRIDE], jac_out[4 * OUT_STRIDE];
  const casadi_real *arg[8];
  int i, np_;
  if (argc < 17) {
    fprintf(stderr, "usage: bench_model N_CALLS x[12] tau[3] p[...]\n");
    return 2;
  }
  for (i = 0; i < 12; ++i) x[i] = atof(argv[2 + i]);
  for (i = 0; i < 3; ++i) tau[i] = atof(argv[14 + i]);
  np_ = (int)bench_nnz(ballbot_ode_sparsity_in(2));
  if (np_ > 64 || argc - 17 != np_) {
    fprintf(stderr, "bench_model: expected %d parameters, got %d\n", np_, argc - 17);
    return 2;
  }
  for (i = 0; i < np_; ++i) p[i] = atof(argv[17 + i]);
  {
    /* every buffer holds its argument or result (exit 3: the program is out of date) */
    const size_t in[] = {BENCH_LEN(x), BENCH_LEN(tau), BENCH_LEN(p)};
    const size_t out[] = {OUT_STRIDE, OUT_STRIDE, OUT_STRIDE, OUT_STRIDE};
    if (ballbot_ode_n_out() > 4 || ballbot_jac_n_out() > 4) {
      fprintf(stderr, "bench_model: more than 4 outputs (%ld, %ld): the buffers alias\n",
              (long)ballbot_ode_n_out(), (long)ballbot_jac_n_out());
      return 3;
    }
    if (bench_sizes_fail("ballbot_ode", "input", ballbot_ode_n_in(), ballbot_ode_sparsity_in, in,
                         BENCH_LEN(in)) ||
        bench_sizes_fail("ballbot_jac", "input", ballbot_jac_n_in(), ballbot_jac_sparsity_in, in,
                         BENCH_LEN(in)) ||
        bench_sizes_fail("ballbot_ode", "output", ballbot_ode_n_out(), ballbot_ode_sparsity_out,
                         out, ballbot_ode_n_out()) ||
        bench_sizes_fail("ballbot_jac", "output", ballbot_jac_n_out(), ballbot_jac_sparsity_out,
                         out, ballbot_jac_n_out()))
      return 3;
  }
  arg[0] = x; arg[1] = tau; arg[2] = p;
  arg[3] = arg[4] = arg[5] = arg[6] = arg[7] = 0;
  {
    double ode = bench(ballbot_ode, ballbot_ode_work, arg, n, ode_out);
    double jac = bench(ballbot_jac, ballbot_jac_work, arg, n / 4 + 1, jac_out);
    printf("{\"ode_ns\": %.2f, \"jac_ns\": %.2f, \"sink\": %g", ode, jac, sink == sink ? 0.0 : 1.0);
    print_outputs("check_ode", ballbot_ode_n_out(), ballbot_ode_sparsity_out, ode_out);
    print_outputs("check_jac", ballbot_jac_n_out(), ballbot_jac_sparsity_out, jac_out);
    puts("}");
  }
  return 0;
}
