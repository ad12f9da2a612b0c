/* The compiled choice of a closed form, shared by the family kernels (_ur_type.c, _stacked_planar.c): what
 * wbik.solvers.analytic.solver.AnalyticSolver does with a form's vectorised branches, for one target at a
 * time, operation by operation as the NumPy code does it (its twin):
 *
 *   the target into the family's frames (AlignedForm.family_targets: G^-1 T X^-1), the start into its
 *   joints (u = s q + o), the family's branches (family_branches), back into the chain's joints
 *   (q = (u - o) s), each wrapped into the limits nearest the start (closed_form.wrap_into_limits), the
 *   usable ones ordered by |q - q0| (first on a tie), screened in that order with the closed-form FK
 *   (family_fk, then X and G) until one passes (AnalyticSolver._screen).
 *
 * A family's file defines MAX_BRANCHES and FAMILY_NUMBERS (how many numbers of its own follow P_FAMILY),
 * includes this header, defines family_branches and family_fk, and ends with CLOSED_FORM_MODULE. Built without FMA contraction
 * (-ffp-contract=off); the transcendental functions are libm's, which NumPy's equal except where it
 * vectorises them (arctan2 and arccos under AVX-512 differ by up to one ulp). */
#ifndef WBIK_CLOSED_FORM_H
#define WBIK_CLOSED_FORM_H

#include "_buffers.h"
#include "_pose_errors.h"
#include <math.h>

#define PI 3.141592653589793
#define TWO_PI (2.0 * PI)
#define JOINTS 6

/* The parameter vector (float64), packed by wbik.solvers.analytic.compiled.CompiledForm. */
enum {
    P_LIMIT_TOLERANCE, P_SCREEN_TOLERANCE, P_BRANCH_MERGE,
    P_PLAIN_BASE, P_BASE_R, P_BASE_P = P_BASE_R + 9,          /* G, rotation row by row */
    P_PLAIN_TOOL = P_BASE_P + 3, P_TOOL_R, P_TOOL_P = P_TOOL_R + 9, /* X */
    P_PLAIN_JOINTS = P_TOOL_P + 3, P_SIGNS, P_OFFSETS = P_SIGNS + JOINTS,
    P_LOWER = P_OFFSETS + JOINTS, P_UPPER = P_LOWER + JOINTS,
    P_FAMILY = P_UPPER + JOINTS,                              /* the family's own numbers */
    P_COUNT = P_FAMILY + FAMILY_NUMBERS
};

/* The family's branches of a target in its frames, u0 the start in its joints: every branch (real or not)
 * into q[k], real[k] whether it exists; returns how many (at most MAX_BRANCHES). */
static int family_branches(const double *params, const double p[3], const double r[9], const double u0[JOINTS],
                           double q[MAX_BRANCHES][JOINTS], int real[MAX_BRANCHES]);
/* The family's FK of joints u in its frames: position (3), rotation row by row (9). */
static void family_fk(const double *params, const double u[JOINTS], double p[3], double r[9]);

/* NumPy's clip (minimum(maximum(x, low), high)) and maximum of two floats: NaN propagates. */
static inline double np_clip(double x, double low, double high)
{
    if (isnan(x))
        return x;
    x = x > low ? x : low;
    return x < high ? x : high;
}

static inline double np_maximum(double a, double b)
{
    return (isnan(a) || a >= b) ? a : b;
}

