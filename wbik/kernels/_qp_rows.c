/* Compiled twins of the QP step's per-step arithmetic (the Python module wbik.kernels._qp_rows):
 *
 * - frame_rows: a frame task's rows at one configuration, from the joint Jacobians Pinocchio keeps in
 *   its data (data.J, world axes at the world origin) and the frame's placement: the position rows
 *   J_v - [p]x J_w (LOCAL_WORLD_ALIGNED, as pin.getFrameJacobian) with e = p - p*, and the rotation rows
 *   Jlog3(M) R^T J_w with e = log3(M), M = R*^T R. The Python twin (wbik.qp.tasks) calls Pinocchio's
 *   getFrameJacobian, log3 and Jlog3; log3 and Jlog3 here follow Pinocchio's formulas (spatial/log.hxx:
 *   the rotation renormalised, the same Taylor switches), so both agree to rounding
 *   (tests/test_rows_kernel.py: to 1e-12). Rotation errors within 0.1 rad of a half turn are left to the
 *   Python twin (frame_rows returns False and writes nothing): there the axis comes from a small
 *   antisymmetric part, rounding is amplified by ~1/(pi - theta), and Pinocchio's own diagonal formula
 *   takes over within ~3.5e-3 rad; Pinocchio then decides alone.
 * - quadratic: one priority level's H = W^T W + diag(d + damping) and c = W^T (s_e * e), W = s_r * J,
 *   the products the Python twin (wbik.qp.step.Level.quadratic) leaves to NumPy/BLAS, summed here
 *   row by row in a fixed order (so the result does not depend on the BLAS build).
 * - stack_rows and tighten_slice: StackedConstraints.add's and .tighten's copies, max and min (NumPy's
 *   bits, signed zeros and NaN included), each one call instead of several slice assignments.
 * - the constraints' rows written in place by wbik.qp.row_plan: frame_rows' held form (a contact's
 *   J dq = -e), polygon_rows (the CoM in its support polygon), position_bounds (joint limits on a step)
 *   and step_box (the box opened and closed). Their twins are the constraints' own rows stacked by
 *   StackedConstraints (tests/test_row_plan.py: the same bits but the polygon's two-term sums, which
 *   BLAS may fuse).
 */
#include "_buffers.h"
#include <float.h>
#include <math.h>

#define HALF_TURN_MARGIN 0.1 /* rad: closer to a half turn, Pinocchio computes log3 (see above) */

/* log3 of a rotation (row-major), as pinocchio::log3; 0 (nothing done) within HALF_TURN_MARGIN of a
 * half turn. */
static int rotation_log(const double R[9], double log[3], double *theta_out)
{
    const double eps = DBL_EPSILON;
    const double prec = pow(eps, 1.0 / 3.0);
    /* renormalise: columns 0 and 1 to unit length, column 2 = c0 x c1, column 0 = c1 x c2 */
    double c0[3] = {R[0], R[3], R[6]}, c1[3] = {R[1], R[4], R[7]}, c2[3];
    double n0 = sqrt(c0[0] * c0[0] + c0[1] * c0[1] + c0[2] * c0[2]);
    double n1 = sqrt(c1[0] * c1[0] + c1[1] * c1[1] + c1[2] * c1[2]);
    for (int i = 0; i < 3; i++) {
        c0[i] /= n0;
        c1[i] /= n1;
    }
    c2[0] = c0[1] * c1[2] - c0[2] * c1[1];
    c2[1] = c0[2] * c1[0] - c0[0] * c1[2];
    c2[2] = c0[0] * c1[1] - c0[1] * c1[0];
    c0[0] = c1[1] * c2[2] - c1[2] * c2[1];
    c0[1] = c1[2] * c2[0] - c1[0] * c2[2];
    c0[2] = c1[0] * c2[1] - c1[1] * c2[0];
    /* Rn(i, j) = c_j[i] */
    const double trace = c0[0] + c1[1] + c2[2];
    const double cos_value = (trace - 1.0) / 2.0;
    if (!(cos_value >= -cos(HALF_TURN_MARGIN)))
        return 0;
    /* (Pinocchio's third branch, pi - sqrt(2 (1 + cos)), lies inside the margin) */
    const double theta = trace <= 3.0 - prec ? acos(cos_value) : sqrt(2.0 * (1.0 - cos_value) + eps * eps);
    const double a0 = 0.5 * (c1[2] - c2[1]), a1 = 0.5 * (c2[0] - c0[2]), a2 = 0.5 * (c0[1] - c1[0]);
    const double squared = a0 * a0 + a1 * a1 + a2 * a2;
    const double t = theta >= prec ? theta / sin(theta) : 1.0 + squared / 6.0 + squared * squared * 3.0 / 40.0;
    log[0] = t * a0;
    log[1] = t * a1;
    log[2] = t * a2;
    *theta_out = theta;
    return 1;
}

