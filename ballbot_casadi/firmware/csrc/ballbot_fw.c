/*
 * ballbot_fw.c - the C API of ballbot_fw.h around the generated period BALLBOT_FW_EMBEDDED.
 *
 * A reading that is NaN or Inf is passed on as NaN: its filter predicts only for that
 * sensor, as in the host step.  The encoder readings of period 0 are missing (there is no
 * previous count to difference), as in the controller FMU.  A period whose result is not
 * finite is rejected: the torques are 0, the state is kept, the fault is counted.
 *
 * Split guidance (ballbot_fw.h): the step of a period whose guidance counter is 0 copies
 * the snapshot (the loop state the period's block stored, the sample state) for
 * ballbot_fw_guidance_background and records the due period (this period plus the
 * latency the block stored); the step of the due period first writes the finished
 * sample state into the guidance state, so the period's block applies it.
 */
#include <math.h>
#include <string.h>

#include "ballbot_fw.h"

static int all_finite(const ballbot_fw_real *v, int n) {
    int i;
    for (i = 0; i < n; ++i)
        if (!isfinite(v[i])) return 0;
    return 1;
}

void ballbot_fw_default_params(ballbot_fw_params *params) {
    if (params != NULL) *params = ballbot_fw_default_params_data;
}

void ballbot_fw_default_state(ballbot_fw_real c0[BALLBOT_FW_NC]) {
    if (c0 != NULL) memcpy(c0, ballbot_fw_default_c0, sizeof ballbot_fw_default_c0);
}

int ballbot_fw_check_params(const ballbot_fw_params *p) {
    int i;
    if (p == NULL) return BALLBOT_FW_EARG;
#define BALLBOT_FW_CHECK_FINITE(name, n) \
    if (!all_finite(p->name, n)) return BALLBOT_FW_EPARAM;
    BALLBOT_FW_PARAM_FIELDS(BALLBOT_FW_CHECK_FINITE)
#undef BALLBOT_FW_CHECK_FINITE
#define BALLBOT_FW_CHECK_COV(name, n) \
    for (i = 0; i < (n); ++i)         \
        if (!(p->name[i * (n) + i] >= 0)) return BALLBOT_FW_EPARAM;
    BALLBOT_FW_COV_FIELDS(BALLBOT_FW_CHECK_COV)
#undef BALLBOT_FW_CHECK_COV
    if (!(p->Ts[0] > 0)) return BALLBOT_FW_EPARAM;
    (void)i;
    return BALLBOT_FW_OK;
}

int ballbot_fw_set_params(ballbot_fw_ctx *ctx, const ballbot_fw_params *params) {
    int rc;
    if (ctx == NULL || params == NULL) return BALLBOT_FW_EARG;
    rc = ballbot_fw_check_params(params);
    if (rc == BALLBOT_FW_OK) ctx->params = *params;
    return rc;
}

int ballbot_fw_init(ballbot_fw_ctx *ctx, const ballbot_fw_params *params,
                    const ballbot_fw_real *c0) {
    int rc;
    if (ctx == NULL || params == NULL) return BALLBOT_FW_EARG;
    rc = ballbot_fw_check_params(params);
    if (rc != BALLBOT_FW_OK) return rc;
    memset(ctx, 0, sizeof *ctx);
#if BALLBOT_FW_GUIDANCE_SPLIT
    ctx->bg_state = BALLBOT_FW_BG_IDLE;
    ctx->bg_due = (unsigned long)-1;
#endif
    ctx->params = *params;
    if (c0 == NULL) c0 = ballbot_fw_default_c0;
    if (!all_finite(c0, BALLBOT_FW_NC)) return BALLBOT_FW_EPARAM;
    memcpy(ctx->c, c0, sizeof ctx->c);
#if BALLBOT_FW_GUIDANCE
    ctx->guidance = ballbot_fw_default_guidance_data;
#endif
    return BALLBOT_FW_OK;
}

#if BALLBOT_FW_GUIDANCE
int ballbot_fw_set_guidance(ballbot_fw_ctx *ctx, const ballbot_fw_real *data) {
    if (ctx == NULL || data == NULL) return BALLBOT_FW_EARG;
    if (!all_finite(data, BALLBOT_FW_N_GUIDANCE)) return BALLBOT_FW_EPARAM;
    ctx->guidance = data;
    return BALLBOT_FW_OK;
}
#endif

#if BALLBOT_FW_GUIDANCE_SPLIT
int ballbot_fw_guidance_background(ballbot_fw_ctx *ctx) {
    int ok;
    if (ctx == NULL) return BALLBOT_FW_EARG;
    if (ctx->bg_state != BALLBOT_FW_BG_PENDING) return BALLBOT_FW_GUIDANCE_IDLE;
    ctx->bg_state = BALLBOT_FW_BG_RUNNING; /* the step leaves the snapshot alone now */
    ctx->bg_arg[0] = ctx->bg_X;
    ctx->bg_arg[1] = ctx->bg_g;
    ctx->bg_arg[2] = ctx->guidance;
    ctx->bg_res[0] = ctx->bg_v;
    ctx->bg_res[1] = ctx->bg_g_next;
    /* the sample's two branches, chosen by its state's first as its conditional does */
    ok = (ctx->bg_g[BALLBOT_FW_GUIDE_FIRST] > 0.5
              ? BALLBOT_FW_GUIDANCE_SAMPLE_FIRST(ctx->bg_arg, ctx->bg_res, ctx->bg_iw, ctx->bg_w, 0)
              : BALLBOT_FW_GUIDANCE_SAMPLE_NEXT(ctx->bg_arg, ctx->bg_res, ctx->bg_iw, ctx->bg_w, 0)) == 0 &&
         all_finite(ctx->bg_g_next, BALLBOT_FW_GUIDE_NS);
    if (!ok) {
        ctx->guidance_faults++;
        ctx->bg_state = BALLBOT_FW_BG_IDLE;
        return BALLBOT_FW_EFAULT;
    }
    ctx->bg_state = BALLBOT_FW_BG_DONE;
    return BALLBOT_FW_GUIDANCE_RAN;
}

