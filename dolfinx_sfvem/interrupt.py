"""SIGINT/SIGTERM as a request to stop a run after its current load step."""
from __future__ import annotations

import signal

from mpi4py import MPI


class StopRequest:
    """Context manager: while active, SIGINT and SIGTERM are recorded instead of ending the process.

    Outside the main thread, where handlers cannot be installed, signals keep their usual effect.
    """

    def __init__(self):
        self.signalled = 0
        self._old = {}

    def _handler(self, signum, frame):
        self.signalled = signum

    def requested(self, comm: MPI.Comm) -> int:
        """The signal number received on any rank, 0 if none (collective: ranks may receive a
        signal at slightly different times)."""
        return comm.allreduce(self.signalled, op=MPI.MAX)

    def __enter__(self) -> "StopRequest":
        for sig in (signal.SIGINT, signal.SIGTERM):
            try:
                self._old[sig] = signal.signal(sig, self._handler)
            except ValueError:          # not in the main thread
                pass
        return self

    def __exit__(self, *exc) -> bool:
        for sig, old in self._old.items():
            signal.signal(sig, old)
        return False
