/*
 * reference_model.c - per-model part of BallbotReference: plays back a scenario's
 * per-period references (attitude reference q, dq, ddq of the balance-only mode, velocity
 * and heading-rate references, the mode) from the generated table ballbot_reference_table
 * (a CasADi linear interpolant on the grid 0, 1, ..., N-1 evaluated at whole row numbers,
 * which returns the stored row exactly; its columns are the block REF_OUT of the outputs).  Row k is output from t_k = startTime + k Ts
 * (within REF_GRID_TOL Ts) until the next row; after the last row the last one is held.
 */
#include <math.h>
#include <stdio.h>

#include "ballbot_reference_cg.h"
#include "fmi2_common.h"
#include "fmu_casadi.h"
#include "ref_vars.h"

typedef struct {
    fmu_casadi_work cg;
    double row;
} ref_work;

/* Output row k (0 <= k < REF_NROWS). */
static int output_row(fmu_instance *inst, fmu_values *v, long k) {
    ref_work *wk = (ref_work *)fmu_model_work(inst);
    wk->row = (double)k;
    wk->cg.arg[REF_REFERENCE_TABLE_ARG_K] = &wk->row;
    wk->cg.res[REF_REFERENCE_TABLE_RES_ROW] = v->r + REF_OUT_IX;
    if (fmu_casadi_call(&wk->cg, REF_REFERENCE_TABLE_FN) != 0) return 1;
    v->b[REF_IX_balance_only] = REF_BALANCE_ONLY ? fmi2True : fmi2False;
    v->i[REF_IX_row] = (fmi2Integer)k;
    return 0;
}

static fmi2Status initialize(fmu_instance *inst, fmu_values *v, double t, char *msg,
                             size_t len) {
    (void)t;
    if (output_row(inst, v, 0) != 0) {
        snprintf(msg, len, "reading row 0 of the reference table failed");
        return fmi2Error;
    }
    return fmi2OK;
}

static fmi2Status do_step(fmu_instance *inst, fmu_values *v, double t, double h, char *msg,
                          size_t len) {
    double Ts = v->r[REF_IX_Ts];
    double k = floor((t + h - fmu_start_time(inst)) / Ts + REF_GRID_TOL);
    if (k > (double)(REF_NROWS - 1)) k = (double)(REF_NROWS - 1);
    if (k < 0.0) k = 0.0;
    if (output_row(inst, v, (long)k) != 0) {
        snprintf(msg, len, "reading row %.0f of the reference table failed", k);
        return fmi2Discard;
    }
    return fmi2OK;
}

const fmu_model_def fmu_model = {
    REF_MODEL_IDENTIFIER, REF_GUID, FMU_CS, &ref_variables, sizeof(ref_work),
    NULL, initialize, NULL, do_step, NULL, NULL, NULL,
};
