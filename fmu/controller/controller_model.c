/*
 * controller_model.c - per-model part of BallbotController: connects the shared FMI 2.0
 * layer (fmi2_common.c) to the CasADi-generated embedded software (ballbot_controller_cg.c:
 * CTRL_EMBEDDED = ballbot_embedded_<ctrl>_<est>, the Function the compiled mission calls;
 * CTRL_INITIAL = ballbot_initial_controller_state_<est>[_obs], the state at power-on the
 * compiled mission starts from; bbc_rpy, the ZYX angles of a quaternion).  ctrl_vr.h /
 * ctrl_vars.h are generated from the variable table of
 * ballbot_casadi/fmi/controller/controller.py: value indices CTRL_IX_<name>, the packed
 * vectors by name (CTRL_<BLOCK>_IX: value index of the first element, CTRL_<BLOCK>_<FIELD>:
 * offset of a field, _N: sizes; the state c, its filter parts xa and xv, the robot's state
 * at power-on x0, the readings meas, the references ref, the estimate x_hat, ...) and the
 * Functions' argument positions (CTRL_<F>_ARG_<input>, CTRL_<F>_RES_<output>), which the
 * calls below set by name (fmu_casadi.h).
 *
 * CTRL_HAS_GUIDANCE (BallbotControllerPath): CTRL_EMBEDDED has the path-following MPC in
 * its guidance slot; controller_path.c is that variant's part (path table, guidance state).
 *
 * Period k runs at t_k = startTime + k Ts.  fmi2DoStep(t_k, n Ts) runs periods k..k+n-1:
 * the first on the readings latched at t_k, the others predict only (readings missing);
 * a step within CTRL_STEP_TOL Ts of n Ts counts as n periods, and n = 0 (a step far
 * shorter than Ts, e.g. the rounding remainder of an importer's clock) runs none;
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
#include "fmu_casadi.h"
#if CTRL_HAS_GUIDANCE
#include "controller_path.h"
#else /* no guidance: no path to check or pass, the state at power-on is CTRL_INITIAL's */
#define ctrl_path_check(r, msg, len) 0
#define ctrl_path_start(cg, r, scratch) fmu_casadi_call(cg, CTRL_INITIAL_FN)
#define ctrl_path_args(arg, res, r) ((void)0)
#endif

typedef struct {
    fmu_casadi_work cg;
    double meas[CTRL_MEAS_N], c_next[CTRL_C_N], cascade, feedforward, com_observer;
} ctrl_work;

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

/* The attitude to check: the restored estimate, or the robot's attitude at power-on. */
static int check_initial(const fmu_values *v, int restored, char *msg, size_t len) {
    const double *r = v->r;
    const double *q = restored ? r + CTRL_C_IX + CTRL_C_XA + CTRL_XA_Q : r + CTRL_X0_IX + CTRL_X0_Q;
    if (!quat_ok(q, restored ? CTRL_QUAT_TOL_RESTORED : CTRL_QUAT_TOL)) {
        snprintf(msg, len, "%s [%g, %g, %g, %g] (%s) must be a unit quaternion (norm 1 within "
                 "%g)", restored ? "the restored attitude estimate" : "the initial attitude",
                 q[0], q[1], q[2], q[3], restored ? "c_xa_0..3" : "x0_q0..3",
                 restored ? CTRL_QUAT_TOL_RESTORED : CTRL_QUAT_TOL);
        return 1;
    }
    return check_cov(r, CTRL_QA_IX, CTRL_NQA, "Qa", msg, len) ||
           check_cov(r, CTRL_RA_IX, CTRL_NRA, "Ra", msg, len) ||
           check_cov(r, CTRL_QV_IX, CTRL_NQV, "Qv", msg, len) ||
           check_cov(r, CTRL_RV_IX, 6, "Rv", msg, len) || ctrl_path_check(r, msg, len);
}

/* Outputs that decode the state: the estimate's attitude angles and body rate. */
static int decode(ctrl_work *wk, double *r, const double *c) {
    memcpy(r + CTRL_OMEGA_IX, c + CTRL_C_XA + CTRL_XA_OMEGA, CTRL_OMEGA_N * sizeof(double));
    wk->cg.arg[CTRL_BBC_RPY_ARG_Q] = r + CTRL_X_HAT_IX + CTRL_X_HAT_Q;
    wk->cg.res[CTRL_BBC_RPY_RES_RPY] = r + CTRL_RPY_IX;
    return fmu_casadi_call(&wk->cg, CTRL_BBC_RPY_FN);
}

