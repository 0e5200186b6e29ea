"""Measuring tools: stage timers by wrapping, repeated timing of a call, PETSc events, memory.

Every time is a pair ``{"wall": s, "cpu": s}`` (``time.perf_counter`` and
``time.process_time``). Under MPI, the times of a collective operation are the largest
over the ranks (the ranks wait for the slowest).
"""
from __future__ import annotations

import contextlib
import functools
import resource
import time
import typing

from mpi4py import MPI

Times = dict[str, float]


def now() -> Times:
    """The current wall clock and process (CPU) time."""
    return {"wall": time.perf_counter(), "cpu": time.process_time()}


def since(start: Times) -> Times:
    """Wall and CPU time elapsed since ``start``."""
    end = now()
    return {k: end[k] - start[k] for k in start}


def max_over_ranks(times: Times, comm: MPI.Comm) -> Times:
    """Each entry's largest value over the ranks of ``comm``."""
    return {k: comm.allreduce(v, op=MPI.MAX) for k, v in times.items()}


def stages_over_ranks(times: dict[str, Times], comm: MPI.Comm) -> dict[str, Times]:
    """Each stage's largest times over the ranks; a stage some ranks never entered counts 0 there
    (e.g. the FEM remeshing, done on rank 0)."""
    stages = sorted(set().union(*comm.allgather(list(times))))
    return {s: max_over_ranks(times.get(s, {"wall": 0.0, "cpu": 0.0}), comm) for s in stages}


class StageTimer:
    """Accumulates the time spent in functions named as stages, by wrapping them.

    ``patch(owner, "name", "stage")`` replaces ``owner.name`` with a wrapper that adds its
    wall and CPU time to ``times["stage"]``; leaving the ``with`` block restores every
    patched attribute. Stages may nest (each time is inclusive); ``calls`` counts the
    entries into each stage.

    Examples
    --------
    >>> with StageTimer() as t:                                   # doctest: +SKIP
    ...     t.patch(dolfinx_sfvem.discretizations.space, "build_projections", "projections")
    ...     build_space()
    >>> t.times["projections"]["wall"]                            # doctest: +SKIP
    """

    def __init__(self):
        self.times: dict[str, Times] = {}
        self.calls: dict[str, int] = {}
        self._restore: list[tuple[object, str, object | None]] = []

    def add(self, stage: str, elapsed: Times) -> None:
        """Add ``elapsed`` to ``stage``."""
        total = self.times.setdefault(stage, {"wall": 0.0, "cpu": 0.0})
        for k, v in elapsed.items():
            total[k] += v
        self.calls[stage] = self.calls.get(stage, 0) + 1

    @contextlib.contextmanager
    def stage(self, stage: str) -> typing.Iterator[None]:
        """Time the body of a ``with`` block as ``stage``."""
        start = now()
        try:
            yield
        finally:
            self.add(stage, since(start))

    def patch(self, owner: object, name: str, stage: str) -> None:
        """Time every call of ``owner.name`` as ``stage`` until the timer is left."""
        original = getattr(owner, name)

        @functools.wraps(original)
        def timed(*args, **kwargs):
            with self.stage(stage):
                return original(*args, **kwargs)

        self._restore.append((owner, name, original if name in vars(owner) else None))
        setattr(owner, name, timed)

    def __enter__(self) -> "StageTimer":
        return self

    def __exit__(self, *exc) -> bool:
        for owner, name, original in reversed(self._restore):
            if original is None:            # was inherited or a bound method: drop the wrapper
                delattr(owner, name)
            else:
                setattr(owner, name, original)
        self._restore.clear()
        return False


def time_collective(call: typing.Callable[[], object], comm: MPI.Comm) -> Times:
    """Wall and CPU time of one collective call: the largest over the ranks, started together."""
    comm.barrier()
    start = now()
    call()
    return max_over_ranks(since(start), comm)


def best_of(call: typing.Callable[[], object], comm: MPI.Comm, *, min_repeats: int = 3, min_total: float = 0.5,
            max_repeats: int = 30) -> dict[str, float]:
    """Smallest wall and smallest CPU time of repeated collective calls.

    Repeats at least ``min_repeats`` times and until ``min_total`` seconds of wall time
    were spent (at most ``max_repeats`` times); all ranks repeat equally often.

    Returns
    -------
    dict
        ``wall``, ``cpu`` (minima over the repeats) and ``repeats``.
    """
    best = {"wall": float("inf"), "cpu": float("inf")}
    total, repeats = 0.0, 0
    while repeats < max_repeats and (repeats < min_repeats or total < min_total):
        t = time_collective(call, comm)
        best = {k: min(best[k], t[k]) for k in best}
        total += t["wall"]
        repeats += 1
    return {**best, "repeats": repeats}


def best_of_passes(passes: typing.Sequence[dict[str, float]]) -> dict[str, float]:
    """Combine :func:`best_of` results of several passes: minima, total repeats, each pass's wall minimum."""
    return {"wall": min(p["wall"] for p in passes), "cpu": min(p["cpu"] for p in passes),
            "repeats": sum(p["repeats"] for p in passes), "wall_per_pass": [p["wall"] for p in passes]}


def petsc_event_times(names: typing.Iterable[str]) -> dict[str, float]:
    """Accumulated time (s, this rank) of the named PETSc log events so far.

    Needs ``PETSc.Log.begin()`` before the events happen.
    """
    from petsc4py import PETSc
    return {name: PETSc.Log.Event(name).getPerfInfo()["time"] for name in names}


def peak_rss_mb() -> float:
    """Peak resident set size of this process so far (MiB; Linux reports KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
