/*
 * Storage, logging, model evaluation, the co-simulation integrator and the
 * FMU-state snapshots of one instance (see instance.h).
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "instance.h"

static const char *const mw_category_names[MW_LOG_COUNT] = {
    "logStatusWarning", "logStatusDiscard", "logStatusError", "logStatusFatal", "logCalls"};

/* ------------------------------------------------------------------ memory */

static size_t at_least_one(size_t n) { return n > 0 ? n : 1; }

MwInstance *mw_instance_new(const MwModel *model, MwInterface type, const char *name, const MwHost *host,
                            int logging_on) {
    MwInstance *inst;
    mw_int sz_arg = 8, sz_res = 2, sz_iw = 0, sz_w = 0;
    size_t nx = model->nx, nu = model->nu, np = model->np, ny = model->ny, nz = model->nz, nd = model->nd;
    size_t n_doubles, name_len;
    double *d;

    MwPlantFunctions plant;
    size_t n_scratch;

    plant.nx = nx;
    plant.nz = nz;
    plant.npiv = model->npiv;
    plant.ode = model->ode;
    plant.ode_sliding = model->ode_sliding;
    plant.events = model->events;
    plant.events_sliding = model->events_sliding;
    plant.update = model->update;
    plant.start = model->start;
    plant.active = model->active;
    plant.pivots = model->pivots;
    if (mw_plant_work_sizes(&plant, &sz_arg, &sz_res, &sz_iw, &sz_w) != 0 ||
        mw_function_work_sizes(&model->out, &sz_arg, &sz_res, &sz_iw, &sz_w) != 0 ||
        mw_function_work_sizes(&model->ode_dir, &sz_arg, &sz_res, &sz_iw, &sz_w) != 0 ||
        mw_function_work_sizes(&model->out_dir, &sz_arg, &sz_res, &sz_iw, &sz_w) != 0 ||
        mw_function_work_sizes(&model->ode_adj, &sz_arg, &sz_res, &sz_iw, &sz_w) != 0 ||
        mw_function_work_sizes(&model->out_adj, &sz_arg, &sz_res, &sz_iw, &sz_w) != 0 ||
        mw_function_work_sizes(&model->tick, &sz_arg, &sz_res, &sz_iw, &sz_w) != 0) {
        return NULL;
    }
    n_scratch = mw_plant_scratch_size(&plant);
    if (sz_arg < 0 || sz_res < 0 || sz_iw < 0 || sz_w < 0) return NULL;

    inst = (MwInstance *)host->alloc(1, sizeof(MwInstance));
    if (inst == NULL) return NULL;
    memset(inst, 0, sizeof(*inst));
    inst->host = *host;
    inst->model = model;
    inst->type = type;

    name_len = strlen(name);
    inst->name = (char *)host->alloc(name_len + 1, sizeof(char));
    /* x, u, p, m, xdot, y, z, d; x_save, m_save; d_save, d_next; dx, du, dp, dxdot, dy, adj; plant scratch; w */
    n_doubles = (nx + nu + np + nz + nx + ny + nz + nd) + (nx + nz) + 2 * nd + (nx + nu + np + nx + ny) +
                (nx + nu + np) + n_scratch + (size_t)sz_w;
    inst->block = (double *)host->alloc(at_least_one(n_doubles), sizeof(double));
    inst->arg = (const double **)host->alloc((size_t)sz_arg, sizeof(const double *));
    inst->res = (double **)host->alloc((size_t)sz_res, sizeof(double *));
    inst->iw = (mw_int *)host->alloc(at_least_one((size_t)sz_iw), sizeof(mw_int));
    if (inst->name == NULL || inst->block == NULL || inst->arg == NULL || inst->res == NULL || inst->iw == NULL) {
        mw_instance_free(inst);
        return NULL;
    }
    memcpy(inst->name, name, name_len + 1);

    d = inst->block;
    inst->x = d; d += nx;
    inst->u = d; d += nu;
    inst->p = d; d += np;
    inst->m = d; d += nz;
    inst->xdot = d; d += nx;
    inst->y = d; d += ny;
    inst->z = d; d += nz;
    inst->d = d; d += nd;
    inst->x_save = d; d += nx;
    inst->m_save = d; d += nz;
    inst->d_save = d; d += nd;
    inst->d_next = d; d += nd;
    inst->dx = d; d += nx;
    inst->du = d; d += nu;
    inst->dp = d; d += np;
    inst->dxdot = d; d += nx;
    inst->dy = d; d += ny;
    inst->adj = d; d += nx + nu + np;
    inst->plant_scratch = d; d += n_scratch;
    inst->w = d;

    inst->plant = plant;
    inst->call.f = &inst->plant; /* the instance does not move: the pointer stays valid */
    inst->call.arg = inst->arg;
    inst->call.res = inst->res;
    inst->call.iw = inst->iw;
    inst->call.w = inst->w;
    inst->call.m = inst->m;
    mw_plant_bind_scratch(&inst->call, inst->plant_scratch);

    inst->log_mask = (1u << MW_LOG_WARNING) | (1u << MW_LOG_DISCARD) | (1u << MW_LOG_ERROR) | (1u << MW_LOG_FATAL);
    if (logging_on) inst->log_mask |= 1u << MW_LOG_CALLS;
    inst->mode = MW_MODE_INSTANTIATED;
    mw_set_start_values(inst);
    return inst;
}

