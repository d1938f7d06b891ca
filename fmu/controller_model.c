/*
 * controller_model.c - per-model part of BallbotController: connects the shared FMI 2.0
 * layer (fmi2_common.c) to the CasADi-generated embedded software (ballbot_controller_cg.c:
 * CTRL_EMBEDDED = ballbot_embedded_<ctrl>_<est>, the Function the compiled mission calls,
 * and bbc_rpy, the ZYX angles of a quaternion).  ctrl_vr.h / ctrl_vars.h are generated from
 * the variable table of ballbot_casadi/fmi/controller.py (value indices CTRL_IX_<name>,
 * block starts, the Function's argument positions CTRL_ARG_<input>, CTRL_RES_<output>).
 *
 * Period k runs at t_k = startTime + k Ts.  fmi2DoStep(t_k, n Ts) runs periods k..k+n-1:
 * the first on the readings latched at t_k, the others predict only (readings missing);
 * the encoder reading of period 0 is missing (no previous count).  The outputs after the
 * step are those of the last period.  Any other step size is refused.  The embedded
 * software's state (c_*), the period counter and the held outputs live in the FMU's
 * variables, so FMU states and fmi2Reset need nothing from this file.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "ballbot_controller_cg.h"
#include "ctrl_vars.h"
#include "fmi2_common.h"

#define NMEAS 9
#define ENC0 6 /* encoders in the readings: acc (3), gyro (3), enc (3) */

typedef struct {
    const casadi_real *arg[CTRL_SZ_ARG];
    casadi_real *res[CTRL_SZ_RES];
    casadi_int iw[CTRL_SZ_IW + 1];
    casadi_real w[CTRL_SZ_W + 1];
    double meas[NMEAS], c_next[CTRL_NC], cascade, feedforward, com_observer;
} ctrl_work;

static int all_finite(const double *v, size_t n) {
    size_t i;
    for (i = 0; i < n; ++i)
        if (!isfinite(v[i])) return 0;
    return 1;
}

static int quat_ok(const double *q, double tol) {
    double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    return fabs(n - 1.0) <= tol;
}

/* The covariance matrices' diagonals must be >= 0 (0: no noise). */
static int check_cov(const double *r, size_t first, size_t n, const char *name, char *msg,
                     size_t len) {
    size_t i;
    for (i = 0; i < n; ++i) {
        double d = r[first + i * n + i];
        if (!(d >= 0.0)) {
            snprintf(msg, len, "%s_%lu_%lu = %g: a covariance's diagonal must be >= 0", name,
                     (unsigned long)i, (unsigned long)i, d);
            return 1;
        }
    }
    return 0;
}

static int check_initial(const fmu_values *v, int restored, char *msg, size_t len) {
    const double *r = v->r;
    const double *c = r + (restored ? CTRL_C0 : CTRL_C0PAR);
    if (!quat_ok(c + CTRL_C_XA, restored ? CTRL_QUAT_TOL_RESTORED : CTRL_QUAT_TOL)) {
        snprintf(msg, len, "%s attitude estimate [%g, %g, %g, %g] (%s_xa_0..3) must be a unit "
                 "quaternion (norm 1 within %g)", restored ? "the restored" : "the initial",
                 c[CTRL_C_XA], c[CTRL_C_XA + 1], c[CTRL_C_XA + 2], c[CTRL_C_XA + 3],
                 restored ? "c" : "c0", restored ? CTRL_QUAT_TOL_RESTORED : CTRL_QUAT_TOL);
        return 1;
    }
    return check_cov(r, CTRL_QA0, 6, "Qa", msg, len) || check_cov(r, CTRL_RA0, 6, "Ra", msg, len) ||
           check_cov(r, CTRL_QV0, CTRL_NQV, "Qv", msg, len) ||
           check_cov(r, CTRL_RV0, 6, "Rv", msg, len);
}