/* AlignedForm.family_targets: p' = G_R^T (p - G_p), R' = G_R^T R; then R'' = R' X_R^T, p'' = p' - R'' X_p. */
static void family_target(const double *params, const double p[3], const double r[9], double fp[3], double fr[9])
{
    memcpy(fp, p, 3 * sizeof(double));
    memcpy(fr, r, 9 * sizeof(double));
    if (params[P_PLAIN_BASE] == 0.0) {
        const double *g = params + P_BASE_R, *gp = params + P_BASE_P;
        double d[3] = {p[0] - gp[0], p[1] - gp[1], p[2] - gp[2]};
        for (int j = 0; j < 3; j++) {
            fp[j] = d[0] * g[j] + d[1] * g[3 + j] + d[2] * g[6 + j];
            for (int k = 0; k < 3; k++)
                fr[3 * j + k] = g[j] * r[k] + g[3 + j] * r[3 + k] + g[6 + j] * r[6 + k];
        }
    }
    if (params[P_PLAIN_TOOL] == 0.0) {
        const double *x = params + P_TOOL_R, *xp = params + P_TOOL_P;
        double rotated[9];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                rotated[3 * i + j] = fr[3 * i] * x[3 * j] + fr[3 * i + 1] * x[3 * j + 1] + fr[3 * i + 2] * x[3 * j + 2];
        memcpy(fr, rotated, sizeof rotated);
        for (int i = 0; i < 3; i++)
            fp[i] = fp[i] - (fr[3 * i] * xp[0] + fr[3 * i + 1] * xp[1] + fr[3 * i + 2] * xp[2]);
    }
}

/* AlignedForm.fk: u = q s + o, the family's FK, then p + R X_p, R X_R, then G_R p + G_p, G_R R. */
static void chain_fk(const double *params, const double q[JOINTS], double p[3], double r[9])
{
    double u[JOINTS];
    for (int i = 0; i < JOINTS; i++)
        u[i] = params[P_PLAIN_JOINTS] == 0.0 ? q[i] * params[P_SIGNS + i] + params[P_OFFSETS + i] : q[i];
    family_fk(params, u, p, r);
    if (params[P_PLAIN_TOOL] == 0.0) {
        const double *x = params + P_TOOL_R, *xp = params + P_TOOL_P;
        double composed[9];
        for (int i = 0; i < 3; i++) {
            p[i] = p[i] + (r[3 * i] * xp[0] + r[3 * i + 1] * xp[1] + r[3 * i + 2] * xp[2]);
            for (int j = 0; j < 3; j++)
                composed[3 * i + j] = r[3 * i] * x[j] + r[3 * i + 1] * x[3 + j] + r[3 * i + 2] * x[6 + j];
        }
        memcpy(r, composed, sizeof composed);
    }
    if (params[P_PLAIN_BASE] == 0.0) {
        const double *g = params + P_BASE_R, *gp = params + P_BASE_P;
        double moved[3], turned[9];
        for (int i = 0; i < 3; i++) {
            moved[i] = (g[3 * i] * p[0] + g[3 * i + 1] * p[1] + g[3 * i + 2] * p[2]) + gp[i];
            for (int j = 0; j < 3; j++)
                turned[3 * i + j] = g[3 * i] * r[j] + g[3 * i + 1] * r[3 + j] + g[3 * i + 2] * r[6 + j];
        }
        memcpy(p, moved, sizeof moved);
        memcpy(r, turned, sizeof turned);
    }
}

/* closed_form.wrap_into_limits for one joint vector (all revolute): 1 when every angle has a 2 pi shift
 * inside its limits, the wrapped joints in wrapped. */
static int wrap_joints(const double *params, const double q[JOINTS], const double reference[JOINTS],
                       double wrapped[JOINTS])
{
    static const double shifts[5] = {0.0, TWO_PI, -TWO_PI, 2 * TWO_PI, -2 * TWO_PI};
    const double tolerance = params[P_LIMIT_TOLERANCE];
    int all_inside = 1;
    for (int i = 0; i < JOINTS; i++) {
        double value = q[i], ref = reference[i], lower = params[P_LOWER + i], upper = params[P_UPPER + i];
        double low = lower - tolerance, high = upper + tolerance;
        double turns = (ref - value) * (1.0 / TWO_PI);
        turns = np_clip(nearbyint(turns), -2.0, 2.0);
        double shifted = turns * TWO_PI;
        shifted += 0.0;
        shifted += value;
        int inside = fabs(shifted - ref) <= PI - 1e-9 && shifted >= low && shifted <= high;
        if (!inside) {
            double best = value, best_distance = INFINITY;
            for (int k = 0; k < 5; k++) {
                double candidate = value + shifts[k];
                int ok = candidate >= low && candidate <= high;
                double distance = fabs(candidate - ref);
                if (ok && distance < best_distance) {
                    best = candidate;
                    best_distance = distance;
                }
                inside |= ok;
            }
            shifted = best;
        }
        all_inside &= inside;
        wrapped[i] = np_clip(shifted, lower, upper);
    }
    return all_inside;
}

