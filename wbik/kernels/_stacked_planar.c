/* The compiled choice of the stacked-planar pose closed form (wbik.solvers.analytic.stacked_planar, the
 * Golem-III arm): its branches and FK, operation by operation as StackedPlanarPose.branches (rolls,
 * pose_branches) and stacked_planar.fk, under the shared choice of _closed_form.h. */
#define SWEEP 7 /* stacked_planar.GIMBAL_LOCK_SWEEP */
#define MAX_BRANCHES (4 * (2 + SWEEP))
#define FAMILY_NUMBERS (12 + SWEEP)
#include "_closed_form.h"

enum {
    F_L1 = P_FAMILY, F_L2, F_L4, F_L5, F_L6, F_H, F_RHO, F_COSINE_TOLERANCE, F_GIMBAL_LOCK, F_TRIPLES,
    F_ROLL_LOW, F_ROLL_HIGH, F_SWEEP /* SWEEP values */
};

/* pose_branches for one roll alpha: branch 2 i + j (the sign of sin(t4 + rho), the planar elbow). */
static void roll_branches(const double *params, const double p[3], const double r[9], double alpha,
                          int real_roll, double q[4][JOINTS], int real[4])
{
    const double l1 = params[F_L1], l2 = params[F_L2], l4 = params[F_L4], l5 = params[F_L5];
    const double l6 = params[F_L6], h = params[F_H], rho = params[F_RHO], tolerance = params[F_COSINE_TOLERANCE];
    double ca = cos(alpha), sa = sin(alpha);
    double beta = atan2(-r[6], sa * r[7] + ca * r[8]);
    double gamma = atan2(-(ca * r[1] - sa * r[2]), ca * r[4] - sa * r[5]);
    double sb = sin(beta), cb = cos(beta);
    double value4 = (h - p[2] - l5 * cb - l6 * sb) / l4;
    int real4 = fabs(value4) <= 1.0 + tolerance;
    double cos4 = np_clip(value4, -1.0, 1.0);
    double root4 = sqrt(1.0 - cos4 * cos4);
    double cg = cos(gamma), sg = sin(gamma);
    for (int i = 0; i < 2; i++) {
        double sin4 = i == 0 ? root4 : -root4;
        double t4 = atan2(sin4, cos4) - rho;
        double l3 = l4 * sin4 + (l6 * cb - l5 * sb);
        double x = l3 * sg - p[1], y = p[0] - l3 * cg;
        /* subproblems.planar_2r */
        double cvalue = (x * x + y * y - l1 * l1 - l2 * l2) / (2.0 * l1 * l2);
        int real2 = fabs(cvalue) <= 1.0 + tolerance;
        double cosine = np_clip(cvalue, -1.0, 1.0);
        double sine = sqrt(1.0 - cosine * cosine), reach = atan2(y, x);
        for (int j = 0; j < 2; j++) {
            double s2 = j == 0 ? sine : -sine;
            double t1 = reach - atan2(l2 * s2, l1 + l2 * cosine), t2 = atan2(s2, cosine);
            double *branch = q[2 * i + j];
            branch[0] = t1;
            branch[1] = t2;
            branch[2] = gamma - (t1 + t2);
            branch[3] = t4;
            branch[4] = -beta - t4;
            branch[5] = alpha;
            real[2 * i + j] = real_roll && real4 && real2;
        }
    }
}

/* StackedPlanarPose.branches for one target: the rolls (alpha with |alpha| <= pi/2, and alpha + pi for two
 * Euler triples; at gimbal lock the start's roll and the sweep), 4 branches each. */
static int family_branches(const double *params, const double p[3], const double r[9], const double u0[JOINTS],
                           double q[MAX_BRANCHES][JOINTS], int real[MAX_BRANCHES])
{
    double rolls[2 + SWEEP];
    int real_roll[2 + SWEEP], triples = params[F_TRIPLES] == 2.0 ? 2 : 1, count = 0;
    double a = atan2(r[7], r[8]);
    double alpha = fabs(a) > PI / 2 ? a - copysign(PI, a) : a;
    if (hypot(r[7], r[8]) < params[F_GIMBAL_LOCK]) {
        double start = np_clip(u0[5], params[F_ROLL_LOW], params[F_ROLL_HIGH]);
        for (int k = 0; k < triples; k++) {
            rolls[count] = start;
            real_roll[count++] = k == 0;
        }
        for (int k = 0; k < SWEEP; k++) {
            rolls[count] = params[F_SWEEP + k];
            real_roll[count++] = 1;
        }
    } else {
        rolls[count] = alpha;
        real_roll[count++] = 1;
        if (triples == 2) {
            rolls[count] = alpha + PI;
            real_roll[count++] = 1;
        }
    }
    for (int k = 0; k < count; k++)
        roll_branches(params, p, r, rolls[k], real_roll[k], q + 4 * k, real + 4 * k);
    return 4 * count;
}

/* stacked_planar.fk: R = Rz(gamma) Ry(-(t4 + t5)) Rx(t6), the gripper centre of the module docstring. */
static void family_fk(const double *params, const double u[JOINTS], double p[3], double r[9])
{
    const double l1 = params[F_L1], l2 = params[F_L2], l4 = params[F_L4], l5 = params[F_L5];
    const double l6 = params[F_L6], h = params[F_H], rho = params[F_RHO];
    double s = u[3] + u[4], t12 = u[0] + u[1];
    double gamma = t12 + u[2];
    double ss = sin(s), cs = cos(s), sg = sin(gamma), cg = cos(gamma), sa = sin(u[5]), ca = cos(u[5]);
    double l3 = l4 * sin(u[3] + rho) + l5 * ss + l6 * cs;
    double sb = -ss;
    p[0] = l1 * sin(u[0]) + l2 * sin(t12) + l3 * cg;
    p[1] = -l1 * cos(u[0]) - l2 * cos(t12) + l3 * sg;
    p[2] = h - l4 * cos(u[3] + rho) - l5 * cs + l6 * ss;
    r[0] = cg * cs;
    r[1] = cg * sb * sa - sg * ca;
    r[2] = cg * sb * ca + sg * sa;
    r[3] = sg * cs;
    r[4] = sg * sb * sa + cg * ca;
    r[5] = sg * sb * ca - cg * sa;
    r[6] = -sb;
    r[7] = cs * sa;
    r[8] = cs * ca;
}

CLOSED_FORM_MODULE(_stacked_planar, "The compiled choice of the stacked-planar pose closed form (see _closed_form.h).")
