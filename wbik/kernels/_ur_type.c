/* Compiled twin of the UR-type closed form's scalar path (wbik.solvers.analytic.ur_type.branches_one,
 * fk_one, ToolClosedForm's tool transform, and the choice of wbik.solvers.analytic: nearest_branch,
 * wrap_one_into_limits, screen_residual, _distinct_one).
 *
 * Every expression is the Python one, operation by operation and in the same order, so that the two
 * paths return the same bits: IEEE arithmetic is exact-rounded, the transcendental functions are the
 * libm ones CPython's math module calls (remainder is exact in both; setup.py keeps GCC from merging
 * sin and cos into sincos with -fno-builtin-sin/-cos), nearbyint rounds half to even as Python's
 * round() in the default rounding mode, the build turns off FMA contraction (-ffp-contract=off), and
 * the Python twin's sums are plain left-to-right additions (Python 3.11's sum(); 3.12's compensated
 * sum would differ). tests/test_ur_kernel.py compares both paths bit for bit.
 *
 * Beyond the twin: nearest_many (solve_many) and distinct (solve_all) also check the chosen branches
 * with the closed-form FK (pose_errors: the batched rule of solve_many), which the analytic solver
 * holds to the robot model (Pinocchio) when it builds the form (check_fk_against_model). Results are
 * written into the caller's arrays; the caller builds the IKResults.
 *
 * The Python module is wbik.kernels._ur_type; wbik.solvers.analytic.ur_kernel wraps it.
 */
#include "_buffers.h"
#include "_pose_errors.h"
#include <math.h>

#define TWO_PI (2.0 * 3.141592653589793)
/* Python's max(a, b) and min(a, b) of two floats: the first unless the second compares larger (smaller),
 * so a NaN argument behaves as in Python. */
#define PY_MAX(a, b) ((b) > (a) ? (b) : (a))
#define PY_MIN(a, b) ((b) < (a) ? (b) : (a))

#define JOINTS 6
#define MAX_BRANCHES 8

/* The parameter vector (float64), built by wbik.solvers.analytic.ur_kernel.URKernel. */
enum {
    P_D1, P_A2, P_A3, P_D4, P_D5, P_D6,
    P_COSINE_TOLERANCE, P_WRIST_SINGULARITY, P_LIMIT_TOLERANCE, P_SCREEN_TOLERANCE, P_BOUND_SLACK,
    P_BRANCH_MERGE, P_HAS_TOOL,
    P_TOOL_R, /* 9 entries, row by row */
    P_TOOL_P = P_TOOL_R + 9,
    P_LOWER = P_TOOL_P + 3,
    P_UPPER = P_LOWER + JOINTS,
    P_COUNT = P_UPPER + JOINTS
};

typedef struct {
    double bound;
    double q[JOINTS];
} Branch;

/* --- the closed form (ur_type.branches_one, subproblems.planar_2r_one) --------------------------- */
static int planar_2r_one(double x, double y, double first, double second, double tolerance,
                         double solutions[2][2])
{
    double cosine = (x * x + y * y - first * first - second * second) / (2.0 * first * second);
    if (!(fabs(cosine) <= 1.0 + tolerance))
        return 0;
    cosine = PY_MIN(1.0, PY_MAX(-1.0, cosine));
    double sine = sqrt(1.0 - cosine * cosine);
    double reach = atan2(y, x);
    solutions[0][0] = reach - atan2(second * sine, first + second * cosine);
    solutions[0][1] = atan2(sine, cosine);
    solutions[1][0] = reach - atan2(-second * sine, first + second * cosine);
    solutions[1][1] = atan2(-sine, cosine);
    return 2;
}

