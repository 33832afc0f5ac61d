/*
 * One whole closed-loop run in one call (handwritten, not generated): the loop of
 * closed_loop/simulate.py around the plant's fixed-step rule (model/dynamics/c/plant_step.c,
 * on the plant's generated functions with a link-mass scale, model/plant.py) and a law's
 * generated <kind>_controller.
 *
 * The arithmetic is the Python loop's, operation for operation: the plant is advanced by
 * the same C rule on the same CasADi expression graph (with the link masses times a
 * parameter), every file is compiled with -ffp-contract=off, and the run starts as the
 * Python loop's (and an FMU's) does: start modes settled with zero torque. At t_k the
 * controller reads the joint-side q, qd (or, for a motor-side law such as the P-PI cascade,
 * the rotor angles and speeds: an elastic gear's own states, else G q and G qd) and the
 * reference row k (and its state z), its torque is held (optionally one period late)
 * while the rule advances the plant by `substeps` sub-steps, and the run stops at the
 * first period whose state is not finite. The state is the plant's whole x (nx: [q; qd]
 * for a rigid plant, [q; qd; q_m; qd_m; tau_m; xi] with drive trains, model/drive_train.py)
 * with nz friction modes. Metrics are accumulated on the fly over the samples k = 0..steps
 * (error q_ref - q, tau_m, the rotor speed); nothing is allocated per step and there is no
 * global state (re-entrant).
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "plant_step.h"

/* The work memory of one generated function. */
typedef struct {
    mw_eval_fn eval;
    const double **arg;
    double **res;
    mw_int *iw;
    double *w;
} mw_call;

static int call_init(mw_call *c, mw_eval_fn eval, mw_work_fn work, int n_in, int n_out)
{
    mw_int sz_arg = 0, sz_res = 0, sz_iw = 0, sz_w = 0;
    memset(c, 0, sizeof(*c));
    c->eval = eval;
    if (work(&sz_arg, &sz_res, &sz_iw, &sz_w) != 0) return -1;
    if (sz_arg < n_in || sz_res < n_out) return -2;
    c->arg = (const double **)calloc((size_t)sz_arg, sizeof(double *));
    c->res = (double **)calloc((size_t)sz_res, sizeof(double *));
    c->iw = (mw_int *)malloc((size_t)(sz_iw > 0 ? sz_iw : 1) * sizeof(mw_int));
    c->w = (double *)malloc((size_t)(sz_w > 0 ? sz_w : 1) * sizeof(double));
    return (c->arg && c->res && c->iw && c->w) ? 0 : -3;
}

static void call_free(mw_call *c)
{
    free(c->w);
    free(c->iw);
    free((void *)c->res);
    free((void *)c->arg);
}

enum { MW_N, MW_N_CTRL_IN, MW_N_SIGNALS, MW_STATE_INDEX, MW_DELAY, MW_SUBSTEPS, MW_STEPS, MW_NX, MW_NZ, MW_MOTOR,
       MW_N_DIMS };
enum { MW_MAX_ERROR, MW_RMS_ERROR, MW_PEAK_TAU, MW_PEAK_QD_M, MW_SAT_FRACTION, MW_N_METRICS };

/*
 * plant      the 16 addresses of the plant's generated functions (mw_plant_open of plant_step.h).
 * dims       MW_N_DIMS integers: joints n, controller inputs, controller signal inputs (4 or 5: q, qd,
 *            q_d, qd_d[, qdd_d]), index of the controller state input z (-1: none), one-period delay
 *            (0/1), RK4 sub-steps per period, periods N, plant states nx, friction modes nz, and 1 if
 *            the controller's first two signals are the rotor angles and speeds (a motor-side law).
 * ctrl_in    the controller's inputs: its parameters (gains, gear ratio, limits, model parameters) as
 *            given; the entries of the signals and of the state are ignored (set here).
 * dt         control period, s.
 * p          the plant's parameter vector, the link-mass scale last.
 * G          (n) gear ratios; tau_sat (n) torque limits counted as saturated (|tau| >= tau_sat), or NULL.
 * q_ref...   (N+1, n) references at t_k, row-major.
 * x0         (nx) start state; z0 (n) the controller state's start, or NULL (zero).
 * rotor      (n) per joint the index of its rotor among the elastic gears' states q_m, qd_m (-1: a rigid
 *            gear, rotor angle G q), or NULL (a rigid plant).
 * metrics    out, (MW_N_METRICS, n) row-major: max |e|, RMS e, max |tau_m|, max |qd_m|, saturated fraction.
 * Q, QD, TAU out, (N+1, n) each, or NULL: the samples of simulate_tracking; QDM the rotor speeds, or NULL.
 * last_k     out: the last sample reached (N, or the period after which the state was not finite).
 * fault      out: after status 2 the 1-based joint at which B(q) is singular, then the state there (1 + nx).
 * Returns 0, 1 if the run diverged, 2 if the inertia matrix became singular, -10 + k for any other
 * failure k (MW_PLANT_*) of the plant's rule (a generated function failed, the modes did not settle or
 * chattered), -3 without memory, -4 if the controller failed.
 */
