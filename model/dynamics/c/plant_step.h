/*
 * The fixed-step rule of the plant (handwritten, not generated), written once: classical RK4
 * sub-steps, the friction events located in each sub-step by bisection on the event indicators,
 * and the mode update repeated until nothing changes. Three engines call it with the plant's
 * generated functions (model/plant.py): the FMU's Co-Simulation step (fmu/c/instance.c), the
 * compiled closed loop (closed_loop/c/kernel.c, and so every sweep) and the Python loop
 * (model/compiled_plant.py, through ctypes). The same C on the same generated code, compiled
 * without floating-point contraction, is why their samples agree to rounding.
 *
 * The plant is a continuous-time system with nz discrete modes m (the friction mode of each
 * joint: +1 sliding forward, -1 sliding backward, 0 stuck; nz may be 0):
 *     xdot = ode(x, u, p, m),   z = events(x, u, p, m) (> 0 while the modes hold),
 *     ode_sliding(x, u, p, m), events_sliding(x, u, p, m) (ode and events where no joint is stuck, bit for
 *         bit, without the masking and the holding torques: the rule uses them while nothing is stuck),
 *     (m, x) <- update(x, u, p, m) (one pass), m <- start(x, u, p, m) (m not read),
 *     active(x, u, p, m) -> [a, quiet] (a = 1: a mode can change, else the modes are constant and events need
 *         no look; quiet = 1: one pass of the update would change nothing at this state, so none is made),
 *     D = pivots(x, u, p, m) (the LDL^T pivots of the matrix the accelerations are solved with;
 *         a pivot that is not positive is a singular inertia matrix at that joint).
 * Every function reads its inputs from the caller's argument vector: arg[0] is the state (set
 * here), arg[1] = u, arg[2] = p and arg[3] = m are the caller's (further inputs, such as an FMU's
 * sampled states, are read by the functions that take them and never touched here).
 */
#ifndef MW_PLANT_STEP_H
#define MW_PLANT_STEP_H

#include <stddef.h>

#include "casadi_abi.h"

/*
 * A source FMU compiled with FMI2_FUNCTION_PREFIX (FMI 2.0) or FMI3_FUNCTION_PREFIX (FMI 3.0), to be
 * linked statically next to other FMUs, gets these names prefixed like its fmi2/fmi3 functions, so
 * that two models never share a symbol. The FMU wrapper's names (fmu/c/model.h) follow this rule.
 */
#if defined(FMI2_FUNCTION_PREFIX) || defined(FMI3_FUNCTION_PREFIX)
#define MW_PLANT_PASTE_(a, b) a##b
#define MW_PLANT_PASTE(a, b) MW_PLANT_PASTE_(a, b)
#if defined(FMI2_FUNCTION_PREFIX)
#define MW_PLANT_SYMBOL(name) MW_PLANT_PASTE(FMI2_FUNCTION_PREFIX, name)
#else
#define MW_PLANT_SYMBOL(name) MW_PLANT_PASTE(FMI3_FUNCTION_PREFIX, name)
#endif
#else
#define MW_PLANT_SYMBOL(name) name
#endif
#define mw_function_work_sizes MW_PLANT_SYMBOL(mw_function_work_sizes)
#define mw_plant_work_sizes MW_PLANT_SYMBOL(mw_plant_work_sizes)
#define mw_plant_scratch_size MW_PLANT_SYMBOL(mw_plant_scratch_size)
#define mw_plant_bind_scratch MW_PLANT_SYMBOL(mw_plant_bind_scratch)
#define mw_plant_events MW_PLANT_SYMBOL(mw_plant_events)
#define mw_plant_settle MW_PLANT_SYMBOL(mw_plant_settle)
#define mw_plant_start MW_PLANT_SYMBOL(mw_plant_start)
#define mw_plant_substeps MW_PLANT_SYMBOL(mw_plant_substeps)
#define mw_plant_advance MW_PLANT_SYMBOL(mw_plant_advance)
#define mw_plant_diagnose MW_PLANT_SYMBOL(mw_plant_diagnose)
#define mw_plant_open MW_PLANT_SYMBOL(mw_plant_open)
#define mw_plant_close MW_PLANT_SYMBOL(mw_plant_close)
#define mw_plant_run_start MW_PLANT_SYMBOL(mw_plant_run_start)
#define mw_plant_run_advance MW_PLANT_SYMBOL(mw_plant_run_advance)
#define mw_plant_run_fault MW_PLANT_SYMBOL(mw_plant_run_fault)

