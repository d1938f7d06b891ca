/* ballbot_fw_cg.h - a hand-written stand-in for the generated period (tests only): the
 * entry points the firmware's ballbot_fw.c calls, with results a test can compute by hand
 * (stub_cg.c).  STUB_GUIDANCE / STUB_SPLIT (0 or 1, given with -D) choose the build. */
#ifndef BALLBOT_FW_CG_H
#define BALLBOT_FW_CG_H
typedef int casadi_int;
int stub_period(const double **arg, double **res, casadi_int *iw, double *w, int mem);
int stub_sample_first(const double **arg, double **res, casadi_int *iw, double *w, int mem);
/* called inside each sample when set: the test's stand-in for the interrupting steps */
extern void (*stub_during_sample)(void);
int stub_sample_next(const double **arg, double **res, casadi_int *iw, double *w, int mem);
#endif
