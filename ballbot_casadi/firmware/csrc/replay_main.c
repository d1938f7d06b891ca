/*
 * replay_main.c - replays a recorded sensor log through the firmware library and writes the
 * torques back.  The same file runs on the host (stdio; argv: input output) and in QEMU
 * (BALLBOT_FW_TARGET: semihosting files fw_replay_in.bin / fw_replay_out.bin in QEMU's
 * working directory, instruction counting with SysTick, stack high-water mark by painting).
 *
 * Input (little-endian doubles): n_steps, n_params, nc, balance_only, calib_loops,
 * n_guidance, bg_delay (split guidance: the background sample runs after the step bg_delay
 * periods after its snapshot's; 0: right after it); the parameters (ballbot_fw_params as a flat array); the power-on state c0
 * (nc); the guidance data (n_guidance = BALLBOT_FW_N_GUIDANCE values, none without a
 * guidance block); per period the readings (BALLBOT_FW_N_READINGS, NaN = missing) and the
 * references q_ref, dq_ref, ddq_ref, v_ref.
 * Output (doubles): a header of OUT_HEADER values (n_steps, stack bytes of one step,
 * SysTick ticks of the calibration loop, its instruction count, sizeof(ballbot_fw_ctx),
 * sizeof(ballbot_fw_real), ROW_EXTRA, stack bytes of the background sample, results
 * not ready at their due period (ctx.guidance_late)); per period
 * tau[3], the step's SysTick ticks, the return code and, with a guidance block, the
 * velocity reference it gave (v_ref_used, 3) and, with split guidance, the SysTick ticks
 * of the background sample run after the step (0 when none was pending; the main loop of
 * a board runs it while the next steps interrupt it: the result is applied at its due
 * period either way).  The stack is painted before the first 8 periods and, with
 * guidance, before the first 8 periods that run (or snapshot) a guidance sample, and
 * before the first 8 background samples.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "ballbot_fw.h"

#define OUT_HEADER 9
#define N_IN_HEADER 7
#define N_REF 15
/* One input row: the readings, then q_ref, dq_ref, ddq_ref (4 each) and v_ref (3). */
#define N_ROW (BALLBOT_FW_N_READINGS + N_REF)
/* The read buffer holds the initial controller state or one row, whichever is longer. */
#define N_BUF (BALLBOT_FW_NC > N_ROW ? BALLBOT_FW_NC : N_ROW)
#if BALLBOT_FW_GUIDANCE_SPLIT
#define ROW_EXTRA 4
static ballbot_fw_real guidance_data[BALLBOT_FW_N_GUIDANCE]; /* flash on a real board */
#elif BALLBOT_FW_GUIDANCE
#define ROW_EXTRA 3
static ballbot_fw_real guidance_data[BALLBOT_FW_N_GUIDANCE]; /* flash on a real board */
#else
#define ROW_EXTRA 0
#endif
#define N_PAR ((int)(sizeof(ballbot_fw_params) / sizeof(ballbot_fw_real)))

static ballbot_fw_ctx ctx; /* the caller-owned context */
static ballbot_fw_params params;

#ifdef BALLBOT_FW_TARGET
#define SYST_CSR (*(volatile uint32_t *)0xE000E010u)
#define SYST_RVR (*(volatile uint32_t *)0xE000E014u)
#define SYST_CVR (*(volatile uint32_t *)0xE000E018u)
#define PAINT 0xA5A5A5A5u
extern uint32_t __stack_bottom;

static uint32_t ticks(void) { return SYST_CVR; }
static void paint_stack(uintptr_t sp) {
    uintptr_t a;
    for (a = (uintptr_t)&__stack_bottom; a < sp; a += 4) *(volatile uint32_t *)a = PAINT;
}
static unsigned long used_stack(uintptr_t sp) {
    uintptr_t a;
    for (a = (uintptr_t)&__stack_bottom; a < sp; a += 4)
        if (*(volatile uint32_t *)a != PAINT) break;
    return (unsigned long)(sp - a);
}
static uint32_t elapsed(uint32_t t0, uint32_t t1) { return (t0 - t1) & 0xFFFFFFu; }
static uintptr_t stack_pointer(void) {
    uintptr_t sp;
    __asm volatile("mov %0, sp" : "=r"(sp));
    return sp;
}
/* 1 + 2 n instructions (mov, then subs + bne per loop). */
static void calib_loop(uint32_t n) {
    __asm volatile("mov r0, %0\n1:\n\tsubs r0, r0, #1\n\tbne 1b" : : "r"(n) : "r0", "cc");
}
#else
static uint32_t ticks(void) { return 0; }
static uint32_t elapsed(uint32_t t0, uint32_t t1) { return t0 - t1; }
#endif

