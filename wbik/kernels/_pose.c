/* Compiled twins of the interface's per-call pose arithmetic (the Python module wbik.kernels._pose):
 *
 * - plain_se3: the plain-float test of wbik.targets._python_accepts_plain_se3 (is a 4x4 homogeneous
 *   matrix a pose as_target accepts on its fast path: position within the bound, unit and orthogonal
 *   rotation columns, det +1, all within the tolerance?);
 * - pose_errors: the errors of the shared FK check (wbik.geometry._python_pose_errors): p - p*, log3(R*^T R)
 *   in the batched check's formula (_pose_errors.h), and both norms;
 * - inside_limits and plain_finite: the tests of the shared check's and the start joints' fast paths
 *   (wbik.solvers.check._python_inside_limits, wbik.robot._python_plain_finite).
 *
 * The same products and sums in the same order as the Python twins (built with -ffp-contract=off), so
 * both give the same bits; tests/test_compiled.py compares them. wbik.kernels switches between them.
 */
#include "_buffers.h"
#include "_pose_errors.h"
#include "_checked_errors.h"
#include <math.h>
#include <string.h>

/* pose_errors(reached, position, rotation, position_error, rotation_error, base_inverse) -> (|e_p|, |e_R|, exact)
 * reached: the reached pose's 4x4 homogeneous matrix; the rest as _checked_errors.h says. */
static PyObject *pose_errors_of(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (check_count("pose_errors", nargs, 6) < 0)
        return NULL;
    double reached[16];
    if (read_doubles(args[0], reached, 4, 4, "reached") < 0)
        return NULL;
    return checked_errors_tuple(reached, args[1], args[2], args[3], args[4], args[5]);
}

static PyObject *ndarray_type; /* numpy.ndarray, read when the module is imported */

/* A numpy.ndarray itself (no subclass, no other buffer) of `count` float64 values along one axis, else 0
 * (and no error set): the fast paths' test, as their Python twins' `type(q) is np.ndarray`. */
static int plain_vector(PyObject *object, Py_buffer *view, Py_ssize_t count)
{
    if ((PyObject *)Py_TYPE(object) != ndarray_type)
        return 0;
    if (float64_view(object, view, 0, "") < 0) {
        PyErr_Clear();
        return 0;
    }
    if (view->ndim == 1 && view->shape[0] == count)
        return 1;
    PyBuffer_Release(view);
    return 0;
}

/* inside_limits(q, lower, upper) -> bool: q a numpy float64 (n,) array of finite values with lower <= q <= upper
 * (lower and upper: the same); False for anything else, which the general path then judges. */
static PyObject *inside_limits(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (check_count("inside_limits", nargs, 3) < 0)
        return NULL;
    Py_buffer views[3];
    Py_ssize_t n = PyObject_Length(args[1]);
    if (n < 0)
        return NULL;
    int held = 0, inside = 1;
    for (; held < 3 && inside; held++)
        inside = plain_vector(args[held], &views[held], n);
    if (!inside)
        held--; /* the failed view was not kept */
    for (Py_ssize_t i = 0; inside && i < n; i++) {
        const double value = *(const double *)((const char *)views[0].buf + i * views[0].strides[0]);
        const double low = *(const double *)((const char *)views[1].buf + i * views[1].strides[0]);
        const double high = *(const double *)((const char *)views[2].buf + i * views[2].strides[0]);
        inside = isfinite(value) && low <= value && value <= high;
    }
    release_views(views, held);
    return PyBool_FromLong(inside);
}

/* plain_finite(q, n) -> bool: q a numpy float64 (n,) array of finite values. */
static PyObject *plain_finite(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (check_count("plain_finite", nargs, 2) < 0)
        return NULL;
    Py_ssize_t n = PyLong_AsSsize_t(args[1]);
    if (n == -1 && PyErr_Occurred())
        return NULL;
    Py_buffer view;
    if (!plain_vector(args[0], &view, n))
        Py_RETURN_FALSE;
    int finite = 1;
    for (Py_ssize_t i = 0; finite && i < n; i++)
        finite = isfinite(*(const double *)((const char *)view.buf + i * view.strides[0]));
    PyBuffer_Release(&view);
    return PyBool_FromLong(finite);
}

/* plain_se3(matrix, bound, tolerance) -> bool, for a float64 buffer of shape (4, 4) (any strides). */
static PyObject *plain_se3(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    double bound, tolerance, m[16];
    if (check_count("plain_se3", nargs, 3) < 0 || read_float(args[1], &bound, "bound") < 0
        || read_float(args[2], &tolerance, "tolerance") < 0 || read_doubles(args[0], m, 4, 4, "matrix") < 0)
        return NULL;
    const double a = m[0], b = m[1], c = m[2], x = m[3];
    const double d = m[4], e = m[5], f = m[6], y = m[7];
    const double g = m[8], h = m[9], i = m[10], z = m[11];
    /* NaN fails every comparison, as in Python */
    if (!(-bound <= x && x <= bound && -bound <= y && y <= bound && -bound <= z && z <= bound))
        Py_RETURN_FALSE;
    const double low = 1.0 - tolerance, high = 1.0 + tolerance;
    double unit0 = a * a + d * d + g * g, unit1 = b * b + e * e + h * h, unit2 = c * c + f * f + i * i;
    double across01 = a * b + d * e + g * h, across02 = a * c + d * f + g * i, across12 = b * c + e * f + h * i;
    double determinant = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g);
    if (low <= unit0 && unit0 <= high && low <= unit1 && unit1 <= high && low <= unit2 && unit2 <= high
        && -tolerance <= across01 && across01 <= tolerance && -tolerance <= across02 && across02 <= tolerance
        && -tolerance <= across12 && across12 <= tolerance && low <= determinant && determinant <= high)
        Py_RETURN_TRUE;
    Py_RETURN_FALSE;
}

static PyMethodDef methods[] = {
    {"plain_se3", (PyCFunction)(void (*)(void))plain_se3, METH_FASTCALL,
     "plain_se3(matrix, bound, tolerance) -> bool: the fast-path test of wbik.targets.as_target"},
    {"pose_errors", (PyCFunction)(void (*)(void))pose_errors_of, METH_FASTCALL,
     "pose_errors(reached, position, rotation, position_error, rotation_error, base_inverse) -> (|e_p|, |e_R|, "
     "exact): the shared check's errors"},
    {"inside_limits", (PyCFunction)(void (*)(void))inside_limits, METH_FASTCALL,
     "inside_limits(q, lower, upper) -> bool: finite float64 joints within their limits"},
    {"plain_finite", (PyCFunction)(void (*)(void))plain_finite, METH_FASTCALL,
     "plain_finite(q, n) -> bool: a float64 (n,) array of finite values"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_pose",
                                    "Compiled twins of the interface's pose arithmetic (wbik.kernels).", -1,
                                    methods};

PyMODINIT_FUNC PyInit__pose(void)
{
    PyObject *numpy = PyImport_ImportModule("numpy");
    if (numpy == NULL)
        return NULL;
    ndarray_type = PyObject_GetAttrString(numpy, "ndarray"); /* kept for the module's life */
    Py_DECREF(numpy);
    if (ndarray_type == NULL)
        return NULL;
    return PyModule_Create(&module);
}
