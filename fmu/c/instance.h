/*
 * One FMU instance: its storage, logging, model evaluation, the co-simulation
 * step (the plant's fixed-step rule, model/dynamics/c/plant_step.c) and FMU-state snapshots. Used by fmi2_functions.c and
 * fmi3_functions.c, which own the state machines of FMI 2.0 and FMI 3.0 and the
 * argument checks; nothing here depends on the FMI version (no FMI header is
 * included: statuses, interface types and the importer's callbacks reach this
 * file in the neutral types below). No global mutable state: everything an
 * instance touches lives in its MwInstance.
 */
#ifndef MW_INSTANCE_H
#define MW_INSTANCE_H

#include "model.h"

/* Statuses, numbered as fmi2Status and fmi3Status (OK, Warning, Discard, Error, Fatal). */
typedef enum { MW_OK = 0, MW_WARNING = 1, MW_DISCARD = 2, MW_ERROR = 3, MW_FATAL = 4 } MwStatus;

/* The interface an instance was created for. */
typedef enum { MW_MODEL_EXCHANGE = 0, MW_CO_SIMULATION = 1 } MwInterface;

/* A function pointer of any type, stored and cast back by the wrapper that owns it. */
typedef void (*MwAnyFunction)(void);

typedef struct MwInstance MwInstance;

/*
 * What the importer gave: memory functions (calloc/free semantics) and the wrapper's adapter
 * that passes one log line, already formatted, to the importer's logger (env and logger are the
 * importer's environment pointer and logging function, for the adapter only).
 */
typedef struct {
    void *(*alloc)(size_t n, size_t size);
    void (*release)(void *p);
    void (*log)(const MwInstance *inst, MwStatus status, const char *category, const char *message);
    void *env;
    MwAnyFunction logger;
} MwHost;

/* Modes of the state machines of Model Exchange and Co-Simulation (FMI 2.0 and 3.0), as bits.
   STEP_COMPLETE is FMI 3.0's Step Mode. */