static int read_doubles(FILE *f, double *v, int n) {
    return (int)fread(v, sizeof(double), (size_t)n, f) == n ? 0 : 1;
}

/* A short input: one line naming where it ends (k >= 0: that row), exit code 2. */
static int ends_early(const char *where, long k) {
    if (k >= 0)
        fprintf(stderr, "replay: the input ends early, in %s %ld\n", where, k);
    else
        fprintf(stderr, "replay: the input ends early, in %s\n", where);
    return 2;
}

static int write_doubles(FILE *f, const double *v, int n) {
    return (int)fwrite(v, sizeof(double), (size_t)n, f) == n ? 0 : 1;
}

static int replay(FILE *in, FILE *out) {
    double hdr[N_IN_HEADER], buf[N_BUF], oh[OUT_HEADER] = {0};
    ballbot_fw_real c0[BALLBOT_FW_NC], meas[BALLBOT_FW_N_READINGS], tau[3];
    ballbot_fw_real *pflat = (ballbot_fw_real *)&params;
    ballbot_fw_references refs;
    long k, n;
    int i, rc;
    unsigned long stack_max = 0, bg_stack_max = 0;
    int bg_runs = 0;
    long bg_at = -1;
    if (read_doubles(in, hdr, N_IN_HEADER) || (int)hdr[1] != N_PAR || (int)hdr[2] != BALLBOT_FW_NC ||
        (int)hdr[5] != BALLBOT_FW_N_GUIDANCE) {
        fprintf(stderr, "replay: input header does not match the library (%d params, nc %d, "
                "%d guidance values)\n", N_PAR, BALLBOT_FW_NC, BALLBOT_FW_N_GUIDANCE);
        return 2;
    }
    n = (long)hdr[0];
    for (i = 0; i < N_PAR; ++i) {
        if (read_doubles(in, buf, 1)) return ends_early("the parameters", -1);
        pflat[i] = (ballbot_fw_real)buf[0];
    }
    if (read_doubles(in, buf, BALLBOT_FW_NC)) return ends_early("the initial state", -1);
    for (i = 0; i < BALLBOT_FW_NC; ++i) c0[i] = (ballbot_fw_real)buf[i];
    rc = ballbot_fw_init(&ctx, &params, c0);
    if (rc != BALLBOT_FW_OK) {
        fprintf(stderr, "replay: ballbot_fw_init returned %d\n", rc);
        return 2;
    }
#if BALLBOT_FW_GUIDANCE
    for (i = 0; i < BALLBOT_FW_N_GUIDANCE; ++i) {
        if (read_doubles(in, buf, 1)) return ends_early("the guidance data", -1);
        guidance_data[i] = (ballbot_fw_real)buf[0];
    }
    rc = ballbot_fw_set_guidance(&ctx, guidance_data);
    if (rc != BALLBOT_FW_OK) {
        fprintf(stderr, "replay: ballbot_fw_set_guidance returned %d\n", rc);
        return 2;
    }
#endif
    refs.balance_only = hdr[3] != 0;
#ifdef BALLBOT_FW_TARGET
    SYST_RVR = 0xFFFFFFu;
    SYST_CVR = 0;
    SYST_CSR = 5u; /* enable, processor clock, no interrupt */
    {
        uint32_t t0 = ticks();
        calib_loop((uint32_t)hdr[4]);
        oh[2] = (double)elapsed(t0, ticks());
        oh[3] = 1 + 2 * hdr[4];
    }
#endif
    oh[0] = (double)n;
    oh[4] = (double)sizeof(ballbot_fw_ctx);
    oh[5] = (double)sizeof(ballbot_fw_real);
    oh[6] = ROW_EXTRA;
    if (write_doubles(out, oh, OUT_HEADER)) return 3;
    for (k = 0; k < n; ++k) {
        double row[5 + ROW_EXTRA + 1];
        uint32_t t0, t1;
        int paint = k < 8;
        for (i = 0; i < 5 + ROW_EXTRA; ++i) row[i] = NAN; /* a column left unwritten shows */
        if (read_doubles(in, buf, N_ROW)) return ends_early("row", k);
        for (i = 0; i < BALLBOT_FW_N_READINGS; ++i) meas[i] = (ballbot_fw_real)buf[i];
        for (i = 0; i < 4; ++i) {
            refs.q_ref[i] = (ballbot_fw_real)buf[BALLBOT_FW_N_READINGS + i];
            refs.dq_ref[i] = (ballbot_fw_real)buf[BALLBOT_FW_N_READINGS + 4 + i];
            refs.ddq_ref[i] = (ballbot_fw_real)buf[BALLBOT_FW_N_READINGS + 8 + i];
        }
        for (i = 0; i < 3; ++i) refs.v_ref[i] = (ballbot_fw_real)buf[BALLBOT_FW_N_READINGS + 12 + i];
#if BALLBOT_FW_GUIDANCE
        paint = paint || (k % BALLBOT_FW_GUIDANCE_EVERY == 0 && k < 8 * BALLBOT_FW_GUIDANCE_EVERY);
#endif
#ifdef BALLBOT_FW_TARGET
        uintptr_t sp = stack_pointer() - 16u;
        if (paint) paint_stack(sp);
#endif
        t0 = ticks();
        rc = ballbot_fw_step(&ctx, meas, &refs, tau);
        t1 = ticks();
#ifdef BALLBOT_FW_TARGET
        if (paint && used_stack(sp) > stack_max) stack_max = used_stack(sp);
#endif
        for (i = 0; i < 3; ++i) row[i] = (double)tau[i];
        row[3] = (double)elapsed(t0, t1);
        row[4] = (double)rc;
#if BALLBOT_FW_GUIDANCE
        for (i = 0; i < 3; ++i) row[5 + i] = (double)ctx.out.v_ref_used[i];
#endif
#if BALLBOT_FW_GUIDANCE_SPLIT
        row[8] = 0;
        if (ctx.bg_state == BALLBOT_FW_BG_PENDING && bg_at < 0) bg_at = k + (long)hdr[6];
        if (ctx.bg_state == BALLBOT_FW_BG_PENDING && k >= bg_at) { /* the main loop's task */
            int brc;
            bg_at = -1;
#ifdef BALLBOT_FW_TARGET
            int bg_paint = bg_runs < 8;
            if (bg_paint) paint_stack(sp);
#endif
            t0 = ticks();
            brc = ballbot_fw_guidance_background(&ctx);
            t1 = ticks();
#ifdef BALLBOT_FW_TARGET
            if (bg_paint && used_stack(sp) > bg_stack_max) bg_stack_max = used_stack(sp);
#endif
            row[8] = (double)elapsed(t0, t1);
            if (brc < 0) row[4] = (double)brc;
            bg_runs++;
        }
#endif
        if (write_doubles(out, row, 5 + ROW_EXTRA)) return 3;
        (void)paint;
    }
    oh[1] = (double)stack_max;
    oh[7] = (double)bg_stack_max;
#if BALLBOT_FW_GUIDANCE_SPLIT
    oh[8] = (double)ctx.guidance_late;
#endif
    (void)bg_runs;
    (void)bg_at;
    (void)bg_stack_max;
    if (fseek(out, 0, SEEK_SET) != 0 || write_doubles(out, oh, OUT_HEADER)) return 3;
    return 0;
}

#ifdef BALLBOT_FW_TARGET
int main(void) {
    const char *in_name = "fw_replay_in.bin", *out_name = "fw_replay_out.bin";
#else
int main(int argc, char **argv) {
    const char *in_name = argc > 1 ? argv[1] : "fw_replay_in.bin";
    const char *out_name = argc > 2 ? argv[2] : "fw_replay_out.bin";
#endif
    FILE *in = fopen(in_name, "rb"), *out;
    int rc;
    if (in == NULL) {
        fprintf(stderr, "replay: cannot open %s\n", in_name);
        return 2;
    }
    out = fopen(out_name, "wb");
    if (out == NULL) {
        fclose(in);
        fprintf(stderr, "replay: cannot open %s\n", out_name);
        return 2;
    }
    rc = replay(in, out);
    fclose(in);
    if (fclose(out) != 0 && rc == 0) rc = 3;
    return rc;
}