static int branches_one(const double *params, const double position[3], const double rotation[9],
                        const double reference[JOINTS], Branch out[MAX_BRANCHES])
{
    const double d1 = params[P_D1], a2 = params[P_A2], a3 = params[P_A3];
    const double d4 = params[P_D4], d5 = params[P_D5], d6 = params[P_D6];
    const double tolerance = params[P_COSINE_TOLERANCE];
    const double x = position[0], y = position[1], z = position[2];
    const double r00 = rotation[0], r01 = rotation[1], r02 = rotation[2];
    const double r10 = rotation[3], r11 = rotation[4], r12 = rotation[5];
    const double r20 = rotation[6], r21 = rotation[7], r22 = rotation[8];
    const double t00 = r01, t01 = r02, t02 = -r00, t10 = r11, t11 = r12, t12 = -r10;
    const double t20 = -r21, t21 = -r22, t22 = r20;
    const double t03 = -x, t13 = -y, t23 = z;
    int count = 0;
    double a = d6 * t12 - t13, b = d6 * t02 - t03;
    double ratio = d4 / PY_MAX(sqrt(a * a + b * b), 1e-300);
    if (!(ratio <= 1.0 + tolerance))
        return 0;
    double offset = acos(PY_MIN(1.0, ratio));
    double shoulder = atan2(-b, a);
    for (int i1 = 0; i1 < 2; i1++) {
        double q1 = i1 == 0 ? shoulder + offset : shoulder - offset;
        double e1 = remainder(q1 - reference[0], TWO_PI);
        double bound1 = e1 * e1;
        double c1 = cos(q1), s1 = sin(q1);
        double cos5 = (t03 * s1 - t13 * c1 - d4) / d6;
        if (!(fabs(cos5) <= 1.0 + tolerance * PY_MAX((fabs(t03 * s1) + fabs(t13 * c1) + d4) / d6, 1.0)))
            continue;
        double u = t00 * s1 - t10 * c1, v = t01 * s1 - t11 * c1;
        double sine5 = sqrt(u * u + v * v);
        double angle5 = atan2(sine5, PY_MIN(1.0, PY_MAX(-1.0, cos5)));
        int singular = sine5 < params[P_WRIST_SINGULARITY];
        double r0 = t00 * c1 + t10 * s1, r1 = t01 * c1 + t11 * s1, r2 = t02 * c1 + t12 * s1;
        for (int i5 = 0; i5 < 2; i5++) {
            double q5 = i5 == 0 ? angle5 : -angle5;
            double c5 = cos(q5), s5 = sin(q5);
            double q6;
            if (singular) {
                q6 = reference[5];
            } else {
                double sign = s5 >= 0.0 ? 1.0 : -1.0;
                q6 = atan2(-sign * v, sign * u);
            }
            double e5 = remainder(q5 - reference[4], TWO_PI), e6 = remainder(q6 - reference[5], TWO_PI);
            double bound5 = bound1 + e5 * e5 + e6 * e6;
            double c6 = cos(q6), s6 = sin(q6);
            double x04x = -s5 * r2 - c5 * (s6 * r1 - c6 * r0);
            double x04y = c5 * (t20 * c6 - t21 * s6) - t22 * s5;
            double px = d5 * (s6 * r0 + c6 * r1) - d6 * r2 + t03 * c1 + t13 * s1;
            double py = t23 - d1 - d6 * t22 + d5 * (t21 * c6 + t20 * s6);
            double elbows[2][2];
            int solutions = planar_2r_one(px, py, a2, a3, tolerance, elbows);
            for (int k = 0; k < solutions; k++) {
                double q2 = elbows[k][0], q3 = elbows[k][1];
                double q23 = q2 + q3;
                double c23 = cos(q23), s23 = sin(q23);
                double q4 = atan2(c23 * x04y - s23 * x04x, x04x * c23 + x04y * s23);
                /* geometry.add_wrapped_squares(bound5, q2, ref2, q3, ref3, q4, ref4) */
                double ea = remainder(q2 - reference[1], TWO_PI), eb = remainder(q3 - reference[2], TWO_PI);
                double ec = remainder(q4 - reference[3], TWO_PI);
                Branch *branch = &out[count++];
                branch->bound = bound5 + ea * ea + eb * eb + ec * ec;
                branch->q[0] = q1;
                branch->q[1] = q2;
                branch->q[2] = q3;
                branch->q[3] = q4;
                branch->q[4] = q5;
                branch->q[5] = q6;
            }
        }
    }
    return count;
}