/* AnalyticSolver._screen: the closed-form FK of q and whether max(|p - p*|, angle(R*^T R)) <= tolerance,
 * the trace summed row by row. */
static int screen(const double *params, const double q[JOINTS], const double position[3],
                  const double rotation[9], double reached_p[3], double reached_r[9])
{
    chain_fk(params, q, reached_p, reached_r);
    double dx = reached_p[0] - position[0], dy = reached_p[1] - position[1], dz = reached_p[2] - position[2];
    double residual = sqrt(dx * dx + dy * dy + dz * dz);
    double trace = rotation[0] * reached_r[0];
    for (int k = 1; k < 9; k++)
        trace = trace + rotation[k] * reached_r[k];
    residual = np_maximum(residual, acos(np_clip((trace - 1.0) / 2.0, -1.0, 1.0)));
    return residual <= params[P_SCREEN_TOLERANCE];
}

/* AnalyticSolver._wrapped_by_joint for one target: every branch in the chain's joints, wrapped into the
 * limits nearest the reference; usable[k] = real and inside the limits; returns the branch count and the
 * number of real ones in *real_count. */
static int wrapped_branches(const double *params, const double position[3], const double rotation[9],
                            const double reference[JOINTS], double q[MAX_BRANCHES][JOINTS],
                            int usable[MAX_BRANCHES], int *real_count)
{
    double fp[3], fr[9], u0[JOINTS], u[MAX_BRANCHES][JOINTS];
    int plain = params[P_PLAIN_JOINTS] != 0.0;
    family_target(params, position, rotation, fp, fr);
    for (int i = 0; i < JOINTS; i++)
        u0[i] = plain ? reference[i] : reference[i] * params[P_SIGNS + i] + params[P_OFFSETS + i];
    int count = family_branches(params, fp, fr, u0, u, usable);
    *real_count = 0;
    for (int k = 0; k < count; k++) {
        double raw[JOINTS];
        for (int i = 0; i < JOINTS; i++)
            raw[i] = plain ? u[k][i] : (u[k][i] - params[P_OFFSETS + i]) * params[P_SIGNS + i];
        *real_count += usable[k];
        int inside = wrap_joints(params, raw, reference, q[k]);
        usable[k] = usable[k] && inside;
    }
    return count;
}

/* AnalyticSolver._choose for one target: the usable branches by |q - q0| (sqrt of the squares summed in
 * joint order; the first on a tie), screened in that order; the first that passes into best (6,), and the
 * batched check's errors of its FK into errors (8,) unless NULL. Returns 1, or 0 (no real branch), -1 (none
 * inside the limits), -2 (none passes the screen); the real branches counted in *real_count. */
