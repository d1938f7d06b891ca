/*
 * example_host.c - runs the firmware's 200 Hz example (example_main.c) on the host: the
 * SysTick registers are plain variables and each "wait for interrupt" runs the timer
 * interrupt once.  After EXAMPLE_TICKS interrupts it prints what the example set up and what
 * its context holds, as JSON, and exits.  At tick EXAMPLE_OVERRUN_AT the COUNTFLAG is set
 * while the interrupt runs (a period that overran).
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

static uint32_t syst_csr, syst_rvr, syst_cvr;
#define SYST_CSR syst_csr
#define SYST_RVR syst_rvr
#define SYST_CVR syst_cvr
static void host_interrupt(void);
#define WAIT_FOR_INTERRUPT() host_interrupt()
#define main example_main
#include "example_main.c"
#undef main

static long ticks;

static void print_array(const char *name, const ballbot_fw_real *v, int n) {
    int i;
    printf("\"%s\": [", name);
    for (i = 0; i < n; ++i) printf("%s%.17g", i ? ", " : "", (double)v[i]);
    printf("], ");
}

/* What the board stubs read, each entry pre-set to -1 so one they leave unwritten shows;
 * the encoders' NaN (a failed sensor) as 1 in "enc_nan". */
static void print_board_stubs(void) {
    ballbot_fw_real acc[3] = {-1, -1, -1}, gyro[3] = {-1, -1, -1}, enc[3] = {-1, -1, -1};
    int i;
    read_imu(acc, gyro);
    read_encoders(enc);
    print_array("acc", acc, 3);
    print_array("gyro", gyro, 3);
    printf("\"enc_nan\": [");
    for (i = 0; i < 3; ++i) printf("%s%d", i ? ", " : "", isnan(enc[i]) ? 1 : 0);
    printf("], ");
}

static void host_interrupt(void) {
    if (ticks == EXAMPLE_TICKS) {
        printf("{\"rvr\": %lu, \"csr\": %lu, \"cvr\": %lu, \"overruns\": %lu, \"period\": %lu, "
               "\"faults\": %lu, \"cascade\": %.17g, ", (unsigned long)syst_rvr,
               (unsigned long)syst_csr, (unsigned long)syst_cvr, (unsigned long)overruns,
               ctx.period, ctx.faults, (double)ctx.cascade);
        print_array("tau_cmd", ctx.out.tau_cmd, 3);
        print_array("x_hat", ctx.out.x_hat, 12);
        print_array("q_ref_used", ctx.out.q_ref_used, 4);
        print_array("rejections", ctx.out.rejections, 4);
        print_array("repairs", ctx.out.repairs, 1);
        print_board_stubs();
        printf("\"returned\": null}\n");
        exit(0);
    }
    if (ticks == EXAMPLE_OVERRUN_AT) syst_csr |= 1u << 16;
    SysTick_Handler();
    syst_csr &= ~(1u << 16);
    ++ticks;
}

int main(void) {
    int rc = example_main();
    printf("{\"returned\": %d}\n", rc);
    return 0;
}
