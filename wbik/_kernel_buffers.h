/* Buffer helpers shared by wbik's C kernels (_pose_kernel.c, solvers/analytic/_ur_kernel.c): float64
 * arrays in (copied into C arrays, any strides) and out (written into C-contiguous arrays), each refusing
 * anything else with a TypeError that names the argument. Header-only: every kernel is one file. */
#ifndef WBIK_KERNEL_BUFFERS_H
#define WBIK_KERNEL_BUFFERS_H

#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <string.h>

/* A native float64 buffer (format "d" or "=d": not a byte-swapped one). */
static int is_float64(const Py_buffer *view)
{
    return view->itemsize == 8 && view->format != NULL
           && (strcmp(view->format, "d") == 0 || strcmp(view->format, "=d") == 0);
}

/* Copy a float64 array of 0 to 2 dimensions holding exactly `count` values, in C order, into out. */
static int read_doubles(PyObject *object, double *out, Py_ssize_t count, const char *what)
{
    Py_buffer view;
    if (PyObject_GetBuffer(object, &view, PyBUF_RECORDS_RO) < 0)
        return -1;
    Py_ssize_t total = 1;
    for (int axis = 0; axis < view.ndim; axis++)
        total *= view.shape[axis];
    if (!is_float64(&view) || total != count || view.ndim > 2) {
        PyBuffer_Release(&view);
        PyErr_Format(PyExc_TypeError, "%s: expected %zd float64 values", what, count);
        return -1;
    }
    const char *base = (const char *)view.buf;
    if (view.ndim == 0) {
        memcpy(out, base, sizeof(double));
    } else if (view.ndim == 1) {
        for (Py_ssize_t i = 0; i < count; i++)
            memcpy(out + i, base + i * view.strides[0], sizeof(double));
    } else {
        Py_ssize_t columns = view.shape[1];
        for (Py_ssize_t i = 0; i < view.shape[0]; i++)
            for (Py_ssize_t j = 0; j < columns; j++)
                memcpy(out + i * columns + j, base + i * view.strides[0] + j * view.strides[1], sizeof(double));
    }
    PyBuffer_Release(&view);
    return 0;
}

/* read_doubles() of an array of exactly the shape (rows,) (columns == 0) or (rows, columns). */
static int read_shaped(PyObject *object, Py_ssize_t rows, Py_ssize_t columns, double *out, const char *what)
{
    Py_buffer view;
    if (PyObject_GetBuffer(object, &view, PyBUF_RECORDS_RO) < 0)
        return -1;
    int shaped = is_float64(&view) && (columns == 0 ? view.ndim == 1 && view.shape[0] == rows
                                                    : view.ndim == 2 && view.shape[0] == rows
                                                          && view.shape[1] == columns);
    PyBuffer_Release(&view);
    if (!shaped) {
        if (columns == 0)
            PyErr_Format(PyExc_TypeError, "%s: expected a (%zd,) float64 array", what, rows);
        else
            PyErr_Format(PyExc_TypeError, "%s: expected a (%zd, %zd) float64 array", what, rows, columns);
        return -1;
    }
    return read_doubles(object, out, columns == 0 ? rows : rows * columns, what);
}

/* A C-contiguous float64 view of exactly `count` values (writable if asked); release it when done. */
static int contiguous_view(PyObject *object, Py_buffer *view, Py_ssize_t count, int writable, const char *what)
{
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(object, view, flags) < 0)
        return -1;
    if (!is_float64(view) || view->len != count * (Py_ssize_t)sizeof(double)) {
        PyBuffer_Release(view);
        PyErr_Format(PyExc_TypeError, "%s: expected a %sC-contiguous float64 array of %zd values", what,
                     writable ? "writable " : "", count);
        return -1;
    }
    return 0;
}

/* Write `count` values into a writable C-contiguous float64 array of exactly that many. */
static int write_doubles(PyObject *object, const double *values, Py_ssize_t count, const char *what)
{
    Py_buffer view;
    if (contiguous_view(object, &view, count, 1, what) < 0)
        return -1;
    memcpy(view.buf, values, count * sizeof(double));
    PyBuffer_Release(&view);
    return 0;
}

#endif
