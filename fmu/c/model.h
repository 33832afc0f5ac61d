/*
 * The narrow contract between the FMI wrappers (written once: instance.c, with
 * fmi2_functions.c for FMI 2.0 and fmi3_functions.c for FMI 3.0) and one exported model (generated per robot: model_data.c and
 * the CasADi code it points to).
 *
 * A model is a continuous-time system with nz discrete modes m (the friction
 * mode of each joint; nz may be 0) and nd sampled discrete states d (a digital
 * controller's integrator; nd may be 0)
 *     xdot = ode(x, u, p, m, d),   y = out(x, u, p, m, d),   z = events(x, u, p, m)
 * with nx states, nu inputs, np parameters and ny outputs, plus the forward
 * directional derivatives of ode and out and their reverse-mode (adjoint)
 * products (m held). The nz event indicators z
 * are positive while the modes are valid. At an event, update(x, u, p, m)
 * gives the next modes and states (one pass; the plant's rule repeats it until
 * nothing changes); start(x, u, p, m) gives the modes to begin from; active and
 * pivots are those of model/dynamics/c/plant_step.h. Co-Simulation integrates
 * them with that rule, the one every engine of the workbench runs. The sampled
 * states change once per sample_period only, at the start of each period:
 * d <- tick(x, u, p, d) with the inputs held over the period (zero-order hold);
 * they are never iterated. Every FMI
 * variable is one row of a table indexed by its value reference; a row says
 * which vector the variable lives in (kind) and where (index). FMI 3.0 groups
 * consecutive rows into array variables (arrays[], one value reference each);
 * FMI 2.0 exposes the rows themselves. The wrapper never knows what the model is.
 */
#ifndef MW_MODEL_H
#define MW_MODEL_H

#include <stddef.h>

#if defined(__GNUC__)
#define MW_HIDDEN __attribute__((visibility("hidden")))
#else
#define MW_HIDDEN
#endif

/*
 * Names of the wrapper's internal functions. A shared library hides them
 * (MW_HIDDEN); a source FMU compiled with FMI2_FUNCTION_PREFIX (FMI 2.0) or
 * FMI3_FUNCTION_PREFIX (FMI 3.0), to be linked statically next to other FMUs,
 * gets them prefixed like the fmi2/fmi3 functions, so that two models in one
 * program never share a symbol. The rule is plant_step.h's (MW_PLANT_SYMBOL),
 * which this header includes first.
 */
#include "plant_step.h"
#define MW_SYMBOL(name) MW_PLANT_SYMBOL(name)
#define mw_model MW_SYMBOL(mw_model)

/* mw_int, MwFunction and the plant's fixed-step rule come from plant_step.h
   (model/dynamics/c/plant_step.h, shipped in sources/), included above. */

/* Where a variable lives. */
typedef enum {
    MW_KIND_STATE = 0,      /* x[index]; may also be an output of the FMU */
    MW_KIND_DERIVATIVE = 1, /* xdot[index] = ode(x, u, p)[index] */
    MW_KIND_INPUT = 2,      /* u[index] */
    MW_KIND_PARAMETER = 3,  /* p[index] */
    MW_KIND_OUTPUT = 4,     /* y[index] = out(x, u, p)[index] */
    MW_KIND_STEP = 5,       /* the co-simulation internal step, a fixed parameter */
    MW_KIND_INDICATOR = 6,  /* z[index] = events(x, u, p, m)[index], an event indicator */
    MW_KIND_DISCRETE = 7    /* d[index], a sampled discrete state */
} MwKind;

/* When a variable may be set (FMI 2.0 causality/variability/initial). */
typedef enum {
    MW_SET_NEVER = 0,   /* calculated: outputs, derivatives */
    MW_SET_INITIAL = 1, /* initial="exact" states and fixed parameters: before initialisation ends */
    MW_SET_TUNABLE = 2, /* tunable parameters: also at communication points / event mode */
    MW_SET_INPUT = 3,   /* inputs: at any time after instantiation */
    MW_SET_STATE = 4    /* continuous states: before initialisation ends, and in Model Exchange's event and
                           continuous-time modes (FMI 2.0.1) */
} MwSettable;

typedef struct {
    const char *name;       /* the FMI name, for log messages */
    unsigned char kind;     /* MwKind */
    unsigned char settable; /* MwSettable */
    unsigned int index;
    double min;             /* range enforced by fmi2SetReal; -HUGE_VAL/HUGE_VAL when none */
    double max;
} MwVariable;

/* An FMI 3.0 variable: rows first .. first + count - 1 of the table (count 1: a scalar). */
typedef struct {
    const char *name;
    unsigned int first;
    unsigned int count;
    unsigned int scalar; /* 1: no <Dimension>, a scalar variable */
} MwArray;

typedef struct {
    const char *model_identifier;
    const char *guid;
    size_t nx, nu, np, ny;
    size_t nz;                    /* discrete modes = event indicators */
    size_t nvars;                 /* rows of variables[], value references 0..nvars-1 */
    const MwVariable *variables;
    size_t narrays;               /* FMI 3.0 variables, value references 0..narrays-1 */
    const MwArray *arrays;
    const double *x_start;        /* nx */
    const double *x_nominal;      /* nx */
    const double *u_start;        /* nu */
    const double *p_start;        /* np */
    double step_start;            /* default internal step of the co-simulation integrator */
    size_t nd;                    /* sampled discrete states d (0: none) */
    double sample_period;         /* s: tick runs once per period; 0 when nd = 0 */
    const double *d_start;        /* nd */
    MwFunction ode;               /* (x, u, p, m, d) -> xdot */
    MwFunction ode_sliding;       /* (x, u, p, m, d) -> xdot where no mode is 0: ode's numbers without the masking */
    MwFunction out;               /* (x, u, p, m, d) -> y */
    MwFunction ode_dir;           /* (x, u, p, m, d, dx, du, dp) -> dxdot, forward mode (d held) */
    MwFunction out_dir;           /* (x, u, p, m, d, dx, du, dp) -> dy, forward mode (d held) */
    MwFunction ode_adj;           /* (x, u, p, m, d, wxdot) -> [ax; au; ap] = J_ode^T wxdot, reverse mode */
    MwFunction out_adj;           /* (x, u, p, m, d, wy) -> [ax; au; ap] = J_out^T wy, reverse mode */
    MwFunction tick;              /* (x, u, p, d) -> d_next, once per sample period */
    MwFunction events;            /* (x, u, p, m) -> z, nz indicators, > 0 while the modes hold */
    MwFunction events_sliding;    /* (x, u, p, m) -> z where no mode is 0: events' numbers, less work */
    MwFunction update;            /* (x, u, p, m) -> (m_next, x_next): one pass of the mode update */
    MwFunction start;             /* (x, u, p, m) -> m: the modes to begin from (m not read) */
    MwFunction active;            /* (x, u, p, m) -> 1 if a mode can change, else 0 */
    size_t npiv;                  /* pivots of the solve of the accelerations (0: none) */
    MwFunction pivots;            /* (x, u, p, m) -> npiv LDL^T pivots: one not positive is a singular B(q) */
} MwModel;

/* Provided by the generated model_data.c. */
MW_HIDDEN const MwModel *mw_model(void);

#endif /* MW_MODEL_H */