/* Jlog3 (row-major) at (theta, log), as pinocchio::Jlog3. */
static void rotation_log_jacobian(double theta, const double log[3], double J[9])
{
    const double prec = pow(DBL_EPSILON, 1.0 / 4.0);
    const double st = sin(theta), ct = cos(theta);
    const double st_1mct = st / (1.0 - ct);
    const double alpha = theta < prec ? 1.0 / 12.0 + theta * theta / 720.0
                                      : 1.0 / (theta * theta) - st_1mct / (2.0 * theta);
    const double diagonal = theta < prec ? 0.5 * (2.0 - theta * theta / 6.0) : 0.5 * (theta * st_1mct);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            J[3 * i + j] = alpha * log[i] * log[j];
    for (int i = 0; i < 3; i++)
        J[4 * i] += diagonal;
    const double v0 = 0.5 * log[0], v1 = 0.5 * log[1], v2 = 0.5 * log[2];
    J[1] -= v2;
    J[2] += v1;
    J[3] += v2;
    J[5] -= v0;
    J[6] -= v1;
    J[7] += v0;
}

/* An int64 index array's view (np.intp on 64-bit platforms); TypeError naming the argument otherwise. */
static int index_view(PyObject *object, Py_buffer *view, const char *what)
{
    if (PyObject_GetBuffer(object, view, PyBUF_RECORDS_RO) < 0)
        return -1;
    if (view->ndim == 1 && view->itemsize == 8 && view->format != NULL
        && (strcmp(view->format, "l") == 0 || strcmp(view->format, "q") == 0) && PyBuffer_IsContiguous(view, 'C'))
        return 0;
    PyBuffer_Release(view);
    PyErr_Format(PyExc_TypeError, "%s: expected a contiguous 1-D int64 array", what);
    return -1;
}

/* frame_rows(rows, joint_jacobians, columns, translation, rotation, target_translation, target_rotation,
 *            jacobian, error[, lower]) -> bool
 * rows: 6 (pose: position rows, then rotation rows) or 3 (rotation rows only); joint_jacobians: (6, nv),
 * any strides (data.J); columns: the int64 indices of the columns in the frame's support (the others are
 * zero); translation (3,) and rotation (3, 3): the frame's world placement; target_translation (3,) (or
 * None when rows is 3) and target_rotation (3, 3): the target; jacobian: (rows, nv) and error (rows,),
 * writable, C-contiguous. With lower ((rows,), writable, C-contiguous), the rows of a frame held where
 * it is, J dq = -e: error gets -e and lower a copy of it. False (nothing written) near a half turn. */
