"""A last word from a process that a compiled library ends with ``exit()``.

A library below Python (an MPI runtime, a mesher, a compiler driver) may end the process by
calling C's ``exit()`` itself: Python then prints no traceback, runs none of its ``atexit``
handlers, and a run that was started with ``--quiet`` ends with its exit status and nothing
else. :func:`arm` registers a C
``atexit`` handler that, unless Python is shutting down normally, writes to stderr that the
process is ending inside a library call, the Python stack at that moment (``faulthandler``) and
the run's last reported phase (:func:`~dolfinx_sfvem.output.run_phase.phase`), so that such an end always says where it
happened. A normal end (``sys.exit``, the end of the script, an uncaught exception, whose
traceback Python prints itself) disarms it first through Python's ``atexit``.

This is a backstop, not a fix: whatever it reports is a defect to be found and removed. The
handler is a small C extension compiled once per interpreter with cffi into DOLFINx's JIT cache
directory, under the package's compile lock (:mod:`dolfinx_sfvem.discretizations.compile_lock`).
"""
from __future__ import annotations

import atexit
import hashlib
import importlib.util
import logging
import sys
import sysconfig

from dolfinx_sfvem import _compat
from dolfinx_sfvem.discretizations.compile_lock import compiler_lock
from dolfinx_sfvem.output import run_phase

log = logging.getLogger(__name__)

#: the extension's C source: ``arm()`` registers ``last_word`` with C's ``atexit``; ``disarm()``
#: marks a normal end; ``set_phase()`` keeps a copy of the last phase string
SOURCE = r"""
#include <Python.h>
#include <stdlib.h>
#include <string.h>

static int finished = 0;
static char phase_text[512] = "";

static void last_word(void)
{
    if (finished || !Py_IsInitialized())
        return;
    PyGILState_STATE state = PyGILState_Ensure();
    PyObject *sys = PyImport_ImportModule("sys");
    PyObject *err = sys ? PyObject_GetAttrString(sys, "stderr") : NULL;
    if (err && err != Py_None) {
        PyObject *r = PyObject_CallMethod(err, "write", "s",
            "error: the process is ending inside a compiled library's call to exit() "
            "(no Python exception; the exit status is the library's)\n");
        Py_XDECREF(r);
        if (phase_text[0]) {
            r = PyObject_CallMethod(err, "write", "s", "last phase of the run: ");
            Py_XDECREF(r);
            r = PyObject_CallMethod(err, "write", "s", phase_text);
            Py_XDECREF(r);
            r = PyObject_CallMethod(err, "write", "s", "\n");
            Py_XDECREF(r);
        }
        r = PyObject_CallMethod(err, "flush", NULL);
        Py_XDECREF(r);
    }
    PyErr_Clear();
    PyObject *fh = PyImport_ImportModule("faulthandler");
    if (fh && err && err != Py_None) {
        PyObject *r = PyObject_CallMethod(fh, "dump_traceback", "OO", err, Py_False);
        Py_XDECREF(r);
    }
    PyErr_Clear();
    Py_XDECREF(fh);
    Py_XDECREF(err);
    Py_XDECREF(sys);
    PyGILState_Release(state);
}

int arm(void) { return atexit(last_word); }
void disarm(void) { finished = 1; }
void set_phase(const char *text)
{
    strncpy(phase_text, text, sizeof(phase_text) - 1);
    phase_text[sizeof(phase_text) - 1] = 0;
}
"""

CDEF = "int arm(void); void disarm(void); void set_phase(const char *text);"

_lib = None


def _module_name() -> str:
    """The extension's name: a hash of its source and the interpreter's ABI."""
    key = SOURCE + CDEF + sys.version + (sysconfig.get_config_var("SOABI") or "")
    return "dolfinx_sfvem_last_word_" + hashlib.sha1(key.encode()).hexdigest()[:16]


def _load():
    """Compile (once per cache directory) and import the extension; its ``lib``."""
    import cffi

    name = _module_name()
    directory = _compat.jit_cache_dir()
    with compiler_lock(directory):
        found = sorted(directory.glob(name + "*.so"))
        if not found:
            ffi = cffi.FFI()
            ffi.cdef(CDEF)
            ffi.set_source(name, SOURCE)
            found = [ffi.compile(tmpdir=str(directory), verbose=False)]
    spec = importlib.util.spec_from_file_location(name, str(found[0]))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.lib


def arm() -> bool:
    """Register the last word for this process (idempotent). Returns whether it is armed: a
    failure to build it (no C compiler) is logged, never raised."""
    global _lib
    if _lib is not None:
        return True
    try:
        lib = _load()
    except Exception as err:        # the backstop must never stop a run
        log.warning("the last-word handler could not be built (%s); a library's exit() would end the "
                    "run without a message", err)
        return False
    if lib.arm() != 0:
        return False
    atexit.register(lib.disarm)
    _lib = lib
    run_phase.report_to(lambda text: lib.set_phase(text.encode("utf-8", "replace")[:511]))
    return True


def disarm() -> None:
    """Silence the last word: the process is about to end on purpose (e.g. ``MPI_Abort`` after
    the error was reported)."""
    if _lib is not None:
        _lib.disarm()