static int choose(const double *params, const double position[3], const double rotation[9],
                  const double reference[JOINTS], double best[JOINTS], double *errors, int *real_count)
{
    double q[MAX_BRANCHES][JOINTS], distance[MAX_BRANCHES];
    int usable[MAX_BRANCHES], order[MAX_BRANCHES], count_usable = 0;
    int count = wrapped_branches(params, position, rotation, reference, q, usable, real_count);
    for (int k = 0; k < count; k++) {
        if (!usable[k])
            continue;
        double total = 0.0;
        for (int i = 0; i < JOINTS; i++) {
            double difference = q[k][i] - reference[i];
            total = i == 0 ? difference * difference : total + difference * difference;
        }
        distance[k] = sqrt(total);
        int j = count_usable++; /* stable insertion by distance */
        while (j > 0 && distance[order[j - 1]] > distance[k]) {
            order[j] = order[j - 1];
            j--;
        }
        order[j] = k;
    }
    for (int rank = 0; rank < count_usable; rank++) {
        double reached_p[3], reached_r[9];
        const double *candidate = q[order[rank]];
        if (screen(params, candidate, position, rotation, reached_p, reached_r)) {
            memcpy(best, candidate, JOINTS * sizeof(double));
            if (errors != NULL)
                pose_errors(reached_p, reached_r, position, rotation, errors);
            return 1;
        }
    }
    return *real_count == 0 ? 0 : count_usable ? -2 : -1;
}

/* numpy.mod(a, b) (fmod, then the divisor's sign) and geometry.wrap_to_pi: pi - mod(pi - a, 2 pi). */
static inline double wrap_to_pi(double a)
{
    double x = PI - a, m = fmod(x, TWO_PI);
    if (m != 0.0) {
        if ((TWO_PI < 0) != (m < 0))
            m += TWO_PI;
    } else {
        m = copysign(0.0, TWO_PI);
    }
    return PI - m;
}

/* AnalyticSolver.solve_all's vectorised path for one target: in branch order, the usable branches (wrapped
 * nearest the reference) that pass the screen and are not within BRANCH_MERGE (geometry.joint_gap) of one
 * kept before, into kept (MAX_BRANCHES, 6), their errors into errors (MAX_BRANCHES, 8); returns how many. */
static int distinct_branches(const double *params, const double position[3], const double rotation[9],
                             const double reference[JOINTS], double *kept, double *errors)
{
    double q[MAX_BRANCHES][JOINTS];
    int usable[MAX_BRANCHES], real_count, kept_count = 0;
    int count = wrapped_branches(params, position, rotation, reference, q, usable, &real_count);
    for (int k = 0; k < count; k++) {
        double reached_p[3], reached_r[9];
        if (!usable[k] || !screen(params, q[k], position, rotation, reached_p, reached_r))
            continue;
        int duplicate = 0;
        for (int other = 0; other < kept_count && !duplicate; other++) {
            int same = 1;
            for (int i = 0; i < JOINTS && same; i++)
                same = fabs(wrap_to_pi(q[k][i] - kept[other * JOINTS + i])) < params[P_BRANCH_MERGE];
            duplicate = same;
        }
        if (duplicate)
            continue;
        memcpy(kept + kept_count * JOINTS, q[k], JOINTS * sizeof(double));
        pose_errors(reached_p, reached_r, position, rotation, errors + 8 * kept_count);
        kept_count++;
    }
    return kept_count;
}

/* --- the module's functions ------------------------------------------------------------------------- */
static int read_arguments(const char *function, PyObject *const *args, Py_ssize_t nargs, Py_ssize_t expected,
                          double *params, double position[3], double rotation[9], double reference[JOINTS])
{
    if (check_count(function, nargs, expected) < 0 || read_doubles(args[0], params, P_COUNT, -1, "params") < 0
        || read_doubles(args[1], position, 3, -1, "position") < 0
        || read_doubles(args[2], rotation, 9, -1, "rotation") < 0
        || read_doubles(args[3], reference, JOINTS, -1, "reference") < 0)
        return -1;
    return 0;
}

/* nearest(params, position, rotation, reference, out) -> int: choose() into out (6,); the number of real
 * branches when one is picked, else the failure code. */
