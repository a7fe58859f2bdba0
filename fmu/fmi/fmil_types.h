/* fmil_types.h: the FMI layer's value types, which a model's config header (fmil_model.h)
 * may use in its fmil_model_t (see fmil.h). */
#ifndef FMIL_TYPES_H
#define FMIL_TYPES_H

#include <stddef.h>
#include <stdint.h>

/* Result of a layer or model call. FMIL_WARNING: done, with a message worth logging. */
typedef enum { FMIL_OK = 0, FMIL_WARNING = 1, FMIL_ERROR = 2 } fmil_status_t;

/* Variable types. FMIL_NONE marks a value reference the model does not use. */
typedef enum { FMIL_NONE = 0, FMIL_F64, FMIL_I32, FMIL_U32, FMIL_U64, FMIL_STR, FMIL_BIN } fmil_type_t;

/* Causalities (variability follows: parameters are fixed). */
typedef enum { FMIL_INDEPENDENT, FMIL_PARAMETER, FMIL_INPUT, FMIL_OUTPUT } fmil_causality_t;

/* A Binary variable's value: len bytes at data (which the model points into its own
 * state); an input accepts at most cap bytes. */
typedef struct {
    uint8_t *data;
    size_t len, cap; /* bytes */
} fmil_binary_t;

/* Longest String value, bytes with the terminator (a String field is char[FMIL_STR_MAX]). */
#define FMIL_STR_MAX 4096

/* One row of the model's variable table, indexed by value reference. offset: bytes of the
 * value's field from the start of fmil_model_t (a double, int32_t, uint32_t, uint64_t,
 * char[FMIL_STR_MAX] or fmil_binary_t by type). */
typedef struct {
    const char *name;
    fmil_type_t type;
    fmil_causality_t causality;
    size_t offset;
} fmil_var_t;

#endif /* FMIL_TYPES_H */
