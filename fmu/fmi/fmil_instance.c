/* fmil_instance.c: the FMI-version-neutral part of the layer: the state table, value
 * references against the model's table, get/set, the step checks and logging. See fmil.h. */
#include "fmil.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { FMIL_ST_INSTANTIATED = 1, FMIL_ST_INIT = 2, FMIL_ST_STEP = 4, FMIL_ST_TERMINATED = 8 };
#define FMIL_ST_ANY (FMIL_ST_INSTANTIATED | FMIL_ST_INIT | FMIL_ST_STEP | FMIL_ST_TERMINATED)

/* Which states each call is legal in; name follows the "fmi2"/"fmi3" prefix in messages. */
static const struct {
    const char *name;
    unsigned states;
} fmil_legal[FMIL_FN_COUNT] = {
    [FMIL_SET_DEBUG_LOGGING] = {"SetDebugLogging", FMIL_ST_ANY},
    [FMIL_SETUP_EXPERIMENT] = {"SetupExperiment", FMIL_ST_INSTANTIATED},
    [FMIL_ENTER_INIT] = {"EnterInitializationMode", FMIL_ST_INSTANTIATED},
    [FMIL_EXIT_INIT] = {"ExitInitializationMode", FMIL_ST_INIT},
    [FMIL_TERMINATE] = {"Terminate", FMIL_ST_STEP},
    [FMIL_RESET] = {"Reset", FMIL_ST_ANY},
    [FMIL_GET] = {"Get<Type>", FMIL_ST_INIT | FMIL_ST_STEP | FMIL_ST_TERMINATED},
    [FMIL_SET] = {"Set<Type>", FMIL_ST_INSTANTIATED | FMIL_ST_INIT | FMIL_ST_STEP}, /* per variable: can_set */
    [FMIL_DO_STEP] = {"DoStep", FMIL_ST_STEP},
    [FMIL_GET_STATUS] = {"Get<Type>Status", FMIL_ST_STEP | FMIL_ST_TERMINATED},
};

void fmil_log(const fmil_instance_t *c, fmil_status_t st, const char *fmt, ...)
{
    char buf[1024];
    va_list ap;
    if (!c || !c->log || (st != FMIL_ERROR && !c->log_events)) {
        return;
    }
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    c->log(c, st, st == FMIL_ERROR ? "logStatusError" : "logEvents", buf);
}

/* Fills c->get_at and c->set_at from the variable table (see fmil.h). */
static void fmil_index(fmil_instance_t *c)
{
    uint32_t vr;
    for (vr = 0; vr < FMIL_NUM_VRS; vr++) {
        const fmil_var_t *vi = &fmil_model_vars[vr];
        if (vi->type >= FMIL_F64 && vi->type <= FMIL_U64) {
            c->get_at[vi->type - 1][vr] = (uint32_t)vi->offset + 1u;
            if (vi->causality == FMIL_INPUT) {
                c->set_at[vi->type - 1][vr] = (uint32_t)vi->offset + 1u;
            }
        }
    }
}

fmil_instance_t *fmil_new(const char *name, const char *resources, int logging, const char *api, fmil_log_fn log,
                          void *env, void (*callback)(void))
{
    fmil_instance_t *c = calloc(1, sizeof *c);
    if (!c) {
        return NULL;
    }
    fmil_index(c);
    snprintf(c->name, sizeof c->name, "%s", name ? name : "");
    snprintf(c->resources, sizeof c->resources, "%s", resources ? resources : "");
    c->log_events = logging ? 1 : 0;
    c->api = api;
    c->log = log;
    c->env = env;
    c->callback = callback;
    if (fmil_model_instantiate(c) == FMIL_ERROR) {
        fmil_model_free(c);
        free(c);
        return NULL;
    }
    fmil_model_start_values(c);
    c->state = FMIL_ST_INSTANTIATED;
    c->dirty = 1;
    return c;
}

