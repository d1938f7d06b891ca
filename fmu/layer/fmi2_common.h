/*
 * fmi2_common.h - shared, hand-written FMI 2.0 layer (Model Exchange and/or Co-Simulation).
 *
 * The common layer (fmi2_common.c and its parts, one topic each: see fmi2_internal.h)
 * implements every fmi2* entry point: the state machine (one table of which call is
 * allowed in which state), logging through the FMI logger,
 * Real, Integer and Boolean variables by value reference (range checks, settability by
 * kind and state), FMU-state snapshots and their serialisation, directional derivatives
 * from a model Jacobian, and the solver-independent parts of Model Exchange and
 * Co-Simulation.  A model supplies one constant `fmu_model_def` (see below): its
 * identifier and GUID, the generated variable table (`fmu_variables`, written by
 * ballbot_casadi/fmi/ from the same Python table as modelDescription.xml) and callbacks
 * that do the numerics.  The model never sees the FMI call sequence.
 *
 * Only fmi2* symbols are exported (compile with -fvisibility=hidden; the FMI headers mark
 * the API functions with FMI2_Export).  Instance memory is allocated in fmi2Instantiate
 * only; no other call allocates, except fmi2GetFMUstate and fmi2DeSerializeFMUstate,
 * which create the snapshot object the caller asked for.
 *
 * Values: each type has its own value array, indexed by `vr - vars->vr0[type]`
 * (value references are unique over all types).  Everything the model needs to continue
 * bit-identically (continuous states, inputs, parameters, held discrete outputs and the
 * model's discrete internal states as kind FMU_KIND_LOCAL) lives in these arrays, so
 * fmi2GetFMUstate/fmi2SetFMUstate/serialisation and fmi2Reset need no model callback.
 * The model work memory (`fmu_model_work`) is scratch only.
 */
#ifndef FMI2_COMMON_H
#define FMI2_COMMON_H

#include <stddef.h>

#include "fmi2Functions.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Interfaces a model implements (fmu_model_def.interfaces). */
#define FMU_ME 1u
#define FMU_CS 2u

/* Variable types. */
typedef enum { FMU_REAL = 0, FMU_INTEGER = 1, FMU_BOOLEAN = 2, FMU_NTYPES = 3 } fmu_vtype;