void mw_instance_free(MwInstance *inst) {
    void (*release)(void *);
    if (inst == NULL) return;
    release = inst->host.release;
    /* FMU states the importer did not free go with the instance (FMI 2.0, 2.1.5; FMI 3.0, 2.3.3) */
    while (inst->snapshots != NULL) mw_snapshot_free(inst, inst->snapshots);
    if (inst->name != NULL) release(inst->name);
    if (inst->block != NULL) release(inst->block);
    if (inst->arg != NULL) release((void *)inst->arg);
    if (inst->res != NULL) release(inst->res);
    if (inst->iw != NULL) release(inst->iw);
    release(inst);
}

void mw_invalidate(MwInstance *inst) {
    inst->xdot_valid = 0;
    inst->y_valid = 0;
    inst->z_valid = 0;
}

void mw_set_start_values(MwInstance *inst) {
    const MwModel *m = inst->model;
    if (m->nx > 0) memcpy(inst->x, m->x_start, m->nx * sizeof(double));
    if (m->nu > 0) memcpy(inst->u, m->u_start, m->nu * sizeof(double));
    if (m->np > 0) memcpy(inst->p, m->p_start, m->np * sizeof(double));
    if (m->nz > 0) memset(inst->m, 0, m->nz * sizeof(double));
    if (m->nd > 0) memcpy(inst->d, m->d_start, m->nd * sizeof(double));
    inst->h_int = m->step_start;
    inst->time = 0.0;
    inst->last_successful_time = 0.0;
    inst->stop_time_defined = 0;
    inst->stop_time = 0.0;
    mw_invalidate(inst);
}

/* ----------------------------------------------------------------- logging */

void mw_log(const MwInstance *inst, MwStatus status, MwLogCategory category, const char *fmt, ...) {
    char text[1024];
    va_list args;

    if (inst == NULL || inst->host.log == NULL || category >= MW_LOG_COUNT) return;
    if ((inst->log_mask & (1u << category)) == 0) return;

    va_start(args, fmt);
    vsnprintf(text, sizeof(text), fmt, args);
    va_end(args);
    inst->host.log(inst, status, mw_category_names[category], text);
}

MwStatus mw_set_logging(MwInstance *inst, const char *fn, int on, size_t n, const char *const categories[]) {
    size_t i;
    int k;
    MwStatus status = MW_OK;

    if (n == 0) {
        inst->log_mask = on ? (1u << MW_LOG_COUNT) - 1u : 0u;
        return MW_OK;
    }
    for (i = 0; i < n; i++) {
        unsigned int bits = 0;
        if (categories[i] == NULL) {
            mw_log(inst, MW_WARNING, MW_LOG_WARNING, "%s: category %u is NULL, ignored", fn, (unsigned int)i);
            status = MW_WARNING;
            continue;
        }
        if (strcmp(categories[i], "logAll") == 0) {
            bits = (1u << MW_LOG_COUNT) - 1u;
        } else {
            for (k = 0; k < MW_LOG_COUNT; k++) {
                if (strcmp(categories[i], mw_category_names[k]) == 0) bits = 1u << k;
            }
        }
        if (bits == 0) {
            mw_log(inst, MW_WARNING, MW_LOG_WARNING, "%s: unknown log category \"%.100s\", ignored", fn,
                   categories[i]);
            status = MW_WARNING;
            continue;
        }
        if (on) {
            inst->log_mask |= bits;
        } else {
            inst->log_mask &= ~bits;
        }
    }
    return status;
}

/* -------------------------------------------------------------- evaluation */

int mw_all_finite(const double *v, size_t n) {
    size_t i;
    for (i = 0; i < n; i++) {
        if (!isfinite(v[i])) return 0;
    }
    return 1;
}

/* (x, u, p, m, d): the functions of four inputs (events, update) read the first four only */
static void set_args(MwInstance *inst, const double *x) {
    inst->arg[0] = x;
    inst->arg[1] = inst->u;
    inst->arg[2] = inst->p;
    inst->arg[3] = inst->m;
    inst->arg[4] = inst->d;
}

static int eval_ode(MwInstance *inst, const double *x, double *xdot) {
    set_args(inst, x);
    inst->res[0] = xdot;
    return inst->model->ode.eval(inst->arg, inst->res, inst->iw, inst->w, 0) == 0 ? 0 : -1;
}

int mw_update_derivatives(MwInstance *inst) {
    if (inst->xdot_valid) return 0;
    if (eval_ode(inst, inst->x, inst->xdot) != 0) return -1;
    inst->xdot_valid = 1;
    return 0;
}

int mw_update_outputs(MwInstance *inst) {
    if (inst->y_valid) return 0;
    set_args(inst, inst->x);
    inst->res[0] = inst->y;
    if (inst->model->out.eval(inst->arg, inst->res, inst->iw, inst->w, 0) != 0) return -1;
    inst->y_valid = 1;
    return 0;
}

int mw_update_indicators(MwInstance *inst) {
    if (inst->z_valid) return 0;
    if (mw_events(inst, inst->x, inst->z) != 0) return -1;
    inst->z_valid = 1;
    return 0;
}