/* Integer type of the CasADi generated code (casadi_abi.h). */
typedef casadi_int mw_int;

/* Signature of a CasADi generated function and of its work-size query. */
typedef int (*mw_eval_fn)(const double **arg, double **res, mw_int *iw, double *w, int mem);
typedef int (*mw_work_fn)(mw_int *sz_arg, mw_int *sz_res, mw_int *sz_iw, mw_int *sz_w);

typedef struct {
    mw_eval_fn eval;
    mw_work_fn work;
} MwFunction;

/* The plant's generated functions and sizes (see the top of this file). */
typedef struct {
    size_t nx;         /* states */
    size_t nz;         /* modes = event indicators (0: no modes; events, update, start, active unused) */
    size_t npiv;       /* pivots (0: no pivots function; a failure is then reported as non-finite) */
    MwFunction ode;    /* (x, u, p, m, ...) -> xdot */
    MwFunction ode_sliding; /* (x, u, p, m, ...) -> xdot where no mode is 0 (nz = 0: unused, ode is used) */
    MwFunction events; /* (x, u, p, m) -> z */
    MwFunction events_sliding; /* (x, u, p, m) -> z where no mode is 0 */
    MwFunction update; /* (x, u, p, m) -> (m_next, x_next) */
    MwFunction start;  /* (x, u, p, m) -> m */
    MwFunction active; /* (x, u, p, m) -> [active, quiet], 1 or 0 each */
    MwFunction pivots; /* (x, u, p, m) -> D */
} MwPlantFunctions;

/* Results of the rule (0 is success). */
enum {
    MW_PLANT_OK = 0,
    MW_PLANT_EVAL = -1,      /* a generated function reported an error */
    MW_PLANT_NONFINITE = -2, /* the state or its derivative left finite numbers (a diverging run) */
    MW_PLANT_SINGULAR = -3,  /* the inertia matrix is singular: fault_joint, fault_x say where */
    MW_PLANT_UNSETTLED = -4, /* the modes did not settle within 2 nz + 2 passes of the update */
    MW_PLANT_CHATTER = -5    /* more than MW_PLANT_MAX_EVENTS events in one sub-step */
};

/* Most events located in one sub-step before the step gives up (a chattering mode). */
#define MW_PLANT_MAX_EVENTS 64
/* Bisection of an event time: the bracket is narrowed to this fraction of the sub-step (at most 60 halvings). */
#define MW_PLANT_EVENT_RTOL 1e-12

/*
 * One evaluation context. arg, res, iw, w: CasADi work memory at least mw_plant_work_sizes large,
 * with arg[1..3] (u, p, m) and any further inputs set by the owner; m points at the modes (nz,
 * == arg[3]); scratch: mw_plant_scratch_size doubles (bound by mw_plant_bind_scratch). active: whether
 * a mode can change, set by mw_plant_settle and mw_plant_start (1 before either ran). Whoever changes the
 * state, inputs or parameters between sub-steps must call mw_plant_settle before the next one (every
 * engine does at the start of each hold interval). After a failure, fault_joint is the
 * 1-based joint whose pivot is not positive (MW_PLANT_SINGULAR, else 0) and fault_x the state
 * (nx doubles, in scratch) at which the derivative was not finite.
 */
