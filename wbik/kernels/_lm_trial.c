/* Compiled twins of bounded_lm's Levenberg-Marquardt (the Python module wbik.kernels._lm_trial): one trial,
 * the policy of wbik.solvers.levenberg_marquardt (LevenbergMarquardt.trial with its helpers _descent,
 * _capped, _frozen_descent, JointBounds.blocked and .project), and a whole attempt on a pose target
 * (BoundedLMSolver._attempt with its residual, the trial and LevenbergMarquardt.update).
 *
 * The trial:
 *     descent = (J^T J + lambda I)^-1 J^T e   (n <= m)   or   J^T (J J^T + lambda I)^-1 e   (n > m),
 *     by Cholesky; capped to max_step; trial = q - descent, clipped into the limits; if it left them,
 *     the joints it leaves at q on a bound (clipped joints only) are frozen and the step recomputed on
 *     the free ones; the result projected (full-turn joints wrapped by 2 pi, the others clipped).
 * The same decisions as the Python twin, with the sums in index order in C (-ffp-contract=off) instead
 * of BLAS and LAPACK's: the two agree to rounding, not to the bit (tests/test_lm_kernel.py), and this one
 * gives the same bits on every CPU. Where the damped system is not numerically positive definite
 * (Cholesky fails) the trial gives 0 and the Python twin, with its least-squares fallback, decides.
 *
 * The attempt takes the chain in wbik.solvers.vectorised_chain's form: T(q) = F A_1(q_1) ... A_n(q_n),
 * A_k = C0_k + f_k C1_k + g_k C2_k (f = sin q, g = 1 - cos q; prismatic f = q), frame k's z its joint's
 * axis; its residual is VectorisedChain.evaluate's: e = log6(T*^-1 T) with the tip-axes Jacobian, both
 * turned into base axes (the same |e|, J^T J and J^T e), lengths x the position weight w. The FK sums in
 * another order than Pinocchio's, so the attempt agrees with the Python one to rounding
 * (tests/test_lm_attempt.py). Its deadline is time.perf_counter()'s clock (CLOCK_MONOTONIC). Where the
 * Python twin would take a path this one does not have (a Cholesky failure: least squares; a rotation
 * error within 1e-6 of pi: Pinocchio's log3) it returns None and the Python attempt runs from the seed.
 */
#include "_buffers.h"
#include <math.h>
#include <string.h>
#include <time.h>


#define MAX_SIZE 32 /* joints or residual rows; larger problems take the Python twin (a few kB of stack) */
#define TWO_PI 6.283185307179586

/* Solve A x = b for a symmetric size x size A (row-major, overwritten by its Cholesky factor L, lower),
 * in place in b. 0 when a pivot is not positive (or NaN). */
static int cholesky_solve(double *A, int size, double *b)
{
    for (int j = 0; j < size; j++) {
        double pivot = A[j * size + j];
        for (int k = 0; k < j; k++)
            pivot -= A[j * size + k] * A[j * size + k];
        if (!(pivot > 0.0))
            return 0;
        const double root = sqrt(pivot);
        A[j * size + j] = root;
        for (int i = j + 1; i < size; i++) {
            double value = A[i * size + j];
            for (int k = 0; k < j; k++)
                value -= A[i * size + k] * A[j * size + k];
            A[i * size + j] = value / root;
        }
    }
    for (int i = 0; i < size; i++) { /* L y = b */
        double value = b[i];
        for (int k = 0; k < i; k++)
            value -= A[i * size + k] * b[k];
        b[i] = value / A[i * size + i];
    }
    for (int i = size - 1; i >= 0; i--) { /* L^T x = y */
        double value = b[i];
        for (int k = i + 1; k < size; k++)
            value -= A[k * size + i] * b[k];
        b[i] = value / A[i * size + i];
    }
    return 1;
}

/* The descent on the joints listed in columns (count of them; the others get 0): the smaller of the two
 * damped systems, as _descent. J row-major m x n. 0 when Cholesky fails. */