int mw_closed_loop(void *const *plant, mw_eval_fn ctrl, mw_work_fn ctrl_work,
                   const long long *dims, const double *const *ctrl_in, double dt,
                   const double *p, const double *G, const double *tau_sat,
                   const double *q_ref, const double *qd_ref, const double *qdd_ref,
                   const double *x0, const double *z0, const long long *rotor,
                   double *metrics, double *Q, double *QD, double *TAU, double *QDM, long long *last_k,
                   double *fault)
{
    const int n = (int)dims[MW_N], n_ctrl_in = (int)dims[MW_N_CTRL_IN], n_sig = (int)dims[MW_N_SIGNALS];
    const int z_index = (int)dims[MW_STATE_INDEX], delay = (int)dims[MW_DELAY], motor = (int)dims[MW_MOTOR];
    const int nx = (int)dims[MW_NX], nz = (int)dims[MW_NZ];
    const long long substeps = dims[MW_SUBSTEPS], steps = dims[MW_STEPS];
    /* the elastic gears' rotor angles q_m start at 2n, their speeds qd_m ne further (model/drive_train.py) */
    int ne = 0;
    if (rotor)
        for (int i = 0; i < n; ++i)
            if (rotor[i] >= 0) ++ne;
    mw_call c = {0}; /* zeroed: call_free is safe on a call whose init never ran */
    MwPlantRun *run = mw_plant_open(nx, nz, nz, plant);
    int status = run ? 0 : -3;
    if (status == 0) status = call_init(&c, ctrl, ctrl_work, n_ctrl_in, z_index >= 0 ? 2 : 1);
    /* state, modes, then the per-joint buffers: inputs, controller state, torques, rotor angles and speeds */
    double *buf = (double *)calloc((size_t)(nx + nz + 8 * n), sizeof(double));
    if (status == 0 && !buf) status = -3;
    if (status != 0) {
        free(buf);
        call_free(&c);
        mw_plant_close(run);
        return status;
    }
    double *x = buf, *q = buf, *qd = buf + n, *m = buf + nx, *u = m + nz;
    double *z = u + n, *z_next = u + 2 * n, *tau_m = u + 3 * n, *held = u + 4 * n, *tau_new = u + 5 * n;
    double *qm = u + 6 * n, *qdm = u + 7 * n;
    double *max_e = metrics, *sum_e2 = metrics + n, *peak_tau = metrics + 2 * n;
    double *peak_qd = metrics + 3 * n, *sat = metrics + 4 * n;
    for (int i = 0; i < MW_N_METRICS * n; ++i) metrics[i] = 0.0;
    memcpy(x, x0, (size_t)nx * sizeof(double));
    if (z0) memcpy(z_next, z0, (size_t)n * sizeof(double));

    for (int j = 0; j < n_ctrl_in; ++j) c.arg[j] = ctrl_in[j];
    c.arg[0] = motor ? qm : q;
    c.arg[1] = motor ? qdm : qd;
    if (z_index >= 0) c.arg[z_index] = z;
    c.res[0] = tau_new;
    if (z_index >= 0) c.res[1] = z_next;

    int rule = mw_plant_run_start(run, x, m, u, p); /* u is zero: the torque an FMU holds at its start */
    long long k = 0;
    for (k = 0; k <= steps && rule == MW_PLANT_OK; ++k) {
        const double *qr = q_ref + k * n;
        for (int i = 0; i < n; ++i) { /* as DriveLayout.motor_state */
            const long long r = rotor ? rotor[i] : -1;
            qm[i] = r >= 0 ? x[2 * n + r] : G[i] * q[i];
            qdm[i] = r >= 0 ? x[2 * n + ne + r] : G[i] * qd[i];
        }
        c.arg[2] = qr;
        c.arg[3] = qd_ref + k * n;
        if (n_sig > 4) c.arg[4] = qdd_ref + k * n;
        if (z_index >= 0) memcpy(z, z_next, (size_t)n * sizeof(double));
        if (c.eval(c.arg, c.res, c.iw, c.w, 0) != 0) { status = -4; break; }
        if (delay && k > 0) {
            memcpy(tau_m, held, (size_t)n * sizeof(double));
        } else {
            memcpy(tau_m, tau_new, (size_t)n * sizeof(double));
        }
        if (delay) memcpy(held, tau_new, (size_t)n * sizeof(double));
        for (int i = 0; i < n; ++i) {
            const double e = qr[i] - q[i], ae = fabs(e), at = fabs(tau_m[i]), av = fabs(qdm[i]);
            if (ae > max_e[i]) max_e[i] = ae;
            sum_e2[i] += e * e;
            if (at > peak_tau[i]) peak_tau[i] = at;
            if (av > peak_qd[i]) peak_qd[i] = av;
            if (tau_sat && at >= tau_sat[i]) sat[i] += 1.0;
        }
        if (Q) {
            memcpy(Q + k * n, q, (size_t)n * sizeof(double));
            memcpy(QD + k * n, qd, (size_t)n * sizeof(double));
            memcpy(TAU + k * n, tau_m, (size_t)n * sizeof(double));
        }
        if (QDM) memcpy(QDM + k * n, qdm, (size_t)n * sizeof(double));
        if (k == steps) break;
        memcpy(u, tau_m, (size_t)n * sizeof(double));
        rule = mw_plant_run_advance(run, x, m, u, p, dt, substeps);
        if (rule == MW_PLANT_NONFINITE) { status = 1; ++k; break; }
    }
    if (status == 0 && rule == MW_PLANT_SINGULAR) {
        fault[0] = (double)mw_plant_run_fault(run, fault + 1);
        status = 2;
    } else if (status == 0 && rule != MW_PLANT_OK) {
        status = -10 + rule;
    }
    if (status >= 0) {
        const double samples = (double)(k > steps ? steps + 1 : k + (status == 1 ? 0 : 1));
        for (int i = 0; i < n; ++i) {
            sum_e2[i] = sqrt(sum_e2[i] / samples);
            sat[i] = sat[i] / samples;
        }
    }
    *last_k = k > steps ? steps : k;
    free(buf);
    call_free(&c);
    mw_plant_close(run);
    return status;
}
