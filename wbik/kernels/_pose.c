/* Compiled twins of the interface's per-call pose arithmetic (the Python module wbik.kernels._pose):
 *
 * - plain_se3: the plain-float test of wbik.targets._python_accepts_plain_se3 (is a 4x4 homogeneous
 *   matrix a pose as_target accepts on its fast path: position within the bound, unit and orthogonal
 *   rotation columns, det +1, all within the tolerance?);
 * - error_parts: the arithmetic of the shared FK check (wbik.geometry._python_error_parts): the position
 *   error p - p*, its norm, and R*^T R, whose log3 Pinocchio then takes.
 *
 * The same products and sums in the same order as the Python twins (built with -ffp-contract=off), so
 * both give the same bits; tests/test_compiled.py compares them. wbik.kernels switches between them.
 */
#include "_buffers.h"
#include <math.h>

/* error_parts(reached, position, rotation, position_error, relative) -> float
 * reached: the reached pose's 4x4 homogeneous matrix; position (3,) and rotation (3, 3) or None: the
 * target. Writes p - p* into position_error (3,) and, for a rotation, R*^T R into relative (3, 3)
 * (sum over k of R*_ki R_kj, k in order); returns |p - p*| = sqrt(x^2 + y^2 + z^2). */
static PyObject *error_parts(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (check_count("error_parts", nargs, 5) < 0)
        return NULL;
    double reached[16], position[3], error[3];
    if (read_doubles(args[0], reached, 4, 4, "reached") < 0 || read_doubles(args[1], position, 3, 0, "position") < 0)
        return NULL;
    for (int i = 0; i < 3; i++)
        error[i] = reached[4 * i + 3] - position[i];
    if (write_doubles(args[3], error, 3, "position_error") < 0)
        return NULL;
    if (args[2] != Py_None) {
        double target[9], relative[9];
        if (read_doubles(args[2], target, 3, 3, "rotation") < 0)
            return NULL;
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                relative[3 * i + j] = target[i] * reached[j] + target[3 + i] * reached[4 + j]
                                      + target[6 + i] * reached[8 + j];
        if (write_doubles(args[4], relative, 9, "relative") < 0)
            return NULL;
    }
    return PyFloat_FromDouble(sqrt(error[0] * error[0] + error[1] * error[1] + error[2] * error[2]));
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
    {"error_parts", (PyCFunction)(void (*)(void))error_parts, METH_FASTCALL,
     "error_parts(reached, position, rotation, position_error, relative) -> |p - p*|: the shared check's "
     "arithmetic"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_pose",
                                    "Compiled twins of the interface's pose arithmetic (wbik.kernels).", -1,
                                    methods};

PyMODINIT_FUNC PyInit__pose(void) { return PyModule_Create(&module); }