/* ur_type.fk_one, then ToolClosedForm.fk_one's tool when the parameters carry one. */
static void fk_one(const double *params, const double q[JOINTS], double position[3], double rotation[9])
{
    const double d1 = params[P_D1], a2 = params[P_A2], a3 = params[P_A3];
    const double d4 = params[P_D4], d5 = params[P_D5], d6 = params[P_D6];
    double q1 = q[0], q2 = q[1], q3 = q[2], q4 = q[3], q5 = q[4], q6 = q[5];
    double q23 = q2 + q3;
    double q234 = q23 + q4;
    double c1 = cos(q1), s1 = sin(q1), c2 = cos(q2), s2 = sin(q2);
    double c4 = cos(q4), s4 = sin(q4), c5 = cos(q5), s5 = sin(q5);
    double c6 = cos(q6), s6 = sin(q6), c23 = cos(q23), s23 = sin(q23);
    double c234 = cos(q234), s234 = sin(q234);
    double side = s1 * s5 + c234 * c1 * c5;
    double front = c1 * s5 - c234 * c5 * s1;
    double r[9] = {
        c234 * c1 * s5 - c5 * s1, c6 * side - s234 * c1 * s6, -s6 * side - s234 * c1 * c6,
        c1 * c5 + c234 * s1 * s5, -c6 * front - s234 * s1 * s6, s6 * front - s234 * c6 * s1,
        -s234 * s5, -c234 * s6 - s234 * c5 * c6, s234 * c5 * s6 - c234 * c6};
    double p[3] = {
        d6 * c234 * c1 * s5 - a3 * c23 * c1 - a2 * c1 * c2 - d6 * c5 * s1 - d5 * s234 * c1 - d4 * s1,
        d6 * (c1 * c5 + c234 * s1 * s5) + d4 * c1 - a3 * c23 * s1 - a2 * c2 * s1 - d5 * s234 * s1,
        d1 + a3 * s23 + a2 * s2 - d5 * (c23 * c4 - s23 * s4) - d6 * s5 * (c23 * s4 + s23 * c4)};
    if (params[P_HAS_TOOL] == 0.0) {
        memcpy(position, p, sizeof p);
        memcpy(rotation, r, sizeof r);
        return;
    }
    /* FK_tool = FK_flange X: p + R p_X, R R_X */
    const double *x = params + P_TOOL_R, *xp = params + P_TOOL_P;
    for (int i = 0; i < 3; i++) {
        double r0 = r[3 * i], r1 = r[3 * i + 1], r2 = r[3 * i + 2];
        position[i] = p[i] + r0 * xp[0] + r1 * xp[1] + r2 * xp[2];
        for (int j = 0; j < 3; j++)
            rotation[3 * i + j] = r0 * x[j] + r1 * x[3 + j] + r2 * x[6 + j];
    }
}

/* ToolClosedForm.branches_one's target transform: R_flange = R R_X^T, p_flange = p - R_flange p_X. */
static void flange_target(const double *params, const double position[3], const double rotation[9],
                          double flange_p[3], double flange_r[9])
{
    if (params[P_HAS_TOOL] == 0.0) {
        memcpy(flange_p, position, 3 * sizeof(double));
        memcpy(flange_r, rotation, 9 * sizeof(double));
        return;
    }
    const double *x = params + P_TOOL_R, *xp = params + P_TOOL_P;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            flange_r[3 * i + j] = rotation[3 * i] * x[3 * j] + rotation[3 * i + 1] * x[3 * j + 1]
                                  + rotation[3 * i + 2] * x[3 * j + 2];
    for (int i = 0; i < 3; i++)
        flange_p[i] = position[i] - (flange_r[3 * i] * xp[0] + flange_r[3 * i + 1] * xp[1]
                                     + flange_r[3 * i + 2] * xp[2]);
}