static PyObject *frame_rows(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 10 && check_count("frame_rows", nargs, 9) < 0)
        return NULL;
    long rows = PyLong_AsLong(args[0]);
    if (rows == -1 && PyErr_Occurred())
        return NULL;
    if (rows != 6 && rows != 3) {
        PyErr_Format(PyExc_ValueError, "rows: expected 6 (pose) or 3 (orientation), got %ld", rows);
        return NULL;
    }
    double p[9], R[9], target_p[3] = {0.0, 0.0, 0.0}, target_R[9];
    if (read_doubles(args[3], p, 3, 0, "translation") < 0 || read_doubles(args[4], R, 3, 3, "rotation") < 0
        || read_doubles(args[6], target_R, 3, 3, "target_rotation") < 0)
        return NULL;
    if (rows == 6 && read_doubles(args[5], target_p, 3, 0, "target_translation") < 0)
        return NULL;
    /* M = R*^T R, its log and Jlog3; K = Jlog3(M) R^T takes world angular velocities to the error's rates */
    double M[9], log[3], theta, Jlog[9], K[9];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            M[3 * i + j] = target_R[i] * R[j] + target_R[3 + i] * R[3 + j] + target_R[6 + i] * R[6 + j];
    if (!rotation_log(M, log, &theta))
        Py_RETURN_FALSE;
    rotation_log_jacobian(theta, log, Jlog);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            K[3 * i + j] = Jlog[3 * i] * R[3 * j] + Jlog[3 * i + 1] * R[3 * j + 1] + Jlog[3 * i + 2] * R[3 * j + 2];

    Py_buffer views[5]; /* joint_jacobians, columns, jacobian, error, lower */
    int held = 0;
    PyObject *result = NULL;
    if (float64_view(args[1], &views[held], 0, "joint_jacobians") < 0)
        goto done;
    held++;
    const Py_buffer *world = &views[0];
    if (world->ndim != 2 || world->shape[0] != 6) {
        PyErr_SetString(PyExc_TypeError, "joint_jacobians: expected a (6, nv) float64 array");
        goto done;
    }
    const Py_ssize_t nv = world->shape[1];
    if (index_view(args[2], &views[held], "columns") < 0)
        goto done;
    held++;
    if (contiguous_view(args[7], &views[held], rows * nv, 1, "jacobian") < 0)
        goto done;
    held++;
    if (contiguous_view(args[8], &views[held], rows, 1, "error") < 0)
        goto done;
    held++;
    if (nargs == 10) {
        if (contiguous_view(args[9], &views[held], rows, 1, "lower") < 0)
            goto done;
        held++;
    }
    const int64_t *indices = (const int64_t *)views[1].buf;
    const Py_ssize_t count = views[1].shape[0];
    for (Py_ssize_t k = 0; k < count; k++)
        if (indices[k] < 0 || indices[k] >= nv) {
            PyErr_Format(PyExc_IndexError, "columns: an index is outside 0..%zd", nv - 1);
            goto done;
        }
    double *out = (double *)views[2].buf, *e = (double *)views[3].buf;
    memset(out, 0, rows * nv * sizeof(double));
    double *rotation_rows = rows == 6 ? out + 3 * nv : out;
    const char *base = (const char *)world->buf;
    const Py_ssize_t row_stride = world->strides[0], column_stride = world->strides[1];
    for (Py_ssize_t k = 0; k < count; k++) {
        const Py_ssize_t j = (Py_ssize_t)indices[k];
        double v[6];
        for (int r = 0; r < 6; r++)
            memcpy(v + r, base + r * row_stride + j * column_stride, sizeof(double));
        const double *w = v + 3;
        if (rows == 6) { /* LOCAL_WORLD_ALIGNED: the linear velocity at p, v - p x w */
            out[j] = v[0] - (p[1] * w[2] - p[2] * w[1]);
            out[nv + j] = v[1] - (p[2] * w[0] - p[0] * w[2]);
            out[2 * nv + j] = v[2] - (p[0] * w[1] - p[1] * w[0]);
        }
        for (int i = 0; i < 3; i++)
            rotation_rows[i * nv + j] = K[3 * i] * w[0] + K[3 * i + 1] * w[1] + K[3 * i + 2] * w[2];
    }
    double *rotation_error = e;
    if (rows == 6) {
        for (int i = 0; i < 3; i++)
            e[i] = p[i] - target_p[i];
        rotation_error = e + 3;
    }
    for (int i = 0; i < 3; i++)
        rotation_error[i] = log[i];
    if (nargs == 10) {
        double *lower = (double *)views[4].buf;
        for (long i = 0; i < rows; i++)
            lower[i] = e[i] = -e[i];
    }
    result = Py_NewRef(Py_True);