static PyObject *nearest(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    double params[P_COUNT], position[3], rotation[9], reference[JOINTS], best[JOINTS];
    if (read_arguments("nearest", args, nargs, 5, params, position, rotation, reference) < 0)
        return NULL;
    int count, outcome = choose(params, position, rotation, reference, best, NULL, &count);
    if (outcome != 1)
        return PyLong_FromLong(outcome);
    if (write_doubles(args[4], best, JOINTS, "out") < 0)
        return NULL;
    return PyLong_FromLong(count);
}

/* nearest_many(params, positions, rotations, references, q, errors, info) -> None: choose() for B targets
 * ((B, 3), (B, 3, 3), (B, 6), C-contiguous float64) into q (B, 6) and errors (B, 8) (zeros where none is
 * picked), (real branch count, outcome) into info (B, 2); without the GIL. */
static PyObject *nearest_many(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    double params[P_COUNT];
    if (check_count("nearest_many", nargs, 7) < 0 || read_doubles(args[0], params, P_COUNT, -1, "params") < 0)
        return NULL;
    Py_buffer views[6], first;
    static const char *names[6] = {"positions", "rotations", "references", "q", "errors", "info"};
    static const Py_ssize_t widths[6] = {3, 9, JOINTS, JOINTS, 8, 2};
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
            int count, outcome = choose(params, positions + 3 * b, rotations + 9 * b, references + JOINTS * b,
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
    release_views(views, held);
    if (held < 6)
        return NULL;
    Py_RETURN_NONE;
}

/* distinct(params, position, rotation, reference, out, errors) -> int: distinct_branches() into out
 * (MAX_BRANCHES, 6) and errors (MAX_BRANCHES, 8); how many rows are kept. */
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

/* fk(params, q, out) -> None: the closed-form FK of q (6,) in the chain's frames into out (12: position,
 * rotation row by row). */
static PyObject *fk(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    double params[P_COUNT], q[JOINTS], pose[12];
    if (check_count("fk", nargs, 3) < 0 || read_doubles(args[0], params, P_COUNT, -1, "params") < 0
        || read_doubles(args[1], q, JOINTS, -1, "q") < 0)
        return NULL;
    chain_fk(params, q, pose, pose + 3);
    if (write_doubles(args[2], pose, 12, "out") < 0)
        return NULL;
    Py_RETURN_NONE;
}

static PyMethodDef closed_form_methods[] = {
    {"nearest", (PyCFunction)(void (*)(void))nearest, METH_FASTCALL,
     "nearest(params, position, rotation, reference, out) -> int: the chosen branch into out"},
    {"nearest_many", (PyCFunction)(void (*)(void))nearest_many, METH_FASTCALL,
     "nearest_many(params, positions, rotations, references, q, errors, info): nearest for a batch"},
    {"distinct", (PyCFunction)(void (*)(void))distinct, METH_FASTCALL,
     "distinct(params, position, rotation, reference, out, errors) -> int: the distinct screened branches"},
    {"fk", (PyCFunction)(void (*)(void))fk, METH_FASTCALL, "fk(params, q, out): the FK into out (12,)"},
    {NULL, NULL, 0, NULL}};

/* The extension module wbik.kernels.<name>, exporting PARAMETER_COUNT and MAX_BRANCHES. */
#define CLOSED_FORM_MODULE(name, doc)                                                                        \
    static struct PyModuleDef closed_form_module = {PyModuleDef_HEAD_INIT, #name, doc, -1,                  \
                                                    closed_form_methods, NULL, NULL, NULL, NULL};           \
    PyMODINIT_FUNC PyInit_##name(void)                                                                       \
    {                                                                                                        \
        PyObject *m = PyModule_Create(&closed_form_module);                                                  \
        if (m != NULL && (PyModule_AddIntConstant(m, "PARAMETER_COUNT", P_COUNT) < 0                         \
                          || PyModule_AddIntConstant(m, "MAX_BRANCHES", MAX_BRANCHES) < 0)) {                \
            Py_DECREF(m);                                                                                    \
            return NULL;                                                                                     \
        }                                                                                                    \
        return m;                                                                                            \
    }

#endif
