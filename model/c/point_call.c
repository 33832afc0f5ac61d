/*
 * Single-point calls of generated functions from Python, with the argument checks done here (handwritten).
 *
 * A PointCall wraps one CasADi-generated function of a loaded library (its evaluation and work-size
 * entry points, as mw_batch takes them) with its work vectors, allocated once. Called with the joint
 * arguments (each a 1-D float64 array or a list/tuple of n numbers), it copies them into its buffers,
 * appends the fixed inputs it was made with (e.g. the parameter vector, kept referenced), evaluates into
 * a fresh NumPy array ((n,) or a Fortran-ordered (rows, cols) matrix, the layout of the generated code)
 * and returns it.
 *
 * It returns None instead, having changed nothing, whenever the general path must decide: an argument
 * of another type, shape or dtype, a non-finite argument, or a non-finite output. The caller then takes
 * its checked path, which raises the usual error or returns the same numbers. The GIL is held throughout,
 * so calls of one PointCall never overlap.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

typedef long long mw_int;
typedef int (*mw_eval_fn)(const double **arg, double **res, mw_int *iw, double *w, int mem);
typedef int (*mw_work_fn)(mw_int *sz_arg, mw_int *sz_res, mw_int *sz_iw, mw_int *sz_w);

#define MW_MAX_ARGS 8

typedef struct {
    PyObject_HEAD
    vectorcallfunc vectorcall;
    mw_eval_fn eval;
    int n_args;             /* joint arguments given per call */
    Py_ssize_t n;           /* their length */
    int n_fixed;            /* inputs after them, fixed at construction */
    npy_intp rows, cols;    /* output shape; cols 0: a vector of rows */
    const double **arg;
    double **res;
    mw_int *iw;
    double *w;
    double *buffer;         /* n_args * n joint values */
    PyObject *keep;         /* the fixed arrays and the library: alive as long as this object */
} PointCall;

static int read_vector(PyObject *obj, Py_ssize_t n, double *out)
{
    if (PyArray_Check(obj)) {
        PyArrayObject *a = (PyArrayObject *)obj;
        if (PyArray_TYPE(a) != NPY_DOUBLE || PyArray_NDIM(a) != 1 || PyArray_DIM(a, 0) != n ||
            !PyArray_ISNOTSWAPPED(a) || !PyArray_ISALIGNED(a))
            return 0;
        const char *data = (const char *)PyArray_DATA(a);
        npy_intp stride = PyArray_STRIDE(a, 0);
        for (Py_ssize_t i = 0; i < n; ++i) out[i] = *(const double *)(data + i * stride);
    } else if (PyList_CheckExact(obj) || PyTuple_CheckExact(obj)) {
        if (PySequence_Fast_GET_SIZE(obj) != n) return 0;
        PyObject **items = PySequence_Fast_ITEMS(obj);
        for (Py_ssize_t i = 0; i < n; ++i) {
            PyObject *item = items[i];
            if (PyFloat_CheckExact(item)) {
                out[i] = PyFloat_AS_DOUBLE(item);
            } else if (PyLong_CheckExact(item)) {
                out[i] = PyLong_AsDouble(item);
                if (out[i] == -1.0 && PyErr_Occurred()) {
                    PyErr_Clear();
                    return 0;
                }
            } else {
                return 0;
            }
        }
    } else {
        return 0;
    }
    for (Py_ssize_t i = 0; i < n; ++i)
        if (!isfinite(out[i])) return 0;
    return 1;
}

static PyObject *point_call_vectorcall(PyObject *callable, PyObject *const *args, size_t nargsf, PyObject *kwnames)
{
    PointCall *self = (PointCall *)callable;
    Py_ssize_t nargs = PyVectorcall_NARGS(nargsf);
    if (kwnames != NULL || nargs != self->n_args) Py_RETURN_NONE;
    for (int j = 0; j < self->n_args; ++j)
        if (!read_vector(args[j], self->n, self->buffer + j * self->n)) Py_RETURN_NONE;
    PyArrayObject *out;
    npy_intp size;
    if (self->cols == 0) {
        out = (PyArrayObject *)PyArray_SimpleNew(1, &self->rows, NPY_DOUBLE);
        size = self->rows;
    } else {
        npy_intp dims[2] = {self->rows, self->cols};
        out = (PyArrayObject *)PyArray_EMPTY(2, dims, NPY_DOUBLE, 1);  /* Fortran order: column-major */
        size = self->rows * self->cols;
    }
    if (out == NULL) return NULL;
    double *data = (double *)PyArray_DATA(out);
    self->res[0] = data;
    if (self->eval(self->arg, self->res, self->iw, self->w, 0) != 0) {
        Py_DECREF(out);
        Py_RETURN_NONE;
    }
    for (npy_intp i = 0; i < size; ++i) {
        if (!isfinite(data[i])) {
            Py_DECREF(out);
            Py_RETURN_NONE;
        }
    }
    return (PyObject *)out;
}