/* Outputs that decode the state: the estimate's attitude angles and body rate. */
static int decode(ctrl_work *wk, double *r, const double *c) {
    memcpy(r + CTRL_OMEGA0, c + CTRL_C_XA + 4, 3 * sizeof(double));
    wk->arg[0] = r + CTRL_XHAT0 + 2; /* q_hat */
    wk->res[0] = r + CTRL_RPY0;
    return bbc_rpy(wk->arg, wk->res, wk->iw, wk->w, 0);
}

static fmi2Status initialize(fmu_instance *inst, fmu_values *v, double t, char *msg,
                             size_t len) {
    ctrl_work *wk = (ctrl_work *)fmu_model_work(inst);
    double *r = v->r, *x = r + CTRL_XHAT0;
    const double *c = r + CTRL_C0, *q;
    (void)t;
    memcpy(r + CTRL_C0, r + CTRL_C0PAR, CTRL_NC * sizeof(double));
    v->i[CTRL_IX_period] = 0;
    /* the estimate before the first period: the state at power-on */
    q = c + CTRL_C_XA;
    x[0] = c[CTRL_C_POS];
    x[1] = c[CTRL_C_POS + 1];
    memcpy(x + 2, q, 4 * sizeof(double));
    x[6] = c[CTRL_C_XV];
    x[7] = c[CTRL_C_XV + 1];
    /* dq = 1/2 q o [0, omega] */
    x[8] = 0.5 * (-q[1] * q[4] - q[2] * q[5] - q[3] * q[6]);
    x[9] = 0.5 * (q[0] * q[4] + q[2] * q[6] - q[3] * q[5]);
    x[10] = 0.5 * (q[0] * q[5] + q[3] * q[4] - q[1] * q[6]);
    x[11] = 0.5 * (q[0] * q[6] + q[1] * q[5] - q[2] * q[4]);
    if (decode(wk, r, c) != 0 || !all_finite(x, 12)) {
        snprintf(msg, len, "the initial estimate (c0_*) is NaN or Inf");
        return fmi2Error;
    }
    return fmi2OK;
}