static int damped_descent(const double *J, int m, int n, const int *columns, int count, const double *e,
                          double damping, double *descent)
{
    double system[MAX_SIZE * MAX_SIZE], right[MAX_SIZE];
    for (int j = 0; j < n; j++)
        descent[j] = 0.0;
    if (count == 0)
        return 1;
    if (count <= m) { /* (J_f^T J_f + lambda I) d_f = J_f^T e */
        for (int a = 0; a < count; a++) {
            for (int b = 0; b < count; b++) {
                double sum = 0.0;
                for (int i = 0; i < m; i++)
                    sum += J[i * n + columns[a]] * J[i * n + columns[b]];
                system[a * count + b] = sum;
            }
            system[a * count + a] += damping;
            double sum = 0.0;
            for (int i = 0; i < m; i++)
                sum += J[i * n + columns[a]] * e[i];
            right[a] = sum;
        }
        if (!cholesky_solve(system, count, right))
            return 0;
        for (int a = 0; a < count; a++)
            descent[columns[a]] = right[a];
        return 1;
    }
    /* d_f = J_f^T (J_f J_f^T + lambda I)^-1 e */
    for (int i = 0; i < m; i++) {
        for (int k = 0; k < m; k++) {
            double sum = 0.0;
            for (int a = 0; a < count; a++)
                sum += J[i * n + columns[a]] * J[k * n + columns[a]];
            system[i * m + k] = sum;
        }
        system[i * m + i] += damping;
        right[i] = e[i];
    }
    if (!cholesky_solve(system, m, right))
        return 0;
    for (int a = 0; a < count; a++) {
        double sum = 0.0;
        for (int i = 0; i < m; i++)
            sum += J[i * n + columns[a]] * right[i];
        descent[columns[a]] = sum;
    }
    return 1;
}

/* _capped: scale the step so its largest |entry| is max_step (no cap when max_step < 0; a NaN entry
 * makes the largest NaN, which caps nothing, as NumPy's max does). */
static void cap(double *step, int n, double max_step)
{
    if (max_step < 0.0)
        return;
    double longest = 0.0;
    int seen_nan = 0;
    for (int j = 0; j < n; j++) {
        const double size = fabs(step[j]);
        seen_nan |= isnan(size);
        if (size > longest)
            longest = size;
    }
    if (seen_nan || !(longest > max_step))
        return;
    const double scale = max_step / longest;
    for (int j = 0; j < n; j++)
        step[j] = step[j] * scale;
}

/* min(max(x, lower), upper), a NaN staying NaN (clip_to_limits) */
static double clip(double x, double lower, double upper)
{
    if (isnan(x))
        return x;
    const double low = x < lower ? lower : x;
    return low > upper ? upper : low;
}

/* NumPy's float mod by 2 pi (the sign of the divisor; +0 for an exact multiple) */
static double mod_two_pi(double x)
{
    double r = fmod(x, TWO_PI);
    if (r != 0.0) {
        if (r < 0.0)
            r += TWO_PI;
    } else {
        r = 0.0;
    }
    return r;
}

/* The trial from J (m x n, row-major), e (m), lambda = w |e|^2 + mu at q, inside [lower, upper]: written
 * into inside (n). wraps: 1.0 for a full-turn joint, 0.0 otherwise, or NULL (none wraps); max_step < 0: no
 * cap. 0 when Cholesky fails (inside unspecified). */
static int bounded_trial(const double *J, int m, int n, const double *e, double damping, const double *q,
                         const double *lower, const double *upper, const double *wraps, double max_step,
                         double *inside)
{
    int columns[MAX_SIZE], count = 0;
    for (int j = 0; j < n; j++)
        columns[j] = j;
    double descent[MAX_SIZE], trial[MAX_SIZE];
    if (!damped_descent(J, m, n, columns, n, e, damping, descent))
        return 0;
    cap(descent, n, max_step);
    int left = 0;
    for (int j = 0; j < n; j++) {
        trial[j] = q[j] - descent[j];
        inside[j] = clip(trial[j], lower[j], upper[j]);
        left |= memcmp(inside + j, trial + j, sizeof(double)) != 0;
    }
    if (left) {
        /* blocked: joints the clipped trial leaves at q (clipped ones only, when some joint wraps) */
        int blocked = 0;
        count = 0;
        for (int j = 0; j < n; j++) {
            const int frozen = inside[j] == q[j] && (wraps == NULL || wraps[j] == 0.0);
            blocked |= frozen;
            if (!frozen)
                columns[count++] = j;
        }
        if (blocked) {
            if (!damped_descent(J, m, n, columns, count, e, damping, descent))
                return 0;
            cap(descent, n, max_step);
            for (int j = 0; j < n; j++)
                trial[j] = q[j] - descent[j];
        }
        for (int j = 0; j < n; j++) { /* JointBounds.project */
            double value = clip(trial[j], lower[j], upper[j]);
            if (wraps != NULL && wraps[j] != 0.0 && value != trial[j]) {
                const double wrapped = lower[j] + mod_two_pi(trial[j] - lower[j]);
                value = isnan(wrapped) ? wrapped : (wrapped < upper[j] ? wrapped : upper[j]);
            }
            inside[j] = value;
        }
    }
    return 1;
}

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

