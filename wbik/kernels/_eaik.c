/* Compiled twin of the eaik method's per-call choice (wbik.kernels.eaik: order_python,
 * choose_python): which of EAIK's branches to screen, in which order, wrapped into the limits, and the
 * choice itself: the first of them whose FK (the product of exponentials of the chain's joint lines)
 * passes the screen.
 *
 * Every expression is the Python twin's, operation by operation and in the same order, so both return
 * the same bits: IEEE arithmetic is exact-rounded, acos is the libm one CPython's math module calls,
 * rint rounds half to even as Python's round() in the default rounding mode, the build turns off FMA
 * contraction (-ffp-contract=off), and the twin's sums are plain left-to-right additions.
 * tests/test_eaik_kernel.py compares both bit for bit.
 *
 * The Python module is wbik.kernels._eaik.
 */
#include "_buffers.h"
#include "_pose_errors.h"
#include <math.h>

#define TWO_PI (2.0 * 3.141592653589793)
#define INVERSE_TURN (1.0 / TWO_PI)
#define TURN_SQUARED (TWO_PI * TWO_PI)
/* Python's max(a, b) and min(a, b) of two floats: the first unless the second compares larger (smaller). */
#define PY_MAX(a, b) ((b) > (a) ? (b) : (a))
#define PY_MIN(a, b) ((b) < (a) ? (b) : (a))

#define MAX_JOINTS 7
#define MAX_BRANCHES 256

/* The parameters of wbik.kernels.eaik.parameters, float64 values packed in a bytes
 * object (read without the buffer protocol's cost): the slack of the bounds (n BOUND_SLACK),
 * LIMIT_TOLERANCE, the screen's tolerance, then lower (n), upper (n), the joint lines' axes (n x 3) and
 * origins (n x 3), and the tip's pose at q = 0 (rotation 3 x 3 row by row, then position). */
enum { P_SLACK, P_LIMIT_TOLERANCE, P_SCREEN_TOLERANCE, P_LOWER };
#define PARAMETER_COUNT(n) (P_LOWER + 8 * (n) + 12)

static const double SHIFTS[5] = {0.0, TWO_PI, -TWO_PI, 2 * TWO_PI, -2 * TWO_PI};

/* eaik.py's wrapped_python: raw wrapped into the limits nearest ref, its squared distance into
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

/* The branches to screen, wrapped into the limits, in the order the choice screens them, written into
 * out (count * joints values); returns how many: the branches are taken in the order of their bounds
 * (sum_i (2 pi)^2 (t_i - rint(t_i))^2, t = (q - r) / 2 pi, +inf where a joint is not finite; stable),
 * each wrapped; before a branch is taken, every wrapped one whose squared distance is at most its
 * bound less the slack comes out, nearest first (ties: the first in the bounds' order). */
static int order_rows(const double *params, int joints, double q[][MAX_JOINTS], int count, const double *ref,
                      double *out)
{
    const double slack = params[P_SLACK], tolerance = params[P_LIMIT_TOLERANCE];
    const double *lower = params + P_LOWER, *upper = params + P_LOWER + joints;
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
    return written;
}

/* The tip's pose of joints q as a 4 x 4 homogeneous matrix (row by row) from the chain's joint lines:
 * T = T_1(q_1) ... T_n(q_n) M with T_k = (Rot(a_k, q_k), o_k - Rot(a_k, q_k) o_k) and
 * Rot(a, t) = cos t I + (1 - cos t) a a^T + sin t [a]x (eaik.py's poe_python, in its order). */
