"""One compile at a time per FFCx cache directory, across processes.

FFCx's cache protocol (``ffcx.codegeneration.jit.get_cached_module``, DOLFINx 0.5 to 0.11): the
first process to need a form creates ``<module>.c`` exclusively and compiles it, then writes
``<module>.c.cached``; a process that finds the ``.c`` already there polls for the ``.cached``
file for ``timeout`` seconds (DOLFINx's default: 10) and then raises "JIT compilation timed out,
probably due to a failed previous compile". So processes started together on an empty cache
(a parameter sweep, several ``mpirun`` jobs) die whenever one waits for another's compile of
the same form that takes longer than that, which a loaded machine's compile of a tangent form
easily does (docs/notes/2026-11-26-concurrent-starts.md).

:func:`compiler_lock` holds an exclusive ``flock`` on ``<cache_dir>/dolfinx_sfvem.lock`` around a
compile, so that FFCx's protocol never waits: a process finds either no ``.c`` file (and compiles)
or a finished module. The lock is released when the holder ends, however it ends, so it never
goes stale. A waiting process logs one message at INFO and waits as long as the compile takes.

A compile interrupted by something FFCx does not catch (Ctrl-C: ``KeyboardInterrupt``) leaves its
``.c`` file behind without ``.c.cached``; every later run would time out on it. The lock's holder
renames the ``.c`` files it started and did not finish to ``.c.failed``, as FFCx does on errors.

In an MPI job DOLFINx compiles on rank 0, then the other ranks load the module (its
``mpi_jit_decorator``): only rank 0 takes the lock (``hold``), the others wait for it inside
DOLFINx's collective; a lock taken on every rank would deadlock (a rank > 0 holding it in the
collective while rank 0 waits for it).
"""
from __future__ import annotations

import contextlib
import fcntl
import logging
import os
import pathlib
import threading
import time
import typing

from .logs import say

log = logging.getLogger(__name__)

#: name of the lock file in the cache directory
LOCK_NAME = "dolfinx_sfvem.lock"

#: lock files this process holds -> nesting depth (a second ``flock`` on a new descriptor of the same
#: file would wait for this process itself)
_held: dict[pathlib.Path, int] = {}
_held_guard = threading.Lock()


@contextlib.contextmanager
def compiler_lock(cache_dir: str | os.PathLike, hold: bool = True) -> typing.Iterator[None]:
    """Hold the cache directory's compile lock for the body (nothing if not ``hold``).

    Parameters
    ----------
    cache_dir
        FFCx's cache directory (created if missing).
    hold
        Take the lock; False on the ranks > 0 of a DOLFINx compile (module docstring).

    Re-entrant within a process. On an exception in the body, the ``.c`` files of the cache
    directory that were created while the lock was held and have no ``.c.cached`` are renamed
    to ``.c.failed`` (interrupted compiles).
    """
    if not hold:
        yield
        return
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
