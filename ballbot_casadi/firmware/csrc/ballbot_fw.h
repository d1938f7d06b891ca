/*
 * ballbot_fw.h - C API of the ballbot embedded software (one 200 Hz period per call).
 *
 * The period is the CasADi-generated Function ballbot_embedded_<ctrl>_<est> (attitude and
 * velocity filters, COM observer, velocity LQR, balance controller, torque limit), the one
 * the compiled mission and the controller FMU run.  ballbot_fw_config.h (generated with the
 * library) fixes the precision (ballbot_fw_real = double or float), the sizes, the
 * parameter struct and the reading layout.
 *
 * No malloc, no global mutable state: everything lives in one caller-owned
 * ballbot_fw_ctx (statically allocated by the caller).  Not re-entrant on one context.
 *
 *   ballbot_fw_ctx ctx;                            (static, caller-owned)
 *   ballbot_fw_params p;
 *   ballbot_fw_default_params(&p);                 (or fill from flash/EEPROM)
 *   ballbot_fw_init(&ctx, &p, NULL);               (NULL: the default power-on state)
 *   every 5 ms: ballbot_fw_step(&ctx, readings, &refs, torques);
 *
 * With a guidance block (BALLBOT_FW_GUIDANCE 1: the path-following MPC of the guided
 * mission, one sample every BALLBOT_FW_GUIDANCE_EVERY periods) the period computes the
 * velocity reference itself (refs->v_ref[2], the heading rate, is still read) from its
 * data: the path table and obstacles (BALLBOT_FW_N_GUIDANCE values, the layout of the
 * package's path_table_layout), caller-owned and only read, so it can live in flash.
 * ballbot_fw_init points the context at ballbot_fw_default_guidance_data;
 *   ballbot_fw_set_guidance(&ctx, my_path_table);   (before the first step)
 * gives another path; the power-on state c0 carries the robot's progress on the path
 * (the default: the default path's start).
 *
 * Split guidance (BALLBOT_FW_GUIDANCE_SPLIT 1, a build with latency L =
 * BALLBOT_FW_GUIDANCE_LATENCY >= 1): the 200 Hz step runs the estimator and the controllers
 * only; in a period whose guidance counter is 0 it also takes a snapshot (the loop state
 * and the guidance state) for the sample.  The sample runs in the main loop:
 *   for (;;) ballbot_fw_guidance_background(&ctx);   (returns at once when nothing is due)
 * and its result is applied by the step of the period L after the snapshot
 * (BALLBOT_FW_GUIDANCE_FIRST_LATENCY for the cold first sample), never earlier, so the
 * firmware is deterministic: it equals the compiled guided mission with that latency.
 * A result not finished by then is not applied (ctx.guidance_late counts it; the
 * previous reference holds until the next sample).
 */
#ifndef BALLBOT_FW_H
#define BALLBOT_FW_H

#include "ballbot_fw_config.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Return codes. */
#define BALLBOT_FW_OK 0            /* all readings used */
#define BALLBOT_FW_PREDICT_ONLY 1  /* some reading was NaN/Inf: its filter predicted only */
#define BALLBOT_FW_EPARAM (-1)     /* a parameter is non-finite or out of range: not applied */
#define BALLBOT_FW_EFAULT (-2)     /* the period gave NaN/Inf: torques zeroed, state kept */
#define BALLBOT_FW_EARG (-3)       /* a NULL pointer */
#define BALLBOT_FW_GUIDANCE_IDLE 0  /* ballbot_fw_guidance_background: no sample pending */
#define BALLBOT_FW_GUIDANCE_RAN 1   /* ... it ran the pending sample */

/* The mode and references of one period. */
typedef struct ballbot_fw_references {
    ballbot_fw_real q_ref[4];   /* attitude reference quaternion (balance-only mode) */
    ballbot_fw_real dq_ref[4];  /* its rate (1/s) */
    ballbot_fw_real ddq_ref[4]; /* its second derivative (1/s^2; used with feedforward) */
    ballbot_fw_real v_ref[3];   /* velocity cascade: vx, vy (m/s), heading rate (rad/s) */
    int balance_only;           /* 1: the balance controller follows q_ref alone; 0: cascade */
} ballbot_fw_references;

