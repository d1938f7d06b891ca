/*
 * fmi2_state.c - FMU states of the shared FMI 2.0 layer: fmi2GetFMUstate,
 * fmi2SetFMUstate, fmi2FreeFMUstate and their serialisation (fmi2SerializedFMUstateSize,
 * fmi2SerializeFMUstate, fmi2DeSerializeFMUstate).  A snapshot holds the mode, the times
 * and every value; every state is validated before it is restored (exactly one mode bit,
 * matching FMU type, finite times, every stored value in range, the model's start-value
 * checks), since the serialised layout and its checksum are public.
 *
 * Part of the layer described in fmi2_common.c (policies) and fmi2_internal.h (parts).
 */
#include "fmi2_internal.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

#define SNAP_MAGIC 0x534e4150u /* "SNAP" */
#define SER_MAGIC "FMU2SNP\x02"

/* The modes an FMU state may hold, and those of one instance type only. */
#define ALL_STATES                                                                          \
    (FMU_ST_INSTANTIATED | FMU_ST_INIT | FMU_ST_EVENT | FMU_ST_CONT | FMU_ST_STEP_COMPLETE |  \
     FMU_ST_STEP_FAILED | FMU_ST_TERMINATED | FMU_ST_ERROR)
#define ME_ONLY_STATES (FMU_ST_EVENT | FMU_ST_CONT)
#define CS_ONLY_STATES (FMU_ST_STEP_COMPLETE | FMU_ST_STEP_FAILED)

/* Snapshot created by fmi2GetFMUstate: the mode, the times and every value. */
typedef struct {
    unsigned magic;
    fmi2Type type;
    fmu_state state;
    double time;
    double t_start;
    double data[1]; /* fmu_values_bytes(): reals, integers, booleans */
} fmu_snapshot;

static size_t snapshot_bytes(void) { return offsetof(fmu_snapshot, data) + fmu_values_bytes(); }

static fmu_values snapshot_values(fmu_snapshot *s) {
    fmu_values v;
    fmu_bind_values(&v, s->data);
    return v;
}

static fmu_snapshot *new_snapshot(fmu_instance *inst, const char *fn) {
    fmu_snapshot *s = (fmu_snapshot *)inst->cb.allocateMemory(
        snapshot_bytes() / sizeof(double) + 1, sizeof(double));
    if (s == NULL) LOG_ERR(inst, "%s: out of memory", fn);
    return s;
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    fmu_instance *inst = fmu_enter(c, CALL_GET_FMU_STATE);
    fmu_snapshot *s;
    fmu_values v;
    if (inst == NULL) return fmi2Error;
    if (FMUstate == NULL) {
        LOG_ERR(inst, "fmi2GetFMUstate: FMUstate is NULL");
        return fmi2Error;
    }
    s = (fmu_snapshot *)*FMUstate;
    if (s != NULL && s->magic != SNAP_MAGIC) {
        LOG_ERR(inst, "fmi2GetFMUstate: *FMUstate is neither NULL nor a state of this FMU");
        return fmi2Error;
    }
    if (s == NULL && (s = new_snapshot(inst, "fmi2GetFMUstate")) == NULL) return fmi2Error;
    s->magic = SNAP_MAGIC;
    s->type = inst->type;
    s->state = inst->state;
    s->time = inst->time;
    s->t_start = inst->t_start;
    v = snapshot_values(s);
    fmu_copy_values(&v, &inst->v);
    *FMUstate = (fmi2FMUstate)s;
    return fmi2OK;
}

/* The stored value ix of type t, as double (exact for the Integer and Boolean values). */
static double stored(const fmu_values *v, fmu_vtype t, size_t ix) {
    if (t == FMU_REAL) return v->r[ix];
    if (t == FMU_INTEGER) return (double)v->i[ix];
    return (double)v->b[ix];
}

/* Is a snapshot consistent (type, mode, finite times, every stored value in range, the
 * model's start-value checks)?  Logs the reason if not. */