static void poe(const double *params, int joints, const double *q, double *pose)
{
    const double *axes = params + P_LOWER + 2 * joints, *origins = axes + 3 * joints, *tip = origins + 3 * joints;
    double r[9] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0}, p[3] = {0.0, 0.0, 0.0};
    for (int k = 0; k < joints; k++) {
        double ax = axes[3 * k], ay = axes[3 * k + 1], az = axes[3 * k + 2];
        double c = cos(q[k]), s = sin(q[k]), v = 1.0 - c;
        double t[9] = {c + v * ax * ax, v * ax * ay - s * az, v * ax * az + s * ay,
                       v * ay * ax + s * az, c + v * ay * ay, v * ay * az - s * ax,
                       v * az * ax - s * ay, v * az * ay + s * ax, c + v * az * az};
        const double *o = origins + 3 * k;
        double offset[3], moved[9];
        for (int i = 0; i < 3; i++)
            offset[i] = o[i] - (t[3 * i] * o[0] + t[3 * i + 1] * o[1] + t[3 * i + 2] * o[2]);
        for (int i = 0; i < 3; i++)
            p[i] = p[i] + (r[3 * i] * offset[0] + r[3 * i + 1] * offset[1] + r[3 * i + 2] * offset[2]);
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                moved[3 * i + j] = r[3 * i] * t[j] + r[3 * i + 1] * t[3 + j] + r[3 * i + 2] * t[6 + j];
        memcpy(r, moved, sizeof(r));
    }
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++)
            pose[4 * i + j] = r[3 * i] * tip[j] + r[3 * i + 1] * tip[3 + j] + r[3 * i + 2] * tip[6 + j];
        pose[4 * i + 3] = p[i] + (r[3 * i] * tip[9] + r[3 * i + 1] * tip[10] + r[3 * i + 2] * tip[11]);
    }
    pose[12] = 0.0;
    pose[13] = 0.0;
    pose[14] = 0.0;
    pose[15] = 1.0;
}

/* The screen on a tip pose: |p - p*| <= tolerance and acos(clip((trace(R*^T R) - 1) / 2)) <= tolerance,
 * the trace summed as sum_ij R_ij R*_ij row by row (eaik.py's screen_values). */
static int screens(const double *reached, const double *position, const double *rotation, double tolerance)
{
    double dx = reached[3] - position[0], dy = reached[7] - position[1], dz = reached[11] - position[2];
    if (!(sqrt(dx * dx + dy * dy + dz * dz) <= tolerance))
        return 0;
    double trace = 0.0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            trace += reached[4 * i + j] * rotation[3 * i + j];
    double cosine = PY_MIN(1.0, PY_MAX(-1.0, 0.5 * (trace - 1.0)));
    return acos(cosine) <= tolerance;
}

/* The branches (K, n) as EAIK returns them and the reference (n,), read into C arrays; the joint count,
 * or -1 with a TypeError. */
static int read_branches(PyObject *params, PyObject *branches_object, PyObject *reference_object,
                         double q[][MAX_JOINTS], int *count, double *ref)
{
    if (!PyBytes_CheckExact(params)) {
        PyErr_SetString(PyExc_TypeError, "params: expected bytes (eaik_kernel.parameters)");
        return -1;
    }
    Py_buffer views[2];
    if (float64_view(reference_object, &views[0], 0, "reference") < 0)
        return -1;
    if (float64_view(branches_object, &views[1], 0, "branches") < 0) {
        release_views(views, 1);
        return -1;
    }
    int joints = -1;
    Py_buffer *reference = &views[0], *branches = &views[1];
    if (reference->ndim != 1 || reference->shape[0] < 1 || reference->shape[0] > MAX_JOINTS) {
        PyErr_SetString(PyExc_TypeError, "reference: expected a (n,) float64 array, 1 <= n <= 7");
    } else if (branches->ndim != 2 || branches->shape[1] != reference->shape[0]
               || branches->shape[0] > MAX_BRANCHES) {
        PyErr_Format(PyExc_TypeError, "branches: expected a (K, %d) float64 array, K <= %d",
                     (int)reference->shape[0], MAX_BRANCHES);
    } else if (PyBytes_GET_SIZE(params) != (Py_ssize_t)(PARAMETER_COUNT(reference->shape[0]) * sizeof(double))) {
        PyErr_Format(PyExc_TypeError, "params: expected %d float64 values",
                     (int)PARAMETER_COUNT(reference->shape[0]));
    } else {
        joints = (int)reference->shape[0];
        *count = (int)branches->shape[0];
        for (int j = 0; j < joints; j++)
            ref[j] = *(const double *)((const char *)reference->buf + j * reference->strides[0]);
        for (int k = 0; k < *count; k++)
            for (int j = 0; j < joints; j++)
                q[k][j] = *(const double *)((const char *)branches->buf + k * branches->strides[0]
                                            + j * branches->strides[1]);
    }
    release_views(views, 2);
    return joints;
}