int mw_prepare(MwInstance *inst, const MwVariable *v) {
    switch ((MwKind)v->kind) {
    case MW_KIND_DERIVATIVE: return mw_update_derivatives(inst);
    case MW_KIND_OUTPUT: return mw_update_outputs(inst);
    case MW_KIND_INDICATOR: return mw_update_indicators(inst);
    default: return 0;
    }
}

double mw_value(const MwInstance *inst, const MwVariable *v) {
    switch ((MwKind)v->kind) {
    case MW_KIND_STATE: return inst->x[v->index];
    case MW_KIND_DERIVATIVE: return inst->xdot[v->index];
    case MW_KIND_INPUT: return inst->u[v->index];
    case MW_KIND_PARAMETER: return inst->p[v->index];
    case MW_KIND_OUTPUT: return inst->y[v->index];
    case MW_KIND_STEP: return inst->h_int;
    case MW_KIND_INDICATOR: return inst->z[v->index];
    case MW_KIND_DISCRETE: return inst->d[v->index];
    default: return NAN;
    }
}

int mw_assign(MwInstance *inst, const MwVariable *v, double value) {
    switch ((MwKind)v->kind) {
    case MW_KIND_STATE: inst->x[v->index] = value; break;
    case MW_KIND_INPUT: inst->u[v->index] = value; break;
    case MW_KIND_PARAMETER: inst->p[v->index] = value; break;
    case MW_KIND_STEP: inst->h_int = value; break;
    case MW_KIND_DISCRETE: inst->d[v->index] = value; break;
    default: return -1;
    }
    mw_invalidate(inst);
    return 0;
}

void mw_clear_seeds(MwInstance *inst) {
    const MwModel *m = inst->model;
    if (m->nx > 0) memset(inst->dx, 0, m->nx * sizeof(double));
    if (m->nu > 0) memset(inst->du, 0, m->nu * sizeof(double));
    if (m->np > 0) memset(inst->dp, 0, m->np * sizeof(double));
    if (m->nx > 0) memset(inst->dxdot, 0, m->nx * sizeof(double));
    if (m->ny > 0) memset(inst->dy, 0, m->ny * sizeof(double));
}

int mw_seed(MwInstance *inst, const MwVariable *v, double seed, int reverse) {
    switch ((MwKind)v->kind) {
    case MW_KIND_STATE: inst->dx[v->index] += seed; return 0; /* a known, or an unknown equal to itself */
    case MW_KIND_INPUT: if (reverse) return -1; inst->du[v->index] += seed; return 0;
    case MW_KIND_PARAMETER: if (reverse) return -1; inst->dp[v->index] += seed; return 0;
    case MW_KIND_DERIVATIVE: if (!reverse) return -1; inst->dxdot[v->index] += seed; return 0;
    case MW_KIND_OUTPUT: if (!reverse) return -1; inst->dy[v->index] += seed; return 0;
    default: return -1;
    }
}

double mw_sensitivity(const MwInstance *inst, const MwVariable *v, int reverse) {
    switch ((MwKind)v->kind) {
    case MW_KIND_STATE: return inst->dx[v->index];
    case MW_KIND_INPUT: return reverse ? inst->du[v->index] : NAN;
    case MW_KIND_PARAMETER: return reverse ? inst->dp[v->index] : NAN;
    case MW_KIND_DERIVATIVE: return reverse ? NAN : inst->dxdot[v->index];
    case MW_KIND_OUTPUT: return reverse ? NAN : inst->dy[v->index];
    default: return NAN;
    }
}

int mw_adjoint(MwInstance *inst, int need_ode, int need_out) {
    const MwModel *m = inst->model;
    size_t i, nx = m->nx, nu = m->nu, np = m->np;
    int pass;
    for (pass = 0; pass < 2; pass++) {
        if (pass == 0 ? !need_ode : !need_out) continue;
        set_args(inst, inst->x);
        inst->arg[5] = pass == 0 ? inst->dxdot : inst->dy;
        inst->res[0] = inst->adj;
        if ((pass == 0 ? m->ode_adj : m->out_adj).eval(inst->arg, inst->res, inst->iw, inst->w, 0) != 0) return -1;
        for (i = 0; i < nx; i++) inst->dx[i] += inst->adj[i];
        for (i = 0; i < nu; i++) inst->du[i] += inst->adj[nx + i];
        for (i = 0; i < np; i++) inst->dp[i] += inst->adj[nx + nu + i];
    }
    return 0;
}

int mw_directional(MwInstance *inst, int need_dxdot, int need_dy) {
    const MwModel *m = inst->model;
    set_args(inst, inst->x);
    inst->arg[5] = inst->dx;
    inst->arg[6] = inst->du;
    inst->arg[7] = inst->dp;
    if (need_dxdot) {
        inst->res[0] = inst->dxdot;
        if (m->ode_dir.eval(inst->arg, inst->res, inst->iw, inst->w, 0) != 0) return -1;
    }
    if (need_dy) {
        inst->res[0] = inst->dy;
        if (m->out_dir.eval(inst->arg, inst->res, inst->iw, inst->w, 0) != 0) return -1;
    }
    return 0;
}

/* ------------------------------------------------------------------ modes */

int mw_events(MwInstance *inst, const double *x, double *z) {
    size_t i;
    set_args(inst, x);
    /* the modes may have been set since the rule last looked (an FMU state restored): which function applies */
    inst->call.any_stuck = 0;
    for (i = 0; i < inst->model->nz; i++) inst->call.any_stuck |= inst->m[i] == 0.0;
    return mw_plant_events(&inst->call, x, z) == MW_PLANT_OK ? 0 : -1;
}