void fmil_free(fmil_instance_t *c)
{
    if (!c) {
        return;
    }
    fmil_model_free(c);
    free(c);
}

fmil_status_t fmil_allowed(const fmil_instance_t *c, fmil_fn_t fn)
{
    if (!c) {
        return FMIL_ERROR;
    }
    if (fmil_legal[fn].states & c->state) {
        return FMIL_OK;
    }
    fmil_log(c, FMIL_ERROR, "%s%s is not allowed in state %u", c->api, fmil_legal[fn].name, c->state);
    return FMIL_ERROR;
}

/* Runs fmil_model_start when parameters changed since it last ran. */
static fmil_status_t fmil_ensure_started(fmil_instance_t *c)
{
    if (!c->dirty) {
        return FMIL_OK;
    }
    if (fmil_model_start(c) == FMIL_ERROR) {
        return FMIL_ERROR;
    }
    c->dirty = 0;
    return FMIL_OK;
}

fmil_status_t fmil_set_debug_logging(fmil_instance_t *c, int on, size_t n, const char *const categories[])
{
    size_t i;
    int events = (n == 0u); /* no categories: all of them */
    if (fmil_allowed(c, FMIL_SET_DEBUG_LOGGING)) {
        return FMIL_ERROR;
    }
    for (i = 0; i < n; i++) {
        if (categories[i] && strcmp(categories[i], "logEvents") == 0) {
            events = 1;
        } else if (!categories[i] || strcmp(categories[i], "logStatusError") != 0) {
            fmil_log(c, FMIL_ERROR, "%sSetDebugLogging: unknown log category \"%s\"", c->api,
                     categories[i] ? categories[i] : "(null)");
            return FMIL_ERROR;
        }
    }
    /* logStatusError is always reported; on/off switches logEvents when it is concerned */
    if (events) {
        c->log_events = on ? 1 : 0;
    }
    return FMIL_OK;
}

fmil_status_t fmil_enter_init(fmil_instance_t *c, double start_time)
{
    if (fmil_allowed(c, FMIL_ENTER_INIT)) {
        return FMIL_ERROR;
    }
    c->time = start_time;
    c->dirty = 1;
    c->state = FMIL_ST_INIT;
    return FMIL_OK;
}

fmil_status_t fmil_exit_init(fmil_instance_t *c)
{
    if (fmil_allowed(c, FMIL_EXIT_INIT) || fmil_ensure_started(c)) {
        return FMIL_ERROR;
    }
    c->state = FMIL_ST_STEP;
    return FMIL_OK;
}

fmil_status_t fmil_terminate(fmil_instance_t *c)
{
    if (fmil_allowed(c, FMIL_TERMINATE)) {
        return FMIL_ERROR;
    }
    c->state = FMIL_ST_TERMINATED;
    return FMIL_OK;
}

fmil_status_t fmil_reset(fmil_instance_t *c)
{
    if (fmil_allowed(c, FMIL_RESET)) {
        return FMIL_ERROR;
    }
    fmil_model_start_values(c);
    c->time = 0.0;
    c->state = FMIL_ST_INSTANTIATED;
    c->dirty = 1;
    return FMIL_OK;
}

/* ---------------------------------------------------------------- get / set */

static const char *const fmil_type_name[] = {
    [FMIL_NONE] = "no",    [FMIL_F64] = "Float64", [FMIL_I32] = "Int32",  [FMIL_U32] = "UInt32",
    [FMIL_U64] = "UInt64", [FMIL_STR] = "String",  [FMIL_BIN] = "Binary",
};

