/*
 * fmu_casadi.h - how a per-model part calls CasADi-generated Functions (one convention
 * for every model of the package).
 *
 * A model keeps one fmu_casadi_work in its scratch memory.  To call a generated Function
 * F it sets every argument and result slot BY NAME, with the positions generated from
 * the Function's name_in()/name_out() into <prefix>_vr.h (<PREFIX>_<F>_ARG_<NAME>,
 * <PREFIX>_<F>_RES_<NAME>; sizes <..>_N; the C symbol <PREFIX>_<F>_FN), then calls
 * fmu_casadi_call(&work, <PREFIX>_<F>_FN):
 *
 *     wk->cg.arg[PLANT_BBP_ODE_ARG_XW] = r + PLANT_XW_IX;
 *     wk->cg.res[PLANT_BBP_ODE_RES_XWDOT] = r + PLANT_DER_IX;
 *     if (fmu_casadi_call(&wk->cg, PLANT_BBP_ODE_FN) != 0) ...
 *
 * The work vectors are sized for the largest Function of the FMU (FMU_INFO_SZ_*,
 * generated into fmu_model_info.h).  No allocation, no state.
 */
#ifndef FMU_CASADI_H
#define FMU_CASADI_H

#include <stddef.h>

#include "fmu_model_info.h"

/* the defaults of CasADi's generated code (same guards, so a model may override both) */
#ifndef casadi_real
#define casadi_real double
#endif
#ifndef casadi_int
#define casadi_int long long int
#endif

/* A generated Function's entry point (CasADi's calling convention). */
typedef int (*fmu_casadi_fn)(const casadi_real **arg, casadi_real **res, casadi_int *iw,
                             casadi_real *w, int mem);

/* Argument and result pointers and the work vectors of one call. */
typedef struct {
    const casadi_real *arg[FMU_INFO_SZ_ARG];
    casadi_real *res[FMU_INFO_SZ_RES];
    casadi_int iw[FMU_INFO_SZ_IW + 1];
    casadi_real w[FMU_INFO_SZ_W + 1];
} fmu_casadi_work;

/* Evaluate f on the arguments and results set in wk (0 on success). */
int fmu_casadi_call(fmu_casadi_work *wk, fmu_casadi_fn f);

/* 1 if the n values at v are all finite, else 0. */
int fmu_all_finite(const double *v, size_t n);

#endif /* FMU_CASADI_H */
