/* One bounded Levenberg-Marquardt trial in C, the policy of wbik.solvers.levenberg_marquardt
 * (LevenbergMarquardt.trial with its helpers _descent, _capped, _frozen_descent, JointBounds.blocked and
 * .project), shared by the kernels _lm_trial.c (one trial) and _lm_attempt.c (a whole attempt):
 *
 *     descent = (J^T J + lambda I)^-1 J^T e   (n <= m)   or   J^T (J J^T + lambda I)^-1 e   (n > m),
 *     by Cholesky; capped to max_step; trial = q - descent, clipped into the limits; if it left them,
 *     the joints it leaves at q on a bound (clipped joints only) are frozen and the step recomputed on
 *     the free ones; the result projected (full-turn joints wrapped by 2 pi, the others clipped).
 *
 * The same decisions as the Python twin, with the sums in index order in C (-ffp-contract=off) instead
 * of BLAS and LAPACK's: the two agree to rounding, not to the bit (tests/test_lm_kernel.py), and this one
 * gives the same bits on every CPU. Where the damped system is not numerically positive definite
 * (Cholesky fails) the trial gives 0 and the Python twin, with its least-squares fallback, decides.
 */
#ifndef WBIK_LM_TRIAL_H
#define WBIK_LM_TRIAL_H

#include <math.h>
#include <string.h>

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

#endif