/* The table row of vr if it is a variable of type; else logs why and returns NULL. */
static const fmil_var_t *fmil_lookup(const fmil_instance_t *c, uint32_t vr, fmil_type_t type, const char *fn)
{
    if (vr >= FMIL_NUM_VRS || fmil_model_vars[vr].type == FMIL_NONE) {
        fmil_log(c, FMIL_ERROR, "%s: no variable with value reference %u", fn, (unsigned)vr);
        return NULL;
    }
    if (fmil_model_vars[vr].type != type) {
        fmil_log(c, FMIL_ERROR, "%s: variable %s (vr %u) is %s, not %s", fn, fmil_model_vars[vr].name, (unsigned)vr,
                 fmil_type_name[fmil_model_vars[vr].type], fmil_type_name[type]);
        return NULL;
    }
    return &fmil_model_vars[vr];
}

/* Whether variable vi may be set in c's state: inputs always (the call's state was
 * checked), parameters before StepMode (marking the model for a restart), others never. */
static int fmil_can_set(fmil_instance_t *c, const fmil_var_t *vi, const char *fn)
{
    if (vi->causality == FMIL_INPUT) {
        return 1;
    }
    if (vi->causality == FMIL_PARAMETER && (c->state & (FMIL_ST_INSTANTIATED | FMIL_ST_INIT))) {
        c->dirty = 1;
        return 1;
    }
    if (vi->causality == FMIL_PARAMETER) {
        fmil_log(c, FMIL_ERROR, "%s: %s is a fixed parameter: it cannot be set in state %u", fn, vi->name, c->state);
    } else {
        fmil_log(c, FMIL_ERROR, "%s: %s is not an input or parameter and cannot be set", fn, vi->name);
    }
    return 0;
}

/* The state check and the count check of every Get/Set (fmil_access): the general case.
 * A Get in InitializationMode starts the model first when parameters changed. */
static fmil_status_t fmil_access_checked(fmil_instance_t *c, int get, size_t nvr, size_t nvals, const char *fn)
{
    if (fmil_allowed(c, get ? FMIL_GET : FMIL_SET)) {
        return FMIL_ERROR;
    }
    if (nvals != nvr) {
        fmil_log(c, FMIL_ERROR, "%s: nValues %zu != nValueReferences %zu (all variables are scalars)", fn, nvals, nvr);
        return FMIL_ERROR;
    }
    if (get && c->state == FMIL_ST_INIT && fmil_ensure_started(c)) {
        return FMIL_ERROR;
    }
    return FMIL_OK;
}

/* The state check and the count check of every Get/Set. StepMode, where the calls of
 * every co-simulation step land, allows both Get and Set and has the model started, so
 * there a matching count is all there is to check, inline; the rest goes the full way. */
static inline fmil_status_t fmil_access(fmil_instance_t *c, int get, size_t nvr, size_t nvals, const char *fn)
{
    if (c && c->state == FMIL_ST_STEP && nvals == nvr) {
        return FMIL_OK;
    }
    return fmil_access_checked(c, get, nvr, nvals, fn);
}

/* 1 + the offset in c->model of variable vr of type for a Get (get != 0) or Set that
 * c->get_at / c->set_at refused: a parameter set before StepMode; else 0, the refusal
 * logged. */
static uint32_t fmil_checked_at(fmil_instance_t *c, uint32_t vr, fmil_type_t type, int get, const char *fn)
{
    const fmil_var_t *vi = fmil_lookup(c, vr, type, fn);
    if (!vi || (!get && !fmil_can_set(c, vi, fn))) {
        return 0u;
    }
    return (uint32_t)vi->offset + 1u;
}

/* These calls run several times per 1 ms co-simulation step: per value one lookup in the
 * instance's table of its type and one copy of a size known at compile time (a loop per
 * type). On an error the values before the bad reference were copied. */