/* Kinds of variables (who computes a value, and when it may be set). */
enum {
    FMU_KIND_STATE = 1,           /* continuous state (Real), output, start value exact */
    FMU_KIND_DERIVATIVE = 2,      /* state derivative (Real), calculated by evaluate */
    FMU_KIND_INPUT = 3,           /* continuous input (Real) */
    FMU_KIND_DISCRETE_INPUT = 4,  /* discrete input (any type; ME: set in event mode) */
    FMU_KIND_OUTPUT = 5,          /* continuous output (Real), calculated by evaluate */
    FMU_KIND_DISCRETE_OUTPUT = 6, /* held output, written by initialize/do_step/event_update */
    FMU_KIND_PARAMETER = 7,       /* fixed parameter: settable before initialisation ends */
    FMU_KIND_LOCAL = 8,           /* discrete internal state of the model (never set) */
    FMU_KIND_N = 9
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

/* Log categories (indices; names in the XML's LogCategories). */
enum { FMU_LOG_ERROR = 0, FMU_LOG_WARNING = 1, FMU_LOG_CALLS = 2, FMU_LOG_N = 3 };

/* One variable (generated).  Integer and Boolean values and ranges are stored as double
 * (exact for 32-bit integers). */
typedef struct {
    const char *name;
    unsigned char kind;   /* FMU_KIND_* */
    unsigned short index; /* STATE/DERIVATIVE: state number; OUTPUT/INPUT: Jacobian row/column
                           * among the continuous outputs/inputs; else position in its kind */
    double start;         /* start value (0 for calculated variables) */
    double min, max;      /* allowed range of a stored value (+-HUGE_VAL: none) */
    unsigned char min_open, max_open; /* strict bounds */
    const char *rule;     /* text of the range, for messages (NULL: only finiteness) */
    unsigned char nan_missing; /* Real inputs and held outputs: NaN is accepted and means
                                * "no value" (a missing sensor reading); Inf is still
                                * refused */
    unsigned short start_from; /* states: 1 + Real index of the parameter the state starts
                                * from (initial = calculated: it equals that parameter until
                                * initialisation ends and cannot be set itself); 0: none */
} fmu_var;

/* The variable table of a model (generated). */
typedef struct {
    size_t n[FMU_NTYPES];               /* number of variables of each type */
    fmi2ValueReference vr0[FMU_NTYPES]; /* type t has the VRs vr0[t] .. vr0[t] + n[t] - 1 */
    const fmu_var *var[FMU_NTYPES];     /* descriptors, by vr - vr0[t] */
    size_t n_states;                    /* continuous states */
    const size_t *state;                /* Real index of state i */
    const size_t *der;                  /* Real index of der(state i) */
    size_t n_outputs;                   /* continuous Real outputs (Jacobian rows after the derivatives) */
    size_t n_inputs;                    /* continuous Real inputs (Jacobian columns after the states) */
} fmu_variables;

/* The value arrays of an instance. */
typedef struct {
    double *r;
    fmi2Integer *i;
    fmi2Boolean *b;
} fmu_values;

typedef struct fmu_instance fmu_instance;

/* Model definition supplied by the per-model part.  Callbacks marked optional may be
 * NULL.  A callback that fails writes a reason into msg (size len); the layer logs it. */
typedef struct {
    const char *model_identifier;
    const char *guid;
    unsigned interfaces;          /* FMU_ME and/or FMU_CS */
    const fmu_variables *vars;
    size_t work_bytes;            /* scratch memory per instance (fmu_model_work) */
    /* optional: check the values for consistency beyond each variable's range (0 = ok):
     * at the end of initialisation (restored = 0) and for every FMU state that
     * fmi2SetFMUstate / fmi2DeSerializeFMUstate would restore (restored = 1; a state the
     * model integrated may have drifted by its integration error). */
    int (*check_initial)(const fmu_values *v, int restored, char *msg, size_t len);
    /* optional: set the discrete states and held outputs at the end of initialisation
     * (time t = start time).  fmi2Error: initialisation fails, the instance enters the
     * error state. */
    fmi2Status (*initialize)(fmu_instance *inst, fmu_values *v, double t, char *msg, size_t len);
    /* derivatives and continuous outputs from states, inputs and parameters (required if
     * the model has any); 0 on success with all results finite. */
    int (*evaluate)(fmu_instance *inst, fmu_values *v);
    /* Co-Simulation: advance from t by h (inputs held).  fmi2OK/fmi2Warning: done;
     * fmi2Discard: numerical failure (the layer restores every value and enters
     * stepFailed); fmi2Error: the step is refused (every value restored, state kept). */
    fmi2Status (*do_step)(fmu_instance *inst, fmu_values *v, double t, double h, char *msg,
                          size_t len);
    /* optional, Model Exchange: continuous-time mode ends at time t (before the importer
     * may change inputs in event mode) */
    void (*event_entered)(fmu_instance *inst, fmu_values *v, double t);
    /* optional, Model Exchange: fmi2NewDiscreteStates at time t; info holds "no event"
     * defaults.  fmi2Error puts the instance into the error state. */
    fmi2Status (*event_update)(fmu_instance *inst, fmu_values *v, double t,
                               fmi2EventInfo *info, char *msg, size_t len);
    /* optional (providesDirectionalDerivative): the dense Jacobian, column-major,
     * rows [derivatives (n_states); continuous outputs (n_outputs)] by columns
     * [states (n_states); continuous inputs (n_inputs)].  0 on success. */
    int (*jacobian)(fmu_instance *inst, const fmu_values *v, double *jac, char *msg,
                    size_t len);
} fmu_model_def;

/* The model definition (defined by the per-model part). */
extern const fmu_model_def fmu_model;

/* Scratch memory of an instance (work_bytes, zero-initialised, aligned for double). */
void *fmu_model_work(fmu_instance *inst);

/* Start time of the experiment (fmi2SetupExperiment). */
double fmu_start_time(const fmu_instance *inst);

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