/* --- the choice (wbik.solvers.analytic) ----------------------------------------------------------- */
/* wrap_one_into_limits: 1 and the wrapped joints, or 0 when some angle has no shift inside its limits. */
static int wrap_one_into_limits(const double *params, const double q[JOINTS], const double reference[JOINTS],
                                double wrapped[JOINTS])
{
    static const double shifts[5] = {0.0, TWO_PI, -TWO_PI, 2 * TWO_PI, -2 * TWO_PI};
    const double tolerance = params[P_LIMIT_TOLERANCE];
    for (int i = 0; i < JOINTS; i++) {
        double value = q[i], ref = reference[i];
        double low = params[P_LOWER + i], high = params[P_UPPER + i];
        /* Python's round(): half to even, and an int, which has no -0.0 (+ 0.0 turns it into 0.0) */
        double turns = nearbyint((ref - value) / TWO_PI) + 0.0;
        double shifted = value + turns * TWO_PI;
        if (-2.0 <= turns && turns <= 2.0 && low - tolerance <= shifted && shifted <= high + tolerance) {
            wrapped[i] = shifted > high ? high : shifted < low ? low : shifted;
            continue;
        }
        int found = 0;
        double best = 0.0, best_distance = INFINITY;
        for (int k = 0; k < 5; k++) {
            shifted = value + shifts[k];
            if (low - tolerance <= shifted && shifted <= high + tolerance && fabs(shifted - ref) < best_distance) {
                best = shifted;
                best_distance = fabs(shifted - ref);
                found = 1;
            }
        }
        if (!found)
            return 0;
        wrapped[i] = PY_MIN(high, PY_MAX(low, best));
    }
    return 1;
}

/* screen_residual(reached, position, rotation): max(|p - p*|, angle(R*^T R)) of a reached pose
 * (the caller computes reached = fk_one(q) and may keep it for the check). */
static double residual(const double reached_p[3], const double reached_r[9], const double position[3],
                       const double rotation[9])
{
    double dx = reached_p[0] - position[0], dy = reached_p[1] - position[1], dz = reached_p[2] - position[2];
    double error = sqrt(dx * dx + dy * dy + dz * dz);
    double trace = 0.0;
    for (int k = 0; k < 9; k++)
        trace += reached_r[k] * rotation[k];
    double angle = acos(PY_MIN(1.0, PY_MAX(-1.0, 0.5 * (trace - 1.0))));
    return PY_MAX(error, angle);
}

static double squared_distance(const double a[JOINTS], const double b[JOINTS])
{
    double total = 0.0;
    for (int i = 0; i < JOINTS; i++) {
        double e = a[i] - b[i];
        total += e * e;
    }
    return total;
}

/* --- argument handling ------------------------------------------------------------------------------ */
/* (params, position, rotation, reference): the common arguments, read into C arrays. */
static int read_arguments(const char *function, PyObject *const *args, Py_ssize_t nargs, Py_ssize_t expected,
                          double params[P_COUNT], double position[3], double rotation[9], double reference[JOINTS])
{
    if (check_count(function, nargs, expected) < 0 || read_doubles(args[0], params, P_COUNT, -1, "params") < 0
        || read_doubles(args[1], position, 3, -1, "position") < 0
        || read_doubles(args[2], rotation, 9, -1, "rotation") < 0
        || read_doubles(args[3], reference, JOINTS, -1, "reference") < 0)
        return -1;
    return 0;
}

/* The branch AnalyticSolver._solve picks (nearest_branch over branches_one): written into best (6,),
 * with the batched check's errors of its closed-form FK into errors (8,) unless errors is NULL.
 * Returns 1 when one is picked, else 0 (no real branch), -1 (real branches, none inside the limits) or
 * -2 (some inside the limits, none passes the screen); *real_count gets the number of real branches. */
static int choose(const double *params, const double position[3], const double rotation[9],
                  const double reference[JOINTS], double best[JOINTS], double *errors, int *real_count)
{
    double flange_p[3], flange_r[9];
    flange_target(params, position, rotation, flange_p, flange_r);
    Branch branches[MAX_BRANCHES];
    int count = branches_one(params, flange_p, flange_r, reference, branches);
    *real_count = count;
    /* bounded.sort(key=bound): stable insertion sort of the branch indices */
    int order[MAX_BRANCHES];
    for (int i = 0; i < count; i++) {
        int j = i;
        while (j > 0 && branches[order[j - 1]].bound > branches[i].bound) {
            order[j] = order[j - 1];
            j--;
        }
        order[j] = i;
    }
    double slack = (double)JOINTS * params[P_BOUND_SLACK];
    double best_distance = INFINITY, best_p[3], best_r[9];
    int found = 0, inside = 0;
    double tolerance = params[P_SCREEN_TOLERANCE];
    for (int k = 0; k < count; k++) {
        const Branch *branch = &branches[order[k]];
        if (branch->bound - slack >= best_distance)
            break;
        if (!(branch->bound < INFINITY))
            continue;
        double q[JOINTS];
        if (!wrap_one_into_limits(params, branch->q, reference, q))
            continue;
        inside = 1;
        double distance = squared_distance(q, reference);
        if (!(distance < best_distance))
            continue;
        double reached_p[3], reached_r[9];
        fk_one(params, q, reached_p, reached_r);
        if (residual(reached_p, reached_r, position, rotation) <= tolerance) {
            memcpy(best, q, JOINTS * sizeof(double));
            memcpy(best_p, reached_p, sizeof best_p);
            memcpy(best_r, reached_r, sizeof best_r);
            best_distance = distance;
            found = 1;
        }
    }
    if (!found)
        return count == 0 ? 0 : inside ? -2 : -1;
    if (errors != NULL)
        pose_errors(best_p, best_r, position, rotation, errors);
    return 1;
}