typedef enum {
    MW_MODE_INSTANTIATED = 1u << 0,
    MW_MODE_INIT = 1u << 1,
    MW_MODE_EVENT = 1u << 2,         /* Model Exchange */
    MW_MODE_CONTINUOUS = 1u << 3,    /* Model Exchange */
    MW_MODE_STEP_COMPLETE = 1u << 4, /* Co-Simulation */
    MW_MODE_STEP_FAILED = 1u << 5,   /* Co-Simulation, after DoStep returned Discard (FMI 2.0 only) */
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

/* Most RK4 sub-steps one DoStep may take: bounds the work (and the time) of one call. */
#define MW_MAX_SUBSTEPS 1000000ull
/* Relative noise in communicationStepSize / internal_step forgiven when counting sub-steps. */
#define MW_SUBSTEP_RTOL 1e-8

typedef struct MwSnapshot MwSnapshot;

struct MwInstance {
    const MwModel *model;
    MwInterface type;
    unsigned int mode;
    MwHost host;
    char *name;
    unsigned int log_mask;

    double time;
    double last_successful_time;
    double h_int;
    int stop_time_defined; /* the experiment's stopTime, enforced by DoStep and SetTime */
    double stop_time;

    /* every FMU state taken from this instance and not yet freed, freed with the instance */
    MwSnapshot *snapshots;

    /* model vectors; m: the discrete modes, z: the event indicators, d: the sampled discrete states */
    double *x, *u, *p, *m, *xdot, *y, *z, *d;
    int xdot_valid, y_valid, z_valid;

    /* the plant's fixed-step rule (plant_step.h) on this instance's functions, work memory and m */
    MwPlantFunctions plant;
    MwPlantCall call;
    double *plant_scratch;           /* mw_plant_scratch_size(&plant) */

    /* what a failed step restores */
    double *x_save, *m_save;         /* nx, nz */
    double *d_save, *d_next;         /* nd, nd */

    /* directional-derivative scratch; adjoint: seeds in dxdot and dy, sensitivities into dx, du, dp */
    double *dx, *du, *dp, *dxdot, *dy, *adj; /* adj: nx + nu + np */

    /* CasADi work buffers, sized for the largest of the model's functions */
    const double **arg;
    double **res;
    mw_int *iw;
    double *w;

    double *block; /* one allocation holding every double vector above */
};

/* A copy of what GetFMUstate saves: mode, times, internal step, x, u, p, m and d. */
struct MwSnapshot {
    MwSnapshot *prev, *next; /* the owning instance's list */
    unsigned int mode;
    double time;
    double last_successful_time;
    double h_int;
    double *values; /* nx + nu + np + nz + nd, right after the struct in the same allocation */
};

#define mw_instance_new MW_SYMBOL(mw_instance_new)
#define mw_instance_free MW_SYMBOL(mw_instance_free)
#define mw_set_start_values MW_SYMBOL(mw_set_start_values)
#define mw_invalidate MW_SYMBOL(mw_invalidate)
#define mw_log MW_SYMBOL(mw_log)
#define mw_set_logging MW_SYMBOL(mw_set_logging)
#define mw_update_derivatives MW_SYMBOL(mw_update_derivatives)
#define mw_update_outputs MW_SYMBOL(mw_update_outputs)
#define mw_all_finite MW_SYMBOL(mw_all_finite)
#define mw_substeps MW_SYMBOL(mw_substeps)
#define mw_do_step MW_SYMBOL(mw_do_step)
#define mw_ticks MW_SYMBOL(mw_ticks)
#define mw_step_plan MW_SYMBOL(mw_step_plan)
#define mw_value_problem MW_SYMBOL(mw_value_problem)
#define mw_is_close MW_SYMBOL(mw_is_close)
#define mw_past_stop_time MW_SYMBOL(mw_past_stop_time)
#define mw_events MW_SYMBOL(mw_events)
#define mw_check_derivatives MW_SYMBOL(mw_check_derivatives)
#define mw_singular_problem MW_SYMBOL(mw_singular_problem)
#define mw_directional MW_SYMBOL(mw_directional)
#define mw_adjoint MW_SYMBOL(mw_adjoint)
#define mw_update_indicators MW_SYMBOL(mw_update_indicators)
#define mw_prepare MW_SYMBOL(mw_prepare)
#define mw_value MW_SYMBOL(mw_value)
#define mw_assign MW_SYMBOL(mw_assign)
#define mw_clear_seeds MW_SYMBOL(mw_clear_seeds)
#define mw_seed MW_SYMBOL(mw_seed)
#define mw_sensitivity MW_SYMBOL(mw_sensitivity)
#define mw_snapshot_new MW_SYMBOL(mw_snapshot_new)
#define mw_snapshot_find MW_SYMBOL(mw_snapshot_find)
#define mw_snapshot_free MW_SYMBOL(mw_snapshot_free)
#define mw_snapshot_take MW_SYMBOL(mw_snapshot_take)
#define mw_snapshot_restore MW_SYMBOL(mw_snapshot_restore)
#define mw_serialized_size MW_SYMBOL(mw_serialized_size)
#define mw_serialize MW_SYMBOL(mw_serialize)
#define mw_deserialize MW_SYMBOL(mw_deserialize)
#define mw_mode_valid MW_SYMBOL(mw_mode_valid)
#define mw_fail MW_SYMBOL(mw_fail)
#define mw_exit_initialization MW_SYMBOL(mw_exit_initialization)
#define mw_set_time MW_SYMBOL(mw_set_time)
#define mw_event_update MW_SYMBOL(mw_event_update)
#define mw_enter MW_SYMBOL(mw_enter)
#define mw_null_arg MW_SYMBOL(mw_null_arg)
#define mw_wrong_size MW_SYMBOL(mw_wrong_size)
#define mw_non_finite MW_SYMBOL(mw_non_finite)
#define mw_state_get MW_SYMBOL(mw_state_get)
#define mw_state_set MW_SYMBOL(mw_state_set)
#define mw_state_free MW_SYMBOL(mw_state_free)
#define mw_state_size MW_SYMBOL(mw_state_size)
#define mw_state_serialize MW_SYMBOL(mw_state_serialize)
#define mw_state_deserialize MW_SYMBOL(mw_state_deserialize)

MW_HIDDEN MwInstance *mw_instance_new(const MwModel *model, MwInterface type, const char *name,
                                      const MwHost *host, int logging_on);
MW_HIDDEN void mw_instance_free(MwInstance *inst);
MW_HIDDEN void mw_set_start_values(MwInstance *inst);
MW_HIDDEN void mw_invalidate(MwInstance *inst);

#if defined(__GNUC__)
#define MW_PRINTF(a, b) __attribute__((format(printf, a, b)))
#else
#define MW_PRINTF(a, b)
#endif
MW_HIDDEN void mw_log(const MwInstance *inst, MwStatus status, MwLogCategory category,
                      const char *fmt, ...) MW_PRINTF(4, 5);
/* fn: the calling FMI function, for the warnings about unknown categories. */
MW_HIDDEN MwStatus mw_set_logging(MwInstance *inst, const char *fn, int on, size_t n, const char *const categories[]);

/* 0 on success; -1 if CasADi reported an error. */
MW_HIDDEN int mw_update_derivatives(MwInstance *inst);
MW_HIDDEN int mw_update_outputs(MwInstance *inst);
MW_HIDDEN int mw_update_indicators(MwInstance *inst);
/* Evaluate what reading variable v needs (derivatives, outputs, indicators): 0, or -1 naming nothing. */
MW_HIDDEN int mw_prepare(MwInstance *inst, const MwVariable *v);
/* The value of variable v (after mw_prepare). */
MW_HIDDEN double mw_value(const MwInstance *inst, const MwVariable *v);
/* Set variable v (a state, input, parameter or the step); 0, or -1 if v is not settable by kind. */
MW_HIDDEN int mw_assign(MwInstance *inst, const MwVariable *v, double value);
MW_HIDDEN int mw_all_finite(const double *v, size_t n);

/*
 * Number of equal RK4 sub-steps of a communication step h: ceil(h / h_int), except that a
 * ratio within a relative MW_SUBSTEP_RTOL of an integer k gives k, so that rounding noise
 * in h (importers that accumulate time differently) never changes the count. 0 if the
 * count would exceed MW_MAX_SUBSTEPS (or is not finite).
 */
MW_HIDDEN unsigned long long mw_substeps(double h, double h_int);

/*
 * Number of sample periods in a communication step h: h / sample_period if that is an integer k >= 1
 * up to a relative MW_SUBSTEP_RTOL (then k), else 0 (a step that is not a whole number of periods).
 * 1 for a model without sampled states (nd = 0).
 */
MW_HIDDEN unsigned long long mw_ticks(const MwModel *model, double h);
/*
 * Check a co-simulation step from tc of length h and plan it: the sample periods (*ticks) and the RK4
 * sub-steps of each (*n). NULL when it can be taken, else what is wrong (written into what[len]).
 */
MW_HIDDEN const char *mw_step_plan(const MwInstance *inst, double tc, double h, unsigned long long *ticks,
                                   unsigned long long *n, char *what, size_t len);
/* Times within a relative 1e-12 (absolute near 0) count as equal, as floating-point sums of steps differ. */
MW_HIDDEN int mw_is_close(double a, double b);
/* Whether t is past the experiment's stopTime, rounding forgiven. */
MW_HIDDEN int mw_past_stop_time(const MwInstance *inst, double t);
/*
 * The co-simulation step from tc to tc + h, planned by mw_step_plan (a step it refuses is MW_ERROR through
 * mw_fail): the friction modes settled, then the sample periods (1 without sampled states), each a tick of
 * d then its RK4 sub-steps with event location (mw_plant_substeps). MW_DISCARD (a state that is not finite,
 * modes that do not settle) keeps the state at tc and puts the instance in MW_MODE_STEP_FAILED; a singular
 * inertia matrix is MW_ERROR naming the joint and q (fn: the calling FMI function, for the messages).
 */
MW_HIDDEN MwStatus mw_do_step(MwInstance *inst, const char *fn, double tc, double h);

/* The event indicators at state x (current u, p, m) into z; 0 on success. */
MW_HIDDEN int mw_events(MwInstance *inst, const double *x, double *z);
/*
 * NULL, or (into what[len]) that the inertia matrix B(q) is singular at state x: the joint whose pivot is
 * not positive and q, at the instance's time.
 */
MW_HIDDEN const char *mw_singular_problem(MwInstance *inst, const double *x, char *what, size_t len);
/*
 * The status of derivatives v[0..n-1] just computed at the instance's state: MW_OK if finite; MW_ERROR
 * (logged, error mode) if B(q) is singular there, naming the joint and q; else MW_DISCARD (mw_non_finite).
 */
MW_HIDDEN MwStatus mw_check_derivatives(MwInstance *inst, const char *fn, const double *v, size_t n);

/* Forward-mode derivatives: seeds dx, du, dp must be filled; 0 on success. */
MW_HIDDEN int mw_directional(MwInstance *inst, int need_dxdot, int need_dy);
/* Zero the seeds of forward (dx, du, dp) and reverse mode (dxdot, dy). */
MW_HIDDEN void mw_clear_seeds(MwInstance *inst);
/*
 * Add a seed: forward mode (reverse = 0) seeds a known (state, input, parameter); reverse mode
 * seeds an unknown (derivative, output, state). 0, or -1 if v cannot take that role.
 */
MW_HIDDEN int mw_seed(MwInstance *inst, const MwVariable *v, double seed, int reverse);
/* After mw_directional: the derivative of unknown v; after mw_adjoint: the sensitivity of known v. */
MW_HIDDEN double mw_sensitivity(const MwInstance *inst, const MwVariable *v, int reverse);
/*
 * Reverse mode: [dx; du; dp] = J_ode^T dxdot + J_out^T dy (+ the seeds of unknown states, already in
 * dx); 0 on success.
 */
MW_HIDDEN int mw_adjoint(MwInstance *inst, int need_ode, int need_out);

/* A new FMU state, linked into the instance's list; NULL when out of memory. */
MW_HIDDEN MwSnapshot *mw_snapshot_new(MwInstance *inst);
/* s if it is an FMU state of this instance not yet freed, else NULL (compares pointers only). */
MW_HIDDEN MwSnapshot *mw_snapshot_find(const MwInstance *inst, const void *s);
/* Unlink from the instance's list and free. */
MW_HIDDEN void mw_snapshot_free(MwInstance *inst, MwSnapshot *snap);
MW_HIDDEN void mw_snapshot_take(const MwInstance *inst, MwSnapshot *snap);
MW_HIDDEN void mw_snapshot_restore(MwInstance *inst, const MwSnapshot *snap);
MW_HIDDEN size_t mw_serialized_size(const MwModel *model);
MW_HIDDEN void mw_serialize(const MwModel *model, const MwSnapshot *snap, unsigned char *out);
/* 0 on success, else a message saying what is wrong with the bytes. */
MW_HIDDEN const char *mw_deserialize(const MwInstance *inst, const unsigned char *in, size_t size, MwSnapshot *snap);
MW_HIDDEN int mw_mode_valid(const MwInstance *inst, unsigned int mode);

/*
 * The version-neutral parts of ExitInitializationMode (start and settle the friction modes, check the
 * derivatives, enter Event Mode or Step Mode), SetTime (finite, not past stopTime in Event Mode, not
 * back in time in Event Mode) and the event update (NewDiscreteStates, UpdateDiscreteStates: settle
 * the friction modes, *x_changed whether the states jumped): NULL, or what is wrong.
 */
MW_HIDDEN const char *mw_exit_initialization(MwInstance *inst, char *what, size_t len);
MW_HIDDEN const char *mw_set_time(MwInstance *inst, double time, char *what, size_t len);
MW_HIDDEN const char *mw_event_update(MwInstance *inst, int *x_changed);

/* The argument checks of both wrappers (fn: the calling FMI function, named in every message). */
/* Log an error, enter the error mode, return MW_ERROR. */
/* NULL if value may be given to variable v (finite, within its [min, max]), else why (written into what[len]). */
MW_HIDDEN const char *mw_value_problem(const MwVariable *v, double value, char *what, size_t len);
MW_HIDDEN MwStatus mw_fail(MwInstance *inst, const char *fn, const char *what);
/* Interfaces a call belongs to (mw_enter). */
enum { MW_FOR_ANY = 0, MW_FOR_ME = 1, MW_FOR_CS = 2 };
/*
 * The instance c if fn is legal for its interface and in its mode (a mask of MwMode bits), else NULL
 * after logging why (and entering the error mode); NULL for a NULL c. mode_name names modes the
 * wrapper's way.
 */
MW_HIDDEN MwInstance *mw_enter(void *c, const char *fn, int interface_type, unsigned int modes,
                               const char *(*mode_name)(unsigned int mode));
/* 1 (after logging, error mode) if ptr is NULL, else 0. */
MW_HIDDEN int mw_null_arg(MwInstance *inst, const char *fn, const char *name, const void *ptr);
/* 1 (after logging, error mode) if got differs from expected, else 0. */
MW_HIDDEN int mw_wrong_size(MwInstance *inst, const char *fn, const char *name, size_t got, size_t expected);
/* MW_DISCARD with a message if v[0..n-1] are not all finite (the one policy for computed values), else MW_OK. */
MW_HIDDEN MwStatus mw_non_finite(MwInstance *inst, const char *fn, const char *what, const double *v, size_t n);

/*
 * The FMU-state calls of FMI 2.0 and 3.0 (Get, Set, Free, SerializedSize, Serialize, Deserialize):
 * NULL on success, else what is wrong (what[len] holds it when it has numbers); the wrapper logs it
 * and returns its error status. A rejected call changes nothing.
 */
MW_HIDDEN const char *mw_state_get(MwInstance *inst, void **state);
MW_HIDDEN const char *mw_state_set(MwInstance *inst, const void *state);
MW_HIDDEN const char *mw_state_free(MwInstance *inst, void **state);
MW_HIDDEN const char *mw_state_size(const MwInstance *inst, const void *state, size_t *size);
/* size_fn: the wrapper's SerializedFMUStateSize, named in the message of a wrong size */
MW_HIDDEN const char *mw_state_serialize(const MwInstance *inst, const void *state, unsigned char *out, size_t size,
                                         const char *size_fn, char *what, size_t len);
MW_HIDDEN const char *mw_state_deserialize(MwInstance *inst, const unsigned char *in, size_t size, void **state,
                                           char *what, size_t len);

#endif /* MW_INSTANCE_H */
