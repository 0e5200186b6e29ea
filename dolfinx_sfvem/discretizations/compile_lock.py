"""One compile at a time per FFCx cache directory, across processes.

FFCx's cache protocol (``ffcx.codegeneration.jit.get_cached_module``, DOLFINx 0.5 to 0.11): the
first process to need a form creates ``<module>.c`` exclusively and compiles it, then writes
``<module>.c.cached``; a process that finds the ``.c`` already there polls for the ``.cached``
file for ``timeout`` seconds (DOLFINx's default: 10) and then raises "JIT compilation timed out,
probably due to a failed previous compile". So processes started together on an empty cache
(a parameter sweep, several ``mpirun`` jobs) die whenever one waits for another's compile of
the same form that takes longer than that, which a loaded machine's compile of a tangent form
easily does.

:func:`compiler_lock` holds an exclusive ``flock`` on ``<cache_dir>/dolfinx_sfvem.lock`` around a
compile, so that FFCx's protocol never waits: a process finds either no ``.c`` file (and compiles)
or a finished module. The lock is released when the holder ends, however it ends, so it never
goes stale. A waiting process logs one message at INFO and waits as long as the compile takes.

A compile interrupted by something FFCx does not catch (Ctrl-C: ``KeyboardInterrupt``) leaves its
``.c`` file behind without ``.c.cached``; every later run would time out on it. The lock's holder
renames the ``.c`` files it started and did not finish to ``.c.failed``, as FFCx does on errors.

:func:`locked_compiles` applies the lock to FFCx's JIT entry points (``compile_forms``,
``compile_expressions``, ``compile_elements``, as DOLFINx calls them, with their ``cache_dir``)
while the package compiles, so every rank takes it around its own compile or cache load only. In
an MPI job DOLFINx compiles on rank 0 and then lets the other ranks load the module (its
``mpi_jit_decorator``); that load is a compile of its own whenever a rank's module name differs
from rank 0's (the package's forms keep one name on every rank:
:func:`~dolfinx_sfvem._compat.settle_coordinate_element`; a user's forms may not). A lock held
across DOLFINx's collective instead would deadlock (a rank holding it while rank 0 waits for it).
"""
from __future__ import annotations

import contextlib
import fcntl
import functools
import logging
import os
import pathlib
import threading
import time
import typing

import ffcx.codegeneration.jit

from dolfinx_sfvem.discretizations.c_compiler import c_compiler
from dolfinx_sfvem.output import run_phase
from dolfinx_sfvem.output.logs import quiet_compilers, say

log = logging.getLogger(__name__)

#: name of the lock file in the cache directory
LOCK_NAME = "dolfinx_sfvem.lock"

#: lock files this process holds -> nesting depth (a second ``flock`` on a new descriptor of the same
#: file would wait for this process itself)
_held: dict[pathlib.Path, int] = {}
_held_guard = threading.Lock()


@contextlib.contextmanager
def compiling() -> typing.Iterator[None]:
    """Context of every JIT compile of the package: the compilers' chatter kept off the console
    (:func:`~dolfinx_sfvem.output.logs.quiet_compilers`), each rank's compile under the inter-process
    lock of its cache directory (:func:`locked_compiles`), with clang when it is installed
    (:func:`~dolfinx_sfvem.discretizations.c_compiler.c_compiler`)."""
    with quiet_compilers(), c_compiler(), locked_compiles(), \
            run_phase.in_phase("compiling forms (FFCx and the C compiler)"):
        yield


def compiled_form(form: "ufl.Form") -> "dolfinx.fem.Form":
    """``dolfinx.fem.form(form)`` compiled in :func:`compiling` (quietly, under the cache
    directory's lock): how every module of the package compiles a UFL form."""
    import dolfinx.fem
    with compiling():
        return dolfinx.fem.form(form)


#: FFCx's JIT entry points that DOLFINx calls (those the installed FFCx has)
_ENTRY_POINTS = tuple(name for name in ("compile_forms", "compile_expressions", "compile_elements")
                      if hasattr(ffcx.codegeneration.jit, name))
#: how many :func:`locked_compiles` are active, and FFCx's own entry points while any is
_active = {"depth": 0, "originals": {}}


@contextlib.contextmanager
def locked_compiles() -> typing.Iterator[None]:
    """While active, FFCx's JIT entry points run under :func:`compiler_lock` of their
    ``cache_dir`` (none without one: FFCx then compiles in a fresh temporary directory).
    Re-entrant; FFCx's functions are restored when the outermost one ends."""
    with _held_guard:
        if not _active["depth"]:
            for name in _ENTRY_POINTS:
                _active["originals"][name] = original = getattr(ffcx.codegeneration.jit, name)
                setattr(ffcx.codegeneration.jit, name, _under_lock(original))
        _active["depth"] += 1
    try:
        yield
    finally:
        with _held_guard:
            _active["depth"] -= 1
            if not _active["depth"]:
                for name, original in _active["originals"].items():
                    setattr(ffcx.codegeneration.jit, name, original)


def _under_lock(compile_function: typing.Callable) -> typing.Callable:
    """``compile_function`` under the lock of the ``cache_dir`` it is given."""
    @functools.wraps(compile_function)
    def locked(*args, **kwargs):
        if kwargs.get("cache_dir") is None:
            return compile_function(*args, **kwargs)
        with compiler_lock(kwargs["cache_dir"]):
            return compile_function(*args, **kwargs)
    return locked


@contextlib.contextmanager
def compiler_lock(cache_dir: str | os.PathLike) -> typing.Iterator[None]:
    """Hold the cache directory's compile lock for the body.

    Parameters
    ----------
    cache_dir
        FFCx's cache directory (created if missing).

    Re-entrant within a process. On an exception in the body, the ``.c`` files of the cache
    directory that were created while the lock was held and have no ``.c.cached`` are renamed
    to ``.c.failed`` (interrupted compiles).
    """
    path = pathlib.Path(cache_dir) / LOCK_NAME
    with _held_guard:
        depth = _held.get(path, 0)
        _held[path] = depth + 1
    try:
        if depth:
            yield
            return
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "a") as lock:
            _acquire(lock, path)
            since = time.time()
            try:
                yield
            except BaseException:
                _set_aside_unfinished(path.parent, since)
                raise
    finally:
        with _held_guard:
            _held[path] -= 1
            if not _held[path]:
                del _held[path]


def _acquire(lock: typing.IO, path: pathlib.Path) -> None:
    """Exclusive ``flock`` on ``lock``, waiting (with one message) while another process holds it."""
    try:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        say(log, f"waiting for another process's compile in {path.parent} (lock {path.name})")
        fcntl.flock(lock, fcntl.LOCK_EX)


def _set_aside_unfinished(cache_dir: pathlib.Path, since: float) -> None:
    """Rename the ``.c`` files modified since ``since`` without ``.c.cached`` to ``.c.failed``."""
    for c_file in cache_dir.glob("*.c"):
        with contextlib.suppress(FileNotFoundError):
            if c_file.stat().st_mtime >= since - 1.0 and not c_file.with_suffix(".c.cached").exists():
                os.replace(c_file, c_file.with_suffix(".c.failed"))
