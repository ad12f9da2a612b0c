/* Compiled twin of the plain-float test in wbik.targets._plain_se3_target: is a 4x4 homogeneous matrix
 * a pose as_target accepts on its fast path (position within the bound, unit and orthogonal rotation
 * columns, det +1, all within the tolerance)?
 *
 * The same products and sums in the same order as the Python test (built with -ffp-contract=off), so
 * both give the same verdict on every matrix; tests/test_se3_check.py compares them. The Python module
 * is wbik._se3_check; wbik.targets falls back on the Python test when it is not built.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

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
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_se3_check",
                                    "Compiled fast-path test of a homogeneous pose (see wbik.targets).", -1,
                                    methods};

PyMODINIT_FUNC PyInit__se3_check(void) { return PyModule_Create(&module); }
