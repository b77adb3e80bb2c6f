/* The engine as a Python extension module (lamech.numeric._cengine_lib): a module with no
 * functions of its own, so that importing it proves the engine was built at install; its
 * C functions (engine.h's entry points) are called through ctypes
 * (lamech/numeric/_cengine.py), which releases the GIL for each call. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

static struct PyModuleDef engine_module = {
    PyModuleDef_HEAD_INIT, "_cengine_lib",
    "lamech's engine in C: its functions are called through ctypes (lamech.numeric._cengine).",
    -1, NULL, NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__cengine_lib(void) { return PyModule_Create(&engine_module); }