done:
    release_views(views, held);
    return result;
}

/* quadratic(jacobian, row_scale, error, error_scale, diagonal, damping, weighted, hessian, gradient
 *           [, goal_rows, lm_damping])
 * jacobian (m, nv); row_scale, error, error_scale (m,); diagonal (nv,); writes W = row_scale * J into
 * weighted (m, nv), H = W^T W + diag(diagonal + damping) into hessian (nv, nv) and c = W^T (error_scale *
 * error) into gradient (nv,). With goal_rows ((m,): 1 on a goal task's rows, else 0) and lm_damping,
 * the damping is damping + lm_damping * sum(goal_rows * error^2) (the Levenberg-Marquardt term, summed
 * row by row). Inputs any strides; outputs writable and C-contiguous. */
static PyObject *quadratic(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 11 && check_count("quadratic", nargs, 9) < 0)
        return NULL;
    double damping, lm_damping = 0.0;
    if (read_float(args[5], &damping, "damping") < 0 || (nargs == 11 && read_float(args[10], &lm_damping,
                                                                                    "lm_damping") < 0))
        return NULL;
    Py_buffer views[3]; /* hessian, weighted, gradient */
    int held = 0;
    PyObject *result = NULL;
    double *scales = NULL;
    if (float64_view(args[7], &views[held], 1, "hessian") < 0)
        goto done;
    held++;
    if (views[0].ndim != 2 || views[0].shape[0] != views[0].shape[1]) {
        PyErr_SetString(PyExc_TypeError, "hessian: expected a square (nv, nv) array");
        goto done;
    }
    const Py_ssize_t nv = views[0].shape[0];
    if (float64_view(args[6], &views[held], 1, "weighted") < 0)
        goto done;
    held++;
    const Py_ssize_t m = views[1].ndim == 2 && views[1].shape[1] == nv ? views[1].shape[0] : -1;
    if (m < 0) {
        PyErr_Format(PyExc_TypeError, "weighted: expected an (m, %zd) array", nv);
        goto done;
    }
    if (contiguous_view(args[8], &views[held], nv, 1, "gradient") < 0)
        goto done;
    held++;
    double *H = (double *)views[0].buf, *W = (double *)views[1].buf, *c = (double *)views[2].buf;
    scales = PyMem_Malloc((4 * m + nv + 1) * sizeof(double));
    if (scales == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    double *row_scale = scales, *e = scales + m, *error_scale = scales + 2 * m, *diagonal = scales + 3 * m;
    if (read_doubles(args[0], W, m, nv, "jacobian") < 0 || read_doubles(args[1], row_scale, m, 0, "row_scale") < 0
        || read_doubles(args[2], e, m, 0, "error") < 0 || read_doubles(args[3], error_scale, m, 0, "error_scale") < 0
        || read_doubles(args[4], diagonal, nv, 0, "diagonal") < 0)
        goto done;
    if (nargs == 11) { /* the goal rows' cost, on the errors before they are scaled below */
        double *goal = scales + 3 * m + nv, cost = 0.0;
        if (read_doubles(args[9], goal, m, 0, "goal_rows") < 0)
            goto done;
        for (Py_ssize_t i = 0; i < m; i++)
            if (goal[i] != 0.0) /* (the other rows do not count, a NaN there included) */
                cost += e[i] * e[i];
        damping += lm_damping * cost;
    }
    for (Py_ssize_t i = 0; i < m; i++) {
        for (Py_ssize_t a = 0; a < nv; a++)
            W[i * nv + a] *= row_scale[i];
        e[i] *= error_scale[i];
    }
    memset(H, 0, nv * nv * sizeof(double));
    memset(c, 0, nv * sizeof(double));
    /* the upper triangle row by row, skipping exact zeros (the columns a task's chain does not move): a
     * NaN in J still reaches H and c, at no more entries than NumPy's 0 x NaN would put it */
    for (Py_ssize_t i = 0; i < m; i++) {
        const double *row = W + i * nv;
        for (Py_ssize_t a = 0; a < nv; a++) {
            const double wa = row[a];
            if (wa == 0.0)
                continue;
            double *h = H + a * nv;
            for (Py_ssize_t b = a; b < nv; b++)
                h[b] += wa * row[b];
            c[a] += wa * e[i];
        }
    }
    for (Py_ssize_t a = 0; a < nv; a++) {
        H[a * nv + a] += diagonal[a] + damping;
        for (Py_ssize_t b = a + 1; b < nv; b++)
            H[b * nv + a] = H[a * nv + b];
    }
    result = Py_NewRef(Py_None);
done:
    PyMem_Free(scales);
    release_views(views, held);
    return result;
}