static fmi2Status initialize(fmu_instance *inst, fmu_values *v, double t, char *msg,
                             size_t len) {
    ctrl_work *wk = (ctrl_work *)fmu_model_work(inst);
    double *r = v->r, *x = r + CTRL_X_HAT_IX, *dq = x + CTRL_X_HAT_DQ;
    const double *c = r + CTRL_C_IX, *q, *w;
    (void)t;
    /* the state at power-on: CTRL_INITIAL (the Function the compiled mission starts from)
     * of the robot's state x0_* and the controllers' model ctrl_* */
    wk->cg.arg[CTRL_INITIAL_ARG_X0] = r + CTRL_X0_IX;
    wk->cg.arg[CTRL_INITIAL_ARG_P_CTRL] = r + CTRL_P_CTRL_IX;
    wk->cg.res[CTRL_INITIAL_RES_C0] = r + CTRL_C_IX;
    if (ctrl_path_start(&wk->cg, r, wk->c_next) != 0 || !fmu_all_finite(c, CTRL_C_N)) {
        snprintf(msg, len, "the state at power-on from x0_* and ctrl_* is NaN or Inf");
        return fmi2Error;
    }
    v->i[CTRL_IX_period] = 0;
    /* the estimate before the first period: the state at power-on */
    q = c + CTRL_C_XA + CTRL_XA_Q;
    w = c + CTRL_C_XA + CTRL_XA_OMEGA;
    /* [x, y] = pos, q = the attitude filter's q, [dx, dy] = the velocity filter's v */
    memcpy(x + CTRL_X_HAT_X, c + CTRL_C_POS, CTRL_C_POS_N * sizeof(double));
    memcpy(x + CTRL_X_HAT_Q, q, CTRL_X_HAT_Q_N * sizeof(double));
    memcpy(x + CTRL_X_HAT_DX, c + CTRL_C_XV + CTRL_XV_V, CTRL_XV_V_N * sizeof(double));
    /* dq = 1/2 q o [0, omega] */
    dq[0] = 0.5 * (-q[1] * w[0] - q[2] * w[1] - q[3] * w[2]);
    dq[1] = 0.5 * (q[0] * w[0] + q[2] * w[2] - q[3] * w[1]);
    dq[2] = 0.5 * (q[0] * w[1] + q[3] * w[0] - q[1] * w[2]);
    dq[3] = 0.5 * (q[0] * w[2] + q[1] * w[1] - q[2] * w[0]);
    if (decode(wk, r, c) != 0 || !fmu_all_finite(x, CTRL_X_HAT_N)) {
        snprintf(msg, len, "the initial estimate is NaN or Inf");
        return fmi2Error;
    }
    return fmi2OK;
}

