/* Micro-benchmark of generated CasADi functions: ns per call, printed as JSON.
 * Usage: bench_model N_CALLS
 * Each entry point is called with the default robot state slightly tilted; the work
 * vectors are allocated once, before timing (no malloc in the timed loop). */
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "ballbot_model.h"

typedef int (*entry_fn)(const casadi_real **, casadi_real **, casadi_int *, casadi_real *, int);
typedef int (*work_fn)(casadi_int *, casadi_int *, casadi_int *, casadi_int *);

static double now_ns(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}

static volatile double sink;

static double bench(entry_fn f, work_fn wf, const casadi_real **arg, long n) {
  casadi_int sz_arg, sz_res, sz_iw, sz_w;
  casadi_real out[1024];
  casadi_real *res[8];
  casadi_int *iw;
  casadi_real *w;
  double best = 1e300;
  int rep;
  long i;
  wf(&sz_arg, &sz_res, &sz_iw, &sz_w);
  iw = (casadi_int *)malloc(sizeof(casadi_int) * (size_t)(sz_iw + 1));
  w = (casadi_real *)malloc(sizeof(casadi_real) * (size_t)(sz_w + 1));
  for (i = 0; i < 8; ++i) res[i] = out + 256 * (i % 4);
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
  static const casadi_real x[12] = {0.1, -0.2, 0.99904822, 0.0348995, 0.0261769, 0.0,
                                   0.1, 0.05, 0.0, 0.01, -0.02, 0.03};
  static const casadi_real tau[3] = {0.2, -0.1, 0.3};
  static casadi_real p[64];
  const casadi_real *arg[8];
  int i;
  for (i = 1; i < argc - 1 && i - 1 < 64; ++i) p[i - 1] = atof(argv[i + 1]);
  arg[0] = x; arg[1] = tau; arg[2] = p;
  arg[3] = arg[4] = arg[5] = arg[6] = arg[7] = 0;
  {
    double ode = bench(ballbot_ode, ballbot_ode_work, arg, n);
    double jac = bench(ballbot_jac, ballbot_jac_work, arg, n / 4 + 1);
    printf("{\"ode_ns\": %.2f, \"jac_ns\": %.2f, \"sink\": %g}\n", ode, jac, sink == sink ? 0.0 : 1.0);
  }
  return 0;
}
