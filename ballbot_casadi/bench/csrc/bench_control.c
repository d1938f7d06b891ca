/* Micro-benchmark of the generated controllers and closed-loop step: us per call, JSON.
 * Usage: bench_control N_CALLS INPUT_FILE
 * INPUT_FILE holds whitespace-separated numbers:
 *   np nk_flc nk_smc nkv nz  p[np]  k_flc[nk_flc]  k_smc[nk_smc]  k_vel[nkv]  x[12]  z[nz]  Ts
 *   v_ref[3]
 * Timed: ballbot_velocity followed by ballbot_flc (one control period of the cascade),
 * the same with ballbot_smc, and the whole closed-loop period ballbot_cl_step_flc
 * (controllers + saturation + RK4 sub-steps), and the compiled chunk of CHUNK periods
 * ballbot_cl_chunk_flc from the given state (reported per period).  Work vectors are
 * allocated before timing; the best of 5 repetitions is reported.  The inputs do not
 * change between calls; the outputs of one call of each (the FLC's and the SMC's torque
 * after the velocity controller, the closed-loop step's and the chunk's first output) are
 * printed for the caller to verify against the Functions. */
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "ballbot_bench_control.h"
#include "bench_json.h"

#define MAXN 128
#define CHUNK 200

typedef int (*entry_fn)(const casadi_real **, casadi_real **, casadi_int *, casadi_real *, int);
typedef int (*work_fn)(casadi_int *, casadi_int *, casadi_int *, casadi_int *);

static volatile double sink;

static double now_ns(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}

/* Generated functions use the argument/result pointer arrays beyond their own inputs
 * and outputs as scratch for nested calls: allocate sz_arg / sz_res entries. */
typedef struct {
  const casadi_real **arg;
  casadi_real **res;
  casadi_int *iw;
  casadi_real *w;
} work_t;

static work_t alloc_work(work_fn wf) {
  casadi_int sz_arg, sz_res, sz_iw, sz_w;
  work_t wk;
  wf(&sz_arg, &sz_res, &sz_iw, &sz_w);
  wk.arg = (const casadi_real **)calloc((size_t)(sz_arg + 1), sizeof(casadi_real *));
  wk.res = (casadi_real **)calloc((size_t)(sz_res + 1), sizeof(casadi_real *));
  wk.iw = (casadi_int *)malloc(sizeof(casadi_int) * (size_t)(sz_iw + 1));
  wk.w = (casadi_real *)malloc(sizeof(casadi_real) * (size_t)(sz_w + 1));
  return wk;
}

static void free_work(work_t wk) {
  free((void *)wk.arg);
  free(wk.res);
  free(wk.iw);
  free(wk.w);
}

/* ", key: [v...]" of the printed JSON object. */
static void print_key(const char *key, const casadi_real *v, casadi_int n) {
  printf(", \"%s\": ", key);
  bench_print_array(v, n);
}

static int read_vec(FILE *fh, casadi_real *v, long n) {
  long i;
  for (i = 0; i < n; ++i)
    if (fscanf(fh, "%lf", &v[i]) != 1) return 1;
  return 0;
}

