/*
 * fmi2_common.h - shared, hand-written FMI 2.0 layer (Model Exchange + Co-Simulation).
 *
 * The common layer (fmi2_common.c) implements every fmi2* entry point: the state machine
 * with call-sequence checks, logging through the FMI logger, value access by value
 * reference, FMU-state snapshots and their serialisation, and the solver-independent
 * parts of Model Exchange and Co-Simulation.  A model supplies one constant
 * `fmu_model_def` (see below) whose callbacks do the numerics; it never sees the FMI API.
 *
 * Only fmi2* symbols are exported (compile with -fvisibility=hidden; the FMI headers
 * mark the API functions with FMI2_Export).  Instance memory is allocated in
 * fmi2Instantiate only; no other call allocates, except fmi2GetFMUstate and
 * fmi2DeSerializeFMUstate, which create the snapshot object the caller asked for.
 *
 * All reals of a model live in one array indexed by value reference (0..n_reals-1).
 */
#ifndef FMI2_COMMON_H
#define FMI2_COMMON_H

#include <stddef.h>

#include "fmi2Functions.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Kinds of real variables (what may be set when). */
enum {
    FMU_KIND_STATE = 1,       /* continuous state, causality output, initial exact */
    FMU_KIND_DERIVATIVE = 2,  /* state derivative, calculated */
    FMU_KIND_INPUT = 3,       /* continuous input */
    FMU_KIND_OUTPUT = 4,      /* calculated output */
    FMU_KIND_PARAMETER = 5    /* fixed parameter: settable before initialisation ends */
};

/* States of the FMI 2.0 state machine (bit masks). */
typedef enum {
    FMU_ST_INSTANTIATED = 1 << 0,
    FMU_ST_INIT = 1 << 1,
    FMU_ST_EVENT = 1 << 2,
    FMU_ST_CONT = 1 << 3,
    FMU_ST_STEP_COMPLETE = 1 << 4,
    FMU_ST_STEP_FAILED = 1 << 5,
    FMU_ST_TERMINATED = 1 << 6,
    FMU_ST_ERROR = 1 << 7,
    FMU_ST_FATAL = 1 << 8
} fmu_state;

/* Log categories (indices; names in fmu_log_category_names, listed in the XML). */
enum { FMU_LOG_ERROR = 0, FMU_LOG_WARNING = 1, FMU_LOG_CALLS = 2, FMU_LOG_N = 3 };

typedef struct fmu_instance fmu_instance;

/* Model definition supplied by the per-model part. */
typedef struct {
    const char *model_identifier;
    const char *guid;
    size_t n_reals;              /* reals have value references 0..n_reals-1 */
    size_t n_states;             /* continuous states */
    size_t state_vr0;            /* states: vr state_vr0 .. state_vr0 + n_states - 1 */
    size_t der_vr0;              /* derivatives: der_vr0 .. der_vr0 + n_states - 1 */
    const double *start;         /* start value of every real (n_reals) */
    const unsigned char *kind;   /* FMU_KIND_* of every real */
    const char *const *names;    /* variable names, for messages */
    size_t work_bytes;           /* model work memory allocated per instance */
    /* Check one value before it is stored; return 0 if acceptable, else write a
     * reason into msg (size msg_len) and return nonzero. */
    int (*check_value)(size_t vr, double value, char *msg, size_t msg_len);
    /* Check the complete start point (0 = ok, else a reason in msg): at the end of
     * initialisation (restored = 0) and for every FMU state that fmi2SetFMUstate or
     * fmi2DeSerializeFMUstate would restore (restored = 1; a state the model integrated
     * may have drifted by its integration error, so the model may be less strict). */
    int (*check_initial)(const double *r, int restored, char *msg, size_t msg_len);
    /* Evaluate derivatives and outputs from states, inputs and parameters in r.
     * Return 0 on success (all results finite). */
    int (*evaluate)(fmu_instance *inst, double *r);
    /* Advance the states in r by h (inputs held); 0 on success. */
    int (*do_step)(fmu_instance *inst, double *r, double h, char *msg, size_t msg_len);
    /* Directional derivative: d r[unknown] = sum_j d r[unknown]/d r[known_j] dv_known[j]
     * for every unknown.  Return 0, or nonzero with a reason in msg. */
    int (*directional_derivative)(fmu_instance *inst, const double *r,
                                  const fmi2ValueReference *unknown, size_t n_unknown,
                                  const fmi2ValueReference *known, size_t n_known,
                                  const double *dv_known, double *dv_unknown,
                                  char *msg, size_t msg_len);
} fmu_model_def;

/* The model definition (defined by the per-model part). */
extern const fmu_model_def fmu_model;

/* Model work memory of an instance (work_bytes, zero-initialised, aligned for double). */
void *fmu_model_work(fmu_instance *inst);

/* Log through the FMI logger if the category is enabled ('%' and '#' are escaped). */
void fmu_log(fmu_instance *inst, fmi2Status status, int category, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;

#ifdef __cplusplus
}
#endif

#endif /* FMI2_COMMON_H */