static int snapshot_valid(fmu_instance *inst, fmu_snapshot *s, const char *fn) {
    fmu_values v;
    size_t k;
    int t;
    if (s->magic != SNAP_MAGIC) {
        LOG_ERR(inst, "%s: not an FMU state of this FMU", fn);
        return 0;
    }
    if (s->type != inst->type) {
        LOG_ERR(inst, "%s: the FMU state belongs to a %s instance", fn,
                s->type == fmi2ModelExchange ? "Model Exchange" : "Co-Simulation");
        return 0;
    }
    if (!((unsigned)s->state & ALL_STATES) ||
        ((unsigned)s->state & ((unsigned)s->state - 1u)) != 0) {
        LOG_ERR(inst, "%s: the FMU state has an invalid mode 0x%x (exactly one mode bit must "
                "be set)", fn, (unsigned)s->state);
        return 0;
    }
    if ((unsigned)s->state & (s->type == fmi2ModelExchange ? CS_ONLY_STATES : ME_ONLY_STATES)) {
        LOG_ERR(inst, "%s: the FMU state's mode %s does not exist for a %s instance", fn,
                fmu_state_name(s->state),
                s->type == fmi2ModelExchange ? "Model Exchange" : "Co-Simulation");
        return 0;
    }
    if (!isfinite(s->time) || !isfinite(s->t_start)) {
        LOG_ERR(inst, "%s: the FMU state has a non-finite time", fn);
        return 0;
    }
    v = snapshot_values(s);
    for (t = 0; t < FMU_NTYPES; ++t) {
        for (k = 0; k < NVARS(t); ++k) {
            const fmu_var *d = &fmu_model.vars->var[t][k];
            double x = stored(&v, (fmu_vtype)t, k);
            if (fmu_evaluated(d->kind)) continue; /* recomputed */
            inst->msg[0] = '\0';
            if (!fmu_value_ok((fmu_vtype)t, d, x, inst->msg, sizeof inst->msg)) {
                LOG_ERR(inst, "%s: the FMU state has an invalid value of '%s' (%g): %s", fn,
                        d->name, x, inst->msg);
                return 0;
            }
        }
    }
    inst->msg[0] = '\0'; /* the start-value checks of fmi2ExitInitializationMode */
    if (fmu_model.check_initial != NULL &&
        fmu_model.check_initial(&v, 1, inst->msg, sizeof inst->msg) != 0) {
        LOG_ERR(inst, "%s: the FMU state is inconsistent: %s", fn, inst->msg);
        return 0;
    }
    return 1;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    fmu_instance *inst = fmu_enter(c, CALL_SET_FMU_STATE);
    fmu_snapshot *s = (fmu_snapshot *)FMUstate;
    fmu_values v;
    if (inst == NULL) return fmi2Error;
    if (s == NULL) {
        LOG_ERR(inst, "fmi2SetFMUstate: FMUstate is NULL");
        return fmi2Error;
    }
    if (!snapshot_valid(inst, s, "fmi2SetFMUstate")) return fmi2Error;
    inst->state = s->state;
    inst->time = s->time;
    inst->t_start = s->t_start;
    v = snapshot_values(s);
    fmu_copy_values(&inst->v, &v);
    inst->dirty = inst->init_dirty = 1;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    fmu_instance *inst = fmu_enter(c, CALL_FREE_FMU_STATE);
    fmu_snapshot *s;
    if (inst == NULL) return fmi2Error;
    if (FMUstate == NULL) {
        LOG_ERR(inst, "fmi2FreeFMUstate: FMUstate is NULL");
        return fmi2Error;
    }
    s = (fmu_snapshot *)*FMUstate;
    if (s == NULL) return fmi2OK;
    if (s->magic != SNAP_MAGIC) {
        LOG_ERR(inst, "fmi2FreeFMUstate: not an FMU state of this FMU");
        return fmi2Error;
    }
    s->magic = 0;
    inst->cb.freeMemory(s);
    *FMUstate = NULL;
    return fmi2OK;
}

/* ------------------------------------------------------------------ serialisation */

/* Serialised layout (host byte order):
 *   magic[8] "FMU2SNP\x02" | GUID hash u64 | n_reals u64 | n_integers u64 | n_booleans u64 |
 *   type i32 | mode u32 | time f64 | t_start f64 | reals f64[n_reals] |
 *   integers i32[n_integers] | booleans i32[n_booleans] | FNV-1a 64 of everything before. */
#define SER_HEADER 64
static uint64_t fnv1a(const unsigned char *p, size_t n, uint64_t h) {
    size_t i;
    for (i = 0; i < n; ++i) {
        h ^= p[i];
        h *= 1099511628211ull;
    }
    return h;
}

#define FNV_OFFSET 1469598103934665603ull

static size_t serialized_size(void) {
    return SER_HEADER + NVARS(FMU_REAL) * 8 + (NVARS(FMU_INTEGER) + NVARS(FMU_BOOLEAN)) * 4 + 8;
}

static uint64_t guid_hash(void) {
    return fnv1a((const unsigned char *)fmu_model.guid, strlen(fmu_model.guid), FNV_OFFSET);
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    fmu_instance *inst = fmu_enter(c, CALL_SERIALIZED_SIZE);
    if (inst == NULL) return fmi2Error;
    if (FMUstate == NULL || size == NULL ||
        ((const fmu_snapshot *)FMUstate)->magic != SNAP_MAGIC) {
        LOG_ERR(inst, "fmi2SerializedFMUstateSize: invalid FMUstate or size pointer");
        return fmi2Error;
    }
    *size = serialized_size();
    return fmi2OK;
}

