/* Compiled twin of the eaik method's per-call choice (wbik.solvers.analytic.eaik_kernel: order_python,
 * screen_python): which of EAIK's branches to screen, in which order, wrapped into the limits, and the
 * FK screen's arithmetic on a tip placement Pinocchio computed. No FK here: the caller runs the chain's
 * FK (Pinocchio) on the rows this kernel writes.
 *
 * Every expression is the Python twin's, operation by operation and in the same order, so both return
 * the same bits: IEEE arithmetic is exact-rounded, acos is the libm one CPython's math module calls,
 * rint rounds half to even as Python's round() in the default rounding mode, the build turns off FMA
 * contraction (-ffp-contract=off), and the twin's sums are plain left-to-right additions.
 * tests/test_eaik_kernel.py compares both bit for bit.
 *
 * The Python module is wbik.solvers.analytic._eaik_kernel.
 */
#include "../../_kernel_buffers.h"
#include <math.h>

#define TWO_PI (2.0 * 3.141592653589793)
#define INVERSE_TURN (1.0 / TWO_PI)
#define TURN_SQUARED (TWO_PI * TWO_PI)
/* Python's max(a, b) and min(a, b) of two floats: the first unless the second compares larger (smaller). */
#define PY_MAX(a, b) ((b) > (a) ? (b) : (a))
#define PY_MIN(a, b) ((b) < (a) ? (b) : (a))

#define MAX_JOINTS 6
#define MAX_BRANCHES 64

/* The parameters of wbik.solvers.analytic.eaik_kernel.parameters, float64 values packed in a bytes
 * object (read without the buffer protocol's cost): the slack of the bounds (n BOUND_SLACK),
 * LIMIT_TOLERANCE, then lower (n) and upper (n). */
enum { P_SLACK, P_LIMIT_TOLERANCE, P_LOWER };

static const double SHIFTS[5] = {0.0, TWO_PI, -TWO_PI, 2 * TWO_PI, -2 * TWO_PI};

/* eaik_kernel.wrapped_python: raw wrapped into the limits nearest ref, its squared distance into
 * *distance; 0 when some joint has no 2 pi shift inside its limits. */
static int wrap(const double *raw, const double *ref, const double *lower, const double *upper,
                double tolerance, int joints, double *out, double *distance)
{
    double total = 0.0;
    for (int i = 0; i < joints; i++) {
        double value = raw[i], low = lower[i], high = upper[i];
        double low_tolerant = low - tolerance, high_tolerant = high + tolerance;
        double turns = rint((ref[i] - value) / TWO_PI);
        double shifted = value + turns * TWO_PI;
        if (low_tolerant <= shifted && shifted <= high_tolerant && -2.0 <= turns && turns <= 2.0) {
            if (shifted > high)
                shifted = high;
            else if (shifted < low)
                shifted = low;
        } else {
            int found = 0;
            double best = 0.0, best_distance = INFINITY;
            for (int s = 0; s < 5; s++) {
                double candidate = value + SHIFTS[s];
                if (low_tolerant <= candidate && candidate <= high_tolerant
                    && fabs(candidate - ref[i]) < best_distance) {
                    best = candidate;
                    best_distance = fabs(candidate - ref[i]);
                    found = 1;
                }
            }
            if (!found)
                return 0;
            shifted = PY_MIN(high, PY_MAX(low, best));
        }
        out[i] = shifted;
        double difference = shifted - ref[i];
        total += difference * difference;
    }
    *distance = total;
    return 1;
}

/* order(params, branches, reference, out) -> int
 * branches (K, n) as EAIK returns them, reference (n,). Writes into out (at least K * n values, C order)
 * the branches to screen, wrapped into the limits, in the order the choice screens them, and returns
 * how many: the branches are taken in the order of their bounds (sum_i (2 pi)^2 (t_i - rint(t_i))^2,
 * t = (q - r) / 2 pi, +inf where a joint is not finite; stable), each wrapped; before a branch is
 * taken, every wrapped one whose squared distance is at most its bound less the slack comes out,
 * nearest first (ties: the first in the bounds' order). */