/* stack_rows(matrix, upper, lower, start, n, rows, bounds, equality)
 * Copies rows (k, n) (any strides) into matrix[start:start + k] and bounds (k,) into upper[n + start:] (and
 * lower[n + start:] when equality); matrix (capacity, n), upper and lower (n + capacity,): C-contiguous and
 * writable, with room for the rows. */
static PyObject *stack_rows(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (check_count("stack_rows", nargs, 8) < 0)
        return NULL;
    Py_ssize_t start = PyNumber_AsSsize_t(args[3], PyExc_OverflowError);
    Py_ssize_t n = start == -1 && PyErr_Occurred() ? -1 : PyNumber_AsSsize_t(args[4], PyExc_OverflowError);
    int equality = PyObject_IsTrue(args[7]);
    if ((start == -1 || n == -1 || equality < 0) && PyErr_Occurred())
        return NULL;
    static const char *names[5] = {"matrix", "upper", "lower", "rows", "bounds"};
    static const int argument[5] = {0, 1, 2, 5, 6}, writable[5] = {1, 1, 1, 0, 0};
    Py_buffer views[5];
    int held = 0;
    PyObject *result = NULL;
    for (; held < 5; held++)
        if (float64_view(args[argument[held]], &views[held], writable[held], names[held]) < 0)
            goto done;
    const Py_buffer *matrix = &views[0], *upper = &views[1], *lower = &views[2], *rows = &views[3],
                    *bounds = &views[4];
    const Py_ssize_t count = rows->ndim == 2 ? rows->shape[0] : -1;
    const Py_ssize_t capacity = matrix->len / (Py_ssize_t)sizeof(double) / (n > 0 ? n : 1);
    const char *problem = NULL;
    if (count < 0 || rows->shape[1] != n)
        problem = "rows: expected a (k, n) float64 array";
    else if (bounds->ndim != 1 || bounds->shape[0] != count)
        problem = "bounds: expected a (k,) float64 array";
    else if (n <= 0 || start < 0 || matrix->ndim != 2 || matrix->shape[1] != n || start > capacity - count
             || upper->len / (Py_ssize_t)sizeof(double) - n - count < start
             || lower->len / (Py_ssize_t)sizeof(double) - n - count < start)
        problem = "matrix, upper, lower: no room for the rows";
    if (problem != NULL) {
        PyErr_SetString(PyExc_TypeError, problem);
        goto done;
    }
    double *M = (double *)matrix->buf, *u = (double *)upper->buf + n + start, *l = (double *)lower->buf + n + start;
    const char *source = (const char *)rows->buf, *values = (const char *)bounds->buf;
    for (Py_ssize_t i = 0; i < count; i++) {
        double *row = M + (start + i) * n;
        for (Py_ssize_t j = 0; j < n; j++)
            memcpy(row + j, source + i * rows->strides[0] + j * rows->strides[1], sizeof(double));
        memcpy(u + i, values + i * bounds->strides[0], sizeof(double));
        if (equality)
            l[i] = u[i];
    }
    result = Py_NewRef(Py_None);
done:
    release_views(views, held);
    return result;
}

/* tighten_slice(lb, ub, start, lower, upper): lb[start + i] = max(lb[start + i], lower[i]) and
 * ub[start + i] = min(ub[start + i], upper[i]) (NumPy's maximum and minimum: a NaN wins) for i < k, the
 * length of lower and upper ((k,), any strides); lb and ub C-contiguous and writable. */
