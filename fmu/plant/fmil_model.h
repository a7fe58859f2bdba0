/* fmil_model.h: the plant's config header for the FMI layer (fmu/fmi/fmil.h): its
 * instantiation token and variable count from the table in navkit_plant.h, and its state,
 * the model plant_model_t. The FMI 3.0 (navkit_plant) and FMI 2.0 (navkit_plant_fmi2) FMUs
 * are both built from it. */
#ifndef PLANT_FMIL_MODEL_H
#define PLANT_FMIL_MODEL_H

#include "navkit_plant.h"

#define FMIL_INSTANTIATION_TOKEN PLANT_INSTANTIATION_TOKEN
#define FMIL_NUM_VRS PLANT_NUM_VARS /* value reference = position in PLANT_VARIABLES */

typedef plant_model_t fmil_model_t;

#endif /* PLANT_FMIL_MODEL_H */