/* nearest(params, position, rotation, reference, out) -> int
 * choose() for one target, the joints written into out (6,). Returns the number of real branches when
 * one is picked, else choose()'s failure code (0, -1 or -2). */
static PyObject *nearest(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    double params[P_COUNT], position[3], rotation[9], reference[JOINTS], best[JOINTS];
    if (read_arguments("nearest", args, nargs, 5, params, position, rotation, reference) < 0)
        return NULL;
    int count;
    int outcome = choose(params, position, rotation, reference, best, NULL, &count);
    if (outcome != 1)
        return PyLong_FromLong(outcome);
    if (write_doubles(args[4], best, JOINTS, "out") < 0)
        return NULL;
    return PyLong_FromLong(count);
}

/* nearest_many(params, positions, rotations, references, q, errors, info) -> None
 * choose() for B targets: positions (B, 3), rotations (B, 3, 3), references (B, 6), all C-contiguous
 * float64; writes the joints into q (B, 6) (zeros where none is picked), the errors into errors (B, 8)
 * (zeros likewise) and (real branch count, outcome) into info (B, 2). The GIL is released meanwhile. */
static PyObject *nearest_many(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    double params[P_COUNT];
    if (check_count("nearest_many", nargs, 7) < 0 || read_doubles(args[0], params, P_COUNT, -1, "params") < 0)
        return NULL;
    Py_buffer views[6];
    static const char *names[6] = {"positions", "rotations", "references", "q", "errors", "info"};
    static const Py_ssize_t widths[6] = {3, 9, JOINTS, JOINTS, 8, 2};
    Py_buffer first;
    if (PyObject_GetBuffer(args[1], &first, PyBUF_ND) < 0)
        return NULL;
    Py_ssize_t batch = first.ndim >= 1 ? first.shape[0] : -1;
    PyBuffer_Release(&first);
    if (batch < 0) {
        PyErr_SetString(PyExc_TypeError, "positions: expected an array of shape (B, 3)");
        return NULL;
    }
    int held = 0;
    for (; held < 6; held++)
        if (contiguous_view(args[1 + held], &views[held], batch * widths[held], held >= 3, names[held]) < 0)
            break;
    if (held == 6) {
        const double *positions = views[0].buf, *rotations = views[1].buf, *references = views[2].buf;
        double *q = views[3].buf, *errors = views[4].buf, *info = views[5].buf;
        Py_BEGIN_ALLOW_THREADS
        for (Py_ssize_t b = 0; b < batch; b++) {
            int count;
            int outcome = choose(params, positions + 3 * b, rotations + 9 * b, references + JOINTS * b,
                                 q + JOINTS * b, errors + 8 * b, &count);
            if (outcome != 1) {
                memset(q + JOINTS * b, 0, JOINTS * sizeof(double));
                memset(errors + 8 * b, 0, 8 * sizeof(double));
            }
            info[2 * b] = count;
            info[2 * b + 1] = outcome;
        }
        Py_END_ALLOW_THREADS
    }
    for (int i = 0; i < held; i++)
        PyBuffer_Release(&views[i]);
    if (held < 6)
        return NULL;
    Py_RETURN_NONE;
}

/* AnalyticSolver._distinct_one: in branch order, every branch wrapped into the limits nearest to the
 * reference that is not within BRANCH_MERGE (modulo 2 pi, every joint) of an earlier kept one and
 * passes the screen, into the first rows of kept (8, 6), with their errors (pose_errors, with the
 * closed-form FK, tool included) into the rows of errors (8, 8); returns how many. */