const char *mw_singular_problem(MwInstance *inst, const double *x, char *what, size_t len) {
    const size_t n = inst->plant.npiv;
    size_t i, at;
    if (n == 0) return NULL;
    set_args(inst, x);
    memcpy(inst->call.fault_x, x, inst->model->nx * sizeof(double));
    if (mw_plant_diagnose(&inst->call) != MW_PLANT_SINGULAR) return NULL;
    at = (size_t)snprintf(what, len, "the inertia matrix B(q) is singular at joint %d (it moves no mass and has no "
                          "motor inertia there) at t = %.17g, q = [", inst->call.fault_joint, inst->time);
    for (i = 0; i < n && at < len; i++) at += (size_t)snprintf(what + at, len - at, i ? ", %.9g" : "%.9g", x[i]);
    if (at < len) snprintf(what + at, len - at, "]");
    return what;
}

MwStatus mw_check_derivatives(MwInstance *inst, const char *fn, const double *v, size_t n) {
    char what[512];
    if (mw_all_finite(v, n)) return MW_OK;
    if (mw_singular_problem(inst, inst->x, what, sizeof(what)) != NULL) return mw_fail(inst, fn, what);
    return mw_non_finite(inst, fn, "the derivatives", v, n);
}

/* -------------------------------------------------------------- integrator */

unsigned long long mw_substeps(double h, double h_int) {
    double ratio = h / h_int;
    double nearest = floor(ratio + 0.5);
    double n_real;
    if (!(ratio > 0.0) || !isfinite(ratio)) return 0;
    /* a ratio that is an integer up to rounding noise counts as that integer */
    n_real = fabs(ratio - nearest) <= MW_SUBSTEP_RTOL * ratio ? nearest : ceil(ratio);
    if (n_real < 1.0) n_real = 1.0;
    if (!(n_real <= (double)MW_MAX_SUBSTEPS)) return 0;
    return (unsigned long long)n_real;
}

unsigned long long mw_ticks(const MwModel *model, double h) {
    double ratio, nearest;
    if (model->nd == 0) return 1;
    ratio = h / model->sample_period;
    nearest = floor(ratio + 0.5);
    if (!(ratio > 0.0) || !isfinite(ratio) || nearest < 1.0 || fabs(ratio - nearest) > MW_SUBSTEP_RTOL * ratio ||
        !(nearest <= (double)MW_MAX_SUBSTEPS))
        return 0;
    return (unsigned long long)nearest;
}

int mw_is_close(double a, double b) {
    double scale = fabs(a) > fabs(b) ? fabs(a) : fabs(b);
    return fabs(a - b) <= 1e-12 * (scale > 1.0 ? scale : 1.0);
}

int mw_past_stop_time(const MwInstance *inst, double t) {
    return inst->stop_time_defined && t > inst->stop_time && !mw_is_close(t, inst->stop_time);
}

const char *mw_step_plan(const MwInstance *inst, double tc, double h, unsigned long long *ticks,
                         unsigned long long *n, char *what, size_t len) {
    const MwModel *m = inst->model;
    double tol = 1e-9 * (fabs(inst->time) > 1.0 ? fabs(inst->time) : 1.0);
    if (!isfinite(tc)) return "currentCommunicationPoint is not finite";
    if (!(h > 0.0) || !isfinite(h)) {
        snprintf(what, len, "communicationStepSize %g must be positive and finite", h);
        return what;
    }
    if (fabs(tc - inst->time) > tol) {
        snprintf(what, len, "currentCommunicationPoint %.17g differs from the FMU time %.17g", tc, inst->time);
        return what;
    }
    if (mw_past_stop_time(inst, tc + h)) {
        snprintf(what, len, "a step from %.17g of %.17g s ends past the stopTime %.17g of the experiment", tc, h,
                 inst->stop_time);
        return what;
    }
    *ticks = mw_ticks(m, h);
    if (*ticks == 0) {
        snprintf(what, len, "communicationStepSize %.17g is not a whole number of sample periods of %.17g s: the "
                 "sampled states (a digital controller) change once per period", h, m->sample_period);
        return what;
    }
    *n = m->nx > 0 ? mw_substeps(h / (double)*ticks, inst->h_int) : 1;
    if (*n == 0 || *n > MW_MAX_SUBSTEPS / *ticks) {
        snprintf(what, len, "communicationStepSize %g needs more than %llu sub-steps of internal_step %g s, "
                 "the most one call takes: use shorter communication steps or a longer internal_step",
                 h, MW_MAX_SUBSTEPS, inst->h_int);
        return what;
    }
    return NULL;
}

/* d <- tick(x, u, p, d): one sample period's update of the sampled states; 0, or -1 (failed, non-finite). */
static int tick(MwInstance *inst) {
    const size_t nd = inst->model->nd;
    inst->arg[0] = inst->x;
    inst->arg[1] = inst->u;
    inst->arg[2] = inst->p;
    inst->arg[3] = inst->d;
    inst->res[0] = inst->d_next;
    if (inst->model->tick.eval(inst->arg, inst->res, inst->iw, inst->w, 0) != 0) return -1;
    if (!mw_all_finite(inst->d_next, nd)) return -1;
    memcpy(inst->d, inst->d_next, nd * sizeof(double));
    mw_invalidate(inst);
    return 0;
}