static void point_call_dealloc(PointCall *self)
{
    PyMem_Free(self->arg);
    PyMem_Free(self->res);
    PyMem_Free(self->iw);
    PyMem_Free(self->w);
    PyMem_Free(self->buffer);
    Py_XDECREF(self->keep);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static PyTypeObject PointCallType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "_mw_point_call.PointCall",
    .tp_basicsize = sizeof(PointCall),
    .tp_dealloc = (destructor)point_call_dealloc,
    .tp_vectorcall_offset = offsetof(PointCall, vectorcall),
    .tp_call = PyVectorcall_Call,
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_VECTORCALL,
    .tp_doc = "One generated function called at one point: f(*joint_vectors) -> array or None.",
};

/* make(eval_address, work_address, n_args, n, fixed, rows, cols, keep) -> PointCall */
static PyObject *make(PyObject *module, PyObject *args)
{
    unsigned long long eval_address, work_address;
    int n_args;
    Py_ssize_t n, rows, cols;
    PyObject *fixed, *keep;
    (void)module;
    if (!PyArg_ParseTuple(args, "KKinO!nnO", &eval_address, &work_address, &n_args, &n, &PyTuple_Type, &fixed,
                          &rows, &cols, &keep))
        return NULL;
    int n_fixed = (int)PyTuple_GET_SIZE(fixed);
    if (n_args < 1 || n_args + n_fixed > MW_MAX_ARGS || n < 1 || rows < 1 || cols < 0) {
        PyErr_SetString(PyExc_ValueError, "make: bad sizes");
        return NULL;
    }
    for (int j = 0; j < n_fixed; ++j) {
        PyObject *a = PyTuple_GET_ITEM(fixed, j);
        if (!PyArray_Check(a) || PyArray_TYPE((PyArrayObject *)a) != NPY_DOUBLE ||
            !PyArray_IS_C_CONTIGUOUS((PyArrayObject *)a) || !PyArray_ISALIGNED((PyArrayObject *)a)) {
            PyErr_SetString(PyExc_ValueError, "make: a fixed input must be a contiguous float64 array");
            return NULL;
        }
    }
    mw_work_fn work = (mw_work_fn)(uintptr_t)work_address;
    mw_int sz_arg = 0, sz_res = 0, sz_iw = 0, sz_w = 0;
    if (work(&sz_arg, &sz_res, &sz_iw, &sz_w) != 0 || sz_arg < n_args + n_fixed || sz_res < 1) {
        PyErr_SetString(PyExc_ValueError, "make: the work-size query failed or is smaller than the signature");
        return NULL;
    }
    PointCall *self = PyObject_New(PointCall, &PointCallType);
    if (self == NULL) return NULL;
    self->vectorcall = point_call_vectorcall;
    self->eval = (mw_eval_fn)(uintptr_t)eval_address;
    self->n_args = n_args;
    self->n = n;
    self->n_fixed = n_fixed;
    self->rows = rows;
    self->cols = cols;
    self->arg = PyMem_Calloc((size_t)sz_arg, sizeof(double *));
    self->res = PyMem_Calloc((size_t)sz_res, sizeof(double *));
    self->iw = PyMem_Calloc((size_t)(sz_iw > 0 ? sz_iw : 1), sizeof(mw_int));
    self->w = PyMem_Calloc((size_t)(sz_w > 0 ? sz_w : 1), sizeof(double));
    self->buffer = PyMem_Calloc((size_t)(n_args * n), sizeof(double));
    self->keep = Py_BuildValue("(OO)", fixed, keep);
    if (!self->arg || !self->res || !self->iw || !self->w || !self->buffer || !self->keep) {
        Py_DECREF(self);
        return PyErr_NoMemory();
    }
    for (int j = 0; j < n_args; ++j) self->arg[j] = self->buffer + j * n;
    for (int j = 0; j < n_fixed; ++j)
        self->arg[n_args + j] = (const double *)PyArray_DATA((PyArrayObject *)PyTuple_GET_ITEM(fixed, j));
    return (PyObject *)self;
}

static PyMethodDef methods[] = {
    {"make", make, METH_VARARGS,
     "make(eval_address, work_address, n_args, n, fixed, rows, cols, keep) -> PointCall"},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module_def = {
    PyModuleDef_HEAD_INIT, .m_name = "_mw_point_call", .m_doc = NULL, .m_size = -1, .m_methods = methods,
};

PyMODINIT_FUNC PyInit__mw_point_call(void)
{
    import_array();
    if (PyType_Ready(&PointCallType) < 0) return NULL;
    PyObject *module = PyModule_Create(&module_def);
    if (module == NULL) return NULL;
    Py_INCREF(&PointCallType);
    if (PyModule_AddObject(module, "PointCall", (PyObject *)&PointCallType) < 0) {
        Py_DECREF(&PointCallType);
        Py_DECREF(module);
        return NULL;
    }
    return module;
}
