/*
 * The fixed-step rule of the plant: RK4 sub-steps, event location by bisection, the settle loop
 * (see plant_step.h). Handwritten, not generated; no global state, nothing allocated per step
 * (re-entrant). The RK4 form is written once here:
 *     s = x + (hs / 2) k1, s = x + (hs / 2) k2, s = x + hs k3,
 *     x <- x + (hs / 6) (k1 + 2 k2 + 2 k3 + k4).
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "plant_step.h"

/* Scratch, in doubles: x0, stage, k1..k4 (6 nx), fault_x (nx), z0, z1 (2 nz), next (nz + nx), piv, value (2). */
size_t mw_plant_scratch_size(const MwPlantFunctions *f) {
    return 8 * f->nx + 3 * f->nz + f->npiv + 2;
}

void mw_plant_bind_scratch(MwPlantCall *c, double *scratch) {
    c->scratch = scratch;
    c->fault_x = scratch + 6 * c->f->nx;
    c->active = 1;
    c->any_stuck = 1;
    c->z_valid = 0;
    c->fault_joint = 0;
}

int mw_function_work_sizes(const MwFunction *fn, mw_int *sz_arg, mw_int *sz_res, mw_int *sz_iw, mw_int *sz_w) {
    mw_int a = 0, r = 0, i = 0, w = 0;
    if (fn->work == NULL || fn->eval == NULL) return -1;
    if (fn->work(&a, &r, &i, &w) != 0) return -1;
    if (a > *sz_arg) *sz_arg = a;
    if (r > *sz_res) *sz_res = r;
    if (i > *sz_iw) *sz_iw = i;
    if (w > *sz_w) *sz_w = w;
    return 0;
}

int mw_plant_work_sizes(const MwPlantFunctions *f, mw_int *sz_arg, mw_int *sz_res, mw_int *sz_iw, mw_int *sz_w) {
    if (mw_function_work_sizes(&f->ode, sz_arg, sz_res, sz_iw, sz_w) != 0) return -1;
    if (f->nz > 0 && (mw_function_work_sizes(&f->ode_sliding, sz_arg, sz_res, sz_iw, sz_w) != 0 ||
                      mw_function_work_sizes(&f->events, sz_arg, sz_res, sz_iw, sz_w) != 0 ||
                      mw_function_work_sizes(&f->events_sliding, sz_arg, sz_res, sz_iw, sz_w) != 0 ||
                      mw_function_work_sizes(&f->update, sz_arg, sz_res, sz_iw, sz_w) != 0 ||
                      mw_function_work_sizes(&f->start, sz_arg, sz_res, sz_iw, sz_w) != 0 ||
                      mw_function_work_sizes(&f->active, sz_arg, sz_res, sz_iw, sz_w) != 0))
        return -1;
    if (f->npiv > 0 && mw_function_work_sizes(&f->pivots, sz_arg, sz_res, sz_iw, sz_w) != 0) return -1;
    if (*sz_arg < 4) *sz_arg = 4;
    if (*sz_res < 2) *sz_res = 2;
    return 0;
}

static int all_finite(const double *v, size_t n) {
    double zero = 0.0; /* 0 x a finite value is 0, 0 x inf or NaN is NaN: one test for the whole vector */
    size_t i;
    for (i = 0; i < n; i++) zero += 0.0 * v[i];
    return zero == 0.0;
}

/* fn at state x, first output into out (and the second into out2 when not NULL). */
static int eval_at(MwPlantCall *c, const MwFunction *fn, const double *x, double *out, double *out2) {
    c->arg[0] = x;
    c->arg[3] = c->m;
    c->res[0] = out;
    if (out2 != NULL) c->res[1] = out2;
    return fn->eval(c->arg, c->res, c->iw, c->w, 0) == 0 ? MW_PLANT_OK : MW_PLANT_EVAL;
}

/* xdot at s into k (ode_sliding where no joint is stuck: the same numbers); a derivative that is not finite
   records s as the fault state. */
