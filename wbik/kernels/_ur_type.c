/* The compiled choice of the UR-type closed form (wbik.solvers.analytic.ur_type): its branches and FK,
 * operation by operation as ur_type.branches_by_joint and ur_type.fk, under the shared choice of
 * _closed_form.h. */
#define MAX_BRANCHES 8
#define FAMILY_NUMBERS 8
#include "_closed_form.h"

enum { F_D1 = P_FAMILY, F_A2, F_A3, F_D4, F_D5, F_D6, F_COSINE_TOLERANCE, F_WRIST_SINGULARITY };

/* ur_type.branches_by_joint for one target: branch 4 i1 + 2 i5 + ie (shoulder, wrist, elbow). */
static int family_branches(const double *params, const double p[3], const double r[9], const double u0[JOINTS],
                           double q[MAX_BRANCHES][JOINTS], int real[MAX_BRANCHES])
{
    const double d1 = params[F_D1], a2 = params[F_A2], a3 = params[F_A3];
    const double d4 = params[F_D4], d5 = params[F_D5], d6 = params[F_D6];
    const double tolerance = params[F_COSINE_TOLERANCE];
    const double t00 = r[1], t01 = r[2], t02 = -r[0], t10 = r[4], t11 = r[5], t12 = -r[3];
    const double t20 = -r[7], t21 = -r[8], t22 = r[6];
    const double t03 = -p[0], t13 = -p[1], t23 = p[2];
    double a = d6 * t12 - t13, b = d6 * t02 - t03;
    double value = d4 / np_maximum(sqrt(a * a + b * b), 1e-300);
    int real1 = fabs(value) <= 1.0 + tolerance;
    double offset = acos(np_clip(value, -1.0, 1.0)), shoulder = atan2(-b, a);
    for (int i1 = 0; i1 < 2; i1++) {
        double q1 = shoulder + (i1 == 0 ? offset : -offset);
        double c1 = cos(q1), s1 = sin(q1);
        double t03_s1 = t03 * s1, t13_c1 = t13 * c1;
        double value5 = (t03_s1 - t13_c1 - d4) / d6;
        double scale = (fabs(t03_s1) + fabs(t13_c1) + d4) / d6;
        int real5 = fabs(value5) <= 1.0 + tolerance * np_maximum(scale, 1.0);
        double cos5 = np_clip(value5, -1.0, 1.0);
        double u = t00 * s1 - t10 * c1, v = t01 * s1 - t11 * c1;
        double sine5 = hypot(u, v);
        double angle5 = atan2(sine5, cos5);
        double length5 = np_maximum(sqrt(sine5 * sine5 + cos5 * cos5), 1e-300);
        double c5 = cos5 / length5;
        double r0 = t00 * c1 + t10 * s1, r1 = t01 * c1 + t11 * s1, r2 = t02 * c1 + t12 * s1;
        for (int i5 = 0; i5 < 2; i5++) {
            double q5 = i5 == 0 ? angle5 : -angle5;
            double s5 = (i5 == 0 ? sine5 : -sine5) / length5;
            double sign = s5 >= 0.0 ? 1.0 : -1.0;
            double q6 = sine5 < params[F_WRIST_SINGULARITY] ? u0[5] : atan2(-sign * v, sign * u);
            double c6 = cos(q6), s6 = sin(q6);
            double x04x = -s5 * r2 - c5 * (s6 * r1 - c6 * r0);
            double x04y = c5 * (t20 * c6 - t21 * s6) - t22 * s5;
            double p13x = d5 * (s6 * r0 + c6 * r1) - d6 * r2 + t03 * c1 + t13 * s1;
            double p13y = t23 - d1 - d6 * t22 + d5 * (t21 * c6 + t20 * s6);
            /* subproblems.planar_2r_elbow */
            double cvalue = (p13x * p13x + p13y * p13y - a2 * a2 - a3 * a3) / (2.0 * a2 * a3);
            int real3 = fabs(cvalue) <= 1.0 + tolerance;
            double cos3 = np_clip(cvalue, -1.0, 1.0);
            double sine = sqrt(1.0 - cos3 * cos3), reach = atan2(p13y, p13x);
            for (int ie = 0; ie < 2; ie++) {
                double s3 = ie == 0 ? sine : -sine;
                double along = a3 + a2 * cos3, across = a2 * s3;
                double c23 = p13x * along - p13y * across, s23 = p13y * along + p13x * across;
                double *branch = q[4 * i1 + 2 * i5 + ie];
                branch[0] = q1;
                branch[1] = reach - atan2(a3 * s3, a2 + a3 * cos3);
                branch[2] = atan2(s3, cos3);
                branch[3] = atan2(c23 * x04y - s23 * x04x, x04x * c23 + x04y * s23);
                branch[4] = q5;
                branch[5] = q6;
                real[4 * i1 + 2 * i5 + ie] = real1 && real5 && real3;
            }
        }
    }
    return MAX_BRANCHES;
}

/* ur_type.fk: base_link -> ee_link (ur_kinematics' forward). */
static void family_fk(const double *params, const double u[JOINTS], double p[3], double r[9])
{
    const double d1 = params[F_D1], a2 = params[F_A2], a3 = params[F_A3];
    const double d4 = params[F_D4], d5 = params[F_D5], d6 = params[F_D6];
    double q23 = u[1] + u[2], q234 = q23 + u[3];
    double c1 = cos(u[0]), s1 = sin(u[0]), c2 = cos(u[1]), s2 = sin(u[1]);
    double c4 = cos(u[3]), s4 = sin(u[3]), c5 = cos(u[4]), s5 = sin(u[4]);
    double c6 = cos(u[5]), s6 = sin(u[5]), c23 = cos(q23), s23 = sin(q23);
    double c234 = cos(q234), s234 = sin(q234);
    double side = s1 * s5 + c234 * c1 * c5;
    double front = c1 * s5 - c234 * c5 * s1;
    r[0] = c234 * c1 * s5 - c5 * s1;
    r[1] = c6 * side - s234 * c1 * s6;
    r[2] = -s6 * side - s234 * c1 * c6;
    r[3] = c1 * c5 + c234 * s1 * s5;
    r[4] = -c6 * front - s234 * s1 * s6;
    r[5] = s6 * front - s234 * c6 * s1;
    r[6] = -s234 * s5;
    r[7] = -c234 * s6 - s234 * c5 * c6;
    r[8] = s234 * c5 * s6 - c234 * c6;
    p[0] = d6 * c234 * c1 * s5 - a3 * c23 * c1 - a2 * c1 * c2 - d6 * c5 * s1 - d5 * s234 * c1 - d4 * s1;
    p[1] = d6 * (c1 * c5 + c234 * s1 * s5) + d4 * c1 - a3 * c23 * s1 - a2 * c2 * s1 - d5 * s234 * s1;
    p[2] = d1 + a3 * s23 + a2 * s2 - d5 * (c23 * c4 - s23 * s4) - d6 * s5 * (c23 * s4 + s23 * c4);
}

CLOSED_FORM_MODULE(_ur_type, "The compiled choice of the UR-type closed form (see _closed_form.h).")