/* settings: the solver's numbers, in this order */
enum { WEIGHT, COST_WEIGHT, FLOOR, DECREASE, INCREASE, REJECT_FLOOR, PROGRESS, STALL, MAX_DAMPING,
       MAX_STEP, FIRST_DAMPING, SURE_COST, MAYBE_COST, POSITION_CHECK, ROTATION_CHECK, ATTEMPT_ITERATIONS,
       SETTINGS };

typedef struct {
    int n;
    const double *first, *constant, *sine, *versine; /* F (4x4), C0, C1, C2: (n, 16) each */
    const double *lower, *upper, *wraps, *prismatic; /* (n,) each; wraps NULL when none wraps */
    const double *settings;
    double goal_rotation[9], goal_position[3];
} Problem;

/* a = a b on the top 3 rows of 4x4 row-major rigid transforms */
static void compose(double *a, const double *b)
{
    double out[12];
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 4; j++) {
            double sum = a[4 * i] * b[j];
            for (int k = 1; k < 3; k++)
                sum += a[4 * i + k] * b[4 * k + j];
            out[4 * i + j] = j == 3 ? sum + a[4 * i + 3] : sum;
        }
    }
    memcpy(a, out, sizeof(out));
}

/* e (6) and J (6 x n, row-major) at q, as VectorisedChain.evaluate; 0 where log3 is within 1e-6 of pi. */
static int residual(const Problem *p, const double *q, double *e, double *J)
{
    const int n = p->n;
    const double w = p->settings[WEIGHT];
    double frame[16], axes[3 * MAX_SIZE], origins[3 * MAX_SIZE];
    memcpy(frame, p->first, sizeof(frame));
    for (int k = 0; k < n; k++) {
        for (int i = 0; i < 3; i++) {
            axes[3 * k + i] = frame[4 * i + 2];
            origins[3 * k + i] = frame[4 * i + 3];
        }
        const double f = p->prismatic[k] != 0.0 ? q[k] : sin(q[k]), g = 1.0 - cos(q[k]);
        double step[16];
        for (int i = 0; i < 16; i++)
            step[i] = f * p->sine[16 * k + i] + g * p->versine[16 * k + i] + p->constant[16 * k + i];
        if (k == 0)
            memcpy(frame, step, sizeof(step)); /* F is folded into A_1 */
        else
            compose(frame, step);
    }
    const double R[9] = {frame[0], frame[1], frame[2], frame[4], frame[5], frame[6], frame[8], frame[9],
                         frame[10]};
    const double position[3] = {frame[3], frame[7], frame[11]};
    for (int k = 0; k < n; k++) { /* column k: [w z x (p - o); z] or [w z; 0] */
        const double *z = axes + 3 * k, *o = origins + 3 * k;
        if (p->prismatic[k] != 0.0) {
            for (int i = 0; i < 3; i++) {
                J[i * n + k] = w * z[i];
                J[(i + 3) * n + k] = 0.0;
            }
            continue;
        }
        const double lever[3] = {position[0] - o[0], position[1] - o[1], position[2] - o[2]};
        J[0 * n + k] = w * (z[1] * lever[2] - z[2] * lever[1]);
        J[1 * n + k] = w * (z[2] * lever[0] - z[0] * lever[2]);
        J[2 * n + k] = w * (z[0] * lever[1] - z[1] * lever[0]);
        for (int i = 0; i < 3; i++)
            J[(i + 3) * n + k] = z[i];
    }
    /* log6(T*^-1 T) (task_error.batch_se3_error): phi = log3(R*^T R), t = R*^T w (p - p*) */
    const double *G = p->goal_rotation;
    double relative[9], offset[3];
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++)
            relative[3 * i + j] = G[i] * R[j] + G[3 + i] * R[3 + j] + G[6 + i] * R[6 + j];
        offset[i] = 0.0;
        for (int k = 0; k < 3; k++)
            offset[i] += (w * position[k] - w * p->goal_position[k]) * G[3 * k + i];
    }
    const double vee[3] = {relative[7] - relative[5], relative[2] - relative[6], relative[3] - relative[1]};
    const double twice_sine = sqrt(vee[0] * vee[0] + vee[1] * vee[1] + vee[2] * vee[2]);
    const double cosine = 0.5 * (relative[0] + relative[4] + relative[8] - 1.0);
    if (twice_sine < 1e-6 && cosine < 0.0)
        return 0; /* near pi: Pinocchio's log3 in the Python twin */
    const double angle = atan2(0.5 * twice_sine, cosine);
    const double scale = angle / (twice_sine > 1e-300 ? twice_sine : 1e-300);
    const double phi[3] = {vee[0] * scale, vee[1] * scale, vee[2] * scale};
    const double theta2 = phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2];
    const double half = 0.5 * sqrt(theta2);
    const double c = theta2 < 1e-6 ? 1.0 / 12.0 + theta2 / 720.0
                                   : (1.0 - half / tan(half)) / (4.0 * half * half);
    const double along = c * (phi[0] * offset[0] + phi[1] * offset[1] + phi[2] * offset[2]);
    const double cross[3] = {phi[1] * offset[2] - phi[2] * offset[1], phi[2] * offset[0] - phi[0] * offset[2],
                             phi[0] * offset[1] - phi[1] * offset[0]};
    double local[6];
    for (int i = 0; i < 3; i++) {
        local[i] = offset[i] * (1.0 - c * theta2) - 0.5 * cross[i] + along * phi[i];
        local[3 + i] = phi[i];
    }
    for (int i = 0; i < 3; i++) { /* both 3-blocks turned into base axes */
        e[i] = R[3 * i] * local[0] + R[3 * i + 1] * local[1] + R[3 * i + 2] * local[2];
        e[3 + i] = R[3 * i] * local[3] + R[3 * i + 1] * local[4] + R[3 * i + 2] * local[5];
    }
    return 1;
}