static int derivative(MwPlantCall *c, const double *s, double *k) {
    const size_t nx = c->f->nx;
    const MwFunction *ode = c->f->nz > 0 && !c->any_stuck ? &c->f->ode_sliding : &c->f->ode;
    if (eval_at(c, ode, s, k, NULL) != 0) return MW_PLANT_EVAL;
    if (all_finite(k, nx)) return MW_PLANT_OK;
    memcpy(c->fault_x, s, nx * sizeof(double));
    return MW_PLANT_NONFINITE;
}

/* One classical RK4 step of length hs from x, in place. */
static int rk4(MwPlantCall *c, double *x, double hs) {
    const size_t nx = c->f->nx;
    double *s = c->scratch + nx, *k1 = s + nx, *k2 = k1 + nx, *k3 = k2 + nx, *k4 = k3 + nx;
    const double half = 0.5 * hs, sixth = hs / 6.0;
    size_t i;
    int status;

    if ((status = derivative(c, x, k1)) != 0) return status;
    for (i = 0; i < nx; i++) s[i] = x[i] + half * k1[i];
    if ((status = derivative(c, s, k2)) != 0) return status;
    for (i = 0; i < nx; i++) s[i] = x[i] + half * k2[i];
    if ((status = derivative(c, s, k3)) != 0) return status;
    for (i = 0; i < nx; i++) s[i] = x[i] + hs * k3[i];
    if ((status = derivative(c, s, k4)) != 0) return status;
    for (i = 0; i < nx; i++) x[i] = x[i] + sixth * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    if (all_finite(x, nx)) return MW_PLANT_OK;
    memcpy(c->fault_x, x, nx * sizeof(double));
    return MW_PLANT_NONFINITE;
}

int mw_plant_events(MwPlantCall *c, const double *x, double *z) {
    if (c->f->nz == 0) return MW_PLANT_OK;
    return eval_at(c, c->any_stuck ? &c->f->events : &c->f->events_sliding, x, z, NULL);
}

/* Whether a mode is 0 (a joint stuck). */
static int any_zero(const double *m, size_t nz) {
    size_t i;
    for (i = 0; i < nz; i++) {
        if (m[i] == 0.0) return 1;
    }
    return 0;
}

int mw_plant_settle(MwPlantCall *c, double *x, int *changed, int *x_changed) {
    const size_t nx = c->f->nx, nz = c->f->nz;
    double *next = c->scratch + 7 * nx + 2 * nz, *value = next + nz + nx + c->f->npiv;
    size_t pass;
    c->z_valid = 0; /* the inputs, parameters or state may differ from those of the last indicators */
    if (changed != NULL) *changed = 0;
    if (x_changed != NULL) *x_changed = 0;
    if (nz == 0) return MW_PLANT_OK;
    if (eval_at(c, &c->f->active, x, value, NULL) != 0) return MW_PLANT_EVAL;
    c->active = value[0] != 0.0;
    c->any_stuck = any_zero(c->m, nz);
    if (!c->active || value[1] != 0.0) return MW_PLANT_OK; /* no mode can change, or none would now */
    for (pass = 0; pass < 2 * nz + 2; pass++) {
        int same_x;
        if (eval_at(c, &c->f->update, x, next, next + nz) != 0) return MW_PLANT_EVAL;
        same_x = memcmp(next + nz, x, nx * sizeof(double)) == 0;
        if (memcmp(next, c->m, nz * sizeof(double)) == 0 && same_x) return MW_PLANT_OK;
        if (!same_x && x_changed != NULL) *x_changed = 1;
        if (changed != NULL) *changed = 1;
        memcpy(c->m, next, nz * sizeof(double));
        memcpy(x, next + nz, nx * sizeof(double));
        c->any_stuck = any_zero(c->m, nz);
    }
    return MW_PLANT_UNSETTLED;
}

