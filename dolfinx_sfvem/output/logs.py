"""The package's messages: records of the logger ``dolfinx_sfvem``, and a console for scripts.

Every message of the library is a record of ``logging.getLogger("dolfinx_sfvem")`` or of a child
(``dolfinx_sfvem.path_following.load_path``, ``dolfinx_sfvem.discretizations.space``, ...): the progress line of every load step
(rank 0), the set-up summaries, cut-backs and stops. A problem made with ``verbose=True`` (the
default) logs them at INFO, with ``verbose=False`` at DEBUG; warnings (a broken output file set
aside) at WARNING. So a script can silence the library
(``logging.getLogger("dolfinx_sfvem").setLevel(logging.WARNING)``), capture it or redirect it.

The console: as long as no handler is attached to the ``dolfinx_sfvem`` logger, the library prints
its records to standard output itself (message only, as a script's progress output), and does
not pass them on to the root logger, so that nothing is printed twice (FFCx 0.5 configures the
root logger when it is imported). Attach a handler of your own to ``dolfinx_sfvem`` and the
console steps aside: the records go to your handler and propagate to the root logger again.

FFCx's just-in-time compilation makes setuptools log every compiler call at INFO on the root
logger; :func:`quiet_compilers` keeps those records away from the root logger's handlers while
the library compiles, unless the ``dolfinx_sfvem`` logger is at DEBUG.
"""
from __future__ import annotations

import contextlib
import logging
import sys
import typing

LOGGER = logging.getLogger("dolfinx_sfvem")
if LOGGER.level == logging.NOTSET:
    LOGGER.setLevel(logging.INFO)


class _Console(logging.StreamHandler):
    """The library's console: the message alone, on the standard output of the moment."""

    def __init__(self):
        super().__init__(sys.stdout)
        self.setFormatter(logging.Formatter("%(message)s"))

    def emit(self, record: logging.LogRecord) -> None:
        self.stream = sys.stdout
        super().emit(record)


_CONSOLE = _Console()


def update_console() -> None:
    """The console attached to the package logger if it has no other handler, else detached."""
    others = [h for h in LOGGER.handlers if h is not _CONSOLE]
    if others and _CONSOLE in LOGGER.handlers:
        LOGGER.removeHandler(_CONSOLE)
        LOGGER.propagate = True
    elif not others and _CONSOLE not in LOGGER.handlers:
        LOGGER.addHandler(_CONSOLE)
        LOGGER.propagate = False


def say(logger: logging.Logger, message: str, verbose: bool = True, comm: typing.Any = None) -> None:
    """Log ``message`` at INFO (``verbose``) or DEBUG, on rank 0 of ``comm`` only if given."""
    if comm is not None and comm.rank != 0:
        return
    update_console()
    logger.log(logging.INFO if verbose else logging.DEBUG, message)


def warn(logger: logging.Logger, message: str) -> None:
    """Log ``message`` at WARNING (every rank that calls it)."""
    update_console()
    logger.warning(message)


def _not_compiler_info(record: logging.LogRecord) -> bool:
    return record.levelno >= logging.WARNING or record.name != "root"


@contextlib.contextmanager
def quiet_compilers() -> typing.Iterator[None]:
    """Setuptools' INFO records on the root logger (FFCx's compiler calls) filtered out of the
    root logger's handlers, and the root logger's level restored afterwards (setuptools sets it);
    nothing changes when the package logger is at DEBUG."""
    if LOGGER.isEnabledFor(logging.DEBUG):
        yield
        return
    root = logging.getLogger()
    level, handlers = root.level, list(root.handlers)
    for handler in handlers:
        handler.addFilter(_not_compiler_info)
    try:
        yield
    finally:
        for handler in handlers:
            handler.removeFilter(_not_compiler_info)
        root.setLevel(level)
