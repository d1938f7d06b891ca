/*
 * fmu_casadi.c - the one call of CasADi-generated Functions and the finiteness check
 * shared by every per-model part (see fmu_casadi.h).
 */
#include "fmu_casadi.h"

#include <math.h>

int fmu_casadi_call(fmu_casadi_work *wk, fmu_casadi_fn f) {
    return f(wk->arg, wk->res, wk->iw, wk->w, 0);
}

int fmu_all_finite(const double *v, size_t n) {
    size_t i;
    for (i = 0; i < n; ++i)
        if (!isfinite(v[i])) return 0;
    return 1;
}