static double squared(const double *e, int count)
{
    double sum = 0.0;
    for (int i = 0; i < count; i++)
        sum += e[i] * e[i];
    return sum;
}

/* BoundedLMSolver._passes: |e_p| and |e_R| within half their (weighted) tolerances */
static int passes(const double *s, const double *e)
{
    return sqrt(squared(e, 3)) <= s[POSITION_CHECK] && sqrt(squared(e + 3, 3)) <= s[ROTATION_CHECK];
}

static double now(void)
{
    struct timespec clock;
    clock_gettime(CLOCK_MONOTONIC, &clock);
    return (double)((long long)clock.tv_sec * 1000000000LL + clock.tv_nsec) / 1e9;
}

/* _attempt: 1 (converged), 0 (not), -1 (the Python twin decides); q updated, *used and *cost set. */
static int attempt(const Problem *p, double *q, long budget, double deadline, long *used, double *cost)
{
    const double *s = p->settings;
    const int n = p->n;
    double e[6], J[6 * MAX_SIZE], trial_e[6], trial_J[6 * MAX_SIZE], inside[MAX_SIZE];
    if (!residual(p, q, e, J))
        return -1;
    *cost = squared(e, 6);
    double damping = s[FIRST_DAMPING], best = *cost;
    long since = 0, limit = (long)s[ATTEMPT_ITERATIONS] < budget ? (long)s[ATTEMPT_ITERATIONS] : budget;
    const long stall = (long)s[STALL];
    const int clock = deadline < INFINITY;
    for (long iteration = 1; iteration <= limit; iteration++) {
        if (*cost <= s[SURE_COST] || (*cost <= s[MAYBE_COST] && passes(s, e))) {
            *used = iteration - 1;
            return 1;
        }
        if (clock && now() > deadline)
            break;
        if (!bounded_trial(J, 6, n, e, s[COST_WEIGHT] * *cost + damping, q, p->lower, p->upper, p->wraps,
                           s[MAX_STEP], inside)
            || !residual(p, inside, trial_e, trial_J))
            return -1;
        const double trial_cost = squared(trial_e, 6);
        const int accepted = trial_cost < *cost;
        if (accepted) {
            memcpy(q, inside, n * sizeof(double));
            memcpy(e, trial_e, sizeof(e));
            memcpy(J, trial_J, 6 * n * sizeof(double));
            *cost = trial_cost;
        }
        if (accepted) { /* LevenbergMarquardt.update */
            damping *= s[DECREASE];
            damping = s[FLOOR] > damping ? s[FLOOR] : damping;
        } else {
            damping = (s[REJECT_FLOOR] > damping ? s[REJECT_FLOOR] : damping) * s[INCREASE];
        }
        if (*cost < s[PROGRESS] * best) {
            best = *cost;
            since = 0;
        } else {
            since++;
        }
        if ((0 < stall && stall <= since) || damping > s[MAX_DAMPING]) {
            *used = iteration;
            return 0;
        }
    }
    *used = limit;
    return passes(s, e);
}

