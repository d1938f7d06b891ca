/* stub_access.c - flat entry points around one static ballbot_fw_ctx for ctypes (tests only). */
#include <string.h>

#include "ballbot_fw.h"

#define NPAR ((int)(sizeof(ballbot_fw_params) / sizeof(ballbot_fw_real)))

static ballbot_fw_ctx ctx;
static ballbot_fw_params prm;
#if BALLBOT_FW_GUIDANCE
static ballbot_fw_real gdata[2][BALLBOT_FW_N_GUIDANCE]; /* alternate: a refusal keeps the last */
static int gnext;
#endif

int t_npar(void) { return NPAR; }
void t_default_params(double *out) {
    ballbot_fw_default_params(&prm);
    memcpy(out, &prm, sizeof prm);
}
void t_default_state(double *out) { ballbot_fw_default_state(out); }
int t_check_params(const double *p) {
    memcpy(&prm, p, sizeof prm);
    return ballbot_fw_check_params(&prm);
}
int t_init(const double *p, const double *c0) {
    memcpy(&prm, p, sizeof prm);
    return ballbot_fw_init(&ctx, &prm, c0);
}
int t_set_params(const double *p) {
    memcpy(&prm, p, sizeof prm);
    return ballbot_fw_set_params(&ctx, &prm);
}
void t_params(double *out) { memcpy(out, &ctx.params, sizeof ctx.params); }
static ballbot_fw_real last_meas[BALLBOT_FW_N_READINGS];
static double last_refs[15];
static int last_balance_only, n_interrupts;

int t_step(const double *meas, const double *r, int balance_only, double *tau) {
    ballbot_fw_references refs;
    if (meas != last_meas) {
        memcpy(last_meas, meas, sizeof last_meas);
        memcpy(last_refs, r, sizeof last_refs);
        last_balance_only = balance_only;
    }
    memcpy(refs.q_ref, r, sizeof refs.q_ref);
    memcpy(refs.dq_ref, r + 4, sizeof refs.dq_ref);
    memcpy(refs.ddq_ref, r + 8, sizeof refs.ddq_ref);
    memcpy(refs.v_ref, r + 12, sizeof refs.v_ref);
    refs.balance_only = balance_only;
    return ballbot_fw_step(&ctx, meas, &refs, tau);
}
/* which: 0 ctx, 1 readings, 2 refs, 3 torques NULL; the torques written to tau */
int t_step_null(int which, double *tau) {
    static const ballbot_fw_real meas[BALLBOT_FW_N_READINGS];
    ballbot_fw_references refs;
    memset(&refs, 0, sizeof refs);
    return ballbot_fw_step(which == 0 ? NULL : &ctx, which == 1 ? NULL : meas,
                           which == 2 ? NULL : &refs, which == 3 ? NULL : tau);
}
int t_null(int which) {
    switch (which) {
    case 0: return ballbot_fw_init(NULL, &prm, NULL);
    case 1: return ballbot_fw_init(&ctx, NULL, NULL);
    case 2: return ballbot_fw_set_params(NULL, &prm);
    case 3: return ballbot_fw_set_params(&ctx, NULL);
    case 4: return ballbot_fw_check_params(NULL);
    default: return 99;
    }
}
const double *t_c(void) { return ctx.c; }
const double *t_echo(void) { return ctx.out.echo; }
unsigned long t_period(void) { return ctx.period; }
unsigned long t_faults(void) { return ctx.faults; }
#if BALLBOT_FW_GUIDANCE
const double *t_vref(void) { return ctx.out.v_ref_used; }
int t_set_guidance(const double *data) {
    if (data == NULL) return ballbot_fw_set_guidance(&ctx, NULL);
    gnext = !gnext;
    memcpy(gdata[gnext], data, sizeof gdata[gnext]);
    return ballbot_fw_set_guidance(&ctx, gdata[gnext]);
}
const double *t_guidance(void) { return ctx.guidance; }
#endif
#if BALLBOT_FW_GUIDANCE_SPLIT
int t_background(void) { return ballbot_fw_guidance_background(&ctx); }
int t_background_null(void) { return ballbot_fw_guidance_background(NULL); }
/* 0 bg_state, 1 bg_due, 2 guidance_late, 3 guidance_faults */
unsigned long t_bg_field(int which) {
    switch (which) {
    case 0: return (unsigned long)ctx.bg_state;
    case 1: return ctx.bg_due;
    case 2: return ctx.guidance_late;
    default: return ctx.guidance_faults;
    }
}
const double *t_bg_X(void) { return ctx.bg_X; }
const double *t_bg_g(void) { return ctx.bg_g; }
#endif

/* The next samples are interrupted by n steps (the last step's readings and references). */
static void interrupt(void) {
    double tau[3];
    int i;
    for (i = 0; i < n_interrupts; ++i) t_step(last_meas, last_refs, last_balance_only, tau);
}
void t_interrupt(int n) {
    n_interrupts = n;
    stub_during_sample = n > 0 ? interrupt : 0;
}
