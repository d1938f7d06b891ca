/*
 * fuzz.c - random FMI 2.0 API calls against an FMU binary of the package (no Python).
 *
 * usage: fuzz <model.so> <guid> <n_calls> <seed>
 *        fuzz --draws <n> <seed>   (prints the first n Real and n Integer argument values
 *                                   the seed draws, one "r <value>" / "i <value>" per line)
 *
 * Generic: compiled against the FMU's generated fmu_model_info.h (numbers of Real,
 * Integer and Boolean variables, states, Real inputs), so it fuzzes any FMU built on
 * fmi2_common.c.  Keeps up to four instances (Model Exchange and Co-Simulation; an
 * interface the FMU lacks is refused with a message) and a few FMU states, and calls
 * random fmi2* functions with random, often invalid arguments: unknown value references
 * (also of the wrong type), NaN/Inf/huge Reals, out-of-range Integers, Booleans other
 * than 0/1, wrong sizes, NULL pointers, wrong call order, wrong GUID, negative/zero step
 * sizes, corrupt serialised states.  Every call that returns
 * something other than fmi2OK on a live instance must have logged a message; such calls
 * without a message are counted as "silent".  A crash fails the test that runs this.
 * Prints a JSON summary.
 */
#define _POSIX_C_SOURCE 200809L
#include <dlfcn.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2FunctionTypes.h"
#include <limits.h>

#include "fmu_model_info.h"

#define NINST 4
#define NSNAP 4
#define NX FMU_INFO_N_STATES
#define NVAL (NX + 8)

static long n_log = 0;

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    (void)env;
    (void)name;
    (void)status;
    if (category == NULL || message == NULL || message[0] == '\0') return;
    ++n_log;
}

static uint64_t rng_state;
static uint64_t rnd(void) {
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return rng_state;
}
static void seed_rng(const char *seed) {
    rng_state = (uint64_t)strtoull(seed, NULL, 10) * 2654435761u + 88172645463325252ull;
}
static double urand(void) { return (double)(rnd() >> 11) * (1.0 / 9007199254740992.0); }
static int irand(int n) { return (int)(rnd() % (uint64_t)n); }

static double rand_real(void) {
    static const double special[] = {0.0, -0.0, 1.0, -1.0, 1e300, -1e300, 1e-300, 0.5};
    int k = irand(12);
    if (k < 8) return special[k];
    if (k == 8) return NAN;
    if (k == 9) return (irand(2) ? 1.0 : -1.0) * INFINITY;
    return (urand() * 2.0 - 1.0) * pow(10.0, urand() * 4.0 - 3.0);
}

/* A value reference, mostly of a variable of the type with first VR vr0 and n variables. */
static fmi2ValueReference rand_vr_of(int vr0, int n) {
    int k = irand(10);
    if (k < 7 && n > 0) return (fmi2ValueReference)(vr0 + irand(n));
    if (k < 9) return (fmi2ValueReference)irand(FMU_INFO_N_VARS + 5);
    return (fmi2ValueReference)0xFFFFFFFFu;
}
static fmi2ValueReference rand_vr(void) {
    return rand_vr_of(FMU_INFO_VR0_REALS, FMU_INFO_N_REALS);
}
static fmi2Integer rand_int(void) {
    static const fmi2Integer special[] = {0, 1, -1, 2, 7, INT_MAX, INT_MIN, 123456789};
    int k = irand(10);
    if (k < 8) return special[k];
    return (fmi2Integer)(rnd() & 0xFFFFFFFFu);
}