static const char *rule_problem(int status) {
    switch (status) {
    case MW_PLANT_EVAL: return "the model failed to evaluate";
    case MW_PLANT_UNSETTLED: return "the friction modes did not settle";
    case MW_PLANT_CHATTER: return "more than 64 friction events in one sub-step";
    default: return "the state became non-finite";
    }
}

MwStatus mw_do_step(MwInstance *inst, const char *fn, double tc, double h) {
    const size_t nx = inst->model->nx, nz = inst->model->nz, nd = inst->model->nd;
    unsigned long long ticks = 1, n = 1, j = 0;
    int status;
    char what[512];
    const char *problem = mw_step_plan(inst, tc, h, &ticks, &n, what, sizeof(what));
    double hs;

    if (problem != NULL) return mw_fail(inst, fn, problem);
    hs = h / (double)(ticks * n);
    mw_log(inst, MW_OK, MW_LOG_CALLS, "%s: from t = %.17g, %llu sub-steps of %.17g s (%llu sample periods)", fn, tc,
           ticks * n, hs, ticks);
    if (nx > 0) memcpy(inst->x_save, inst->x, nx * sizeof(double));
    if (nz > 0) memcpy(inst->m_save, inst->m, nz * sizeof(double));
    if (nd > 0) memcpy(inst->d_save, inst->d, nd * sizeof(double));
    mw_invalidate(inst);
    /* inputs or parameters may have changed since the last step: the modes follow them first */
    set_args(inst, inst->x);
    inst->call.fault_substep = 0;
    status = mw_plant_settle(&inst->call, inst->x, NULL, NULL);
    for (j = 0; j < ticks && status == 0; j++) {
        if (nd > 0) {
            status = tick(inst) == 0 ? MW_PLANT_OK : MW_PLANT_NONFINITE; /* the sampled states: once per period */
            set_args(inst, inst->x);
        }
        if (status == 0 && nx > 0) status = mw_plant_substeps(&inst->call, inst->x, hs, n);
    }
    if (status == MW_PLANT_NONFINITE && nx > 0) status = mw_plant_diagnose(&inst->call);
    if (status != 0) {
        if (nx > 0) memcpy(inst->x, inst->x_save, nx * sizeof(double));
        if (nz > 0) memcpy(inst->m, inst->m_save, nz * sizeof(double));
        if (nd > 0) memcpy(inst->d, inst->d_save, nd * sizeof(double));
        mw_invalidate(inst);
        inst->last_successful_time = tc;
        if (status == MW_PLANT_SINGULAR) {
            size_t at = (size_t)snprintf(what, sizeof(what), "the inertia matrix B(q) is singular at joint %d (it "
                                         "moves no mass and has no motor inertia there) in the step from t = %.17g, "
                                         "q = [", inst->call.fault_joint, tc);
            size_t i;
            for (i = 0; i < inst->plant.npiv && at < sizeof(what); i++)
                at += (size_t)snprintf(what + at, sizeof(what) - at, i ? ", %.9g" : "%.9g", inst->call.fault_x[i]);
            if (at < sizeof(what)) snprintf(what + at, sizeof(what) - at, "]");
            return mw_fail(inst, fn, what);
        }
        mw_log(inst, MW_DISCARD, MW_LOG_DISCARD,
               "%s: %s in sub-step %llu of %llu of period %llu of %llu; the state at the communication point "
               "%.17g is kept", fn, rule_problem(status), inst->call.fault_substep, n, j, ticks, tc);
        inst->mode = MW_MODE_STEP_FAILED;
        return MW_DISCARD;
    }
    inst->time = tc + h;
    inst->last_successful_time = inst->time;
    return MW_OK;
}

/* --------------------------------------------------------------- snapshots */

MwSnapshot *mw_snapshot_new(MwInstance *inst) {
    const MwModel *m = inst->model;
    size_t nv = m->nx + m->nu + m->np + m->nz + m->nd;
    MwSnapshot *snap = (MwSnapshot *)inst->host.alloc(1, sizeof(MwSnapshot) + nv * sizeof(double));
    if (snap == NULL) return NULL;
    snap->mode = inst->mode;
    snap->time = inst->time;
    snap->last_successful_time = inst->last_successful_time;
    snap->h_int = inst->h_int;
    snap->values = (double *)(void *)(snap + 1);
    snap->prev = NULL;
    snap->next = inst->snapshots;
    if (inst->snapshots != NULL) inst->snapshots->prev = snap;
    inst->snapshots = snap;
    return snap;
}

MwSnapshot *mw_snapshot_find(const MwInstance *inst, const void *s) {
    MwSnapshot *snap;
    if (s == NULL) return NULL;
    for (snap = inst->snapshots; snap != NULL; snap = snap->next) {
        if ((const void *)snap == s) return snap;
    }
    return NULL;
}

void mw_snapshot_free(MwInstance *inst, MwSnapshot *snap) {
    if (snap->prev != NULL) {
        snap->prev->next = snap->next;
    } else {
        inst->snapshots = snap->next;
    }
    if (snap->next != NULL) snap->next->prev = snap->prev;
    inst->host.release(snap);
}