/* Before the period: the due period applies the finished sample (or counts it late). */
static void guidance_apply(ballbot_fw_ctx *ctx) {
    if (ctx->period != ctx->bg_due) return;
    ctx->bg_due = (unsigned long)-1;
    if (ctx->bg_state == BALLBOT_FW_BG_DONE) {
        memcpy(ctx->c + BALLBOT_FW_GUIDE_OFFSET + 1, ctx->bg_g_next, sizeof ctx->bg_g_next);
        ctx->bg_state = BALLBOT_FW_BG_IDLE;
    } else {
        ctx->guidance_late++;
    }
}

/* After an accepted period whose counter was 0: the snapshot for the background. */
static void guidance_snapshot(ballbot_fw_ctx *ctx, unsigned long period) {
    const ballbot_fw_real *g = ctx->c_next + BALLBOT_FW_GUIDE_OFFSET;
    if (ctx->bg_state == BALLBOT_FW_BG_RUNNING) { /* the last sample still runs: skip */
        ctx->guidance_late++;
        return;
    }
    memcpy(ctx->bg_X, g + BALLBOT_FW_GUIDE_SNAP, sizeof ctx->bg_X);
    memcpy(ctx->bg_g, g + 1, sizeof ctx->bg_g);
    ctx->bg_due = period + (unsigned long)g[BALLBOT_FW_GUIDE_DUE];
    ctx->bg_state = BALLBOT_FW_BG_PENDING;
}
#endif

int ballbot_fw_step(ballbot_fw_ctx *ctx, const ballbot_fw_real *readings,
                    const ballbot_fw_references *refs, ballbot_fw_real torques[3]) {
    int i, rc = BALLBOT_FW_OK;
#if BALLBOT_FW_GUIDANCE_SPLIT
    int sampling;
#endif
    if (torques == NULL) return BALLBOT_FW_EARG;
    torques[0] = torques[1] = torques[2] = 0;
    if (ctx == NULL || readings == NULL || refs == NULL) return BALLBOT_FW_EARG;
#if BALLBOT_FW_GUIDANCE_SPLIT
    guidance_apply(ctx);
    sampling = ctx->c[BALLBOT_FW_GUIDE_OFFSET] == 0;
#endif
    for (i = 0; i < BALLBOT_FW_N_READINGS; ++i) {
        int fresh = isfinite(readings[i]) &&
                    !(ctx->period == 0 && i >= BALLBOT_FW_READING_ENC &&
                      i < BALLBOT_FW_READING_ENC + BALLBOT_FW_N_ENC);
        ctx->meas[i] = fresh ? readings[i] : (ballbot_fw_real)NAN;
        if (!fresh) rc = BALLBOT_FW_PREDICT_ONLY;
    }
    ctx->cascade = refs->balance_only ? 0 : 1;
    ctx->arg[BALLBOT_FW_ARG_c] = ctx->c;
    ctx->arg[BALLBOT_FW_ARG_meas] = ctx->meas;
    ctx->arg[BALLBOT_FW_ARG_cascade] = &ctx->cascade;
#define BALLBOT_FW_WIRE_REF(name, n) ctx->arg[BALLBOT_FW_ARG_##name] = refs->name;
    BALLBOT_FW_REFERENCE_FIELDS(BALLBOT_FW_WIRE_REF)
#undef BALLBOT_FW_WIRE_REF
#define BALLBOT_FW_WIRE_PAR(name, n) ctx->arg[BALLBOT_FW_ARG_##name] = ctx->params.name;
    BALLBOT_FW_PARAM_FIELDS(BALLBOT_FW_WIRE_PAR)
#undef BALLBOT_FW_WIRE_PAR
#define BALLBOT_FW_WIRE_RES(name, n) ctx->res[BALLBOT_FW_RES_##name] = ctx->out.name;
    BALLBOT_FW_OUTPUT_FIELDS(BALLBOT_FW_WIRE_RES)
#undef BALLBOT_FW_WIRE_RES
    ctx->res[BALLBOT_FW_RES_c_next] = ctx->c_next;
#if BALLBOT_FW_GUIDANCE
    ctx->arg[BALLBOT_FW_ARG_k_guid] = ctx->guidance;
#endif
    ctx->period++;
    if (BALLBOT_FW_EMBEDDED(ctx->arg, ctx->res, ctx->iw, ctx->w, 0) != 0 ||
        !all_finite(ctx->c_next, BALLBOT_FW_NC) || !all_finite(ctx->out.tau_lim, 3)) {
        ctx->faults++;
        return BALLBOT_FW_EFAULT;
    }
#if BALLBOT_FW_GUIDANCE_SPLIT
    if (sampling) guidance_snapshot(ctx, ctx->period - 1);
#endif
    memcpy(ctx->c, ctx->c_next, sizeof ctx->c);
    for (i = 0; i < 3; ++i) torques[i] = ctx->out.tau_lim[i];
    return rc;
}
