/*
 * Batch evaluation of CasADi-generated functions (handwritten, not generated).
 *
 * mw_batch() evaluates one generated function at N points in a single call:
 * input j of point k is read from in[j] + k * in_stride[j] (a stride of 0
 * broadcasts the same vector, e.g. the parameter vector p), output j is
 * written to out[j] + k * out_stride[j]. The work vectors are allocated once
 * per call and reused for every point; there is no global mutable state, so
 * concurrent calls from several threads are safe.
 */
#include <stdlib.h>

#include "casadi_abi.h"

typedef casadi_int mw_int;
typedef int (*mw_eval_fn)(const double **arg, double **res, mw_int *iw, double *w, int mem);
typedef int (*mw_work_fn)(mw_int *sz_arg, mw_int *sz_res, mw_int *sz_iw, mw_int *sz_w);

/* eval and work are passed as function pointers (ctypes hands over their addresses): no
   conversion between object and function pointers, which ISO C does not define. */
int mw_batch(mw_eval_fn eval, mw_work_fn work,
             int n_in, const double *const *in, const long long *in_stride,
             int n_out, double *const *out, const long long *out_stride,
             long long n_points)
{
    mw_int sz_arg = 0, sz_res = 0, sz_iw = 0, sz_w = 0;
    if (work(&sz_arg, &sz_res, &sz_iw, &sz_w) != 0) return -1;
    if (sz_arg < n_in || sz_res < n_out) return -2;

    const double **arg = (const double **)calloc((size_t)sz_arg, sizeof(double *));
    double **res = (double **)calloc((size_t)sz_res, sizeof(double *));
    mw_int *iw = (mw_int *)malloc((size_t)(sz_iw > 0 ? sz_iw : 1) * sizeof(mw_int));
    double *w = (double *)malloc((size_t)(sz_w > 0 ? sz_w : 1) * sizeof(double));
    int status = 0;
    if (!arg || !res || !iw || !w) {
        status = -3;
    } else {
        for (long long k = 0; k < n_points && status == 0; ++k) {
            for (int j = 0; j < n_in; ++j) arg[j] = in[j] + k * in_stride[j];
            for (int j = 0; j < n_out; ++j) res[j] = out[j] + k * out_stride[j];
            if (eval(arg, res, iw, w, 0) != 0) status = -4;
        }
    }
    free(w);
    free(iw);
    free(res);
    free(arg);
    return status;
}