void mw_snapshot_take(const MwInstance *inst, MwSnapshot *snap) {
    const MwModel *m = inst->model;
    snap->mode = inst->mode;
    snap->time = inst->time;
    snap->last_successful_time = inst->last_successful_time;
    snap->h_int = inst->h_int;
    if (m->nx > 0) memcpy(snap->values, inst->x, m->nx * sizeof(double));
    if (m->nu > 0) memcpy(snap->values + m->nx, inst->u, m->nu * sizeof(double));
    if (m->np > 0) memcpy(snap->values + m->nx + m->nu, inst->p, m->np * sizeof(double));
    if (m->nz > 0) memcpy(snap->values + m->nx + m->nu + m->np, inst->m, m->nz * sizeof(double));
    if (m->nd > 0) memcpy(snap->values + m->nx + m->nu + m->np + m->nz, inst->d, m->nd * sizeof(double));
}

void mw_snapshot_restore(MwInstance *inst, const MwSnapshot *snap) {
    const MwModel *m = inst->model;
    inst->mode = snap->mode;
    inst->time = snap->time;
    inst->last_successful_time = snap->last_successful_time;
    inst->h_int = snap->h_int;
    if (m->nx > 0) memcpy(inst->x, snap->values, m->nx * sizeof(double));
    if (m->nu > 0) memcpy(inst->u, snap->values + m->nx, m->nu * sizeof(double));
    if (m->np > 0) memcpy(inst->p, snap->values + m->nx + m->nu, m->np * sizeof(double));
    if (m->nz > 0) memcpy(inst->m, snap->values + m->nx + m->nu + m->np, m->nz * sizeof(double));
    if (m->nd > 0) memcpy(inst->d, snap->values + m->nx + m->nu + m->np + m->nz, m->nd * sizeof(double));
    mw_invalidate(inst);
}

int mw_mode_valid(const MwInstance *inst, unsigned int mode) {
    unsigned int allowed = MW_MODE_INSTANTIATED | MW_MODE_INIT | MW_MODE_TERMINATED | MW_MODE_ERROR;
    if (inst->type == MW_MODEL_EXCHANGE) {
        allowed |= MW_MODE_EVENT | MW_MODE_CONTINUOUS;
    } else {
        allowed |= MW_MODE_STEP_COMPLETE | MW_MODE_STEP_FAILED;
    }
    /* exactly one bit, and an allowed one */
    return mode != 0 && (mode & (mode - 1u)) == 0 && (mode & allowed) == mode;
}

/*
 * Serialized FMU state, version 3 (2 had no sampled states: nd was 4 bytes of zeros), native byte order:
 *   0   8 bytes  "MWFMUST1"
 *   8   uint32   format version (2)
 *  12   uint32   0x01020304, byte-order mark
 *  16   uint64   total size in bytes
 *  24   64 bytes GUID of the model, zero padded
 *  88   uint32   nx, nu, np, mode
 * 104   double   time, last successful time, internal step
 * 128   uint32   nz, nd
 * 136   double   x[nx], u[nu], p[np], m[nz], d[nd]
 */
#define MW_SER_MAGIC "MWFMUST1"
#define MW_SER_VERSION 3u
#define MW_SER_BOM 0x01020304u
#define MW_SER_GUID 64u
#define MW_SER_HEADER 136u

size_t mw_serialized_size(const MwModel *m) {
    return MW_SER_HEADER + (m->nx + m->nu + m->np + m->nz + m->nd) * sizeof(double);
}

static void put_u32(unsigned char *out, size_t at, unsigned int v) {
    unsigned int w = v;
    memcpy(out + at, &w, 4);
}

static unsigned int get_u32(const unsigned char *in, size_t at) {
    unsigned int v;
    memcpy(&v, in + at, 4);
    return v;
}

void mw_serialize(const MwModel *m, const MwSnapshot *snap, unsigned char *out) {
    unsigned long long total = (unsigned long long)mw_serialized_size(m);
    size_t guid_len = strlen(m->guid);
    size_t nv = m->nx + m->nu + m->np + m->nz + m->nd;

    memset(out, 0, MW_SER_HEADER);
    memcpy(out, MW_SER_MAGIC, 8);
    put_u32(out, 8, MW_SER_VERSION);
    put_u32(out, 12, MW_SER_BOM);
    memcpy(out + 16, &total, 8);
    memcpy(out + 24, m->guid, guid_len < MW_SER_GUID ? guid_len : MW_SER_GUID - 1);
    put_u32(out, 88, (unsigned int)m->nx);
    put_u32(out, 92, (unsigned int)m->nu);
    put_u32(out, 96, (unsigned int)m->np);
    put_u32(out, 100, snap->mode);
    memcpy(out + 104, &snap->time, 8);
    memcpy(out + 112, &snap->last_successful_time, 8);
    memcpy(out + 120, &snap->h_int, 8);
    put_u32(out, 128, (unsigned int)m->nz);
    put_u32(out, 132, (unsigned int)m->nd);
    if (nv > 0) memcpy(out + MW_SER_HEADER, snap->values, nv * sizeof(double));
}