/* The caller-owned context: parameters, state, outputs of the last period, work memory. */
typedef struct ballbot_fw_ctx {
    ballbot_fw_params params;               /* settable at run time: ballbot_fw_set_params */
    ballbot_fw_real c[BALLBOT_FW_NC];       /* the embedded software's state */
    ballbot_fw_outputs out;                 /* every output of the last accepted period */
    ballbot_fw_real c_next[BALLBOT_FW_NC];  /* work: the candidate next state */
    ballbot_fw_real meas[BALLBOT_FW_N_READINGS];
    ballbot_fw_real cascade;
    const ballbot_fw_real *arg[BALLBOT_FW_SZ_ARG];
    ballbot_fw_real *res[BALLBOT_FW_SZ_RES];
    casadi_int iw[BALLBOT_FW_SZ_IW + 1];
    ballbot_fw_real w[BALLBOT_FW_SZ_W + 1];
    unsigned long period;                   /* index of the next period */
    unsigned long faults;                   /* periods rejected with BALLBOT_FW_EFAULT */
#if BALLBOT_FW_GUIDANCE
    const ballbot_fw_real *guidance;        /* the guidance data (not copied) */
#endif
#if BALLBOT_FW_GUIDANCE_SPLIT
    /* The background sample: snapshot, result, its state, the period it is due. */
    volatile int bg_state;                  /* BALLBOT_FW_BG_*: written by step and background */
    unsigned long bg_due;                   /* the period whose step applies the result */
    unsigned long guidance_late;            /* results not ready at their due period */
    unsigned long guidance_faults;          /* samples that gave NaN/Inf (not applied) */
    ballbot_fw_real bg_X[BALLBOT_FW_GUIDE_NSNAP];   /* snapshot: the loop state */
    ballbot_fw_real bg_g[BALLBOT_FW_GUIDE_NS];      /* snapshot: the sample state */
    ballbot_fw_real bg_v[BALLBOT_FW_GUIDE_NV];      /* result: the sample's reference */
    ballbot_fw_real bg_g_next[BALLBOT_FW_GUIDE_NS]; /* result: the next sample state */
    const ballbot_fw_real *bg_arg[BALLBOT_FW_BG_SZ_ARG];
    ballbot_fw_real *bg_res[BALLBOT_FW_BG_SZ_RES];
    casadi_int bg_iw[BALLBOT_FW_BG_SZ_IW + 1];
    ballbot_fw_real bg_w[BALLBOT_FW_BG_SZ_W + 1];
#endif
} ballbot_fw_ctx;

/* The package's default parameters (the controller FMU's start values). */
void ballbot_fw_default_params(ballbot_fw_params *params);
/* The default power-on state: robot upright at rest, filters aligned. */
void ballbot_fw_default_state(ballbot_fw_real c0[BALLBOT_FW_NC]);
/* Check params (finite, Ts > 0, covariance diagonals >= 0); BALLBOT_FW_OK or EPARAM. */
int ballbot_fw_check_params(const ballbot_fw_params *params);
/* Start: parameters and power-on state c0 (NULL: default).  BALLBOT_FW_OK, EPARAM or EARG. */
int ballbot_fw_init(ballbot_fw_ctx *ctx, const ballbot_fw_params *params,
                    const ballbot_fw_real *c0);
/* Replace the parameters at run time (state kept); a rejected set changes nothing. */
int ballbot_fw_set_params(ballbot_fw_ctx *ctx, const ballbot_fw_params *params);
/* One period: readings (BALLBOT_FW_N_READINGS in the order of BALLBOT_FW_READING_*; NaN
 * = missing) and references in, the three wheel torques (N m, limited) out.  Returns
 * BALLBOT_FW_OK, PREDICT_ONLY, EFAULT (torques 0) or EARG.  torques are always finite. */
int ballbot_fw_step(ballbot_fw_ctx *ctx, const ballbot_fw_real *readings,
                    const ballbot_fw_references *refs, ballbot_fw_real torques[3]);
#if BALLBOT_FW_GUIDANCE
/* Point the guidance block at its data (BALLBOT_FW_N_GUIDANCE values, kept by pointer: it
 * must outlive the context).  BALLBOT_FW_OK, EPARAM (a value not finite: nothing changed)
 * or EARG. */
int ballbot_fw_set_guidance(ballbot_fw_ctx *ctx, const ballbot_fw_real *data);
#endif
#if BALLBOT_FW_GUIDANCE_SPLIT
/* Background states (ctx->bg_state). */
#define BALLBOT_FW_BG_IDLE 0     /* nothing to do */
#define BALLBOT_FW_BG_PENDING 1  /* a snapshot waits for its sample */
#define BALLBOT_FW_BG_RUNNING 2  /* the background task runs it */
#define BALLBOT_FW_BG_DONE 3     /* its result waits for the due period */
/* The main loop's task: run the pending guidance sample on its snapshot.
 * BALLBOT_FW_GUIDANCE_RAN, BALLBOT_FW_GUIDANCE_IDLE (nothing pending), EFAULT (the
 * sample gave NaN/Inf: not applied) or EARG.  Interrupted by the step at any point. */
int ballbot_fw_guidance_background(ballbot_fw_ctx *ctx);
#endif

#ifdef __cplusplus
}
#endif
#endif /* BALLBOT_FW_H */
