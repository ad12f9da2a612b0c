/* Argument helpers shared by wbik's C kernels (every _<name>.c in this folder): float64
 * arrays in (copied into C arrays, any strides) and out (written into C-contiguous writable arrays),
 * floats, and the argument count. Anything else raises a TypeError naming the argument. Header-only
 * (static inline: a kernel that uses a helper gets it, the others no "unused" warning). */
#ifndef WBIK_KERNEL_BUFFERS_H
#define WBIK_KERNEL_BUFFERS_H

#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <string.h>

/* TypeError unless exactly `expected` positional arguments were given. */
static inline int check_count(const char *function, Py_ssize_t nargs, Py_ssize_t expected)
{
    if (nargs == expected)
        return 0;
    PyErr_Format(PyExc_TypeError, "%s expects %zd arguments, got %zd", function, expected, nargs);
    return -1;
}

/* A Python float (or anything with __float__) as a double; TypeError naming the argument otherwise. */
static inline int read_float(PyObject *object, double *out, const char *what)
{
    *out = PyFloat_AsDouble(object);
    if (*out == -1.0 && PyErr_Occurred()) {
        PyErr_Format(PyExc_TypeError, "%s: expected a float, got %s", what, Py_TYPE(object)->tp_name);
        return -1;
    }
    return 0;
}

/* A strided view of a native float64 array (format "d" or "=d"), writable and C-contiguous if asked;
 * TypeError naming the argument for anything else (the view is then released). */
static inline int float64_view(PyObject *object, Py_buffer *view, int writable, const char *what)
{
    if (!PyObject_CheckBuffer(object)) {
        PyErr_Format(PyExc_TypeError, "%s: expected a float64 array, got %s", what, Py_TYPE(object)->tp_name);
        return -1;
    }
    if (PyObject_GetBuffer(object, view, PyBUF_RECORDS_RO) < 0)
        return -1;
    const char *problem = NULL;
    if (view->itemsize != 8 || view->format == NULL
        || (strcmp(view->format, "d") != 0 && strcmp(view->format, "=d") != 0))
        problem = "a float64 array";
    else if (writable && (view->readonly || !PyBuffer_IsContiguous(view, 'C')))
        problem = "a writable C-contiguous array";
    if (problem == NULL)
        return 0;
    PyBuffer_Release(view);
    PyErr_Format(PyExc_TypeError, "%s: expected %s", what, problem);
    return -1;
}

/* Copy a float64 array into out, in C order: exactly `count` values of any shape when columns < 0,
 * else exactly the shape (count,) (columns == 0) or (count, columns). */
static inline int read_doubles(PyObject *object, double *out, Py_ssize_t count, Py_ssize_t columns,
                               const char *what)
{
    Py_buffer view;
    if (float64_view(object, &view, 0, what) < 0)
        return -1;
    if (view.ndim > 2) {
        PyBuffer_Release(&view);
        PyErr_Format(PyExc_TypeError, "%s: expected an array of at most 2 dimensions", what);
        return -1;
    }
    Py_ssize_t total = 1;
    for (int axis = 0; axis < view.ndim; axis++)
        total *= view.shape[axis];
    int fits = columns < 0 ? total == (Py_ssize_t)count
               : columns == 0 ? view.ndim == 1 && view.shape[0] == count
                              : view.ndim == 2 && view.shape[0] == count && view.shape[1] == columns;
    if (!fits) {
        PyBuffer_Release(&view);
        if (columns < 0)
            PyErr_Format(PyExc_TypeError, "%s: expected %zd float64 values", what, count);
        else if (columns == 0)
            PyErr_Format(PyExc_TypeError, "%s: expected a (%zd,) float64 array", what, count);
        else
            PyErr_Format(PyExc_TypeError, "%s: expected a (%zd, %zd) float64 array", what, count, columns);
        return -1;
    }
    const char *base = (const char *)view.buf;
    if (view.ndim == 0) {
        memcpy(out, base, sizeof(double));
    } else if (view.ndim == 1) {
        for (Py_ssize_t i = 0; i < view.shape[0]; i++)
            memcpy(out + i, base + i * view.strides[0], sizeof(double));
    } else {
        Py_ssize_t width = view.shape[1];
        for (Py_ssize_t i = 0; i < view.shape[0]; i++)
            for (Py_ssize_t j = 0; j < width; j++)
                memcpy(out + i * width + j, base + i * view.strides[0] + j * view.strides[1], sizeof(double));
    }
    PyBuffer_Release(&view);
    return 0;
}

/* A writable C-contiguous float64 view of exactly `count` values; release it when done. */
static inline int contiguous_view(PyObject *object, Py_buffer *view, Py_ssize_t count, int writable,
                                  const char *what)
{
    if (float64_view(object, view, writable, what) < 0)
        return -1;
    if (view->len == count * (Py_ssize_t)sizeof(double) && PyBuffer_IsContiguous(view, 'C'))
        return 0;
    PyBuffer_Release(view);
    PyErr_Format(PyExc_TypeError, "%s: expected a C-contiguous float64 array of %zd values", what, count);
    return -1;
}

/* Release the first `count` of a kernel's views (the one way out of a kernel holding several). */
static inline void release_views(Py_buffer *views, int count)
{
    for (int i = 0; i < count; i++)
        PyBuffer_Release(&views[i]);
}

/* Write `count` values into a writable C-contiguous float64 array of exactly that many. */
static inline int write_doubles(PyObject *object, const double *values, Py_ssize_t count, const char *what)
{
    Py_buffer view;
    if (contiguous_view(object, &view, count, 1, what) < 0)
        return -1;
    memcpy(view.buf, values, count * sizeof(double));
    PyBuffer_Release(&view);
    return 0;
}

#endif