const char *mw_deserialize(const MwInstance *inst, const unsigned char *in, size_t size, MwSnapshot *snap) {
    const MwModel *m = inst->model;
    size_t expected = mw_serialized_size(m);
    size_t nv = m->nx + m->nu + m->np + m->nz + m->nd;
    unsigned long long total;
    char guid[MW_SER_GUID];
    size_t guid_len = strlen(m->guid);
    double t, tl, h;

    if (size != expected) return "the size does not match this model's serialized FMU state";
    if (memcmp(in, MW_SER_MAGIC, 8) != 0) return "the bytes are not a serialized FMU state of this wrapper";
    if (get_u32(in, 8) != MW_SER_VERSION) return "unsupported format version";
    if (get_u32(in, 12) != MW_SER_BOM) return "the byte order differs from this platform's";
    memcpy(&total, in + 16, 8);
    if (total != (unsigned long long)expected) return "the size recorded in the header is wrong";
    memset(guid, 0, sizeof(guid));
    memcpy(guid, m->guid, guid_len < MW_SER_GUID ? guid_len : MW_SER_GUID - 1);
    if (memcmp(in + 24, guid, MW_SER_GUID) != 0) return "the state belongs to another model (GUID differs)";
    if (get_u32(in, 88) != m->nx || get_u32(in, 92) != m->nu || get_u32(in, 96) != m->np ||
        get_u32(in, 128) != m->nz || get_u32(in, 132) != m->nd)
        return "the vector sizes differ from this model's";
    if (!mw_mode_valid(inst, get_u32(in, 100))) return "the recorded mode is not valid for this instance type";
    memcpy(&t, in + 104, 8);
    memcpy(&tl, in + 112, 8);
    memcpy(&h, in + 120, 8);
    if (!isfinite(t) || !isfinite(tl) || !(h > 0.0) || !isfinite(h)) return "the recorded times are not valid";
    if (nv > 0) {
        /* check before touching the snapshot, so a bad buffer leaves it unchanged */
        size_t i;
        for (i = 0; i < nv; i++) {
            double v;
            memcpy(&v, in + MW_SER_HEADER + i * sizeof(double), sizeof(double));
            if (!isfinite(v)) return "the recorded values are not finite";
        }
        memcpy(snap->values, in + MW_SER_HEADER, nv * sizeof(double));
    }
    snap->mode = get_u32(in, 100);
    snap->time = t;
    snap->last_successful_time = tl;
    snap->h_int = h;
    return NULL;
}

/* ------------------------------------------------------- FMU-state calls */

const char *mw_state_get(MwInstance *inst, void **state) {
    MwSnapshot *snap;
    if (state == NULL) return "argument FMUstate is NULL";
    if (*state == NULL) {
        snap = mw_snapshot_new(inst);
        if (snap == NULL) return "out of memory";
        *state = snap;
    } else {
        snap = mw_snapshot_find(inst, *state);
        if (snap == NULL) return "*FMUstate is not an FMU state of this instance";
    }
    mw_snapshot_take(inst, snap);
    return NULL;
}

const char *mw_state_set(MwInstance *inst, const void *state) {
    const MwSnapshot *snap = mw_snapshot_find(inst, state);
    if (snap == NULL) return "FMUstate is NULL or not an FMU state of this instance";
    if (!mw_mode_valid(inst, snap->mode)) return "the FMU state was taken by an instance of the other interface type";
    mw_snapshot_restore(inst, snap);
    return NULL;
}

const char *mw_state_free(MwInstance *inst, void **state) {
    MwSnapshot *snap;
    if (state == NULL) return "argument FMUstate is NULL";
    if (*state == NULL) return NULL;
    snap = mw_snapshot_find(inst, *state);
    if (snap == NULL) return "*FMUstate is not an FMU state of this instance";
    mw_snapshot_free(inst, snap);
    *state = NULL;
    return NULL;
}

const char *mw_state_size(const MwInstance *inst, const void *state, size_t *size) {
    if (size == NULL) return "argument size is NULL";
    if (mw_snapshot_find(inst, state) == NULL) return "FMUstate is NULL or not an FMU state of this instance";
    *size = mw_serialized_size(inst->model);
    return NULL;
}

const char *mw_state_serialize(const MwInstance *inst, const void *state, unsigned char *out, size_t size,
                               const char *size_fn, char *what, size_t len) {
    const MwSnapshot *snap = mw_snapshot_find(inst, state);
    if (snap == NULL) return "FMUstate is NULL or not an FMU state of this instance";
    if (out == NULL) return "argument serializedState[] is NULL";
    if (size != mw_serialized_size(inst->model)) {
        snprintf(what, len, "size %lu differs from %s, %lu bytes", (unsigned long)size, size_fn,
                 (unsigned long)mw_serialized_size(inst->model));
        return what;
    }
    mw_serialize(inst->model, snap, out);
    return NULL;
}

const char *mw_state_deserialize(MwInstance *inst, const unsigned char *in, size_t size, void **state, char *what,
                                 size_t len) {
    MwSnapshot *snap;
    const char *problem;
    if (in == NULL) return "argument serializedState[] is NULL";
    if (state == NULL) return "argument FMUstate is NULL";
    /* *state is an output: its incoming value is not read; a new FMU state is always allocated */
    snap = mw_snapshot_new(inst);
    if (snap == NULL) return "out of memory";
    problem = mw_deserialize(inst, in, size, snap);
    if (problem != NULL) {
        mw_snapshot_free(inst, snap);
        snprintf(what, len, "%lu bytes rejected: %s", (unsigned long)size, problem);
        return what;
    }
    *state = snap;
    return NULL;
}

