/* Compiled twins of the interface's per-call pose arithmetic (the Python module wbik._pose_kernel):
 *
 * - plain_se3: the plain-float test of wbik.targets._python_accepts_plain_se3 (is a 4x4 homogeneous
 *   matrix a pose as_target accepts on its fast path: position within the bound, unit and orthogonal
 *   rotation columns, det +1, all within the tolerance?);
 * - error_parts: the arithmetic of the shared FK check (wbik.geometry._python_error_parts): the position
 *   error p - p*, its norm, and R*^T R, whose log3 Pinocchio then takes.
 *
 * The same products and sums in the same order as the Python twins (built with -ffp-contract=off), so
 * both give the same bits; tests/test_compiled.py compares them. wbik.compiled switches between them.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <string.h>

/* Copy a float64 buffer of the given shape (any strides) into out, in C order; TypeError otherwise. */
static int read_matrix(PyObject *object, Py_ssize_t rows, Py_ssize_t columns, double *out, const char *what)
{
    Py_buffer view;
    if (PyObject_GetBuffer(object, &view, PyBUF_RECORDS_RO) < 0)
        return -1;
    int ok = view.itemsize == 8 && view.format != NULL && strcmp(view.format, "d") == 0
             && ((columns == 0 && view.ndim == 1 && view.shape[0] == rows)
                 || (columns > 0 && view.ndim == 2 && view.shape[0] == rows && view.shape[1] == columns));
    if (!ok) {
        PyBuffer_Release(&view);
        if (columns == 0)
            PyErr_Format(PyExc_TypeError, "%s: expected a (%zd,) float64 array", what, rows);
        else
            PyErr_Format(PyExc_TypeError, "%s: expected a (%zd, %zd) float64 array", what, rows, columns);
        return -1;
    }
    const char *base = (const char *)view.buf;
    if (columns == 0) {
        for (Py_ssize_t i = 0; i < rows; i++)
            memcpy(out + i, base + i * view.strides[0], sizeof(double));
    } else {
        for (Py_ssize_t i = 0; i < rows; i++)
            for (Py_ssize_t j = 0; j < columns; j++)
                memcpy(out + i * columns + j, base + i * view.strides[0] + j * view.strides[1], sizeof(double));
    }
    PyBuffer_Release(&view);
    return 0;
}

/* Write count doubles into a writable C-contiguous float64 buffer of exactly that many values. */
static int write_values(PyObject *object, const double *values, Py_ssize_t count, const char *what)
{
    Py_buffer view;
    if (PyObject_GetBuffer(object, &view, PyBUF_WRITABLE | PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0)
        return -1;
    if (view.itemsize != 8 || view.len != count * 8 || view.format == NULL || strcmp(view.format, "d") != 0) {
        PyBuffer_Release(&view);
        PyErr_Format(PyExc_TypeError, "%s: expected a writable contiguous float64 array of %zd values", what,
                     count);
        return -1;
    }
    memcpy(view.buf, values, count * sizeof(double));
    PyBuffer_Release(&view);
    return 0;
}

/* error_parts(reached, position, rotation, position_error, relative) -> float
 * reached: the reached pose's 4x4 homogeneous matrix; position (3,) and rotation (3, 3) or None: the
 * target. Writes p - p* into position_error (3,) and, for a rotation, R*^T R into relative (3, 3)
 * (sum over k of R*_ki R_kj, k in order); returns |p - p*| = sqrt(x^2 + y^2 + z^2). */
static PyObject *error_parts(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 5) {
        PyErr_Format(PyExc_TypeError, "error_parts expects 5 arguments, got %zd", nargs);
        return NULL;
    }
    double reached[16], position[3], error[3];
    if (read_matrix(args[0], 4, 4, reached, "reached") < 0 || read_matrix(args[1], 3, 0, position, "position") < 0)
        return NULL;
    for (int i = 0; i < 3; i++)
        error[i] = reached[4 * i + 3] - position[i];
    if (write_values(args[3], error, 3, "position_error") < 0)
        return NULL;
    if (args[2] != Py_None) {
        double target[9], relative[9];
        if (read_matrix(args[2], 3, 3, target, "rotation") < 0)
            return NULL;
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                relative[3 * i + j] = target[i] * reached[j] + target[3 + i] * reached[4 + j]
                                      + target[6 + i] * reached[8 + j];
        if (write_values(args[4], relative, 9, "relative") < 0)
            return NULL;
    }
    return PyFloat_FromDouble(sqrt(error[0] * error[0] + error[1] * error[1] + error[2] * error[2]));
}

/* plain_se3(matrix, bound, tolerance) -> bool, for a float64 buffer of shape (4, 4) (any strides). */
static PyObject *plain_se3(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 3) {
        PyErr_Format(PyExc_TypeError, "plain_se3 expects 3 arguments, got %zd", nargs);
        return NULL;
    }
    double bound = PyFloat_AsDouble(args[1]), tolerance = PyFloat_AsDouble(args[2]);
    if (PyErr_Occurred())
        return NULL;
    Py_buffer view;
    if (PyObject_GetBuffer(args[0], &view, PyBUF_RECORDS_RO) < 0)
        return NULL;
    if (view.ndim != 2 || view.shape[0] != 4 || view.shape[1] != 4 || view.itemsize != 8 || view.format == NULL
        || strcmp(view.format, "d") != 0) {
        PyBuffer_Release(&view);
        PyErr_SetString(PyExc_TypeError, "plain_se3: expected a (4, 4) float64 array");
        return NULL;
    }
    double m[12];
    const char *base = (const char *)view.buf;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 4; j++)
            memcpy(m + 4 * i + j, base + i * view.strides[0] + j * view.strides[1], sizeof(double));
    PyBuffer_Release(&view);
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
    {"error_parts", (PyCFunction)(void (*)(void))error_parts, METH_FASTCALL,
     "error_parts(reached, position, rotation, position_error, relative) -> |p - p*|: the shared check's "
     "arithmetic"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_pose_kernel",
                                    "Compiled twins of the interface's pose arithmetic (wbik.compiled).", -1,
                                    methods};

PyMODINIT_FUNC PyInit__pose_kernel(void) { return PyModule_Create(&module); }
