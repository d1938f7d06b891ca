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
 * With CTRL_HAS_GUIDANCE (BallbotControllerPath, ballbot_casadi/fmi/controller/path.py)
 * CTRL_EMBEDDED is the embedded software with the path-following MPC in its guidance
 * slot (the compiled guided mission's Function): it reads the path table k_guid (FMU
 * parameters, checked by check_path), its state c carries the guidance state c_guide_*,
 * which initialize() starts with CTRL_GUIDE_INITIAL (ballbot_guidance_mpc_initial, the
 * Function the mission starts from) at path_s0.
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

typedef struct {
    fmu_casadi_work cg;
    double meas[CTRL_MEAS_N], c_next[CTRL_C_N], cascade, feedforward, com_observer;
#if CTRL_HAS_GUIDANCE
    double c0[CTRL_C_N - CTRL_C_GUIDE_N]; /* the state at power-on without the guidance's */
#endif
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

#if CTRL_HAS_GUIDANCE
/* Point of the path table at arc length s (s in [0, L]): linear interpolation. */
static void path_point(const double *k, double s, double *p) {
    const double *pts = k + CTRL_K_GUID_POINTS;
    double u = s / k[CTRL_K_GUID_LENGTH] * (double)(CTRL_PATH_SAMPLES - 1), f;
    long i = (long)floor(u);
    if (i < 0) i = 0;
    if (i > CTRL_PATH_SAMPLES - 2) i = CTRL_PATH_SAMPLES - 2;
    f = u - (double)i;
    p[0] = (1.0 - f) * pts[2 * i] + f * pts[2 * i + 2];
    p[1] = (1.0 - f) * pts[2 * i + 1] + f * pts[2 * i + 3];
}

/* The path table, its obstacles and path_s0 (module docstring of
 * ballbot_casadi/fmi/controller/path.py). */
static int check_path(const double *r, char *msg, size_t len) {
    const double *k = r + CTRL_K_GUID_IX, *ob = k + CTRL_K_GUID_OBSTACLES;
    const double *pts = k + CTRL_K_GUID_POINTS, *tg = k + CTRL_K_GUID_TANGENTS;
    const double L = k[CTRL_K_GUID_LENGTH], s0 = r[CTRL_IX_path_s0];
    const double *x0 = r + CTRL_X0_IX + CTRL_X0_X;
    double best = INFINITY, p[2], d;
    size_t i, j;
    for (i = 0; i < CTRL_K_GUID_N; ++i)
        if (!isfinite(k[i])) {
            snprintf(msg, len, "path parameter %lu of the path table (path_length .. obstacle*_r) "
                     "is %g: every entry must be finite", (unsigned long)i, k[i]);
            return 1;
        }
    if (!(L > 0.0) || !(k[CTRL_K_GUID_CLOSED] == 0.0 || k[CTRL_K_GUID_CLOSED] == 1.0) ||
        !(k[CTRL_K_GUID_SPEED] > 0.0 && k[CTRL_K_GUID_SPEED] <= CTRL_V_MAX)) {
        snprintf(msg, len, "path_length = %g, path_closed = %g, path_speed = %g: need a length "
                 "> 0, closed 0 or 1 and a speed in (0, %g] m/s", L, k[CTRL_K_GUID_CLOSED],
                 k[CTRL_K_GUID_SPEED], CTRL_V_MAX);
        return 1;
    }
    for (i = 0; i < CTRL_PATH_SAMPLES; ++i) {
        double n = sqrt(tg[2 * i] * tg[2 * i] + tg[2 * i + 1] * tg[2 * i + 1]);
        double dx = pts[2 * i] - x0[0], dy = pts[2 * i + 1] - x0[1];
        if (!(fabs(n - 1.0) <= CTRL_TANGENT_TOL)) {
            snprintf(msg, len, "path_t%lu = [%g, %g] must be a unit vector (norm 1 within %g)",
                     (unsigned long)i, tg[2 * i], tg[2 * i + 1], CTRL_TANGENT_TOL);
            return 1;
        }
        if (dx * dx + dy * dy < best) best = dx * dx + dy * dy;
    }
    for (j = 0; j < CTRL_PATH_OBSTACLES; ++j) {
        const double *o = ob + 3 * j;
        const double *at[3];
        const char *what[3] = {"the path's start (path_p0)", "the path's end", "the robot's start "
                               "(x0_x, x0_y)"};
        if (!(o[2] >= 0.0)) {
            snprintf(msg, len, "obstacle%lu_r = %g must be >= 0 (0: no obstacle)", (unsigned long)j,
                     o[2]);
            return 1;
        }
        at[0] = pts;
        at[1] = pts + 2 * (CTRL_PATH_SAMPLES - 1);
        at[2] = x0;
        for (i = 0; i < 3; ++i) {
            double dx = at[i][0] - o[0], dy = at[i][1] - o[1];
            if (o[2] > 0.0 && dx * dx + dy * dy < o[2] * o[2]) {
                snprintf(msg, len, "obstacle%lu (radius %g m at [%g, %g]) covers %s [%g, %g]: the "
                         "path cannot pass through it", (unsigned long)j, o[2], o[0], o[1],
                         what[i], at[i][0], at[i][1]);
                return 1;
            }
        }
    }
    if (!(s0 >= 0.0 && s0 <= L)) {
        snprintf(msg, len, "path_s0 = %g must be in [0, path_length = %g]", s0, L);
        return 1;
    }
    path_point(k, s0, p);
    d = sqrt((p[0] - x0[0]) * (p[0] - x0[0]) + (p[1] - x0[1]) * (p[1] - x0[1]));
    if (!(d <= sqrt(best) + CTRL_S0_TOL)) {
        snprintf(msg, len, "path_s0 = %g puts the start %g m from the robot (x0_x, x0_y), the "
                 "nearest path point is %g m away: path_s0 must be the start's projection on "
                 "the path (within %g m)", s0, d, sqrt(best), CTRL_S0_TOL);
        return 1;
    }
    return 0;
}
#endif

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
#if CTRL_HAS_GUIDANCE
           check_path(r, msg, len) ||
#endif
           check_cov(r, CTRL_RV_IX, 6, "Rv", msg, len);
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
#if CTRL_HAS_GUIDANCE
    /* the state without the guidance's, then the guidance's state g0 as the compiled
     * guided mission starts it (CTRL_GUIDE_INITIAL: the law's initial Function of the
     * robot's state x0_*, the velocity controller's state at power-on and path_s0) */
    wk->cg.res[CTRL_INITIAL_RES_C0] = wk->c0;
    if (fmu_casadi_call(&wk->cg, CTRL_INITIAL_FN) != 0) {
        snprintf(msg, len, "the state at power-on from x0_* and ctrl_* could not be computed");
        return fmi2Error;
    }
    memcpy(r + CTRL_C_IX, wk->c0, CTRL_C_GUIDE * sizeof(double));
    memcpy(r + CTRL_C_IX + CTRL_C_GUIDE + CTRL_C_GUIDE_N, wk->c0 + CTRL_C_GUIDE,
           (CTRL_C_N - CTRL_C_GUIDE - CTRL_C_GUIDE_N) * sizeof(double));
    wk->cg.arg[CTRL_GUIDE_INITIAL_ARG_X0] = r + CTRL_X0_IX;
    wk->cg.arg[CTRL_GUIDE_INITIAL_ARG_Z0] = c + CTRL_C_Z;
    wk->cg.arg[CTRL_GUIDE_INITIAL_ARG_S0] = r + CTRL_IX_path_s0;
    wk->cg.res[CTRL_GUIDE_INITIAL_RES_G0] = r + CTRL_C_IX + CTRL_C_GUIDE;
    if (fmu_casadi_call(&wk->cg, CTRL_GUIDE_INITIAL_FN) != 0 || !fmu_all_finite(c, CTRL_C_N)) {
#else
    wk->cg.res[CTRL_INITIAL_RES_C0] = r + CTRL_C_IX;
    if (fmu_casadi_call(&wk->cg, CTRL_INITIAL_FN) != 0 || !fmu_all_finite(c, CTRL_C_N)) {
#endif
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
#if CTRL_HAS_GUIDANCE
    arg[CTRL_EMBEDDED_ARG_K_GUID] = r + CTRL_K_GUID_IX;
    res[CTRL_EMBEDDED_RES_V_REF_USED] = r + CTRL_V_REF_USED_IX;
#endif
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
