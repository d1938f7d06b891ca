/*
 * fmi2_internal.h - what the parts of the shared FMI 2.0 layer share (not for model code:
 * a model includes fmi2_common.h only).
 *
 * The layer is one topic per file:
 *   fmi2_common.c    the instance, the call table (fmu_enter), logging, variable checks,
 *                    value storage, fmi2SetDebugLogging and the version queries;
 *   fmi2_instance.c  life cycle: fmi2Instantiate, fmi2FreeInstance, fmi2SetupExperiment,
 *                    initialisation mode, fmi2Terminate, fmi2Reset;
 *   fmi2_values.c    fmi2Get* and fmi2Set* by value reference (which kind may be set when);
 *   fmi2_state.c     FMU states: get, set, free, (de)serialisation;
 *   fmi2_modes.c     directional derivatives, Model Exchange and Co-Simulation.
 * The policies of the whole layer are described at the top of fmi2_common.c.
 *
 * Every function and object here is prefixed fmu_, so it cannot clash with a model's
 * symbols when they are linked into one binary; they have external linkage but are hidden
 * like the rest of the layer (-fvisibility=hidden: only fmi2* symbols are exported).  The
 * macros and CALL_* constants are seen by the layer's files only.  No mutable state.
 */
#ifndef FMI2_INTERNAL_H
#define FMI2_INTERNAL_H

#include <stddef.h>

#include "fmi2_common.h"

#define FMU_MAGIC 0x464d5532u /* "FMU2" */
#define MSG_LEN 512

#define NVARS(t) (fmu_model.vars->n[t])

struct fmu_instance {
    unsigned magic;
    fmi2Type type;
    fmu_state state;
    fmi2CallbackFunctions cb;
    char *name;
    int log_on[FMU_LOG_N];
    double time;
    double t_start;
    int dirty;             /* derivatives/continuous outputs must be re-evaluated */
    int init_dirty;        /* initialization mode: held outputs must be re-computed */
    fmu_values v;          /* all values (one block) */
    fmu_values backup;     /* values at the start of a co-simulation step */
    double *jac;           /* Jacobian buffer (models with directional derivatives) */
    void *work;            /* model scratch memory */
    char msg[MSG_LEN];     /* message buffer of the model callbacks */
    char logbuf[2 * MSG_LEN + 16];
};

/* The fmi2* calls, rows of the call table (fmi2_common.c). */
typedef enum {
    CALL_SET_DEBUG_LOGGING, CALL_SETUP_EXPERIMENT, CALL_ENTER_INIT, CALL_EXIT_INIT,
    CALL_TERMINATE, CALL_RESET,
    CALL_GET_REAL, CALL_GET_INTEGER, CALL_GET_BOOLEAN, CALL_GET_STRING,
    CALL_SET_REAL, CALL_SET_INTEGER, CALL_SET_BOOLEAN, CALL_SET_STRING,
    CALL_GET_FMU_STATE, CALL_SET_FMU_STATE, CALL_FREE_FMU_STATE, CALL_SERIALIZED_SIZE,
    CALL_SERIALIZE, CALL_DESERIALIZE, CALL_DIRECTIONAL_DERIVATIVE,
    CALL_ENTER_EVENT_MODE, CALL_NEW_DISCRETE_STATES, CALL_ENTER_CONT_MODE,
    CALL_COMPLETED_INTEGRATOR_STEP, CALL_SET_TIME, CALL_SET_CONT_STATES, CALL_GET_DERIVATIVES,
    CALL_GET_EVENT_INDICATORS, CALL_GET_CONT_STATES, CALL_GET_NOMINALS,
    CALL_SET_REAL_INPUT_DERIVATIVES, CALL_GET_REAL_OUTPUT_DERIVATIVES, CALL_DO_STEP,
    CALL_CANCEL_STEP, CALL_GET_STATUS, CALL_GET_REAL_STATUS, CALL_GET_INTEGER_STATUS,
    CALL_GET_BOOLEAN_STATUS, CALL_GET_STRING_STATUS,
    CALL_N
} fmu_call;

