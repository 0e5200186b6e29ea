"""Ctrl-C and SIGTERM during a load path: stop after the current step, or interrupt at once.

In a script (the main thread of a plain interpreter) :class:`StopRequest` turns the first SIGINT
(Ctrl-C) or SIGTERM into a request to stop after the current load step: the run ends with every
converged step written and a message saying it was stopped (``solve(..., resume=True)``
continues it). A second SIGINT or SIGTERM (a batch scheduler's second notice before it kills)
interrupts at once with :class:`Interrupted`, a ``KeyboardInterrupt`` that names its signal:
the load path puts the state back to its last converged step and writes its outputs before the
exception goes on.

Where Python cannot install signal handlers (a thread other than the main one) or where the user
expects Ctrl-C to interrupt (an IPython kernel: Jupyter's "interrupt the kernel"), no handler is
installed and Ctrl-C raises ``KeyboardInterrupt`` as usual; the load path then puts the state back
to its last converged step and writes its outputs before the exception goes on
(:meth:`~dolfinx_sfvem.path_following.load_path.LoadPath.run`).
"""
from __future__ import annotations

import logging
import signal
import sys
import threading

from mpi4py import MPI

from dolfinx_sfvem.output.logs import say

log = logging.getLogger(__name__)


def in_notebook_kernel() -> bool:
    """Whether this process is an IPython kernel (a Jupyter notebook)."""
    ipython = sys.modules.get("IPython")
    shell = ipython.get_ipython() if ipython is not None and hasattr(ipython, "get_ipython") else None
    return shell is not None and type(shell).__name__ == "ZMQInteractiveShell"


def handles_signals() -> bool:
    """Whether :class:`StopRequest` installs its handlers by default: in the main thread of a
    process that is not an IPython kernel."""
    return threading.current_thread() is threading.main_thread() and not in_notebook_kernel()


class Interrupted(KeyboardInterrupt):
    """A run interrupted at once by the signal ``signum`` (a second SIGINT or SIGTERM)."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = int(signum)


def raise_interrupted(signum: int, frame) -> None:
    """A signal handler: raise :class:`Interrupted` (SIGTERM outside a load path, where Python's
    default would end the process without a word)."""
    raise Interrupted(signum)


def interrupt_in(err: BaseException) -> KeyboardInterrupt | None:
    """The ``KeyboardInterrupt`` that ``err`` is or was raised from (its ``__cause__`` /
    ``__context__`` chain), None if there is none: code that the signal handler interrupted may
    wrap the interrupt into an exception of its own (e.g. a ``RuntimeError`` of Python's class
    creation)."""
    seen = set()
    while err is not None and id(err) not in seen:
        if isinstance(err, KeyboardInterrupt):
            return err
        seen.add(id(err))
        err = err.__cause__ or err.__context__
    return None


def signal_of(interrupt: KeyboardInterrupt) -> int:
    """The signal number of a ``KeyboardInterrupt``: an :class:`Interrupted`'s own, SIGINT for
    any other (Python raises those on Ctrl-C where no handler is installed)."""
    return getattr(interrupt, "signum", int(signal.SIGINT))


class StopRequest:
    """Context manager: while active, the first SIGINT or SIGTERM is recorded as a request to stop
    after the current step, a second one of either raises :class:`Interrupted` (module docstring).

    Parameters
    ----------
    enabled
        Install the handlers; None: where :func:`handles_signals` says so.
    """

    def __init__(self, enabled: bool | None = None):
        self.enabled = handles_signals() if enabled is None else bool(enabled)
        self.signalled = 0
        self._old = {}

    def _handler(self, signum, frame):
        if self.signalled:
            raise Interrupted(signum)
        say(log, f"signal {signum}: stopping after the current step (the same signal or Ctrl-C again "
                 "interrupts at once)")
        self.signalled = signum

    def requested(self, comm: MPI.Comm) -> int:
        """The signal number received on any rank, 0 if none (collective: ranks may receive a
        signal at slightly different times)."""
        return comm.allreduce(self.signalled, op=MPI.MAX)

    def __enter__(self) -> "StopRequest":
        if self.enabled:
            for sig in (signal.SIGINT, signal.SIGTERM):
                try:
                    self._old[sig] = signal.signal(sig, self._handler)
                except ValueError:          # not in the main thread after all
                    pass
        return self

    def __exit__(self, *exc) -> bool:
        for sig, old in self._old.items():
            signal.signal(sig, old)
        return False
