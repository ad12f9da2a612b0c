/* Compiled twin of one Levenberg-Marquardt trial (the Python module wbik.kernels._lm_trial): the policy's
 * LevenbergMarquardt.trial, computed by _lm_trial.h (which says how, and how it agrees with the twin). */
#include "_buffers.h"
#include "_lm_trial.h"

/* lm_trial(jacobian, error, damping, q, lower, upper, wraps, max_step, out) -> bool
 * jacobian (m, n), error (m,), q, lower, upper (n,): float64, any strides; wraps: (n,) float64 of 1.0 for a
 * full-turn joint and 0.0 otherwise, or None (no joint wraps); damping: lambda = w |e|^2 + mu; max_step:
 * the cap, < 0 for none; out (n,): writable C-contiguous, the trial inside the limits. False (out
 * unspecified) when Cholesky fails or the problem is larger than MAX_SIZE. */
static PyObject *lm_trial(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (check_count("lm_trial", nargs, 9) < 0)
        return NULL;
    double damping, max_step;
    if (read_float(args[2], &damping, "damping") < 0 || read_float(args[7], &max_step, "max_step") < 0)
        return NULL;
    Py_buffer jacobian_view;
    if (float64_view(args[0], &jacobian_view, 0, "jacobian") < 0)
        return NULL;
    const int two_d = jacobian_view.ndim == 2;
    const Py_ssize_t m = two_d ? jacobian_view.shape[0] : 0, n = two_d ? jacobian_view.shape[1] : 0;
    PyBuffer_Release(&jacobian_view);
    if (!two_d) {
        PyErr_SetString(PyExc_TypeError, "jacobian: expected an (m, n) float64 array");
        return NULL;
    }
    if (m < 1 || n < 1 || m > MAX_SIZE || n > MAX_SIZE)
        Py_RETURN_FALSE;
    double J[MAX_SIZE * MAX_SIZE], e[MAX_SIZE], q[MAX_SIZE], lower[MAX_SIZE], upper[MAX_SIZE],
        wraps[MAX_SIZE];
    if (read_doubles(args[0], J, m, n, "jacobian") < 0 || read_doubles(args[1], e, m, 0, "error") < 0
        || read_doubles(args[3], q, n, 0, "q") < 0 || read_doubles(args[4], lower, n, 0, "lower") < 0
        || read_doubles(args[5], upper, n, 0, "upper") < 0)
        return NULL;
    const int any_wrap = args[6] != Py_None;
    if (any_wrap && read_doubles(args[6], wraps, n, 0, "wraps") < 0)
        return NULL;
    double inside[MAX_SIZE];
    if (!bounded_trial(J, (int)m, (int)n, e, damping, q, lower, upper, any_wrap ? wraps : NULL, max_step,
                       inside))
        Py_RETURN_FALSE;
    if (write_doubles(args[8], inside, n, "out") < 0)
        return NULL;
    Py_RETURN_TRUE;
}

static PyMethodDef methods[] = {
    {"lm_trial", (PyCFunction)(void (*)(void))lm_trial, METH_FASTCALL,
     "lm_trial(jacobian, error, damping, q, lower, upper, wraps, max_step, out) -> bool: one bounded "
     "Levenberg-Marquardt trial (False: let the Python twin decide)"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_lm_trial",
                                    "Compiled twin of the Levenberg-Marquardt trial (wbik.kernels).", -1,
                                    methods};

PyMODINIT_FUNC PyInit__lm_trial(void) { return PyModule_Create(&module); }