static PyObject *order(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (check_count("order", nargs, 4) < 0)
        return NULL;
    Py_buffer views[4];
    int held = 1;
    PyObject *result = NULL;
    if (!PyBytes_CheckExact(args[0])) {
        PyErr_SetString(PyExc_TypeError, "params: expected bytes (eaik_kernel.parameters)");
        return NULL;
    }
    if (float64_view(args[1], &views[1], 0, "branches") < 0)
        goto done;
    held = 2;
    if (float64_view(args[2], &views[2], 0, "reference") < 0)
        goto done;
    held = 3;
    if (float64_view(args[3], &views[3], 1, "out") < 0)
        goto done;
    held = 4;
    Py_buffer *branches = &views[1], *reference = &views[2], *out_view = &views[3];
    if (reference->ndim != 1 || reference->shape[0] < 1 || reference->shape[0] > MAX_JOINTS) {
        PyErr_SetString(PyExc_TypeError, "reference: expected a (n,) float64 array, 1 <= n <= 6");
        goto done;
    }
    int joints = (int)reference->shape[0];
    if (branches->ndim != 2 || branches->shape[1] != joints || branches->shape[0] > MAX_BRANCHES) {
        PyErr_Format(PyExc_TypeError, "branches: expected a (K, %d) float64 array, K <= %d", joints,
                     MAX_BRANCHES);
        goto done;
    }
    int count = (int)branches->shape[0];
    if (PyBytes_GET_SIZE(args[0]) != (Py_ssize_t)((P_LOWER + 2 * joints) * sizeof(double))) {
        PyErr_Format(PyExc_TypeError, "params: expected %d float64 values", P_LOWER + 2 * joints);
        goto done;
    }
    if (out_view->len < (Py_ssize_t)(count * joints * sizeof(double))) {
        PyErr_Format(PyExc_TypeError, "out: expected at least %d float64 values", count * joints);
        goto done;
    }
    double params[P_LOWER + 2 * MAX_JOINTS], ref[MAX_JOINTS], q[MAX_BRANCHES][MAX_JOINTS];
    memcpy(params, PyBytes_AS_STRING(args[0]), (P_LOWER + 2 * joints) * sizeof(double));
    for (int j = 0; j < joints; j++)
        ref[j] = *(const double *)((const char *)reference->buf + j * reference->strides[0]);
    for (int k = 0; k < count; k++)
        for (int j = 0; j < joints; j++)
            q[k][j] = *(const double *)((const char *)branches->buf + k * branches->strides[0]
                                        + j * branches->strides[1]);
    const double slack = params[P_SLACK], tolerance = params[P_LIMIT_TOLERANCE];
    const double *lower = params + P_LOWER, *upper = params + P_LOWER + joints;
    double *out = (double *)out_view->buf;

    double bounds[MAX_BRANCHES];
    int ranked[MAX_BRANCHES];
    for (int k = 0; k < count; k++) {
        double total = 0.0;
        for (int j = 0; j < joints; j++) {
            double turns = (q[k][j] - ref[j]) * INVERSE_TURN;
            turns = turns - rint(turns);
            total += turns * turns * TURN_SQUARED;
        }
        bounds[k] = total < INFINITY ? total : INFINITY; /* NaN (a joint not finite): +inf */
    }
    /* a stable sort of the branches by bound */
    for (int k = 0; k < count; k++)
        ranked[k] = k;
    for (int k = 1; k < count; k++) {
        int index = ranked[k], at = k;
        while (at > 0 && bounds[ranked[at - 1]] > bounds[index]) {
            ranked[at] = ranked[at - 1];
            at--;
        }
        ranked[at] = index;
    }

    double pending_distance[MAX_BRANCHES], pending_q[MAX_BRANCHES][MAX_JOINTS];
    int pending_rank[MAX_BRANCHES], waiting = 0, written = 0;
    for (int rank = 0; rank <= count; rank++) {
        double bound = rank < count ? bounds[ranked[rank]] : INFINITY;
        /* every pending branch at most bound - slack away comes out, nearest (then lowest rank) first;
         * after the last branch (or at an infinite bound) all of them */
        int last = rank == count || !(bound < INFINITY);
        while (waiting) {
            int best = 0;
            for (int p = 1; p < waiting; p++)
                if (pending_distance[p] < pending_distance[best]
                    || (pending_distance[p] == pending_distance[best] && pending_rank[p] < pending_rank[best]))
                    best = p;
            if (!last && !(pending_distance[best] <= bound - slack))
                break;
            memcpy(out + written * joints, pending_q[best], joints * sizeof(double));
            written++;
            waiting--;
            pending_distance[best] = pending_distance[waiting];
            pending_rank[best] = pending_rank[waiting];
            memcpy(pending_q[best], pending_q[waiting], joints * sizeof(double));
        }
        if (last)
            break;
        double distance;
        if (wrap(q[ranked[rank]], ref, lower, upper, tolerance, joints, pending_q[waiting], &distance)) {
            pending_distance[waiting] = distance;
            pending_rank[waiting] = rank;
            waiting++;
        }
    }
    result = PyLong_FromLong(written);
done:
    release_views(views + 1, held - 1);
    return result;
}

/* screen(reached, position, rotation, tolerance) -> bool
 * reached: the 4x4 homogeneous matrix of the tip (Pinocchio's FK); position (3,), rotation (3, 3): the
 * target. True when |p - p*| <= tolerance and acos(clip((trace(R*^T R) - 1) / 2)) <= tolerance, the
 * trace summed as sum_ij R_ij R*_ij row by row (eaik_kernel.screen_python). */
static PyObject *screen(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    double reached[16], position[3], rotation[9], tolerance;
    if (check_count("screen", nargs, 4) < 0 || read_doubles(args[0], reached, 4, 4, "reached") < 0
        || read_doubles(args[1], position, 3, 0, "position") < 0
        || read_doubles(args[2], rotation, 3, 3, "rotation") < 0 || read_float(args[3], &tolerance, "tolerance") < 0)
        return NULL;
    double dx = reached[3] - position[0], dy = reached[7] - position[1], dz = reached[11] - position[2];
    if (!(sqrt(dx * dx + dy * dy + dz * dz) <= tolerance))
        Py_RETURN_FALSE;
    double trace = 0.0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            trace += reached[4 * i + j] * rotation[3 * i + j];
    double cosine = PY_MIN(1.0, PY_MAX(-1.0, 0.5 * (trace - 1.0)));
    if (acos(cosine) <= tolerance)
        Py_RETURN_TRUE;
    Py_RETURN_FALSE;
}

static PyMethodDef methods[] = {
    {"order", (PyCFunction)(void (*)(void))order, METH_FASTCALL,
     "order(params, branches, reference, out) -> int: the wrapped branches to screen, in order, into out"},
    {"screen", (PyCFunction)(void (*)(void))screen, METH_FASTCALL,
     "screen(reached, position, rotation, tolerance) -> bool: the FK screen's arithmetic"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_eaik_kernel",
                                    "Compiled per-call choice of the eaik method (see eaik_kernel.py).", -1,
                                    methods};

PyMODINIT_FUNC PyInit__eaik_kernel(void) { return PyModule_Create(&module); }