#define FMIL_COPY_LOOP(CT, LT, GET)                                                                                    \
    for (i = 0; i < nvr; i++) {                                                                                        \
        const uint32_t r = vr[i];                                                                                      \
        uint32_t at = (r < FMIL_NUM_VRS) ? (GET ? c->get_at : c->set_at)[(LT)-1][r] : 0u;                              \
        if (at == 0u && (at = fmil_checked_at(c, r, LT, GET, fn)) == 0u) {                                             \
            return FMIL_ERROR;                                                                                         \
        }                                                                                                              \
        if (GET) {                                                                                                     \
            ((CT *)values)[i] = *(const CT *)(const void *)(base + (at - 1u));                                         \
        } else {                                                                                                       \
            *(CT *)(void *)(base + (at - 1u)) = ((const CT *)values)[i];                                               \
        }                                                                                                              \
    }

/* Get (get != 0) or Set of nvr scalars of type between values and the model. */
static fmil_status_t fmil_copy(fmil_instance_t *c, const uint32_t vr[], size_t nvr, void *values, size_t nvals,
                               fmil_type_t type, int get, const char *fn)
{
    char *base;
    size_t i;
    if (fmil_access(c, get, nvr, nvals, fn)) {
        return FMIL_ERROR;
    }
    base = (char *)&c->model;
    switch (type) {
    case FMIL_F64:
        if (get) {
            FMIL_COPY_LOOP(double, FMIL_F64, 1)
        } else {
            FMIL_COPY_LOOP(double, FMIL_F64, 0)
        }
        break;
    case FMIL_I32:
        if (get) {
            FMIL_COPY_LOOP(int32_t, FMIL_I32, 1)
        } else {
            FMIL_COPY_LOOP(int32_t, FMIL_I32, 0)
        }
        break;
    case FMIL_U32:
        if (get) {
            FMIL_COPY_LOOP(uint32_t, FMIL_U32, 1)
        } else {
            FMIL_COPY_LOOP(uint32_t, FMIL_U32, 0)
        }
        break;
    case FMIL_U64:
        if (get) {
            FMIL_COPY_LOOP(uint64_t, FMIL_U64, 1)
        } else {
            FMIL_COPY_LOOP(uint64_t, FMIL_U64, 0)
        }
        break;
    default:
        fmil_log(c, FMIL_ERROR, "%s: not a scalar type", fn);
        return FMIL_ERROR;
    }
    if (!get) {
        fmil_model_inputs_changed(c);
    }
    return FMIL_OK;
}
#undef FMIL_COPY_LOOP

fmil_status_t fmil_get(fmil_instance_t *c, const uint32_t vr[], size_t nvr, void *values, size_t nvals,
                       fmil_type_t type, const char *fn)
{
    return fmil_copy(c, vr, nvr, values, nvals, type, 1, fn);
}

fmil_status_t fmil_set(fmil_instance_t *c, const uint32_t vr[], size_t nvr, const void *values, size_t nvals,
                       fmil_type_t type, const char *fn)
{
    return fmil_copy(c, vr, nvr, (void *)values, nvals, type, 0, fn);
}

fmil_status_t fmil_get_strings(fmil_instance_t *c, const uint32_t vr[], size_t nvr, const char *values[], size_t nvals,
                               const char *fn)
{
    size_t i;
    if (fmil_access(c, 1, nvr, nvals, fn)) {
        return FMIL_ERROR;
    }
    for (i = 0; i < nvr; i++) {
        const fmil_var_t *vi = fmil_lookup(c, vr[i], FMIL_STR, fn);
        if (!vi) {
            return FMIL_ERROR;
        }
        values[i] = (const char *)&c->model + vi->offset;
    }
    return FMIL_OK;
}

fmil_status_t fmil_set_strings(fmil_instance_t *c, const uint32_t vr[], size_t nvr, const char *const values[],
                               size_t nvals, const char *fn)
{
    size_t i;
    if (fmil_access(c, 0, nvr, nvals, fn)) {
        return FMIL_ERROR;
    }
    for (i = 0; i < nvr; i++) {
        const fmil_var_t *vi = fmil_lookup(c, vr[i], FMIL_STR, fn);
        const char *s = values[i] ? values[i] : "";
        if (!vi || !fmil_can_set(c, vi, fn)) {
            return FMIL_ERROR;
        }
        if (strlen(s) >= FMIL_STR_MAX) {
            fmil_log(c, FMIL_ERROR, "%s: %s is longer than %d bytes", fn, vi->name, FMIL_STR_MAX - 1);
            return FMIL_ERROR;
        }
        memcpy((char *)&c->model + vi->offset, s, strlen(s) + 1u);
    }
    return FMIL_OK;
}

