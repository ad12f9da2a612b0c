/* The batched FK check's errors of one reached pose against a target, shared by the closed forms'
 * kernels (_ur_type.c, _eaik.c): the rule of wbik.solvers.analytic.batch.evaluate_batch, with the
 * rotation error in geometry.batch_log3's formula. Header-only (static inline). */
#ifndef WBIK_POSE_ERRORS_H
#define WBIK_POSE_ERRORS_H

#include <math.h>

/* errors = (ex, ey, ez, rx, ry, rz, |e_p|, |e_R|): position error p - p*, rotation error log3(R*^T R)
 * as vee(M - M^T) angle / |vee(M - M^T)| with M = R*^T R (sum over k of R*_ki R_kj, k in order) and
 * angle = atan2(|vee| / 2, (trace M - 1) / 2), and both norms. The formula loses the axis only near a
 * half turn: the result is 1 there (|vee| < 1e-6 with a negative cosine, geometry.batch_log3's rule, where
 * that function takes Pinocchio's log3), else 0. The closed forms' kernels check branches that passed their
 * screen (rotation error <= 1e-7 rad); the shared check takes Pinocchio's log3 where the result is 1. */
static inline int pose_errors(const double reached_p[3], const double reached_r[9], const double position[3],
                               const double rotation[9], double errors[8])
{
    double m[9];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            m[3 * i + j] = rotation[i] * reached_r[j] + rotation[3 + i] * reached_r[3 + j]
                           + rotation[6 + i] * reached_r[6 + j];
    double vee[3] = {m[7] - m[5], m[2] - m[6], m[3] - m[1]};
    double twice_sine = sqrt(vee[0] * vee[0] + vee[1] * vee[1] + vee[2] * vee[2]);
    double cosine = 0.5 * (m[0] + m[4] + m[8] - 1.0);
    double scale = atan2(0.5 * twice_sine, cosine) / (1e-300 > twice_sine ? 1e-300 : twice_sine); /* Python max() */
    for (int i = 0; i < 3; i++) {
        errors[i] = reached_p[i] - position[i];
        errors[3 + i] = vee[i] * scale;
    }
    errors[6] = sqrt(errors[0] * errors[0] + errors[1] * errors[1] + errors[2] * errors[2]);
    errors[7] = sqrt(errors[3] * errors[3] + errors[4] * errors[4] + errors[5] * errors[5]);
    return twice_sine < 1e-6 && cosine < 0.0;
}

#endif