/* order(params, branches, reference, out) -> int: order_rows into out (at least K * n values). */
static PyObject *order(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (check_count("order", nargs, 4) < 0)
        return NULL;
    double q[MAX_BRANCHES][MAX_JOINTS], ref[MAX_JOINTS];
    int count = 0;
    int joints = read_branches(args[0], args[1], args[2], q, &count, ref);
    if (joints < 0)
        return NULL;
    Py_buffer out_view;
    if (float64_view(args[3], &out_view, 1, "out") < 0)
        return NULL;
    if (out_view.len < (Py_ssize_t)(count * joints * sizeof(double))) {
        PyBuffer_Release(&out_view);
        PyErr_Format(PyExc_TypeError, "out: expected at least %d float64 values", count * joints);
        return NULL;
    }
    double params[PARAMETER_COUNT(MAX_JOINTS)];
    memcpy(params, PyBytes_AS_STRING(args[0]), PARAMETER_COUNT(joints) * sizeof(double));
    int written = order_rows(params, joints, q, count, ref, (double *)out_view.buf);
    PyBuffer_Release(&out_view);
    return PyLong_FromLong(written);
}

/* choose(params, branches, reference, target, out) -> int
 * The first of order_rows' branches whose FK (poe) passes the screen on the target (its 4 x 4
 * homogeneous matrix): 1, with out (n + 24 values) holding its joints (n), its 4 x 4 tip pose (16) and
 * the batched check's errors of that pose (pose_errors: e_p, e_R, |e_p|, |e_R|); 0 (out untouched)
 * when none passes. */
static PyObject *choose(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (check_count("choose", nargs, 5) < 0)
        return NULL;
    double q[MAX_BRANCHES][MAX_JOINTS], ref[MAX_JOINTS], target[16];
    int count = 0;
    int joints = read_branches(args[0], args[1], args[2], q, &count, ref);
    if (joints < 0 || read_doubles(args[3], target, 4, 4, "target") < 0)
        return NULL;
    Py_buffer out_view;
    if (contiguous_view(args[4], &out_view, joints + 24, 1, "out") < 0)
        return NULL;
    double params[PARAMETER_COUNT(MAX_JOINTS)], rows[MAX_BRANCHES * MAX_JOINTS], pose[16];
    const double position[3] = {target[3], target[7], target[11]};
    const double rotation[9] = {target[0], target[1], target[2], target[4], target[5], target[6],
                                target[8], target[9], target[10]};
    memcpy(params, PyBytes_AS_STRING(args[0]), PARAMETER_COUNT(joints) * sizeof(double));
    int screened = order_rows(params, joints, q, count, ref, rows), found = 0;
    for (int row = 0; row < screened && !found; row++) {
        poe(params, joints, rows + row * joints, pose);
        if (!screens(pose, position, rotation, params[P_SCREEN_TOLERANCE]))
            continue;
        double *out = (double *)out_view.buf;
        const double reached_p[3] = {pose[3], pose[7], pose[11]};
        const double reached_r[9] = {pose[0], pose[1], pose[2], pose[4], pose[5], pose[6], pose[8], pose[9],
                                     pose[10]};
        memcpy(out, rows + row * joints, joints * sizeof(double));
        memcpy(out + joints, pose, sizeof(pose));
        pose_errors(reached_p, reached_r, position, rotation, out + joints + 16);
        found = 1;
    }
    PyBuffer_Release(&out_view);
    return PyLong_FromLong(found);
}

static PyMethodDef methods[] = {
    {"order", (PyCFunction)(void (*)(void))order, METH_FASTCALL,
     "order(params, branches, reference, out) -> int: the wrapped branches to screen, in order, into out"},
    {"choose", (PyCFunction)(void (*)(void))choose, METH_FASTCALL,
     "choose(params, branches, reference, target, out) -> int: the choice and its check's arithmetic"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_eaik",
                                    "Compiled per-call choice of the eaik method (see eaik.py).", -1,
                                    methods};

PyMODINIT_FUNC PyInit__eaik(void) { return PyModule_Create(&module); }
