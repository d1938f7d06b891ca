/*
 * controller_path.c - the path-following controller FMU's own part (BallbotControllerPath,
 * ballbot_casadi/fmi/controller/path.py): the checks of its path parameters and the start
 * of the guidance state.  Compiled only into that variant, with controller_model.c.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "controller_path.h"
#include "ctrl_vr.h"

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
 * ballbot_casadi/fmi/controller/path.py); 1 with the message in msg if one is bad. */
int ctrl_path_check(const double *r, char *msg, size_t len) {
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

/* The state at power-on (the caller set CTRL_INITIAL's result to c): CTRL_INITIAL's
 * state without the guidance's (into the scratch c0), around the guidance state g0 as
 * the compiled guided mission starts it (CTRL_GUIDE_INITIAL, the law's initial Function,
 * of the robot's state x0_*, the velocity controller's state at power-on and path_s0). */
int ctrl_path_start(fmu_casadi_work *cg, double *r, double *c0) {
    double *c = r + CTRL_C_IX;
    cg->res[CTRL_INITIAL_RES_C0] = c0;
    if (fmu_casadi_call(cg, CTRL_INITIAL_FN) != 0) return 1;
    memcpy(c, c0, CTRL_C_GUIDE * sizeof(double));
    memcpy(c + CTRL_C_GUIDE + CTRL_C_GUIDE_N, c0 + CTRL_C_GUIDE,
           (CTRL_C_N - CTRL_C_GUIDE - CTRL_C_GUIDE_N) * sizeof(double));
    cg->arg[CTRL_GUIDE_INITIAL_ARG_X0] = r + CTRL_X0_IX;
    cg->arg[CTRL_GUIDE_INITIAL_ARG_Z0] = c + CTRL_C_Z;
    cg->arg[CTRL_GUIDE_INITIAL_ARG_S0] = r + CTRL_IX_path_s0;
    cg->res[CTRL_GUIDE_INITIAL_RES_G0] = c + CTRL_C_GUIDE;
    return fmu_casadi_call(cg, CTRL_GUIDE_INITIAL_FN);
}

/* The embedded software's guidance argument (the path table) and result (v_ref_used). */
void ctrl_path_args(const double **arg, double **res, double *r) {
    arg[CTRL_EMBEDDED_ARG_K_GUID] = r + CTRL_K_GUID_IX;
    res[CTRL_EMBEDDED_RES_V_REF_USED] = r + CTRL_V_REF_USED_IX;
}