fmil_status_t fmil_get_binaries(fmil_instance_t *c, const uint32_t vr[], size_t nvr, size_t sizes[],
                                const uint8_t *values[], size_t nvals, const char *fn)
{
    size_t i;
    if (fmil_access(c, 1, nvr, nvals, fn)) {
        return FMIL_ERROR;
    }
    for (i = 0; i < nvr; i++) {
        const fmil_var_t *vi = fmil_lookup(c, vr[i], FMIL_BIN, fn);
        const fmil_binary_t *b;
        if (!vi) {
            return FMIL_ERROR;
        }
        b = (const fmil_binary_t *)(const void *)((const char *)&c->model + vi->offset);
        values[i] = b->data;
        sizes[i] = b->len;
    }
    return FMIL_OK;
}

fmil_status_t fmil_set_binaries(fmil_instance_t *c, const uint32_t vr[], size_t nvr, const size_t sizes[],
                                const uint8_t *const values[], size_t nvals, const char *fn)
{
    size_t i;
    if (fmil_access(c, 0, nvr, nvals, fn)) {
        return FMIL_ERROR;
    }
    for (i = 0; i < nvr; i++) {
        const fmil_var_t *vi = fmil_lookup(c, vr[i], FMIL_BIN, fn);
        fmil_binary_t *b;
        if (!vi || !fmil_can_set(c, vi, fn)) {
            return FMIL_ERROR;
        }
        b = (fmil_binary_t *)(void *)((char *)&c->model + vi->offset);
        if (sizes[i] > b->cap) {
            fmil_log(c, FMIL_ERROR, "%s: %s of %zu bytes exceeds %zu", fn, vi->name, sizes[i], b->cap);
            return FMIL_ERROR;
        }
        if (sizes[i] > 0u) {
            memcpy(b->data, values[i], sizes[i]);
        }
        b->len = sizes[i];
    }
    return FMIL_OK;
}

fmil_status_t fmil_no_values(const fmil_instance_t *c, size_t nvr, const char *fn)
{
    if (nvr == 0u) {
        return FMIL_OK;
    }
    fmil_log(c, FMIL_ERROR, "%s: the model has no variable of this type", fn);
    return FMIL_ERROR;
}

/* ---------------------------------------------------------------- co-simulation */

fmil_status_t fmil_do_step(fmil_instance_t *c, double t, double h)
{
    fmil_status_t st;
    if (fmil_allowed(c, FMIL_DO_STEP)) {
        return FMIL_ERROR;
    }
    if (!(h > 0.0) || !isfinite(h)) {
        fmil_log(c, FMIL_ERROR, "%sDoStep: communicationStepSize %g must be > 0", c->api, h);
        return FMIL_ERROR;
    }
    if (fabs(t - c->time) > 1e-9 * (1.0 + fabs(c->time))) {
        fmil_log(c, FMIL_ERROR, "%sDoStep: currentCommunicationPoint %.9f s != the FMU's time %.9f s", c->api, t,
                 c->time);
        return FMIL_ERROR;
    }
    st = fmil_model_step(c, t, h);
    if (st != FMIL_ERROR) {
        c->time = t + h; /* the importer's clock: no drift */
    }
    return st;
}

fmil_status_t fmil_unsupported(const fmil_instance_t *c, const char *fn)
{
    fmil_log(c, FMIL_ERROR, "%s is not supported by %s", fn, FMIL_MODEL_IDENTIFIER);
    return FMIL_ERROR;
}