static PyObject *tighten_slice(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (check_count("tighten_slice", nargs, 5) < 0)
        return NULL;
    Py_ssize_t start = PyNumber_AsSsize_t(args[2], PyExc_OverflowError);
    if (start == -1 && PyErr_Occurred())
        return NULL;
    static const char *names[4] = {"lb", "ub", "lower", "upper"};
    static const int argument[4] = {0, 1, 3, 4}, writable[4] = {1, 1, 0, 0};
    Py_buffer views[4];
    int held = 0;
    PyObject *result = NULL;
    for (; held < 4; held++)
        if (float64_view(args[argument[held]], &views[held], writable[held], names[held]) < 0)
            goto done;
    const Py_buffer *lb = &views[0], *ub = &views[1], *lower = &views[2], *upper = &views[3];
    const Py_ssize_t count = lower->ndim == 1 ? lower->shape[0] : -1;
    const Py_ssize_t size = lb->len / (Py_ssize_t)sizeof(double);
    if (!(count >= 0 && upper->ndim == 1 && upper->shape[0] == count && start >= 0 && start <= size - count
          && ub->len == lb->len)) {
        PyErr_SetString(PyExc_TypeError, "lower, upper: expected two (k,) float64 arrays that fit lb and ub");
        goto done;
    }
    double *low = (double *)lb->buf + start, *high = (double *)ub->buf + start;
    const char *l = (const char *)lower->buf, *u = (const char *)upper->buf;
    for (Py_ssize_t i = 0; i < count; i++) {
        double a, b;
        memcpy(&a, l + i * lower->strides[0], sizeof(double));
        memcpy(&b, u + i * upper->strides[0], sizeof(double));
        /* NumPy's maximum/minimum: a NaN from either side wins, and between equal values (+0 and -0) the
         * second operand */
        low[i] = isnan(low[i]) || isnan(a) ? (isnan(low[i]) ? low[i] : a) : (a >= low[i] ? a : low[i]);
        high[i] = isnan(high[i]) || isnan(b) ? (isnan(high[i]) ? high[i] : b) : (b <= high[i] ? b : high[i]);
    }
    result = Py_NewRef(Py_None);
done:
    release_views(views, held);
    return result;
}

/* NumPy's maximum and minimum on two doubles: a NaN from either side wins, and between equal values (+0
 * and -0) the second operand. */
static inline double numpy_max(double a, double b)
{
    return isnan(a) || isnan(b) ? (isnan(a) ? a : b) : (b >= a ? b : a);
}

static inline double numpy_min(double a, double b)
{
    return isnan(a) || isnan(b) ? (isnan(a) ? a : b) : (b <= a ? b : a);
}

/* polygon_rows(normals, offsets, com, com_jacobian, G, h): the CoM-in-polygon rows G = N J_xy and
 * h = d - N c_xy; normals (m, 2), offsets (m,), com (3,) and com_jacobian (3, nv) any strides; G (m, nv)
 * and h (m,) writable, C-contiguous. */