/* One period of the embedded software (k: its index; fresh: the readings are new). */
static int period(ctrl_work *wk, fmu_values *v, long k, int fresh) {
    double *r = v->r;
    int i;
    for (i = 0; i < NMEAS; ++i) wk->meas[i] = fresh ? r[CTRL_MEAS0 + i] : NAN;
    if (k == 0)
        for (i = ENC0; i < NMEAS; ++i) wk->meas[i] = NAN; /* no previous count */
    wk->cascade = v->b[CTRL_IX_balance_only] ? 0.0 : 1.0;
    wk->feedforward = v->b[CTRL_IX_feedforward] ? 1.0 : 0.0;
    wk->arg[CTRL_ARG_c] = r + CTRL_C0;
    wk->arg[CTRL_ARG_meas] = wk->meas;
    wk->arg[CTRL_ARG_q_ref] = r + CTRL_REF0;
    wk->arg[CTRL_ARG_dq_ref] = r + CTRL_REF0 + 4;
    wk->arg[CTRL_ARG_ddq_ref] = r + CTRL_REF0 + 8;
    wk->arg[CTRL_ARG_v_ref] = r + CTRL_REF0 + 12;
    wk->arg[CTRL_ARG_p_ctrl] = r + CTRL_P_CTRL0;
    wk->arg[CTRL_ARG_p_est] = r + CTRL_P_EST0;
    wk->arg[CTRL_ARG_k_bal] = r + CTRL_K_BAL0;
    wk->arg[CTRL_ARG_k_vel] = r + CTRL_K_VEL0;
    wk->arg[CTRL_ARG_Ts] = r + CTRL_IX_Ts;
    wk->arg[CTRL_ARG_cascade] = &wk->cascade;
    wk->arg[CTRL_ARG_feedforward] = &wk->feedforward;
    wk->arg[CTRL_ARG_Qa] = r + CTRL_QA0;
    wk->arg[CTRL_ARG_Ra] = r + CTRL_RA0;
    wk->arg[CTRL_ARG_Qv] = r + CTRL_QV0;
    wk->arg[CTRL_ARG_Rv] = r + CTRL_RV0;
    wk->res[CTRL_RES_c_next] = wk->c_next;
    wk->res[CTRL_RES_tau_lim] = r + CTRL_TAU0;
    wk->res[CTRL_RES_tau_cmd] = r + CTRL_TAUCMD0;
    wk->res[CTRL_RES_x_hat] = r + CTRL_XHAT0;
    wk->res[CTRL_RES_q_ref_used] = r + CTRL_REFUSED0;
    wk->res[CTRL_RES_dq_ref_used] = r + CTRL_REFUSED0 + 4;
    wk->res[CTRL_RES_ddq_ref_used] = r + CTRL_REFUSED0 + 8;
    wk->res[CTRL_RES_diag] = r + CTRL_DIAG0;
    wk->res[CTRL_RES_nis] = r + CTRL_NIS0;
    wk->res[CTRL_RES_repairs] = r + CTRL_IX_repairs;
#if CTRL_HAS_OBSERVER
    wk->com_observer = v->b[CTRL_IX_com_observer] ? 1.0 : 0.0;
    wk->arg[CTRL_ARG_com_observer] = &wk->com_observer;
    wk->arg[CTRL_ARG_k_obs] = r + CTRL_K_OBS0;
    wk->res[CTRL_RES_com_hat] = r + CTRL_COMHAT0;
#endif
    if (CTRL_EMBEDDED(wk->arg, wk->res, wk->iw, wk->w, 0) != 0) return 1;
    if (!all_finite(wk->c_next, CTRL_NC) || !all_finite(r + CTRL_TAU0, 6) ||
        !all_finite(r + CTRL_XHAT0, 12))
        return 1;
    memcpy(r + CTRL_C0, wk->c_next, sizeof wk->c_next);
    return decode(wk, r, r + CTRL_C0);
}

static fmi2Status do_step(fmu_instance *inst, fmu_values *v, double t, double h, char *msg,
                          size_t len) {
    ctrl_work *wk = (ctrl_work *)fmu_model_work(inst);
    double Ts = v->r[CTRL_IX_Ts], n = floor(h / Ts + 0.5);
    long k = v->i[CTRL_IX_period], j;
    if (!(n >= 1.0) || !(fabs(h - n * Ts) <= CTRL_STEP_TOL * Ts)) {
        snprintf(msg, len, "communication step %.17g is not a whole number of controller "
                 "periods Ts = %g (use a multiple of Ts)", h, Ts);
        return fmi2Error;
    }
    if (!(n <= CTRL_MAX_PERIODS) || !((double)k + n <= CTRL_PERIOD_MAX)) {
        snprintf(msg, len, "communication step %g from t = %g spans %g periods (at most %g per "
                 "step, period index at most %.0f)", h, t, n, CTRL_MAX_PERIODS,
                 CTRL_PERIOD_MAX);
        return fmi2Error;
    }
    for (j = 0; j < (long)n; ++j) {
        if (period(wk, v, k + j, j == 0) != 0) {
            snprintf(msg, len, "period %ld (t = %g) of the embedded software gave NaN or Inf "
                     "(check the parameters and the readings)", k + j,
                     fmu_start_time(inst) + (double)(k + j) * Ts);
            return fmi2Discard;
        }
    }
    v->i[CTRL_IX_period] = (fmi2Integer)(k + (long)n);
    return fmi2OK;
}

const fmu_model_def fmu_model = {
    CTRL_MODEL_IDENTIFIER, CTRL_GUID, FMU_CS, &ctrl_variables, sizeof(ctrl_work),
    check_initial, initialize, NULL, do_step, NULL, NULL, NULL,
};