/* Names of the variable types, by fmu_vtype (index FMU_NTYPES: "String"). */
extern const char *const fmu_type_names[FMU_NTYPES + 1];

/* ------------------------------------------------------------------ logging */

#define LOG_ERR(inst, ...) fmu_log((inst), fmi2Error, FMU_LOG_ERROR, __VA_ARGS__)
#define LOG_CALL(inst, ...) fmu_log((inst), fmi2OK, FMU_LOG_CALLS, __VA_ARGS__)

/* An error before an instance exists (fmi2Instantiate), through the given logger. */
void fmu_log_early(const fmi2CallbackFunctions *cb, const char *name, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Log a model callback's message with the status it returned (nothing for fmi2OK). */
void fmu_log_model(fmu_instance *inst, fmi2Status st, const char *fn);

/* ------------------------------------------------------------------ checks */

/* The instance behind c, or NULL if c is not a live instance of this layer. */
fmu_instance *fmu_as_instance(fmi2Component c);

/* Name of a state of the state machine, for messages. */
const char *fmu_state_name(fmu_state s);

/* FMU_ME or FMU_CS. */
unsigned fmu_interface_of(fmi2Type type);

/* Name of a call (its fmi2* function). */
const char *fmu_call_name(fmu_call call);

/* Resolve the instance and check the call against the call table; NULL if refused (logged). */
fmu_instance *fmu_enter(fmi2Component c, fmu_call call);

/* The descriptor of value reference vr of type t (its value index in *ix), or NULL. */
const fmu_var *fmu_lookup(fmu_vtype t, fmi2ValueReference vr, size_t *ix);

/* Are all value references known variables of type t (t = FMU_NTYPES: String)? */
int fmu_vrs_ok(fmu_instance *inst, const char *fn, fmu_vtype t, const fmi2ValueReference vr[],
               size_t nvr);

/* Is v an allowed stored value of variable d of type t?  1, or 0 with a reason in msg. */
int fmu_value_ok(fmu_vtype t, const fmu_var *d, double v, char *msg, size_t len);

/* Is the kind calculated by evaluate (read through fmu_refresh)? */
int fmu_evaluated(unsigned kind);

/* Evaluate derivatives and continuous outputs if inputs, states or parameters changed
 * (fmi2Error and the error state if the model evaluates to NaN or Inf; logged). */
fmi2Status fmu_refresh(fmu_instance *inst, const char *fn);

/* ------------------------------------------------------------------ values */

/* States that start from a parameter (fmu_var.start_from) take its value: called whenever
 * values may change before initialisation ends. */
void fmu_apply_start_from(fmu_values *v);

/* Bytes of one set of values (reals, integers, booleans). */
size_t fmu_values_bytes(void);

/* Point v at a block of fmu_values_bytes() (reals first: aligned for double). */
void fmu_bind_values(fmu_values *v, void *block);

/* Copy every value (one contiguous block). */
void fmu_copy_values(fmu_values *dst, const fmu_values *src);

/* ------------------------------------------------------------------ derivatives */

/* Directional (adjoint = 0: out = J seed, nKnown seeds, nUnknown results) or adjoint
 * (adjoint = 1: out = seed^T J, nUnknown seeds, nKnown results) derivatives of the
 * unknowns (derivatives, continuous outputs, states) with respect to the knowns (states,
 * continuous inputs) from the model Jacobian; fn names the call in messages.  Used by
 * fmi2GetDirectionalDerivative and the FMI 3.0 entry points. */
fmi2Status fmu_derivatives(fmi2Component c, const char *fn, const fmi2ValueReference unknown[],
                           size_t nUnknown, const fmi2ValueReference known[], size_t nKnown,
                           const double seed[], double out[], int adjoint);

#endif /* FMI2_INTERNAL_H */