/* --------------------------------------------------------- argument checks */

const char *mw_value_problem(const MwVariable *v, double value, char *what, size_t len) {
    if (!isfinite(value)) {
        snprintf(what, len, "variable %.60s: value %g is not finite", v->name, value);
        return what;
    }
    if (value < v->min || value > v->max) {
        snprintf(what, len, "variable %.60s: value %.17g is outside [%g, %g]", v->name, value, v->min, v->max);
        return what;
    }
    return NULL;
}

MwStatus mw_fail(MwInstance *inst, const char *fn, const char *what) {
    mw_log(inst, MW_ERROR, MW_LOG_ERROR, "%s: %s", fn, what);
    inst->mode = MW_MODE_ERROR;
    return MW_ERROR;
}

MwInstance *mw_enter(void *c, const char *fn, int interface_type, unsigned int modes,
                     const char *(*mode_name)(unsigned int mode)) {
    MwInstance *inst = (MwInstance *)c;
    if (inst == NULL) return NULL;
    mw_log(inst, MW_OK, MW_LOG_CALLS, "%s", fn);
    if (interface_type == MW_FOR_ME && inst->type != MW_MODEL_EXCHANGE) {
        mw_fail(inst, fn, "this function belongs to Model Exchange, the instance is Co-Simulation");
        return NULL;
    }
    if (interface_type == MW_FOR_CS && inst->type != MW_CO_SIMULATION) {
        mw_fail(inst, fn, "this function belongs to Co-Simulation, the instance is Model Exchange");
        return NULL;
    }
    if ((inst->mode & modes) == 0) {
        mw_log(inst, MW_ERROR, MW_LOG_ERROR, "%s: illegal call sequence, not allowed in mode \"%s\"", fn,
               mode_name(inst->mode));
        inst->mode = MW_MODE_ERROR;
        return NULL;
    }
    return inst;
}

int mw_null_arg(MwInstance *inst, const char *fn, const char *name, const void *ptr) {
    if (ptr != NULL) return 0;
    mw_log(inst, MW_ERROR, MW_LOG_ERROR, "%s: argument %s is NULL", fn, name);
    inst->mode = MW_MODE_ERROR;
    return 1;
}

int mw_wrong_size(MwInstance *inst, const char *fn, const char *name, size_t got, size_t expected) {
    char what[160];
    if (got == expected) return 0;
    snprintf(what, sizeof(what), "%s is %lu, expected %lu", name, (unsigned long)got, (unsigned long)expected);
    mw_fail(inst, fn, what);
    return 1;
}

MwStatus mw_non_finite(MwInstance *inst, const char *fn, const char *what, const double *v, size_t n) {
    if (mw_all_finite(v, n)) return MW_OK;
    mw_log(inst, MW_DISCARD, MW_LOG_DISCARD, "%s: %s at t = %.17g are not all finite", fn, what, inst->time);
    return MW_DISCARD;
}

/* ------------------------------------------------ mode changes of both versions */

const char *mw_exit_initialization(MwInstance *inst, char *what, size_t len) {
    int modes;
    mw_invalidate(inst);
    set_args(inst, inst->x);
    modes = mw_plant_start(&inst->call, inst->x);
    mw_invalidate(inst);
    if (modes != 0)
        return modes == MW_PLANT_EVAL ? "the model failed to compute the friction modes"
                                      : "the initial friction modes did not settle";
    if (mw_update_derivatives(inst) != 0) return "the model failed to evaluate the derivatives";
    if (!mw_all_finite(inst->xdot, inst->model->nx)) {
        const char *singular = mw_singular_problem(inst, inst->x, what, len);
        return singular != NULL ? singular : "the initial state and parameters give non-finite derivatives";
    }
    inst->mode = inst->type == MW_MODEL_EXCHANGE ? MW_MODE_EVENT : MW_MODE_STEP_COMPLETE;
    return NULL;
}

const char *mw_set_time(MwInstance *inst, double time, char *what, size_t len) {
    if (!isfinite(time)) return "time is not finite";
    /* Past stopTime: an error in event mode. In continuous-time mode an integrator may try points past
       it inside a step that it then interpolates back (CVode does); the step is refused only if it is
       accepted there (CompletedIntegratorStep). */
    if (inst->mode == MW_MODE_EVENT && mw_past_stop_time(inst, time)) {
        snprintf(what, len, "time %.17g is past the stopTime %.17g of the experiment", time, inst->stop_time);
        return what;
    }
    /* in event mode time stands still or moves on to the event; it never goes back */
    if (inst->mode == MW_MODE_EVENT && time < inst->time && !mw_is_close(time, inst->time)) {
        snprintf(what, len, "time %.17g is before the current time %.17g: in event mode time may not go back", time,
                 inst->time);
        return what;
    }
    inst->time = time;
    return NULL;
}

const char *mw_event_update(MwInstance *inst, int *x_changed) {
    int changed, status;
    /* the friction modes follow the state, inputs and parameters: a joint sticks or breaks loose */
    set_args(inst, inst->x);
    status = mw_plant_settle(&inst->call, inst->x, &changed, x_changed);
    if (changed) mw_invalidate(inst);
    if (status == 0) return NULL;
    return status == MW_PLANT_EVAL ? "the model failed to update the friction modes" : "the friction modes did not settle";
}