static int distinct_branches(const double *params, const double position[3], const double rotation[9],
                             const double reference[JOINTS], double kept[MAX_BRANCHES * JOINTS],
                             double errors[MAX_BRANCHES * 8])
{
    double flange_p[3], flange_r[9];
    flange_target(params, position, rotation, flange_p, flange_r);
    Branch branches[MAX_BRANCHES];
    int count = branches_one(params, flange_p, flange_r, reference, branches);
    int kept_count = 0;
    double merge = params[P_BRANCH_MERGE], tolerance = params[P_SCREEN_TOLERANCE];
    for (int k = 0; k < count; k++) {
        double *q = kept + kept_count * JOINTS;
        if (!wrap_one_into_limits(params, branches[k].q, reference, q))
            continue;
        int duplicate = 0;
        for (int other = 0; other < kept_count && !duplicate; other++) {
            int same = 1;
            for (int i = 0; i < JOINTS && same; i++)
                same = fabs(remainder(q[i] - kept[other * JOINTS + i], TWO_PI)) < merge;
            duplicate = same;
        }
        if (duplicate)
            continue;
        double reached_p[3], reached_r[9];
        fk_one(params, q, reached_p, reached_r);
        if (residual(reached_p, reached_r, position, rotation) <= tolerance) {
            pose_errors(reached_p, reached_r, position, rotation, errors + 8 * kept_count);
            kept_count++;
        }
    }
    return kept_count;
}

/* distinct(params, position, rotation, reference, out, errors) -> int
 * distinct_branches(), written into out (8, 6) and errors (8, 8); returns how many rows are kept (the
 * rows after them hold no answer: errors zeros, out zeros or a rejected branch). */
static PyObject *distinct(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    double params[P_COUNT], position[3], rotation[9], reference[JOINTS];
    if (read_arguments("distinct", args, nargs, 6, params, position, rotation, reference) < 0)
        return NULL;
    double kept[MAX_BRANCHES * JOINTS] = {0.0}, errors[MAX_BRANCHES * 8] = {0.0};
    int kept_count = distinct_branches(params, position, rotation, reference, kept, errors);
    if (write_doubles(args[4], kept, MAX_BRANCHES * JOINTS, "out") < 0
        || write_doubles(args[5], errors, MAX_BRANCHES * 8, "errors") < 0)
        return NULL;
    return PyLong_FromLong(kept_count);
}

/* fk(params, q, out) -> None: the kernel's FK of q (6,), tool included, into out (12: position, then
 * rotation row by row); for the agreement tests. */
static PyObject *fk(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    double params[P_COUNT], q[JOINTS], pose[12];
    if (check_count("fk", nargs, 3) < 0 || read_doubles(args[0], params, P_COUNT, -1, "params") < 0
        || read_doubles(args[1], q, JOINTS, -1, "q") < 0)
        return NULL;
    fk_one(params, q, pose, pose + 3);
    if (write_doubles(args[2], pose, 12, "out") < 0)
        return NULL;
    Py_RETURN_NONE;
}

static PyMethodDef methods[] = {
    {"nearest", (PyCFunction)(void (*)(void))nearest, METH_FASTCALL,
     "nearest(params, position, rotation, reference, out) -> int: the chosen branch into out"},
    {"nearest_many", (PyCFunction)(void (*)(void))nearest_many, METH_FASTCALL,
     "nearest_many(params, positions, rotations, references, q, errors, info): nearest for a batch"},
    {"distinct", (PyCFunction)(void (*)(void))distinct, METH_FASTCALL,
     "distinct(params, position, rotation, reference, out, errors) -> int: the distinct screened branches"},
    {"fk", (PyCFunction)(void (*)(void))fk, METH_FASTCALL, "fk(params, q, out): the FK into out (12,)"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_ur_type",
                                    "Compiled scalar path of the UR-type closed form (see ur_kernel.py).", -1,
                                    methods};

PyMODINIT_FUNC PyInit__ur_type(void)
{
    PyObject *m = PyModule_Create(&module);
    if (m != NULL && PyModule_AddIntConstant(m, "PARAMETER_COUNT", P_COUNT) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