#define F(name) name##TYPE *name
typedef struct {
    F(fmi2GetTypesPlatform); F(fmi2GetVersion); F(fmi2SetDebugLogging);
    F(fmi2Instantiate); F(fmi2FreeInstance); F(fmi2SetupExperiment);
    F(fmi2EnterInitializationMode); F(fmi2ExitInitializationMode); F(fmi2Terminate);
    F(fmi2Reset); F(fmi2GetReal); F(fmi2GetInteger); F(fmi2GetBoolean); F(fmi2GetString);
    F(fmi2SetReal); F(fmi2SetInteger); F(fmi2SetBoolean); F(fmi2SetString);
    F(fmi2GetFMUstate); F(fmi2SetFMUstate); F(fmi2FreeFMUstate);
    F(fmi2SerializedFMUstateSize); F(fmi2SerializeFMUstate); F(fmi2DeSerializeFMUstate);
    F(fmi2GetDirectionalDerivative); F(fmi2EnterEventMode); F(fmi2NewDiscreteStates);
    F(fmi2EnterContinuousTimeMode); F(fmi2CompletedIntegratorStep); F(fmi2SetTime);
    F(fmi2SetContinuousStates); F(fmi2GetDerivatives); F(fmi2GetEventIndicators);
    F(fmi2GetContinuousStates); F(fmi2GetNominalsOfContinuousStates);
    F(fmi2SetRealInputDerivatives); F(fmi2GetRealOutputDerivatives); F(fmi2DoStep);
    F(fmi2CancelStep); F(fmi2GetStatus); F(fmi2GetRealStatus); F(fmi2GetIntegerStatus);
    F(fmi2GetBooleanStatus); F(fmi2GetStringStatus);
} api;
#undef F

static void *lib;
static void load(void **slot, const char *name) {
    *slot = dlsym(lib, name);
    if (*slot == NULL) {
        fprintf(stderr, "missing symbol %s\n", name);
        exit(3);
    }
}
#define LOAD(a, name) load((void **)&(a).name, #name)