static unsigned char *put(unsigned char *p, const void *x, size_t n) {
    memcpy(p, x, n);
    return p + n;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte data[],
                                 size_t size) {
    fmu_instance *inst = fmu_enter(c, CALL_SERIALIZE);
    fmu_snapshot *s = (fmu_snapshot *)FMUstate;
    unsigned char *p = (unsigned char *)data;
    fmu_values v;
    uint64_t u, h;
    int32_t i32;
    uint32_t st;
    size_t k;
    int t;
    if (inst == NULL) return fmi2Error;
    if (s == NULL || s->magic != SNAP_MAGIC || data == NULL) {
        LOG_ERR(inst, "fmi2SerializeFMUstate: invalid FMUstate or NULL buffer");
        return fmi2Error;
    }
    if (size < serialized_size()) {
        LOG_ERR(inst, "fmi2SerializeFMUstate: buffer of %lu bytes is too small, need %lu",
                (unsigned long)size, (unsigned long)serialized_size());
        return fmi2Error;
    }
    p = put(p, SER_MAGIC, 8);
    u = guid_hash();
    p = put(p, &u, 8);
    for (t = 0; t < FMU_NTYPES; ++t) {
        u = (uint64_t)NVARS(t);
        p = put(p, &u, 8);
    }
    i32 = (int32_t)s->type;
    p = put(p, &i32, 4);
    st = (uint32_t)s->state;
    p = put(p, &st, 4);
    p = put(p, &s->time, 8);
    p = put(p, &s->t_start, 8);
    v = snapshot_values(s);
    p = put(p, v.r, NVARS(FMU_REAL) * 8);
    for (k = 0; k < NVARS(FMU_INTEGER); ++k) {
        i32 = (int32_t)v.i[k];
        p = put(p, &i32, 4);
    }
    for (k = 0; k < NVARS(FMU_BOOLEAN); ++k) {
        i32 = (int32_t)v.b[k];
        p = put(p, &i32, 4);
    }
    h = fnv1a((const unsigned char *)data, (size_t)(p - (unsigned char *)data), FNV_OFFSET);
    memcpy(p, &h, 8);
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[],
                                   size_t size, fmi2FMUstate *FMUstate) {
    const char *fn = "fmi2DeSerializeFMUstate";
    fmu_instance *inst = fmu_enter(c, CALL_DESERIALIZE);
    const unsigned char *p = (const unsigned char *)serializedState;
    uint64_t u, h;
    int32_t i32;
    uint32_t st;
    fmu_snapshot *s;
    fmu_values v;
    size_t need = serialized_size(), k, off;
    int t;
    if (inst == NULL) return fmi2Error;
    if (p == NULL || FMUstate == NULL) {
        LOG_ERR(inst, "%s: NULL argument", fn);
        return fmi2Error;
    }
    if (*FMUstate != NULL && ((fmu_snapshot *)*FMUstate)->magic != SNAP_MAGIC) {
        LOG_ERR(inst, "%s: *FMUstate is neither NULL nor a state of this FMU", fn);
        return fmi2Error;
    }
    if (size != need) {
        LOG_ERR(inst, "%s: corrupt state: %lu bytes, expected %lu", fn, (unsigned long)size,
                (unsigned long)need);
        return fmi2Error;
    }
    if (memcmp(p, SER_MAGIC, 8) != 0) {
        LOG_ERR(inst, "%s: corrupt state: bad magic", fn);
        return fmi2Error;
    }
    memcpy(&h, p + need - 8, 8);
    if (h != fnv1a(p, need - 8, FNV_OFFSET)) {
        LOG_ERR(inst, "%s: corrupt state: checksum mismatch", fn);
        return fmi2Error;
    }
    memcpy(&u, p + 8, 8);
    if (u != guid_hash()) {
        LOG_ERR(inst, "%s: the state was serialised by an FMU with a different GUID", fn);
        return fmi2Error;
    }
    for (t = 0; t < FMU_NTYPES; ++t) {
        memcpy(&u, p + 16 + 8 * (size_t)t, 8);
        if (u != (uint64_t)NVARS(t)) {
            LOG_ERR(inst, "%s: corrupt state: wrong number of %s variables", fn, fmu_type_names[t]);
            return fmi2Error;
        }
    }
    s = (fmu_snapshot *)*FMUstate;
    if (s == NULL) {
        if ((s = new_snapshot(inst, fn)) == NULL) return fmi2Error;
        *FMUstate = (fmi2FMUstate)s;
    }
    s->magic = SNAP_MAGIC;
    memcpy(&i32, p + 40, 4);
    memcpy(&st, p + 44, 4);
    s->type = (fmi2Type)i32;
    s->state = (fmu_state)st;
    memcpy(&s->time, p + 48, 8);
    memcpy(&s->t_start, p + 56, 8);
    v = snapshot_values(s);
    off = SER_HEADER;
    memcpy(v.r, p + off, NVARS(FMU_REAL) * 8);
    off += NVARS(FMU_REAL) * 8;
    for (k = 0; k < NVARS(FMU_INTEGER); ++k, off += 4) {
        memcpy(&i32, p + off, 4);
        v.i[k] = (fmi2Integer)i32;
    }
    for (k = 0; k < NVARS(FMU_BOOLEAN); ++k, off += 4) {
        memcpy(&i32, p + off, 4);
        v.b[k] = (fmi2Boolean)i32;
    }
    if (!snapshot_valid(inst, s, fn)) {
        s->magic = 0;
        inst->cb.freeMemory(s);
        *FMUstate = NULL;
        return fmi2Error;
    }
    return fmi2OK;
}
