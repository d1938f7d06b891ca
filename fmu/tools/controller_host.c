/*
 * controller_host.c - minimal FMI 2.0 Co-Simulation host in C (no Python) for the
 * controller FMU: loads the binary with dlopen, instantiates it with its default
 * parameters and runs periods on synthetic readings (at rest with a small wobble).
 *
 * usage: controller_host <BallbotController.so> <guid> <n_steps> <bench_reps>
 *
 * Prints one JSON object, on success only: the final wheel torques and "step_us", the
 * best-of-reps mean wall time of one 5 ms controller step (fmi2SetReal of the nine readings,
 * fmi2DoStep, fmi2GetReal of the three torques), in micro-seconds.  Exit status 0 on success; else
 * 2 usage, 3 the binary or a symbol not loaded, 4 fmi2Instantiate refused (e.g. a wrong
 * GUID), 5 initialisation failed, 6 a period failed, 7 non-finite torques (the FMU's log
 * and one line naming the failure, with the period counted from 0, on stderr).
 */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "ctrl_vr.h" /* generated: value references */
#include "fmi2_host.h"

int main(int argc, char **argv) {
    void *lib;
    host_api f;
    fmi2CallbackFunctions cb;
    fmi2Component c;
    const fmi2ValueReference meas_vr[9] = {
        CTRL_VR_sensor_acc_x, CTRL_VR_sensor_acc_y, CTRL_VR_sensor_acc_z,
        CTRL_VR_sensor_gyro_x, CTRL_VR_sensor_gyro_y, CTRL_VR_sensor_gyro_z,
        CTRL_VR_sensor_enc0, CTRL_VR_sensor_enc1, CTRL_VR_sensor_enc2};
    const fmi2ValueReference tau_vr[3] = {CTRL_VR_tau0, CTRL_VR_tau1, CTRL_VR_tau2};
    double meas[9], tau[3] = {0.0, 0.0, 0.0}, best = 1e300, t = 0.0;
    const double h = 0.005;
    long n, reps, r, k;
    if (argc < 5) {
        fprintf(stderr, "usage: %s lib guid n_steps bench_reps\n", argv[0]);
        return 2;
    }
    n = atol(argv[3]);
    reps = atol(argv[4]);
    lib = host_load(argv[1], &f);
    cb = host_callbacks();
    c = host_instantiate(&f, argv[0], "controller", argv[2], &cb);
    if (f.setup(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK || f.enter_init(c) != fmi2OK ||
        f.exit_init(c) != fmi2OK) {
        return host_fail(argv[0], 5, "the initialisation failed");
    }
    for (r = 0; r < (reps > 0 ? reps : 1); ++r) {
        double t0 = host_now_s(), dt;
        for (k = 0; k < n; ++k) {
            double s = sin(0.01 * (double)k);
            meas[0] = 0.05 * s;
            meas[1] = -0.04 * s;
            meas[2] = 9.81;
            meas[3] = 0.01 * s;
            meas[4] = -0.01 * s;
            meas[5] = 0.002;
            meas[6] = 20.0 * s;
            meas[7] = -10.0 * s;
            meas[8] = -10.0 * s;
            if (f.set_real(c, meas_vr, 9, meas) != fmi2OK || f.do_step(c, t, h, fmi2True) != fmi2OK ||
                f.get_real(c, tau_vr, 3, tau) != fmi2OK) {
                return host_fail(argv[0], 6, "period %ld failed", k);
            }
            t += h;
        }
        dt = (host_now_s() - t0) / (double)n;
        if (dt < best) best = dt;
    }
    if (!(isfinite(tau[0]) && isfinite(tau[1]) && isfinite(tau[2]))) {
        return host_fail(argv[0], 7, "non-finite torques after %ld periods", n);
    }
    printf("{\"t\": %.17g, \"tau\": [%.17g, %.17g, %.17g]", t, tau[0], tau[1], tau[2]);
    if (reps > 0) printf(", \"step_us\": %.6g", best * 1e6);
    printf("}\n");
    f.free_instance(c);
    dlclose(lib);
    return 0;
}