int main(int argc, char **argv) {
  long n = argc > 1 ? atol(argv[1]) : 100000, i;
  long np_, nkf, nks, nkv, nz;
  static casadi_real p[MAXN], kf[MAXN], ks[MAXN], kv[MAXN], x[12], z[MAXN], Ts;
  static casadi_real vref[3], qr[4], dqr[4], ddqr[4], zn[MAXN], tau[3], diag[MAXN];
  static casadi_real xz[MAXN], xzn[MAXN], xo[12], tc[3], ts_[3], q1[4], q2[4], q3[4], dg[MAXN];
  static casadi_real zero4[4], w6[6], one = 1.0;
  static casadi_real sq[CHUNK * 4], sz4[CHUNK * 4], sv[CHUNK * 3], sw[CHUNK * 6];
  static casadi_real chunk_out[9][MAXN * CHUNK];
  double best_chunk = 1e300;
  work_t wch;
  const casadi_real **va, **ba, **bs, **ca_;
  casadi_real **vr, **br, **bsr, **cr;
  work_t wv, wf_, ws, wc;
  double best[3] = {1e300, 1e300, 1e300};
  int rep, k;
  FILE *fh;
  if (argc < 3 || !(fh = fopen(argv[2], "r"))) {
    fprintf(stderr, "usage: bench_control N_CALLS INPUT_FILE\n");
    return 2;
  }
  if (fscanf(fh, "%ld %ld %ld %ld %ld", &np_, &nkf, &nks, &nkv, &nz) != 5 || np_ > MAXN ||
      nkf > MAXN || nks > MAXN || nkv > MAXN || nz + 12 > MAXN || read_vec(fh, p, np_) ||
      read_vec(fh, kf, nkf) || read_vec(fh, ks, nks) || read_vec(fh, kv, nkv) ||
      read_vec(fh, x, 12) || read_vec(fh, z, nz) || read_vec(fh, &Ts, 1) || read_vec(fh, vref, 3)) {
    fprintf(stderr, "bench_control: malformed input file\n");
    return 2;
  }
  fclose(fh);
  {
    /* every buffer below holds its argument or result (exit 3: the program is out of date) */
    const size_t v_in[] = {BENCH_LEN(x), BENCH_LEN(vref), BENCH_LEN(z), BENCH_LEN(p),
                           BENCH_LEN(kv), 1};
    const size_t v_out[] = {BENCH_LEN(qr), BENCH_LEN(dqr), BENCH_LEN(ddqr), BENCH_LEN(zn)};
    const size_t f_in[] = {BENCH_LEN(x), BENCH_LEN(qr), BENCH_LEN(dqr), BENCH_LEN(ddqr),
                           BENCH_LEN(p), BENCH_LEN(kf)};
    const size_t s_in[] = {BENCH_LEN(x), BENCH_LEN(qr), BENCH_LEN(dqr), BENCH_LEN(ddqr),
                           BENCH_LEN(p), BENCH_LEN(ks)};
    const size_t f_out[] = {BENCH_LEN(tau), BENCH_LEN(diag)};
    const size_t c_in[] = {BENCH_LEN(xz), BENCH_LEN(zero4), BENCH_LEN(zero4), BENCH_LEN(zero4),
                           BENCH_LEN(vref), BENCH_LEN(w6), BENCH_LEN(p), BENCH_LEN(p),
                           BENCH_LEN(kf), BENCH_LEN(kv), 1, 1, 1};
    const size_t c_out[] = {BENCH_LEN(xzn), BENCH_LEN(xo), BENCH_LEN(tc), BENCH_LEN(ts_),
                            BENCH_LEN(q1), BENCH_LEN(q2), BENCH_LEN(q3), BENCH_LEN(dg)};
    const size_t k_in[] = {BENCH_LEN(xz), BENCH_LEN(sq), BENCH_LEN(sz4), BENCH_LEN(sz4),
                           BENCH_LEN(sv), BENCH_LEN(sw), BENCH_LEN(p), BENCH_LEN(p),
                           BENCH_LEN(kf), BENCH_LEN(kv), 1, 1, 1};
    size_t k_out[BENCH_LEN(chunk_out)];
    for (k = 0; k < (int)BENCH_LEN(chunk_out); ++k) k_out[k] = BENCH_LEN(chunk_out[0]);
    if (bench_sizes_fail("ballbot_velocity", "input", ballbot_velocity_n_in(),
                         ballbot_velocity_sparsity_in, v_in, BENCH_LEN(v_in)) ||
        bench_sizes_fail("ballbot_velocity", "output", ballbot_velocity_n_out(),
                         ballbot_velocity_sparsity_out, v_out, BENCH_LEN(v_out)) ||
        bench_sizes_fail("ballbot_flc", "input", ballbot_flc_n_in(), ballbot_flc_sparsity_in,
                         f_in, BENCH_LEN(f_in)) ||
        bench_sizes_fail("ballbot_flc", "output", ballbot_flc_n_out(), ballbot_flc_sparsity_out,
                         f_out, BENCH_LEN(f_out)) ||
        bench_sizes_fail("ballbot_smc", "input", ballbot_smc_n_in(), ballbot_smc_sparsity_in,
                         s_in, BENCH_LEN(s_in)) ||
        bench_sizes_fail("ballbot_smc", "output", ballbot_smc_n_out(), ballbot_smc_sparsity_out,
                         f_out, BENCH_LEN(f_out)) ||
        bench_sizes_fail("ballbot_cl_step_flc", "input", ballbot_cl_step_flc_n_in(),
                         ballbot_cl_step_flc_sparsity_in, c_in, BENCH_LEN(c_in)) ||
        bench_sizes_fail("ballbot_cl_step_flc", "output", ballbot_cl_step_flc_n_out(),
                         ballbot_cl_step_flc_sparsity_out, c_out, BENCH_LEN(c_out)) ||
        bench_sizes_fail("ballbot_cl_chunk_flc", "input", ballbot_cl_chunk_flc_n_in(),
                         ballbot_cl_chunk_flc_sparsity_in, k_in, BENCH_LEN(k_in)) ||
        bench_sizes_fail("ballbot_cl_chunk_flc", "output", ballbot_cl_chunk_flc_n_out(),
                         ballbot_cl_chunk_flc_sparsity_out, k_out, BENCH_LEN(k_out)))
      return 3;
  }
  wv = alloc_work(ballbot_velocity_work);
  wf_ = alloc_work(ballbot_flc_work);
  ws = alloc_work(ballbot_smc_work);
  wc = alloc_work(ballbot_cl_step_flc_work);
  va = wv.arg; vr = wv.res; ba = wf_.arg; br = wf_.res; bs = ws.arg; bsr = ws.res;
  ca_ = wc.arg; cr = wc.res;
  va[0] = x; va[1] = vref; va[2] = z; va[3] = p; va[4] = kv; va[5] = &Ts;
  vr[0] = qr; vr[1] = dqr; vr[2] = ddqr; vr[3] = zn;
  ba[0] = x; ba[1] = qr; ba[2] = dqr; ba[3] = ddqr; ba[4] = p; ba[5] = kf;
  br[0] = tau; br[1] = diag;
  bs[0] = x; bs[1] = qr; bs[2] = dqr; bs[3] = ddqr; bs[4] = p; bs[5] = ks;
  bsr[0] = tau; bsr[1] = diag;
  memcpy(xz, x, sizeof(x));
  memcpy(xz + 12, z, sizeof(casadi_real) * (size_t)nz);
  ca_[0] = xz; ca_[1] = zero4; ca_[2] = zero4; ca_[3] = zero4; ca_[4] = vref; ca_[5] = w6;
  ca_[6] = p; ca_[7] = p; ca_[8] = kf; ca_[9] = kv; ca_[10] = &Ts; ca_[11] = &one;
  ca_[12] = &one;
  cr[0] = xzn; cr[1] = xo; cr[2] = tc; cr[3] = ts_; cr[4] = q1; cr[5] = q2; cr[6] = q3; cr[7] = dg;
  wch = alloc_work(ballbot_cl_chunk_flc_work);
  for (i = 0; i < CHUNK; ++i) {
    sq[4 * i] = 1.0;
    sv[3 * i] = vref[0]; sv[3 * i + 1] = vref[1]; sv[3 * i + 2] = vref[2];
  }
  wch.arg[0] = xz; wch.arg[1] = sq; wch.arg[2] = sz4; wch.arg[3] = sz4; wch.arg[4] = sv;
  wch.arg[5] = sw; wch.arg[6] = p; wch.arg[7] = p; wch.arg[8] = kf; wch.arg[9] = kv;
  wch.arg[10] = &Ts; wch.arg[11] = &one; wch.arg[12] = &one;
  for (k = 0; k < 9; ++k) wch.res[k] = chunk_out[k];
  for (rep = 0; rep < 5; ++rep) {
    double t0 = now_ns(), t;
    ballbot_cl_chunk_flc(wch.arg, wch.res, wch.iw, wch.w, 0);
    sink += chunk_out[0][0];
    t = (now_ns() - t0) / CHUNK / 1000.0;
    if (t < best_chunk) best_chunk = t;
  }
  for (rep = 0; rep < 5; ++rep) {
    for (k = 0; k < 3; ++k) {
      double t0 = now_ns(), t;
      for (i = 0; i < n; ++i) {
        if (k < 2) {
          ballbot_velocity(va, vr, wv.iw, wv.w, 0);
          if (k == 0) ballbot_flc(ba, br, wf_.iw, wf_.w, 0);
          else ballbot_smc(bs, bsr, ws.iw, ws.w, 0);
          sink += tau[0];
        } else {
          ballbot_cl_step_flc(ca_, cr, wc.iw, wc.w, 0);
          sink += xzn[0];
        }
      }
      t = (now_ns() - t0) / (double)n / 1000.0;
      if (t < best[k]) best[k] = t;
    }
  }
  printf("{\"control_step_us\": %.4f, \"control_step_smc_us\": %.4f, \"cl_period_us\": %.4f, "
         "\"cl_chunk_period_us\": %.4f, \"sink\": %g", best[0], best[1], best[2], best_chunk,
         sink == sink ? 0.0 : 1.0);
  /* one call of each on the same inputs, for the caller to verify */
  ballbot_velocity(va, vr, wv.iw, wv.w, 0);
  ballbot_flc(ba, br, wf_.iw, wf_.w, 0);
  print_key("check_tau_flc", tau, 3);
  ballbot_smc(bs, bsr, ws.iw, ws.w, 0);
  print_key("check_tau_smc", tau, 3);
  ballbot_cl_step_flc(ca_, cr, wc.iw, wc.w, 0);
  print_key("check_cl_step", xzn, bench_nnz(ballbot_cl_step_flc_sparsity_out(0)));
  ballbot_cl_chunk_flc(wch.arg, wch.res, wch.iw, wch.w, 0);
  print_key("check_chunk", chunk_out[0], bench_nnz(ballbot_cl_chunk_flc_sparsity_out(0)));
  puts("}");
  free_work(wv); free_work(wf_); free_work(ws); free_work(wc); free_work(wch);
  return 0;
}
