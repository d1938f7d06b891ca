/*
 * example_main.c - how the library drops into an STM32 project: a 200 Hz timer interrupt
 * runs one period; the main loop only sleeps.  The sensor and motor drivers are stubs
 * (read_imu, read_encoders, set_wheel_torques: replace them with the board's drivers).
 * Built for Cortex-M7 (the tests link it, and run it on the host with stand-in registers:
 * tests/firmware/example_host.c); SysTick stands in for the timer:
 * with a 400 MHz core clock, reload 400e6 / 200 - 1.
 *
 * With a guidance block (BALLBOT_FW_GUIDANCE) the context starts on the default path
 * (ballbot_fw_default_guidance_data); inside the period (latency 0) the period that runs a
 * guidance sample takes several 5 ms periods on this core (README, firmware), which the
 * overrun counter below records.  The split build (BALLBOT_FW_GUIDANCE_SPLIT) runs the
 * sample in the main loop instead (ballbot_fw_guidance_background), interrupted by the
 * timer; its result is applied BALLBOT_FW_GUIDANCE_LATENCY periods after its snapshot.
 */
#include <math.h>
#include <stdint.h>

#include "ballbot_fw.h"

#define CORE_HZ 400000000u
#define LOOP_HZ 200u
#ifndef SYST_CSR /* a host build of the example (the tests) brings its own registers and idle */
#define SYST_CSR (*(volatile uint32_t *)0xE000E010u)
#define SYST_RVR (*(volatile uint32_t *)0xE000E014u)
#define SYST_CVR (*(volatile uint32_t *)0xE000E018u)
#define WAIT_FOR_INTERRUPT() __asm volatile("wfi")
#endif

static ballbot_fw_ctx ctx; /* the one caller-owned context */
static ballbot_fw_references refs;
static volatile uint32_t overruns;

/* Board stubs: readings in m/s^2, rad/s and encoder ticks/s; NaN when a sensor failed. */
static void read_imu(ballbot_fw_real acc[3], ballbot_fw_real gyro[3]) {
    acc[0] = 0;
    acc[1] = 0;
    acc[2] = (ballbot_fw_real)9.81;
    gyro[0] = gyro[1] = gyro[2] = 0;
}
static void read_encoders(ballbot_fw_real enc[3]) { enc[0] = enc[1] = enc[2] = (ballbot_fw_real)NAN; }
static void set_wheel_torques(const ballbot_fw_real tau[3]) { (void)tau; }

void SysTick_Handler(void) {
    ballbot_fw_real readings[BALLBOT_FW_N_READINGS], tau[3];
    read_imu(readings + BALLBOT_FW_READING_ACC, readings + BALLBOT_FW_READING_GYRO);
    read_encoders(readings + BALLBOT_FW_READING_ENC);
    (void)ballbot_fw_step(&ctx, readings, &refs, tau); /* tau is finite (0 on a fault) */
    set_wheel_torques(tau);
    if (SYST_CSR & (1u << 16)) overruns++; /* COUNTFLAG set again: the period overran */
}

int main(void) {
    ballbot_fw_params p;
    ballbot_fw_default_params(&p);
    if (ballbot_fw_init(&ctx, &p, NULL) != BALLBOT_FW_OK) return 1;
    refs.q_ref[0] = 1;
    refs.balance_only = 0; /* velocity cascade, v_ref = 0: stand still */
    SYST_RVR = CORE_HZ / LOOP_HZ - 1u;
    SYST_CVR = 0;
    SYST_CSR = 7u; /* enable, interrupt, processor clock */
#if BALLBOT_FW_GUIDANCE_SPLIT
    for (;;)
        if (ballbot_fw_guidance_background(&ctx) == BALLBOT_FW_GUIDANCE_IDLE) WAIT_FOR_INTERRUPT();
#else
    for (;;) WAIT_FOR_INTERRUPT();
#endif
}
