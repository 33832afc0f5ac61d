/*
 * One FMU instance: its storage, logging, model evaluation, the co-simulation
 * integrator and FMU-state snapshots. Used by fmi2_functions.c, which owns the
 * FMI 2.0 state machine and the argument checks. No global mutable state:
 * everything an instance touches lives in its MwInstance.
 */
#ifndef MW_INSTANCE_H
#define MW_INSTANCE_H

#include "fmi2Functions.h"
#include "model.h"

/* Modes of the FMI 2.0 state machines of Model Exchange and Co-Simulation, as bits. */
typedef enum {
    MW_MODE_INSTANTIATED = 1u << 0,
    MW_MODE_INIT = 1u << 1,
    MW_MODE_EVENT = 1u << 2,         /* Model Exchange */
    MW_MODE_CONTINUOUS = 1u << 3,    /* Model Exchange */
    MW_MODE_STEP_COMPLETE = 1u << 4, /* Co-Simulation */
    MW_MODE_STEP_FAILED = 1u << 5,   /* Co-Simulation, after fmi2DoStep returned fmi2Discard */
    MW_MODE_TERMINATED = 1u << 6,
    MW_MODE_ERROR = 1u << 7
} MwMode;

/* Log categories, in the order of <LogCategories> in modelDescription.xml. */
typedef enum {
    MW_LOG_WARNING = 0,
    MW_LOG_DISCARD = 1,
    MW_LOG_ERROR = 2,
    MW_LOG_FATAL = 3,
    MW_LOG_CALLS = 4,
    MW_LOG_COUNT = 5
} MwLogCategory;

#define MW_INSTANCE_MAGIC 0x4d57464du /* "MWFM" */
#define MW_SNAPSHOT_MAGIC 0x4d575353u /* "MWSS" */

typedef struct {
    unsigned int magic;
    const MwModel *model;
    fmi2Type type;
    unsigned int mode;
    fmi2CallbackFunctions cb;
    char *name;
    unsigned int log_mask;

    double time;
    double last_successful_time;
    double h_int;

    /* model vectors */
    double *x, *u, *p, *xdot, *y;
    int xdot_valid, y_valid;

    /* integrator scratch */
    double *x_save, *x_stage, *k1, *k2, *k3, *k4;

    /* directional-derivative scratch */
    double *dx, *du, *dp, *dxdot, *dy;

    /* CasADi work buffers, sized for the largest of the model's functions */
    const double **arg;
    double **res;
    mw_int *iw;
    double *w;

    double *block; /* one allocation holding every double vector above */
} MwInstance;

/* A copy of what fmi2GetFMUstate saves: mode, times, internal step, x, u and p. */
typedef struct {
    unsigned int magic;
    const MwModel *model;
    unsigned int mode;
    double time;
    double last_successful_time;
    double h_int;
    double *values; /* nx + nu + np, right after the struct in the same allocation */
} MwSnapshot;

MW_HIDDEN MwInstance *mw_instance_new(const MwModel *model, fmi2Type type, fmi2String name,
                                      const fmi2CallbackFunctions *cb, fmi2Boolean logging_on);
MW_HIDDEN void mw_instance_free(MwInstance *inst);
MW_HIDDEN void mw_set_start_values(MwInstance *inst);
MW_HIDDEN void mw_invalidate(MwInstance *inst);

#if defined(__GNUC__)
#define MW_PRINTF(a, b) __attribute__((format(printf, a, b)))
#else
#define MW_PRINTF(a, b)
#endif
MW_HIDDEN void mw_log(const MwInstance *inst, fmi2Status status, MwLogCategory category,
                      const char *fmt, ...) MW_PRINTF(4, 5);
MW_HIDDEN fmi2Status mw_set_logging(MwInstance *inst, fmi2Boolean on, size_t n, const fmi2String categories[]);

/* 0 on success; -1 if CasADi reported an error. */
MW_HIDDEN int mw_update_derivatives(MwInstance *inst);
MW_HIDDEN int mw_update_outputs(MwInstance *inst);
MW_HIDDEN int mw_all_finite(const double *v, size_t n);

/* The co-simulation step from tc to tc + h; fmi2Discard keeps the state at tc. */
MW_HIDDEN fmi2Status mw_do_step(MwInstance *inst, double tc, double h);

/* Forward-mode derivatives: seeds dx, du, dp must be filled; 0 on success. */
MW_HIDDEN int mw_directional(MwInstance *inst, int need_dxdot, int need_dy);

MW_HIDDEN MwSnapshot *mw_snapshot_new(const MwInstance *inst);
MW_HIDDEN void mw_snapshot_take(const MwInstance *inst, MwSnapshot *snap);
MW_HIDDEN void mw_snapshot_restore(MwInstance *inst, const MwSnapshot *snap);
MW_HIDDEN size_t mw_serialized_size(const MwModel *model);
MW_HIDDEN void mw_serialize(const MwSnapshot *snap, fmi2Byte *out);
/* 0 on success, else a message saying what is wrong with the bytes. */
MW_HIDDEN const char *mw_deserialize(const MwInstance *inst, const fmi2Byte *in, size_t size, MwSnapshot *snap);
MW_HIDDEN int mw_mode_valid(const MwInstance *inst, unsigned int mode);

#endif /* MW_INSTANCE_H */