static PyObject *polygon_rows(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (check_count("polygon_rows", nargs, 6) < 0)
        return NULL;
    static const char *names[4] = {"normals", "com_jacobian", "G", "h"};
    static const int argument[4] = {0, 3, 4, 5}, writable[4] = {0, 0, 1, 1};
    Py_buffer views[4];
    int held = 0;
    PyObject *result = NULL;
    double *offsets = NULL, com[3];
    for (; held < 4; held++)
        if (float64_view(args[argument[held]], &views[held], writable[held], names[held]) < 0)
            goto done;
    const Py_buffer *N = &views[0], *J = &views[1];
    const Py_ssize_t m = N->ndim == 2 && N->shape[1] == 2 ? N->shape[0] : -1;
    const Py_ssize_t nv = J->ndim == 2 && J->shape[0] == 3 ? J->shape[1] : -1;
    if (m < 0 || nv < 0 || views[2].len != m * nv * (Py_ssize_t)sizeof(double)
        || views[3].len != m * (Py_ssize_t)sizeof(double)) {
        PyErr_SetString(PyExc_TypeError, "polygon_rows: expected normals (m, 2), com_jacobian (3, nv), "
                                         "G (m, nv) and h (m,)");
        goto done;
    }
    offsets = PyMem_Malloc((m + 1) * sizeof(double));
    if (offsets == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    if (read_doubles(args[1], offsets, m, 0, "offsets") < 0 || read_doubles(args[2], com, 3, 0, "com") < 0)
        goto done;
    double *G = (double *)views[2].buf, *h = (double *)views[3].buf;
    const char *normal = (const char *)N->buf, *jacobian = (const char *)J->buf;
    for (Py_ssize_t i = 0; i < m; i++) {
        double n0, n1;
        memcpy(&n0, normal + i * N->strides[0], sizeof(double));
        memcpy(&n1, normal + i * N->strides[0] + N->strides[1], sizeof(double));
        for (Py_ssize_t j = 0; j < nv; j++) {
            double x, y;
            memcpy(&x, jacobian + j * J->strides[1], sizeof(double));
            memcpy(&y, jacobian + J->strides[0] + j * J->strides[1], sizeof(double));
            G[i * nv + j] = n0 * x + n1 * y;
        }
        h[i] = offsets[i] - (n0 * com[0] + n1 * com[1]);
    }
    result = Py_NewRef(Py_None);
done:
    PyMem_Free(offsets);
    release_views(views, held);
    return result;
}

/* position_bounds(q, q_index, v_index, lower, upper, lb, ub): a position limit on each step, for every k:
 * lb[v_k] = max(lb[v_k], lower[k] - q[q_k]), ub[v_k] = min(ub[v_k], upper[k] - q[q_k]) (NumPy's maximum
 * and minimum); q (nq,), lower and upper (k,) any strides; the indices int64; lb and ub (nv,) writable,
 * C-contiguous. */
static PyObject *position_bounds(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (check_count("position_bounds", nargs, 7) < 0)
        return NULL;
    Py_buffer views[7]; /* q, lower, upper, lb, ub, q_index, v_index */
    static const char *names[5] = {"q", "lower", "upper", "lb", "ub"};
    static const int argument[5] = {0, 3, 4, 5, 6}, writable[5] = {0, 0, 0, 1, 1};
    int held = 0;
    PyObject *result = NULL;
    for (; held < 5; held++)
        if (float64_view(args[argument[held]], &views[held], writable[held], names[held]) < 0)
            goto done;
    if (index_view(args[1], &views[held], "q_index") < 0)
        goto done;
    held++;
    if (index_view(args[2], &views[held], "v_index") < 0)
        goto done;
    held++;
    const Py_buffer *q = &views[0], *lower = &views[1], *upper = &views[2];
    const Py_ssize_t count = views[5].shape[0], nq = q->ndim == 1 ? q->shape[0] : -1;
    const Py_ssize_t nv = views[3].len / (Py_ssize_t)sizeof(double);
    if (nq < 0 || views[6].shape[0] != count || lower->ndim != 1 || lower->shape[0] != count
        || upper->ndim != 1 || upper->shape[0] != count || views[4].len != views[3].len) {
        PyErr_SetString(PyExc_TypeError, "position_bounds: expected q (nq,), k indices and limits, lb and ub "
                                         "(nv,)");
        goto done;
    }
    const int64_t *q_index = (const int64_t *)views[5].buf, *v_index = (const int64_t *)views[6].buf;
    for (Py_ssize_t k = 0; k < count; k++)
        if (q_index[k] < 0 || q_index[k] >= nq || v_index[k] < 0 || v_index[k] >= nv) {
            PyErr_SetString(PyExc_IndexError, "position_bounds: an index outside q or lb");
            goto done;
        }
    double *lb = (double *)views[3].buf, *ub = (double *)views[4].buf;
    const char *qs = (const char *)q->buf, *ls = (const char *)lower->buf, *us = (const char *)upper->buf;
    for (Py_ssize_t k = 0; k < count; k++) {
        double value, low, high;
        memcpy(&value, qs + q_index[k] * q->strides[0], sizeof(double));
        memcpy(&low, ls + k * lower->strides[0], sizeof(double));
        memcpy(&high, us + k * upper->strides[0], sizeof(double));
        lb[v_index[k]] = numpy_max(lb[v_index[k]], low - value);
        ub[v_index[k]] = numpy_min(ub[v_index[k]], high - value);
    }
    result = Py_NewRef(Py_None);
done:
    release_views(views, held);
    return result;
}

/* step_box(lb, ub, radius, close, toward_rest): close false: lb = -radius, ub = radius (the box a step
 * starts from); close true: StackedConstraints.close_box, ub = max(ub, min(lb, 0)) first if toward_rest,
 * then lb = min(lb, ub). lb and ub (nv,) writable, C-contiguous. */
static PyObject *step_box(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (check_count("step_box", nargs, 5) < 0)
        return NULL;
    double radius;
    int close = PyObject_IsTrue(args[3]), toward_rest = PyObject_IsTrue(args[4]);
    if (close < 0 || toward_rest < 0 || read_float(args[2], &radius, "radius") < 0)
        return NULL;
    Py_buffer views[2];
    int held = 0;
    PyObject *result = NULL;
    for (; held < 2; held++)
        if (float64_view(args[held], &views[held], 1, held ? "ub" : "lb") < 0)
            goto done;
    if (views[0].len != views[1].len) {
        PyErr_SetString(PyExc_TypeError, "step_box: lb and ub differ in length");
        goto done;
    }
    double *lb = (double *)views[0].buf, *ub = (double *)views[1].buf;
    const Py_ssize_t nv = views[0].len / (Py_ssize_t)sizeof(double);
    for (Py_ssize_t i = 0; i < nv; i++) {
        if (!close) {
            lb[i] = -radius;
            ub[i] = radius;
            continue;
        }
        if (toward_rest)
            ub[i] = numpy_max(ub[i], numpy_min(lb[i], 0.0));
        lb[i] = numpy_min(lb[i], ub[i]);
    }
    result = Py_NewRef(Py_None);
done:
    release_views(views, held);
    return result;
}

static PyMethodDef methods[] = {
    {"frame_rows", (PyCFunction)(void (*)(void))frame_rows, METH_FASTCALL,
     "frame_rows(rows, joint_jacobians, columns, translation, rotation, target_translation, target_rotation, "
     "jacobian, error[, lower]) -> bool: a frame task's rows, or a held frame's (False near a half turn: "
     "nothing written)"},
    {"quadratic", (PyCFunction)(void (*)(void))quadratic, METH_FASTCALL,
     "quadratic(jacobian, row_scale, error, error_scale, diagonal, damping, weighted, hessian, gradient"
     "[, goal_rows, lm_damping]): one level's H and c"},
    {"stack_rows", (PyCFunction)(void (*)(void))stack_rows, METH_FASTCALL,
     "stack_rows(matrix, upper, lower, start, n, rows, bounds, equality): StackedConstraints.add's copies"},
    {"tighten_slice", (PyCFunction)(void (*)(void))tighten_slice, METH_FASTCALL,
     "tighten_slice(lb, ub, start, lower, upper): StackedConstraints.tighten on a slice"},
    {"polygon_rows", (PyCFunction)(void (*)(void))polygon_rows, METH_FASTCALL,
     "polygon_rows(normals, offsets, com, com_jacobian, G, h): the CoM-in-polygon rows"},
    {"position_bounds", (PyCFunction)(void (*)(void))position_bounds, METH_FASTCALL,
     "position_bounds(q, q_index, v_index, lower, upper, lb, ub): position limits on a step"},
    {"step_box", (PyCFunction)(void (*)(void))step_box, METH_FASTCALL,
     "step_box(lb, ub, radius, close, toward_rest): the step box opened, or closed"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_qp_rows",
                                    "Compiled twins of the QP step's rows and quadratic (wbik.kernels).", -1,
                                    methods};

PyMODINIT_FUNC PyInit__qp_rows(void) { return PyModule_Create(&module); }
