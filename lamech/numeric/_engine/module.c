/* The engine as a Python extension module (lamech.numeric._cengine_lib). Importing it
 * proves the engine was built at install; most of its C functions (engine.h's entry
 * points) are called through ctypes (lamech/numeric/_cengine.py), which releases the GIL
 * for each call. The two called once per right-hand side from Python (the evaluation of
 * (q'', lambda) and the right-hand side on a mode's rows: SciPy's steps, B2) are here as
 * Python functions too: ctypes' conversions and the binding's checks in Python cost 3-4 us
 * a call, more than the evaluation (benchmarks, 2026-11-29); here the buffers are checked
 * in C (type, order, length, every index), in well under a microsecond. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <string.h>

#include "engine.h"

/* ``o``'s buffer as a C-contiguous vector of float64 (kind 'd') or int64 (kind 'q') of
 * ``count`` entries (-1: any), writable if asked; a ValueError (or TypeError) otherwise */
static int vector(PyObject *o, Py_buffer *v, char kind, Py_ssize_t count, int writable,
                  const char *name)
{
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(o, v, flags) < 0)
        return -1;
    const char *f = v->format != NULL ? v->format : "B";
    if (*f == '<' || *f == '=' || *f == '@')
        f++;
    int ok = v->itemsize == 8 && v->ndim == 1;
    if (kind == 'd')
        ok = ok && strcmp(f, "d") == 0;
    else
        ok = ok && (strcmp(f, "q") == 0 || strcmp(f, "l") == 0);
    if (!ok) {
        PyBuffer_Release(v);
        PyErr_Format(PyExc_ValueError, "engine: %s must be a C-contiguous vector of %s", name,
                     kind == 'd' ? "float64" : "int64");
        return -1;
    }
    if (count >= 0 && v->shape[0] != count) {
        Py_ssize_t got = v->shape[0];
        PyBuffer_Release(v);
        PyErr_Format(PyExc_ValueError, "engine: %s has shape (%zd,), expected (%zd,)", name,
                     got, count);
        return -1;
    }
    return 0;
}

/* every entry of the int64 vector ``v`` in [low, high) */
static int in_range(const Py_buffer *v, int64_t low, int64_t high, const char *name)
{
    const int64_t *x = (const int64_t *)v->buf;
    for (Py_ssize_t i = 0; i < v->shape[0]; i++) {
        if (x[i] < low || x[i] >= high) {
            PyErr_Format(PyExc_ValueError, "engine: %s holds an index outside [%lld, %lld)",
                         name, (long long)low, (long long)high);
            return -1;
        }
    }
    return 0;
}

static const lm_system *system_at(PyObject *address)
{
    void *p = PyLong_AsVoidPtr(address);
    if (p == NULL && !PyErr_Occurred())
        PyErr_SetString(PyExc_ValueError, "engine: no system record");
    return (const lm_system *)p;
}

/* the arguments every function here begins with: their count, the system's record and t */
static int head(PyObject *const *args, Py_ssize_t nargs, Py_ssize_t want, const char *usage,
                const lm_system **sy, double *t)
{
    if (nargs != want) {
        PyErr_SetString(PyExc_TypeError, usage);
        return -1;
    }
    *sy = system_at(args[0]);
    if (*sy == NULL)
        return -1;
    *t = PyFloat_AsDouble(args[1]);
    if (*t == -1.0 && PyErr_Occurred())
        return -1;
    return 0;
}

/* accelerations(system address, t, y, p, out): [q''; lambda] with every constraint
 * active into out (n + m); returns the entry point's status */
static PyObject *accelerations(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    const lm_system *sy;
    double t;
    if (head(args, nargs, 5, "accelerations(system, t, y, p, out)", &sy, &t) < 0)
        return NULL;
    Py_buffer b[3];
    int got = 0;
    PyObject *result = NULL;
    if (vector(args[2], &b[0], 'd', 2 * sy->n, 0, "y") < 0)
        goto done;
    got = 1;
    if (vector(args[3], &b[1], 'd', sy->np, 0, "p") < 0)
        goto done;
    got = 2;
    if (vector(args[4], &b[2], 'd', sy->n + sy->m, 1, "out") < 0)
        goto done;
    got = 3;
    int64_t code = lm_accelerations_entry(sy, t, (const double *)b[0].buf,
                                          (const double *)b[1].buf, (double *)b[2].buf);
    result = PyLong_FromLongLong((long long)code);
done:
    for (int i = 0; i < got; i++)
        PyBuffer_Release(&b[i]);
    return result;
}

/* rhs(system address, t, y, p, rows, slip_j, slip_k, slip_c, out): y' = [v; q''] on the
 * active rows into out (2n); returns the entry point's status */
static PyObject *rhs(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    const lm_system *sy;
    double t;
    if (head(args, nargs, 9, "rhs(system, t, y, p, rows, slip_j, slip_k, slip_c, out)", &sy,
             &t) < 0)
        return NULL;
    Py_buffer b[7];
    int got = 0;
    PyObject *result = NULL;
    int64_t m = sy->m;
    if (vector(args[2], &b[0], 'd', 2 * sy->n, 0, "y") < 0)
        goto done;
    got = 1;
    if (vector(args[3], &b[1], 'd', sy->np, 0, "p") < 0)
        goto done;
    got = 2;
    if (vector(args[4], &b[2], 'q', -1, 0, "rows") < 0)
        goto done;
    got = 3;
    Py_ssize_t na = b[2].shape[0];
    if (vector(args[5], &b[3], 'q', -1, 0, "slip_j") < 0)
        goto done;
    got = 4;
    Py_ssize_t ns = b[3].shape[0];
    if (vector(args[6], &b[4], 'q', ns, 0, "slip_k") < 0)
        goto done;
    got = 5;
    if (vector(args[7], &b[5], 'd', ns, 0, "slip_c") < 0)
        goto done;
    got = 6;
    if (vector(args[8], &b[6], 'd', 2 * sy->n, 1, "out") < 0)
        goto done;
    got = 7;
    if (na > m) {
        PyErr_SetString(PyExc_ValueError, "engine: more active rows than constraints");
        goto done;
    }
    if (in_range(&b[2], 0, m > 0 ? m : 1, "rows") < 0 ||
        in_range(&b[3], 0, m > 0 ? m : 1, "slip_j") < 0 ||
        in_range(&b[4], 0, na > 0 ? na : 1, "slip_k") < 0)
        goto done;
    int64_t code = lm_rhs_kernel(sy, t, (const double *)b[0].buf, (const double *)b[1].buf,
                                 (const int64_t *)b[2].buf, (int64_t)na,
                                 (const int64_t *)b[3].buf, (const int64_t *)b[4].buf,
                                 (const double *)b[5].buf, (int64_t)ns, (double *)b[6].buf);
    result = PyLong_FromLongLong((long long)code);
done:
    for (int i = 0; i < got; i++)
        PyBuffer_Release(&b[i]);
    return result;
}

static PyMethodDef engine_methods[] = {
    {"accelerations", (PyCFunction)(void (*)(void))accelerations, METH_FASTCALL,
     "accelerations(system, t, y, p, out) -> status"},
    {"rhs", (PyCFunction)(void (*)(void))rhs, METH_FASTCALL,
     "rhs(system, t, y, p, rows, slip_j, slip_k, slip_c, out) -> status"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef engine_module = {
    PyModuleDef_HEAD_INIT, "_cengine_lib",
    "lamech's engine in C: its functions are called through ctypes (lamech.numeric._cengine), "
    "the two of each right-hand side also from here.",
    -1, engine_methods, NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__cengine_lib(void) { return PyModule_Create(&engine_module); }