int main(int argc, char **argv) {
    api f;
    fmi2CallbackFunctions cb;
    fmi2Component inst[NINST] = {0};
    fmi2FMUstate snap[NSNAP] = {0};
    int snap_owner[NSNAP];
    long n, i, n_calls = 0, n_ok = 0, n_err = 0, n_discard = 0, n_other = 0, n_silent = 0;
    long n_null_inst = 0, n_bad_guid = 0, n_steps_ok = 0, n_init_ok = 0;
    long n_int_ok = 0, n_bool_ok = 0, n_int_err = 0, n_bool_err = 0;
    const char *guid;
    static fmi2Byte buf[65536];
    if (argc == 4 && strcmp(argv[1], "--draws") == 0) {
        n = atol(argv[2]);
        seed_rng(argv[3]);
        for (i = 0; i < n; ++i) printf("r %.17g\n", rand_real());
        for (i = 0; i < n; ++i) printf("i %ld\n", (long)rand_int());
        return 0;
    }
    if (argc < 5) {
        fprintf(stderr, "usage: %s lib guid n_calls seed\n", argv[0]);
        return 2;
    }
    lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (lib == NULL) {
        fprintf(stderr, "dlopen failed: %s\n", dlerror());
        return 3;
    }
    guid = argv[2];
    n = atol(argv[3]);
    seed_rng(argv[4]);
    LOAD(f, fmi2GetTypesPlatform); LOAD(f, fmi2GetVersion); LOAD(f, fmi2SetDebugLogging);
    LOAD(f, fmi2Instantiate); LOAD(f, fmi2FreeInstance); LOAD(f, fmi2SetupExperiment);
    LOAD(f, fmi2EnterInitializationMode); LOAD(f, fmi2ExitInitializationMode);
    LOAD(f, fmi2Terminate); LOAD(f, fmi2Reset); LOAD(f, fmi2GetReal); LOAD(f, fmi2GetInteger);
    LOAD(f, fmi2GetBoolean); LOAD(f, fmi2GetString); LOAD(f, fmi2SetReal);
    LOAD(f, fmi2SetInteger); LOAD(f, fmi2SetBoolean); LOAD(f, fmi2SetString);
    LOAD(f, fmi2GetFMUstate); LOAD(f, fmi2SetFMUstate); LOAD(f, fmi2FreeFMUstate);
    LOAD(f, fmi2SerializedFMUstateSize); LOAD(f, fmi2SerializeFMUstate);
    LOAD(f, fmi2DeSerializeFMUstate); LOAD(f, fmi2GetDirectionalDerivative);
    LOAD(f, fmi2EnterEventMode); LOAD(f, fmi2NewDiscreteStates);
    LOAD(f, fmi2EnterContinuousTimeMode); LOAD(f, fmi2CompletedIntegratorStep);
    LOAD(f, fmi2SetTime); LOAD(f, fmi2SetContinuousStates); LOAD(f, fmi2GetDerivatives);
    LOAD(f, fmi2GetEventIndicators); LOAD(f, fmi2GetContinuousStates);
    LOAD(f, fmi2GetNominalsOfContinuousStates); LOAD(f, fmi2SetRealInputDerivatives);
    LOAD(f, fmi2GetRealOutputDerivatives); LOAD(f, fmi2DoStep); LOAD(f, fmi2CancelStep);
    LOAD(f, fmi2GetStatus); LOAD(f, fmi2GetRealStatus); LOAD(f, fmi2GetIntegerStatus);
    LOAD(f, fmi2GetBooleanStatus); LOAD(f, fmi2GetStringStatus);
    cb.logger = logger;
    cb.allocateMemory = calloc;
    cb.freeMemory = free;
    cb.stepFinished = NULL;
    cb.componentEnvironment = NULL;
    for (i = 0; i < NSNAP; ++i) snap_owner[i] = -1;

    for (i = 0; i < n; ++i) {
        int s = irand(NINST), op = irand(41), k, j;
        fmi2Component c = inst[s];
        fmi2Status st = fmi2OK;
        long before = n_log;
        fmi2ValueReference vr[8], vr2[8];
        double val[NVAL], val2[NVAL];
        size_t nvr = (size_t)irand(6), nvr2 = (size_t)irand(4), sz = 0;
        int counted = 1;
        for (k = 0; k < 8; ++k) {
            vr[k] = rand_vr();
            vr2[k] = rand_vr();
        }
        for (k = 0; k < NVAL; ++k) {
            val[k] = rand_real();
            val2[k] = rand_real();
        }
        if (c == NULL && op != 0 && irand(4) != 0) op = 0; /* mostly (re)instantiate */
        switch (op) {
        case 0: { /* instantiate */
            int bad = irand(8) == 0;
            fmi2Type ty = irand(2) ? fmi2CoSimulation : fmi2ModelExchange;
            fmi2Component nc;
            if (inst[s] != NULL) {
                for (j = 0; j < NSNAP; ++j)
                    if (snap_owner[j] == s && snap[j] != NULL) {
                        f.fmi2FreeFMUstate(inst[s], &snap[j]);
                        snap_owner[j] = -1;
                    }
                f.fmi2FreeInstance(inst[s]);
                inst[s] = NULL;
            }
            nc = f.fmi2Instantiate(irand(20) ? "fuzz" : "", ty, bad ? "{bogus}" : guid, "",
                                   &cb, fmi2False, fmi2False);
            if (nc == NULL) {
                if (n_log == before) ++n_silent;
                if (bad) ++n_bad_guid;
                else ++n_err;
            } else if (bad) {
                fprintf(stderr, "instantiated with a wrong GUID\n");
                return 10;
            } else {
                ++n_ok;
            }
            inst[s] = nc;
            ++n_calls;
            counted = 0;
            break;
        }
        case 1: { /* a valid initialisation sequence */
            if (c == NULL) break;
            st = f.fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0);
            if (st == fmi2OK) st = f.fmi2EnterInitializationMode(c);
            if (st == fmi2OK) st = f.fmi2ExitInitializationMode(c);
            if (st == fmi2OK) ++n_init_ok;
            break;
        }
        case 2: st = f.fmi2SetupExperiment(c, irand(2), rand_real(), rand_real(), irand(2), rand_real()); break;
        case 3: st = f.fmi2EnterInitializationMode(c); break;
        case 4: st = f.fmi2ExitInitializationMode(c); break;
        case 5: st = f.fmi2Terminate(c); break;
        case 6: st = f.fmi2Reset(c); break;
        case 7: case 8: st = f.fmi2GetReal(c, vr, nvr, irand(30) ? val : NULL); break;
        case 9: case 10: case 11: st = f.fmi2SetReal(c, vr, nvr, irand(30) ? val : NULL); break;
        case 12: { /* Integers: get, or set random (often out-of-range) values */
            fmi2Integer iv[8];
            for (k = 0; k < 8; ++k) {
                vr[k] = rand_vr_of(FMU_INFO_VR0_INTEGERS, FMU_INFO_N_INTEGERS);
                iv[k] = rand_int();
            }
            st = irand(2) ? f.fmi2GetInteger(c, vr, nvr, irand(30) ? iv : NULL)
                          : f.fmi2SetInteger(c, vr, nvr, irand(30) ? iv : NULL);
            if (c != NULL && nvr > 0) {
                if (st == fmi2OK) ++n_int_ok;
                else ++n_int_err;
            }
            break;
        }
        case 13: { /* Booleans: get, or set 0/1 and invalid values */
            fmi2Boolean bv[8];
            for (k = 0; k < 8; ++k) {
                vr[k] = rand_vr_of(FMU_INFO_VR0_BOOLEANS, FMU_INFO_N_BOOLEANS);
                bv[k] = irand(4) ? irand(2) : rand_int();
            }
            st = irand(2) ? f.fmi2GetBoolean(c, vr, nvr, irand(30) ? bv : NULL)
                          : f.fmi2SetBoolean(c, vr, nvr, irand(30) ? bv : NULL);
            if (c != NULL && nvr > 0) {
                if (st == fmi2OK) ++n_bool_ok;
                else ++n_bool_err;
            }
            break;
        }
        case 14: {
            fmi2String sv[8] = {"a", "b", "c", "d", "e", "f", "g", "h"};
            st = f.fmi2SetString(c, vr, nvr, sv);
            if (st == fmi2OK && irand(2)) st = f.fmi2GetString(c, vr, nvr, sv);
            break;
        }
        case 15: { /* get FMU state */
            j = irand(NSNAP);
            if (snap[j] != NULL && snap_owner[j] != s) {
                counted = 0;
                break;
            }
            st = f.fmi2GetFMUstate(c, &snap[j]);
            if (st == fmi2OK) snap_owner[j] = s;
            break;
        }
        case 16: { /* set FMU state (possibly of another instance of the same FMU) */
            j = irand(NSNAP);
            if (snap[j] == NULL && irand(2)) { counted = 0; break; }
            st = f.fmi2SetFMUstate(c, snap[j]);
            break;
        }
        case 17: {
            j = irand(NSNAP);
            if (snap[j] != NULL && snap_owner[j] != s) { counted = 0; break; }
            st = f.fmi2FreeFMUstate(c, &snap[j]);
            if (st == fmi2OK) snap_owner[j] = -1;
            break;
        }
        case 18: { /* serialise, corrupt, deserialise */
            fmi2FMUstate tmp = NULL;
            j = irand(NSNAP);
            if (snap[j] == NULL || snap_owner[j] != s) { counted = 0; break; }
            st = f.fmi2SerializedFMUstateSize(c, snap[j], &sz);
            if (st != fmi2OK) break;
            if (sz > sizeof buf) return 11;
            st = f.fmi2SerializeFMUstate(c, snap[j], buf, irand(10) ? sz : sz / 2);
            if (st != fmi2OK) break;
            if (irand(2)) buf[irand((int)sz)] ^= (fmi2Byte)(1 + irand(255));
            st = f.fmi2DeSerializeFMUstate(c, buf, irand(10) ? sz : sz - 1, &tmp);
            if (tmp != NULL) {
                fmi2Status st2 = f.fmi2SetFMUstate(c, tmp);
                f.fmi2FreeFMUstate(c, &tmp);
                if (st == fmi2OK) st = st2;
            }
            break;
        }
        case 19: case 20:
            st = f.fmi2GetDirectionalDerivative(c, vr, nvr, vr2, nvr2, val2, irand(30) ? val : NULL);
            break;
        case 21: st = f.fmi2EnterEventMode(c); break;
        case 22: {
            fmi2EventInfo ei;
            st = f.fmi2NewDiscreteStates(c, irand(20) ? &ei : NULL);
            break;
        }
        case 23: st = f.fmi2EnterContinuousTimeMode(c); break;
        case 24: {
            fmi2Boolean a, b;
            st = f.fmi2CompletedIntegratorStep(c, fmi2True, &a, &b);
            break;
        }
        case 25: st = f.fmi2SetTime(c, irand(3) ? urand() : rand_real()); break;
        case 26: { /* continuous states: mostly the current ones, slightly perturbed */
            size_t nx = irand(8) ? NX : (size_t)irand(NX + 2);
            if (f.fmi2GetContinuousStates(c, val2, NX) == fmi2OK && irand(4)) {
                for (k = 0; k < NX; ++k) val2[k] += 1e-3 * (urand() - 0.5);
                before = n_log;
            }
            st = f.fmi2SetContinuousStates(c, val2, nx);
            break;
        }
        case 27: st = f.fmi2GetDerivatives(c, val, irand(8) ? NX : (size_t)irand(NX + 2)); break;
        case 28: st = f.fmi2GetEventIndicators(c, val, (size_t)irand(2)); break;
        case 29: st = f.fmi2GetContinuousStates(c, val, irand(8) ? NX : (size_t)irand(NX + 6)); break;
        case 30: st = f.fmi2GetNominalsOfContinuousStates(c, val, irand(8) ? NX : 3); break;
        case 31: case 32: case 33: { /* do step: mostly at the right time, random sizes */
            double t = 0.0, h;
            fmi2Status ts = f.fmi2GetRealStatus(c, fmi2LastSuccessfulTime, &t);
            before = n_log;
            if (ts != fmi2OK || irand(6) == 0) t = rand_real();
            h = irand(4) ? 1e-3 * (1 + irand(10)) : rand_real();
            if (fabs(h) > 1.0 && isfinite(h) && fabs(h) < 1e6) h = 1.0; /* bound run time */
            st = f.fmi2DoStep(c, t, h, fmi2True);
            if (st == fmi2OK) ++n_steps_ok;
            break;
        }
        case 34: st = f.fmi2CancelStep(c); break;
        case 35: {
            fmi2Status sv;
            fmi2Real rv;
            fmi2Integer iv;
            fmi2Boolean bv;
            fmi2String strv;
            fmi2StatusKind kind = (fmi2StatusKind)irand(4);
            switch (irand(5)) {
            case 0: st = f.fmi2GetStatus(c, kind, &sv); break;
            case 1: st = f.fmi2GetRealStatus(c, kind, &rv); break;
            case 2: st = f.fmi2GetIntegerStatus(c, kind, &iv); break;
            case 3: st = f.fmi2GetBooleanStatus(c, kind, &bv); break;
            default: st = f.fmi2GetStringStatus(c, kind, &strv); break;
            }
            break;
        }
        case 36: {
            fmi2Integer order[8] = {1, 1, 1, 1, 1, 1, 1, 1};
            st = irand(2) ? f.fmi2SetRealInputDerivatives(c, vr, nvr, order, val)
                          : f.fmi2GetRealOutputDerivatives(c, vr, nvr, order, val);
            break;
        }
        case 37: {
            fmi2String cats[3] = {"logCalls", irand(2) ? "logStatusError" : "bogus", NULL};
            fmi2String on[2] = {"logStatusError", "logStatusWarning"};
            size_t nc = (size_t)irand(3);
            st = f.fmi2SetDebugLogging(c, irand(4) == 0, nc, irand(10) ? cats : NULL);
            /* never switch error logging off for good: re-enable it */
            f.fmi2SetDebugLogging(c, fmi2True, 2, on);
            f.fmi2SetDebugLogging(c, fmi2False, 0, NULL);
            break;
        }
        case 38: { /* Real inputs, small values (drive the model forward) */
            fmi2ValueReference tv[] = FMU_INFO_REAL_INPUT_VRS;
            double u[sizeof tv / sizeof tv[0]];
            for (k = 0; k < (int)(sizeof tv / sizeof tv[0]); ++k) u[k] = urand() - 0.5;
            st = f.fmi2SetReal(c, tv, (size_t)FMU_INFO_N_REAL_INPUTS, u);
            break;
        }
        case 39: { /* Integer / Boolean values that are often valid (e.g. noise on) */
            fmi2ValueReference one[1];
            fmi2Integer iv[1];
            fmi2Boolean bv[1];
            st = fmi2OK;
            if (FMU_INFO_N_BOOLEANS > 0) {
                one[0] = (fmi2ValueReference)(FMU_INFO_VR0_BOOLEANS + irand(FMU_INFO_N_BOOLEANS));
                bv[0] = irand(2);
                st = f.fmi2SetBoolean(c, one, 1, bv);
            }
            if (st == fmi2OK && FMU_INFO_N_INTEGERS > 0) {
                one[0] = (fmi2ValueReference)(FMU_INFO_VR0_INTEGERS + irand(FMU_INFO_N_INTEGERS));
                iv[0] = irand(1000);
                st = f.fmi2SetInteger(c, one, 1, iv);
            }
            break;
        }
        default: { /* NULL instance: must fail without crashing */
            fmi2Real dummy[NVAL];
            fmi2ValueReference v0 = 0;
            if (f.fmi2GetReal(NULL, &v0, 1, dummy) == fmi2OK ||
                f.fmi2DoStep(NULL, 0.0, 1e-3, fmi2True) == fmi2OK ||
                f.fmi2GetDerivatives(NULL, dummy, NX) == fmi2OK) {
                fprintf(stderr, "a call on a NULL instance returned fmi2OK\n");
                return 12;
            }
            ++n_null_inst;
            counted = 0;
            break;
        }
        }
        if (!counted) continue;
        if (c == NULL) { /* calls on a NULL slot must fail */
            if (op != 1 && st == fmi2OK) {
                fprintf(stderr, "op %d on a NULL instance returned fmi2OK\n", op);
                return 13;
            }
            ++n_null_inst;
            continue;
        }
        ++n_calls;
        if (st == fmi2OK) ++n_ok;
        else if (st == fmi2Error) ++n_err;
        else if (st == fmi2Discard) ++n_discard;
        else ++n_other;
        if (st != fmi2OK && n_log == before) {
            ++n_silent;
            if (n_silent <= 5) fprintf(stderr, "silent non-OK status %d in op %d\n", (int)st, op);
        }
    }
    for (i = 0; i < NINST; ++i) {
        if (inst[i] == NULL) continue;
        for (int j2 = 0; j2 < NSNAP; ++j2)
            if (snap_owner[j2] == i && snap[j2] != NULL) f.fmi2FreeFMUstate(inst[i], &snap[j2]);
        f.fmi2FreeInstance(inst[i]);
    }
    printf("{\"calls\": %ld, \"ok\": %ld, \"error\": %ld, \"discard\": %ld, \"other\": %ld, "
           "\"silent\": %ld, \"null_instance\": %ld, \"bad_guid\": %ld, \"steps_ok\": %ld, "
           "\"init_ok\": %ld, \"log_messages\": %ld, \"integer_ok\": %ld, "
           "\"integer_error\": %ld, \"boolean_ok\": %ld, \"boolean_error\": %ld}\n",
           n_calls, n_ok, n_err, n_discard, n_other, n_silent, n_null_inst, n_bad_guid,
           n_steps_ok, n_init_ok, n_log, n_int_ok, n_int_err, n_bool_ok, n_bool_err);
    dlclose(lib);
    return 0;
}
