/*
 * host.c - minimal FMI 2.0 Co-Simulation host in C (no Python): loads the plant binary
 * with dlopen, instantiates it, applies constant wheel torques and steps it.
 *
 * usage: host <BallbotPlant.so> <guid> <n_steps> <step> <tau0> <tau1> <tau2> <roll0> [bench_reps]
 *
 * Prints one JSON object: the final time, the final 12 model states and the continuous
 * outputs, and, with bench_reps > 0, "step_us", the best-of-reps mean wall time of one
 * fmi2DoStep + reading the 12 states (micro-seconds).  Exit status 0 on success; else
 * 2 usage, 3 the binary or a symbol not loaded, 4 fmi2Instantiate refused (e.g. a wrong
 * GUID), 5 initialisation refused, 6 a step refused, 7 a value not read (the FMU's log
 * and one line naming the failure, with the step counted from 0, on stderr; nothing on
 * stdout).
 */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "fmi2_host.h"
#include "plant_vr.h" /* generated: value references */

#define NX PLANT_XW_PHI /* the 12 model states (the wheel angles follow them) */
#define NOUT PLANT_Y_N  /* continuous outputs */

int main(int argc, char **argv) {
    void *lib;
    host_api f;
    fmi2CallbackFunctions cb;
    fmi2Component c;
    fmi2ValueReference vr_x[NX], vr_tau[3], vr_q[4], vr_y[NOUT];
    double x[NX], y[NOUT], tau[3], q[4], h, t = 0.0, roll0, best = 1e300;
    long n, i, reps = 0, r;
    int k;
    if (argc < 9) {
        fprintf(stderr, "usage: %s lib guid n_steps step tau0 tau1 tau2 roll0 [bench_reps]\n",
                argv[0]);
        return 2;
    }
    n = atol(argv[3]);
    h = atof(argv[4]);
    for (k = 0; k < 3; ++k) tau[k] = atof(argv[5 + k]);
    roll0 = atof(argv[8]);
    if (argc > 9) reps = atol(argv[9]);
    for (k = 0; k < NX; ++k) vr_x[k] = (fmi2ValueReference)(PLANT_VR_x + k);
    for (k = 0; k < NOUT; ++k) vr_y[k] = (fmi2ValueReference)(PLANT_VR_roll + k);
    for (k = 0; k < 3; ++k) vr_tau[k] = (fmi2ValueReference)(PLANT_VR_tau0 + k);
    for (k = 0; k < 4; ++k) vr_q[k] = (fmi2ValueReference)(PLANT_VR_x0_q0 + k); /* the start state */
    lib = host_load(argv[1], &f);
    cb = host_callbacks();
    /* start quaternion of a roll about body x */
    q[0] = cos(roll0 / 2);
    q[1] = sin(roll0 / 2);
    q[2] = 0.0;
    q[3] = 0.0;
    for (r = 0; r <= reps; ++r) {
        double t0;
        c = host_instantiate(&f, argv[0], "host", argv[2], &cb);
        if (f.setup(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK ||
            f.enter_init(c) != fmi2OK || f.set_real(c, vr_q, 4, q) != fmi2OK ||
            f.set_real(c, vr_tau, 3, tau) != fmi2OK || f.exit_init(c) != fmi2OK) {
            return host_fail(argv[0], 5, "the initialisation was refused");
        }
        t = 0.0;
        t0 = host_now_s();
        for (i = 0; i < n; ++i) {
            if (f.set_real(c, vr_tau, 3, tau) != fmi2OK || f.do_step(c, t, h, fmi2True) != fmi2OK) {
                return host_fail(argv[0], 6, "step %ld was refused", i);
            }
            t += h;
            if (f.get_real(c, vr_x, NX, x) != fmi2OK) {
                return host_fail(argv[0], 7, "the states were not read after step %ld", i);
            }
        }
        if (r > 0 || reps == 0) {
            double per = (host_now_s() - t0) / (double)n * 1e6;
            if (per < best) best = per;
        }
        if (f.get_real(c, vr_y, NOUT, y) != fmi2OK) {
            return host_fail(argv[0], 7, "the outputs were not read");
        }
        f.terminate(c);
        f.free_instance(c);
    }
    printf("{\"t\": %.17g, \"x\": [", t);
    for (k = 0; k < NX; ++k) printf("%s%.17g", k ? ", " : "", x[k]);
    printf("], \"y\": [");
    for (k = 0; k < NOUT; ++k) printf("%s%.17g", k ? ", " : "", y[k]);
    printf("], \"step_us\": %.6g}\n", best);
    dlclose(lib);
    return 0;
}