typedef struct {
    const MwPlantFunctions *f;
    const double **arg;
    double **res;
    mw_int *iw;
    double *w;
    double *m;
    double *scratch;
    int active;
    int any_stuck; /* a mode is 0: the sub-steps need ode's masking (set with active) */
    int z_valid; /* scratch holds the indicators at the current state (cleared by mw_plant_settle) */
    int fault_joint;
    double *fault_x;
    unsigned long long fault_substep; /* the 1-based sub-step of mw_plant_substeps that failed (0: none) */
} MwPlantCall;

/* Raise *sz_* to what one generated function needs (0 on success, -1 if it has none or its query failed). */
int mw_function_work_sizes(const MwFunction *fn, mw_int *sz_arg, mw_int *sz_res, mw_int *sz_iw, mw_int *sz_w);
/* Raise *sz_* to what the plant's functions need (0 on success, -1 if a work query failed). */
int mw_plant_work_sizes(const MwPlantFunctions *f, mw_int *sz_arg, mw_int *sz_res, mw_int *sz_iw, mw_int *sz_w);
/* Doubles of scratch an MwPlantCall needs. */
size_t mw_plant_scratch_size(const MwPlantFunctions *f);
/* Bind scratch (mw_plant_scratch_size doubles) to a call whose other fields are set. */
void mw_plant_bind_scratch(MwPlantCall *c, double *scratch);

/* The event indicators at state x into z (nz). */
int mw_plant_events(MwPlantCall *c, const double *x, double *z);
/*
 * Repeat the mode update at state x (changed in place: a joint that sticks has its velocity set to 0)
 * until the modes and the state stop changing. *changed: whether anything changed, *x_changed: whether
 * the state did (either may be NULL). Updates c->active first and does nothing when no mode can change.
 */
int mw_plant_settle(MwPlantCall *c, double *x, int *changed, int *x_changed);
/* The modes to begin from at state x (the start function), then settled. */
int mw_plant_start(MwPlantCall *c, double *x);
/*
 * n sub-steps of length hs from x (in place), inputs and parameters held: each an RK4 step; with
 * active modes, an event indicator that crosses zero is located by bisection on the step length, the
 * modes are settled there and the rest of the sub-step is taken the same way.
 */
int mw_plant_substeps(MwPlantCall *c, double *x, double hs, unsigned long long n);
/* One hold interval of length h with the inputs held: settle the modes, then n sub-steps of h / n. */
int mw_plant_advance(MwPlantCall *c, double *x, double h, unsigned long long n);
/*
 * After MW_PLANT_NONFINITE: whether the inertia matrix is singular at c->fault_x (the pivots); sets
 * c->fault_joint and returns MW_PLANT_SINGULAR if so, else MW_PLANT_NONFINITE.
 */
int mw_plant_diagnose(MwPlantCall *c);

/*
 * A self-contained run for ctypes and the closed-loop kernel: the functions given as 16 addresses
 * (eval, work of ode, ode_sliding, events, events_sliding, update, start, active, pivots; those of an absent function
 * NULL when nz = 0 or npiv = 0), with its own work memory. NULL when out of memory or a work query failed.
 */
typedef struct MwPlantRun MwPlantRun;
MwPlantRun *mw_plant_open(long long nx, long long nz, long long npiv, void *const *functions);
void mw_plant_close(MwPlantRun *run);
/* mw_plant_start on x (nx) and m (nz, written) with inputs u and parameters p. */
int mw_plant_run_start(MwPlantRun *run, double *x, double *m, const double *u, const double *p);
/* mw_plant_advance of x and m (in place) over h in n sub-steps with inputs u and parameters p. */
int mw_plant_run_advance(MwPlantRun *run, double *x, double *m, const double *u, const double *p, double h,
                         long long n);
/* After a failure: the joint (1-based, 0 if none) and the state at the failure into x (nx). */
int mw_plant_run_fault(const MwPlantRun *run, double *x);

#endif /* MW_PLANT_STEP_H */