/* lm_attempt(chain, joints, settings, rotation, position, q, budget, deadline, out) -> (converged,
 * iterations, |e|) or None (the Python twin decides). chain (3n + 1, 16): F, then C0, C1, C2 by joint;
 * joints (4, n): lower, upper, wraps (1.0 / 0.0), prismatic (1.0 / 0.0); settings (SETTINGS,): the enum's
 * order, MAX_DAMPING inf and MAX_STEP < 0 for none (those three C-contiguous float64); rotation (3, 3) and
 * position (3,): the target in the chain's base frame; q (n,) the seed; budget: iterations; deadline:
 * perf_counter seconds (inf: none); out (n,): the last q. */
static PyObject *lm_attempt(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (check_count("lm_attempt", nargs, 9) < 0)
        return NULL;
    Py_buffer views[3];
    if (float64_view(args[1], &views[1], 0, "joints") < 0)
        return NULL;
    const Py_ssize_t n = views[1].ndim == 2 && views[1].shape[0] == 4 ? views[1].shape[1] : 0;
    PyBuffer_Release(&views[1]);
    if (n < 1 || n > MAX_SIZE) {
        PyErr_SetString(PyExc_TypeError, "joints: expected a (4, n) float64 array, n <= 32");
        return NULL;
    }
    long budget = PyLong_AsLong(args[6]);
    double deadline;
    if ((budget == -1 && PyErr_Occurred()) || read_float(args[7], &deadline, "deadline") < 0)
        return NULL;
    if (contiguous_view(args[0], &views[0], (3 * n + 1) * 16, 0, "chain") < 0)
        return NULL;
    if (contiguous_view(args[1], &views[1], 4 * n, 0, "joints") < 0) {
        release_views(views, 1);
        return NULL;
    }
    if (contiguous_view(args[2], &views[2], SETTINGS, 0, "settings") < 0) {
        release_views(views, 2);
        return NULL;
    }
    Problem p = {.n = (int)n, .settings = views[2].buf};
    const double *chain = views[0].buf, *joints = views[1].buf;
    p.first = chain;
    p.constant = chain + 16;
    p.sine = chain + 16 * (n + 1);
    p.versine = chain + 16 * (2 * n + 1);
    p.lower = joints;
    p.upper = joints + n;
    p.prismatic = joints + 3 * n;
    for (Py_ssize_t j = 0; j < n; j++)
        if (joints[2 * n + j] != 0.0)
            p.wraps = joints + 2 * n;
    double q[MAX_SIZE], cost = 0.0;
    long used = 0;
    int outcome = -2;
    if (read_doubles(args[3], p.goal_rotation, 3, 3, "rotation") == 0
        && read_doubles(args[4], p.goal_position, 3, 0, "position") == 0
        && read_doubles(args[5], q, n, 0, "q") == 0)
        outcome = attempt(&p, q, budget, deadline, &used, &cost);
    release_views(views, 3);
    if (outcome == -2 || (outcome >= 0 && write_doubles(args[8], q, n, "out") < 0))
        return NULL;
    if (outcome == -1)
        Py_RETURN_NONE;
    return Py_BuildValue("(Nld)", PyBool_FromLong(outcome), used, sqrt(cost));
}

static PyMethodDef methods[] = {
    {"lm_trial", (PyCFunction)(void (*)(void))lm_trial, METH_FASTCALL,
     "lm_trial(jacobian, error, damping, q, lower, upper, wraps, max_step, out) -> bool: one bounded "
     "Levenberg-Marquardt trial (False: let the Python twin decide)"},
    {"lm_attempt", (PyCFunction)(void (*)(void))lm_attempt, METH_FASTCALL,
     "lm_attempt(chain, joints, settings, rotation, position, q, budget, deadline, out) -> (converged, "
     "iterations, |e|) or None: one bounded_lm attempt on a pose target (None: let the Python twin decide)"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_lm_trial",
                                    "Compiled twins of bounded_lm's trial and attempt (wbik.kernels).", -1,
                                    methods};

PyMODINIT_FUNC PyInit__lm_trial(void) { return PyModule_Create(&module); }