int mw_plant_start(MwPlantCall *c, double *x) {
    const size_t nx = c->f->nx, nz = c->f->nz;
    double *next = c->scratch + 7 * nx + 2 * nz;
    if (nz == 0) return MW_PLANT_OK;
    if (eval_at(c, &c->f->start, x, next, NULL) != 0) return MW_PLANT_EVAL; /* not into m: start reads arg[3] */
    memcpy(c->m, next, nz * sizeof(double));
    return mw_plant_settle(c, x, NULL, NULL);
}

/* Whether an indicator went from positive to not positive. */
static int crossed(const double *z0, const double *z1, size_t nz) {
    size_t i;
    for (i = 0; i < nz; i++) {
        if (z0[i] > 0.0 && !(z1[i] > 0.0)) return 1;
    }
    return 0;
}

/* One sub-step of length hs from x with event location (see plant_step.h). */
static int substep(MwPlantCall *c, double *x, double hs) {
    const size_t nx = c->f->nx, nz = c->f->nz;
    double *x0 = c->scratch, *z0 = c->scratch + 7 * nx, *z1 = z0 + nz;
    double remaining = hs;
    int events = 0, status;
    if (nz == 0 || !c->active) return rk4(c, x, hs);
    while (remaining > 0.0) {
        double lo = 0.0, hi = 1.0;
        int it;
        if (!c->z_valid && (status = mw_plant_events(c, x, z0)) != 0) return status;
        memcpy(x0, x, nx * sizeof(double)); /* the start of this piece */
        if ((status = rk4(c, x, remaining)) != 0) return status;
        if ((status = mw_plant_events(c, x, z1)) != 0) return status;
        if (!crossed(z0, z1, nz)) {
            memcpy(z0, z1, nz * sizeof(double)); /* the indicators at the start of the next sub-step */
            c->z_valid = 1;
            return MW_PLANT_OK;
        }
        c->z_valid = 0;
        for (it = 0; it < 60 && (hi - lo) > MW_PLANT_EVENT_RTOL; it++) {
            double mid = 0.5 * (lo + hi);
            memcpy(x, x0, nx * sizeof(double));
            if ((status = rk4(c, x, mid * remaining)) != 0) return status;
            if ((status = mw_plant_events(c, x, z1)) != 0) return status;
            if (crossed(z0, z1, nz)) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        memcpy(x, x0, nx * sizeof(double));
        if ((status = rk4(c, x, hi * remaining)) != 0) return status;
        if ((status = mw_plant_settle(c, x, NULL, NULL)) != 0) return status;
        remaining -= hi * remaining;
        if (++events > MW_PLANT_MAX_EVENTS) return MW_PLANT_CHATTER;
        if (!c->active) return rk4(c, x, remaining);
    }
    return MW_PLANT_OK;
}

int mw_plant_substeps(MwPlantCall *c, double *x, double hs, unsigned long long n) {
    unsigned long long k;
    int status;
    c->fault_joint = 0;
    c->fault_substep = 0;
    for (k = 0; k < n; k++) {
        if ((status = substep(c, x, hs)) != 0) {
            c->fault_substep = k + 1;
            return status;
        }
    }
    return MW_PLANT_OK;
}

int mw_plant_advance(MwPlantCall *c, double *x, double h, unsigned long long n) {
    int status = mw_plant_settle(c, x, NULL, NULL);
    if (status != 0) return status;
    return mw_plant_substeps(c, x, h / (double)n, n);
}

int mw_plant_diagnose(MwPlantCall *c) {
    const size_t nx = c->f->nx, nz = c->f->nz, npiv = c->f->npiv;
    double *piv = c->scratch + 7 * nx + 2 * nz + nz + nx;
    size_t j;
    c->fault_joint = 0;
    /* a state that overflowed is a diverging run, whatever its pivots say */
    if (npiv == 0 || !all_finite(c->fault_x, nx) || eval_at(c, &c->f->pivots, c->fault_x, piv, NULL) != 0) return MW_PLANT_NONFINITE;
    for (j = 0; j < npiv; j++) {
        if (!(piv[j] > 0.0)) {
            c->fault_joint = (int)j + 1;
            return MW_PLANT_SINGULAR;
        }
    }
    return MW_PLANT_NONFINITE;
}

/* ------------------------------------------------------------ self-contained runs (ctypes, kernel) */

struct MwPlantRun {
    MwPlantFunctions f;
    MwPlantCall call;
    double *block; /* scratch */
};

void mw_plant_close(MwPlantRun *run) {
    if (run == NULL) return;
    free(run->block);
    free(run->call.w);
    free(run->call.iw);
    free((void *)run->call.res);
    free((void *)run->call.arg);
    free(run);
}

static MwFunction function_at(void *const *functions, int k) {
    MwFunction fn;
    /* ctypes hands over the addresses of the generated functions; here they become function pointers again */
    memcpy(&fn.eval, &functions[2 * k], sizeof(fn.eval));
    memcpy(&fn.work, &functions[2 * k + 1], sizeof(fn.work));
    return fn;
}

MwPlantRun *mw_plant_open(long long nx, long long nz, long long npiv, void *const *functions) {
    mw_int sz_arg = 0, sz_res = 0, sz_iw = 0, sz_w = 0;
    MwPlantRun *run;
    if (nx < 0 || nz < 0 || npiv < 0) return NULL;
    run = (MwPlantRun *)calloc(1, sizeof(MwPlantRun));
    if (run == NULL) return NULL;
    run->f.nx = (size_t)nx;
    run->f.nz = (size_t)nz;
    run->f.npiv = (size_t)npiv;
    run->f.ode = function_at(functions, 0);
    run->f.ode_sliding = function_at(functions, 1);
    run->f.events = function_at(functions, 2);
    run->f.events_sliding = function_at(functions, 3);
    run->f.update = function_at(functions, 4);
    run->f.start = function_at(functions, 5);
    run->f.active = function_at(functions, 6);
    run->f.pivots = function_at(functions, 7);
    run->call.f = &run->f;
    if (mw_plant_work_sizes(&run->f, &sz_arg, &sz_res, &sz_iw, &sz_w) != 0) {
        mw_plant_close(run);
        return NULL;
    }
    run->call.arg = (const double **)calloc((size_t)sz_arg, sizeof(double *));
    run->call.res = (double **)calloc((size_t)sz_res, sizeof(double *));
    run->call.iw = (mw_int *)calloc((size_t)(sz_iw > 0 ? sz_iw : 1), sizeof(mw_int));
    run->call.w = (double *)calloc((size_t)(sz_w > 0 ? sz_w : 1), sizeof(double));
    run->block = (double *)calloc(mw_plant_scratch_size(&run->f), sizeof(double));
    if (!run->call.arg || !run->call.res || !run->call.iw || !run->call.w || !run->block) {
        mw_plant_close(run);
        return NULL;
    }
    mw_plant_bind_scratch(&run->call, run->block);
    return run;
}

static void bind_inputs(MwPlantRun *run, double *m, const double *u, const double *p) {
    run->call.arg[1] = u;
    run->call.arg[2] = p;
    run->call.m = m;
}

int mw_plant_run_start(MwPlantRun *run, double *x, double *m, const double *u, const double *p) {
    bind_inputs(run, m, u, p);
    run->call.fault_joint = 0;
    return mw_plant_start(&run->call, x);
}

int mw_plant_run_advance(MwPlantRun *run, double *x, double *m, const double *u, const double *p, double h,
                         long long n) {
    int status;
    if (n < 1) return MW_PLANT_EVAL;
    bind_inputs(run, m, u, p);
    status = mw_plant_advance(&run->call, x, h, (unsigned long long)n);
    return status == MW_PLANT_NONFINITE ? mw_plant_diagnose(&run->call) : status;
}

int mw_plant_run_fault(const MwPlantRun *run, double *x) {
    memcpy(x, run->call.fault_x, run->f.nx * sizeof(double));
    return run->call.fault_joint;
}