/* One period of the embedded software (k: its index; fresh: the readings are new). */
static int period(ctrl_work *wk, fmu_values *v, long k, int fresh) {
    double *r = v->r;
    const double *ref = r + CTRL_REF_IX;
    const double **arg = wk->cg.arg;
    double **res = wk->cg.res;
    int i;
    for (i = 0; i < CTRL_MEAS_N; ++i) wk->meas[i] = fresh ? r[CTRL_MEAS_IX + i] : NAN;
    if (k == 0)
        for (i = 0; i < CTRL_MEAS_ENC_N; ++i)
            wk->meas[CTRL_MEAS_ENC + i] = NAN; /* no previous count */
    wk->cascade = v->b[CTRL_IX_balance_only] ? 0.0 : 1.0;
    wk->feedforward = v->b[CTRL_IX_feedforward] ? 1.0 : 0.0;
    arg[CTRL_EMBEDDED_ARG_C] = r + CTRL_C_IX;
    arg[CTRL_EMBEDDED_ARG_MEAS] = wk->meas;
    arg[CTRL_EMBEDDED_ARG_Q_REF] = ref + CTRL_REF_Q_REF;
    arg[CTRL_EMBEDDED_ARG_DQ_REF] = ref + CTRL_REF_DQ_REF;
    arg[CTRL_EMBEDDED_ARG_DDQ_REF] = ref + CTRL_REF_DDQ_REF;
    arg[CTRL_EMBEDDED_ARG_V_REF] = ref + CTRL_REF_V_REF;
    arg[CTRL_EMBEDDED_ARG_P_CTRL] = r + CTRL_P_CTRL_IX;
    arg[CTRL_EMBEDDED_ARG_P_EST] = r + CTRL_P_EST_IX;
    arg[CTRL_EMBEDDED_ARG_K_BAL] = r + CTRL_K_BAL_IX;
    arg[CTRL_EMBEDDED_ARG_K_VEL] = r + CTRL_K_VEL_IX;
    arg[CTRL_EMBEDDED_ARG_TS] = r + CTRL_IX_Ts;
    arg[CTRL_EMBEDDED_ARG_CASCADE] = &wk->cascade;
    arg[CTRL_EMBEDDED_ARG_FEEDFORWARD] = &wk->feedforward;
    arg[CTRL_EMBEDDED_ARG_QA] = r + CTRL_QA_IX;
    arg[CTRL_EMBEDDED_ARG_RA] = r + CTRL_RA_IX;
    arg[CTRL_EMBEDDED_ARG_QV] = r + CTRL_QV_IX;
    arg[CTRL_EMBEDDED_ARG_RV] = r + CTRL_RV_IX;
    res[CTRL_EMBEDDED_RES_C_NEXT] = wk->c_next;
    res[CTRL_EMBEDDED_RES_TAU_LIM] = r + CTRL_TAU_IX;
    res[CTRL_EMBEDDED_RES_TAU_CMD] = r + CTRL_TAU_CMD_IX;
    res[CTRL_EMBEDDED_RES_X_HAT] = r + CTRL_X_HAT_IX;
    res[CTRL_EMBEDDED_RES_Q_REF_USED] = r + CTRL_REF_USED_IX + CTRL_REF_USED_Q;
    res[CTRL_EMBEDDED_RES_DQ_REF_USED] = r + CTRL_REF_USED_IX + CTRL_REF_USED_DQ;
    res[CTRL_EMBEDDED_RES_DDQ_REF_USED] = r + CTRL_REF_USED_IX + CTRL_REF_USED_DDQ;
    res[CTRL_EMBEDDED_RES_DIAG] = r + CTRL_DIAG_IX;
    res[CTRL_EMBEDDED_RES_NIS] = r + CTRL_NIS_IX;
    res[CTRL_EMBEDDED_RES_REPAIRS] = r + CTRL_IX_repairs;
    res[CTRL_EMBEDDED_RES_REJECTIONS] = r + CTRL_REJECTIONS_IX;
#if CTRL_HAS_OBSERVER
    wk->com_observer = v->b[CTRL_IX_com_observer] ? 1.0 : 0.0;
    arg[CTRL_EMBEDDED_ARG_COM_OBSERVER] = &wk->com_observer;
    arg[CTRL_EMBEDDED_ARG_K_OBS] = r + CTRL_K_OBS_IX;
    res[CTRL_EMBEDDED_RES_COM_HAT] = r + CTRL_COM_HAT_IX;
#endif
    ctrl_path_args(arg, res, r);
    if (fmu_casadi_call(&wk->cg, CTRL_EMBEDDED_FN) != 0) return 1;
    if (!fmu_all_finite(wk->c_next, CTRL_C_N) || !fmu_all_finite(r + CTRL_TAU_IX, CTRL_TAU_N) ||
        !fmu_all_finite(r + CTRL_TAU_CMD_IX, CTRL_TAU_CMD_N) ||
        !fmu_all_finite(r + CTRL_X_HAT_IX, CTRL_X_HAT_N))
        return 1;
    memcpy(r + CTRL_C_IX, wk->c_next, sizeof wk->c_next);
    return decode(wk, r, r + CTRL_C_IX);
}

static fmi2Status do_step(fmu_instance *inst, fmu_values *v, double t, double h, char *msg,
                          size_t len) {
    ctrl_work *wk = (ctrl_work *)fmu_model_work(inst);
    double Ts = v->r[CTRL_IX_Ts], n = floor(h / Ts + 0.5);
    long k = v->i[CTRL_IX_period], j;
    /* within STEP_TOL Ts of n Ts counts as n periods, n = 0 included: an importer whose
     * clock is a running sum issues a last step of 1e-17 .. 1e-13 s, which runs nothing */
    if (!(fabs(h - n * Ts) <= CTRL_STEP_TOL * Ts)) {
        snprintf(msg, len, "communication step %.17g is not a whole number of controller "
                 "periods Ts = %g (use a multiple of Ts, within %g Ts)", h, Ts, CTRL_STEP_TOL);
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
