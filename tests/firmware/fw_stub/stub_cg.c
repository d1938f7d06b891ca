/* stub_cg.c - the stand-in period and guidance sample (tests only; see ballbot_fw_config.h).
 *
 * Period: c_next = c with c[0] + 1; tau_lim = (c[0], meas[0] (NaN -> -1), 10 cascade + Ts
 *   + 1e-3 sum_j (j + 1) ref_j over the 15 references);
 * echo = the readings (NaN -> -1), q_ref[0], q_ref[3], dq_ref[1], ddq_ref[2], v_ref[0..2],
 * cascade, Ts, Qa[3], k[1].  meas[0] = 666: returns 1; 777: c_next[0] NaN; 888: tau NaN.
 * Guidance: v_ref_used = (c[3], c[1], k_guid[1]); split: the counter c[1] counts modulo
 * BALLBOT_FW_GUIDANCE_EVERY and a period with counter 0 stores due (FIRST_LATENCY while
 * first, else LATENCY) and snap (c[0], c[7]).
 * Samples (X, g, k) -> (v, g_next): first g_next = (0, 1000 + 100 X[0] + X[1] + k[0]);
 * next g_next = (0, g[1] + 100 X[0] + X[1] + k[1]); k[0] < 0: g_next NaN (a failed sample). */
#include <math.h>

#include "ballbot_fw_config.h"

/* sum over the 15 references (q_ref, dq_ref, ddq_ref, v_ref in order) of (j + 1) ref_j:
 * every reference moves the torque by its own amount, so a reference read from the wrong
 * place shows in the replay's rows */
static double refs_weighted(const double **arg) {
    const double *r[4];
    double sum = 0;
    int j, i, at = 0;
    r[0] = arg[BALLBOT_FW_ARG_q_ref]; r[1] = arg[BALLBOT_FW_ARG_dq_ref];
    r[2] = arg[BALLBOT_FW_ARG_ddq_ref]; r[3] = arg[BALLBOT_FW_ARG_v_ref];
    for (j = 0; j < 4; ++j)
        for (i = 0; i < (j < 3 ? 4 : 3); ++i) sum += (double)(++at) * r[j][i];
    return sum;
}

int stub_period(const double **arg, double **res, casadi_int *iw, double *w, int mem) {
    const double *c = arg[BALLBOT_FW_ARG_c], *m = arg[BALLBOT_FW_ARG_meas];
    double *cn = res[BALLBOT_FW_RES_c_next], *tau = res[BALLBOT_FW_RES_tau_lim];
    double *e = res[BALLBOT_FW_RES_echo];
    int i;
    (void)iw; (void)w; (void)mem;
    if (m[0] == 666) return 1;
    for (i = 0; i < BALLBOT_FW_NC; ++i) cn[i] = c[i];
    cn[0] = m[0] == 777 ? NAN : c[0] + 1;
    tau[0] = c[0];
    tau[1] = isnan(m[0]) ? -1 : m[0];
    tau[2] = m[0] == 888 ? NAN : 10 * arg[BALLBOT_FW_ARG_cascade][0] + arg[BALLBOT_FW_ARG_Ts][0]
                                 + 1e-3 * refs_weighted(arg);
    for (i = 0; i < BALLBOT_FW_N_READINGS; ++i) e[i] = isnan(m[i]) ? -1 : m[i];
    e[5] = arg[BALLBOT_FW_ARG_q_ref][0];
    e[6] = arg[BALLBOT_FW_ARG_q_ref][3];
    e[7] = arg[BALLBOT_FW_ARG_dq_ref][1];
    e[8] = arg[BALLBOT_FW_ARG_ddq_ref][2];
    for (i = 0; i < 3; ++i) e[9 + i] = arg[BALLBOT_FW_ARG_v_ref][i];
    e[12] = arg[BALLBOT_FW_ARG_cascade][0];
    e[13] = arg[BALLBOT_FW_ARG_Ts][0];
    e[14] = arg[BALLBOT_FW_ARG_Qa][3];
    e[15] = arg[BALLBOT_FW_ARG_k][1];
#if STUB_GUIDANCE
    res[BALLBOT_FW_RES_v_ref_used][0] = c[3];
    res[BALLBOT_FW_RES_v_ref_used][1] = c[1];
    res[BALLBOT_FW_RES_v_ref_used][2] = arg[BALLBOT_FW_ARG_k_guid][1];
#if STUB_SPLIT
    cn[1] = fmod(c[1] + 1, BALLBOT_FW_GUIDANCE_EVERY);
    if (c[1] == 0) {
        cn[4] = c[2] > 0.5 ? BALLBOT_FW_GUIDANCE_FIRST_LATENCY : BALLBOT_FW_GUIDANCE_LATENCY;
        cn[5] = c[0];
        cn[6] = c[7];
    }
#endif
#endif
    return 0;
}

void (*stub_during_sample)(void) = 0;

static int sample(const double **arg, double **res, double base, double k) {
    const double *X = arg[0], *g = arg[1], *kg = arg[2];
    if (stub_during_sample != 0) stub_during_sample();
    res[0][0] = X[0];
    res[0][1] = X[1];
    res[1][0] = 0;
    res[1][1] = kg[0] < 0 ? NAN : base + 100 * X[0] + X[1] + k;
    (void)g;
    return 0;
}

int stub_sample_first(const double **arg, double **res, casadi_int *iw, double *w, int mem) {
    (void)iw; (void)w; (void)mem;
    return sample(arg, res, 1000, arg[2][0]);
}

int stub_sample_next(const double **arg, double **res, casadi_int *iw, double *w, int mem) {
    (void)iw; (void)w; (void)mem;
    return sample(arg, res, arg[1][1], arg[2][1]);
}
