"""The load stepping control as a generator of attempts (stepping.LoadStepping.attempts, docs/architecture.md).

- Every attempt is yielded: a converged one after the stepper moved to its load, a failed one
  after the state is back at the last converged step and the increment halved; a cut increment
  grows again after two successes.
- When the smallest increment fails, SolveFailed follows the yielded failure.
- A caller that stops after an attempt leaves the stepper at the last converged step.
"""
import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

from dolfinx_sfvem.snes import NewtonResult, SolveFailed
from dolfinx_sfvem.stepping import LoadStepping


def state() -> PETSc.Vec:
    x = PETSc.Vec().createSeq(2, comm=MPI.COMM_SELF)
    x.set(0.0)
    return x


class newton_to:
    """A stand-in for the step solver: Newton moves x to [load, load] and converges for loads up
    to ``fails_above``."""

    def __init__(self, x: PETSc.Vec, fails_above: float):
        self.x, self.fails_above = x, fails_above

    def solve_at(self, load: float) -> NewtonResult:
        self.x.set(load)
        ok = load <= self.fails_above + 1e-12
        return NewtonResult(ok, 2 if ok else -5, 3, [1.0, 1e-12], 1.0, 0, 1, failure="" if ok else "diverged")


def test_attempts_cut_back_and_grow_again():
    x = state()
    stepper = LoadStepping(2)
    seen = []
    for attempt in stepper.attempts(newton_to(x, fails_above=0.5)):
        seen.append((attempt.load, attempt.converged, x.array[0], stepper.increment))
        if len(seen) == 4:
            break
    assert seen == [(0.5, True, 0.5, 0.5), (1.0, False, 0.5, 0.25), (0.75, False, 0.5, 0.125),
                    (0.625, False, 0.5, 0.0625)]
    assert stepper.load == 0.5

    stepper = LoadStepping(4, min_increment=0.125)
    stepper.restore({"load": 0.0, "increment": 0.125, "streak": 0})
    loads = [(a.load, stepper.increment) for a in stepper.attempts(newton_to(x, fails_above=1.0))]
    assert loads == [(0.125, 0.125), (0.25, 0.25), (0.5, 0.25), (0.75, 0.25), (1.0, 0.25)]
    assert stepper.load == 1.0


def test_smallest_increment_failing_raises_after_the_attempt():
    x = state()
    stepper = LoadStepping(1, min_increment=0.25)
    attempts = []
    with pytest.raises(SolveFailed, match="failed with the smallest increment 0.25.*last converged load factor 0"):
        for attempt in stepper.attempts(newton_to(x, fails_above=0.1)):
            attempts.append(attempt.load)
    assert attempts == [1.0, 0.5, 0.25] and stepper.load == 0.0 and np.all(x.array == 0.0)
