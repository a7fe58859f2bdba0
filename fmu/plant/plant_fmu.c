/* plant_fmu.c: the plant model (plant_model.c) behind the FMI layer (fmu/fmi/fmil.h): its
 * variable table and the hooks. Parameters take effect when the model starts (at
 * ExitInitializationMode, or at a Get in InitializationMode after a parameter changed):
 * plant_start checks them and loads the world; its message names the parameter or the world
 * file and line. */
#include <string.h>

#include "fmil.h"

_Static_assert(PLANT_STR_MAX == FMIL_STR_MAX, "the plant's String fields are the layer's size");
/* the layer reads a Binary variable's field as an fmil_binary_t */
_Static_assert(sizeof(plant_binary_t) == sizeof(fmil_binary_t) &&
                   offsetof(plant_binary_t, data) == offsetof(fmil_binary_t, data) &&
                   offsetof(plant_binary_t, len) == offsetof(fmil_binary_t, len) &&
                   offsetof(plant_binary_t, cap) == offsetof(fmil_binary_t, cap),
               "plant_binary_t is laid out as fmil_binary_t");

#define PLANT_ROW(n, c, s, u, d, t) {#n, t, FMIL_##c, offsetof(fmil_model_t, v.n)},
#define PLANT_F64(n, c, s, u, d) PLANT_ROW(n, c, s, u, d, FMIL_F64)
#define PLANT_I32(n, c, s, u, d) PLANT_ROW(n, c, s, u, d, FMIL_I32)
#define PLANT_STR(n, c, s, u, d) PLANT_ROW(n, c, s, u, d, FMIL_STR)
#define PLANT_BIN(n, c, s, u, d) PLANT_ROW(n, c, s, u, d, FMIL_BIN)
const fmil_var_t fmil_model_vars[FMIL_NUM_VRS] = {PLANT_VARIABLES(PLANT_F64, PLANT_I32, PLANT_STR, PLANT_BIN)};

fmil_status_t fmil_model_instantiate(fmil_instance_t *c)
{
    (void)c; /* no resources: a world file is a parameter (an absolute path) */
    return FMIL_OK;
}

void fmil_model_start_values(fmil_instance_t *c)
{
    plant_set_start_values(&c->model);
    c->model.t = 0.0;
}

fmil_status_t fmil_model_start(fmil_instance_t *c)
{
    char err[1024];
    c->model.v.time = c->time;
    if (plant_start(&c->model, c->time, err, sizeof err)) {
        fmil_log(c, FMIL_ERROR, "%s", err);
        return FMIL_ERROR;
    }
    return FMIL_OK;
}

void fmil_model_inputs_changed(fmil_instance_t *c)
{
    plant_inputs_changed(&c->model);
}

fmil_status_t fmil_model_step(fmil_instance_t *c, double t, double h)
{
    plant_step(&c->model, h);
    c->model.t = t + h; /* the importer's clock: no drift */
    c->model.v.time = c->model.t;
    return FMIL_OK;
}

void fmil_model_free(fmil_instance_t *c)
{
    plant_release(&c->model);
}
