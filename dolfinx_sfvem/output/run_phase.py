"""What the run is doing now (a load step, a compile): the phase that a report of where the
process ended names (:mod:`~dolfinx_sfvem.output.last_word`).

:func:`phase` records it and hands it to the reporter registered with :func:`report_to`, if any.
"""
from __future__ import annotations

import contextlib
import typing

_phase = ""
_reporter: typing.Callable[[str], None] | None = None


def report_to(reporter: typing.Callable[[str], None] | None) -> None:
    """Hand every phase recorded from now on to ``reporter`` (None: to no one)."""
    global _reporter
    _reporter = reporter


def phase(text: str) -> str:
    """Record what the run is doing now; returns the phase it replaces."""
    global _phase
    previous, _phase = _phase, text
    if _reporter is not None:
        _reporter(text)
    return previous


@contextlib.contextmanager
def in_phase(text: str) -> typing.Iterator[None]:
    """:func:`phase` for the body, the previous phase again after it."""
    previous = phase(text)
    try:
        yield
    finally:
        phase(previous)
