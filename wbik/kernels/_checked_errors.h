/* The shared FK check's errors of a reached pose as Python objects go in and out: the one body of
 * wbik.kernels._pose.pose_errors (the reached pose given) and wbik.kernels._chain_fk.tip_errors (the
 * reached pose computed by Pinocchio's FK). Header-only; include after _buffers.h and _pose_errors.h. */
#ifndef WBIK_CHECKED_ERRORS_H
#define WBIK_CHECKED_ERRORS_H

#include <math.h>
#include <string.h>

/* reached <- B^-1 reached for a 4x4 rigid transform B^-1 (both row by row): the top three rows, each entry
 * summed over k in order, the translation added last (geometry.plain_composed); the last row kept. */
static inline void base_moved(double reached[16], const double base[16])
{
    double moved[12];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 4; j++) {
            double sum = base[4 * i] * reached[j] + base[4 * i + 1] * reached[4 + j] + base[4 * i + 2] * reached[8 + j];
            moved[4 * i + j] = j == 3 ? sum + base[4 * i + 3] : sum;
        }
    memcpy(reached, moved, sizeof(moved));
}

/* errors = (e_p, e_R, |e_p|, |e_R|) of `reached` (4x4, row by row) on the target (rotation: 9 values row by
 * row, or NULL for a position, then e_R = 0); returns whether the formula kept the axis (pose_errors). */
static inline int target_errors(const double reached[16], const double position[3], const double *rotation,
                                double errors[8])
{
    const double reached_p[3] = {reached[3], reached[7], reached[11]};
    const double reached_r[9] = {reached[0], reached[1], reached[2], reached[4], reached[5], reached[6],
                                 reached[8], reached[9], reached[10]};
    if (rotation != NULL)
        return !pose_errors(reached_p, reached_r, position, rotation, errors);
    for (int i = 0; i < 3; i++) {
        errors[i] = reached_p[i] - position[i];
        errors[3 + i] = 0.0;
    }
    errors[6] = sqrt(errors[0] * errors[0] + errors[1] * errors[1] + errors[2] * errors[2]);
    errors[7] = 0.0;
    return 1;
}

/* (|e_p|, |e_R|, exact) of `reached` (a 4x4 homogeneous matrix, row by row) on the target (position (3,),
 * rotation (3, 3) or None), writing e_p = p - p* into position_error (3,) and e_R = log3(R*^T R) in the
 * batched check's formula into rotation_error (3,) (0 for a position-only target). base_inverse: None, or a
 * 4x4 rigid transform B^-1 applied first (base_moved). exact is False where the formula loses the axis
 * (|vee| < 1e-6 near a half turn, geometry.batch_log3's rule): the caller then takes Pinocchio's log3. */
static inline PyObject *checked_errors_tuple(double reached[16], PyObject *position_object,
                                             PyObject *rotation_object, PyObject *position_error,
                                             PyObject *rotation_error, PyObject *base_object)
{
    double position[3], rotation[9], errors[8];
    if (read_doubles(position_object, position, 3, 0, "position") < 0)
        return NULL;
    if (base_object != Py_None) {
        double base[16];
        if (read_doubles(base_object, base, 4, 4, "base_inverse") < 0)
            return NULL;
        base_moved(reached, base);
    }
    if (rotation_object != Py_None && read_doubles(rotation_object, rotation, 3, 3, "rotation") < 0)
        return NULL;
    const int exact = target_errors(reached, position, rotation_object == Py_None ? NULL : rotation, errors);
    if (write_doubles(position_error, errors, 3, "position_error") < 0
        || write_doubles(rotation_error, errors + 3, 3, "rotation_error") < 0)
        return NULL;
    PyObject *position_norm = PyFloat_FromDouble(errors[6]), *rotation_norm = PyFloat_FromDouble(errors[7]);
    PyObject *result = position_norm && rotation_norm
                       ? PyTuple_Pack(3, position_norm, rotation_norm, exact ? Py_True : Py_False) : NULL;
    Py_XDECREF(position_norm);
    Py_XDECREF(rotation_norm);
    return result;
}

#endif
