"""The load stepping control as a generator of attempts (stepping.LoadStepping.attempts, docs/architecture.md).

Fixed increments (``adaptive=False, predictor=False``):

- Every attempt is yielded: a converged one after the stepper moved to its load, a failed one
  after the state is back at the last converged step and the increment halved; a cut increment
  grows again after two successes.
- When the smallest increment fails, SolveFailed follows the yielded failure.
- A caller that stops after an attempt leaves the stepper at the last converged step.

Adaptive increments and the secant predictor (the defaults):

- the increment grows by up to 2 after easy steps (few Newton iterations), up to max_increment,
  and shrinks after hard ones, never below min_increment;
- a step starts from the secant extrapolation of the last two converged states (exact on a
  linear path), and from the last state when Newton cannot start from the prediction;
- a step the caller rejects (overlapping solids) is cut back as a failed one, never accepted;
- a resumed run continues exactly, also in the middle of a grown increment (a real problem).
"""
import shutil

import numpy as np
import pytest

import dolfinx_sfvem as sf
from mpi4py import MPI
from petsc4py import PETSc

from dolfinx_sfvem.path_following.snes import NewtonResult, SolveFailed
from dolfinx_sfvem.path_following.stepping import LoadStepping


def state() -> PETSc.Vec:
    x = PETSc.Vec().createSeq(2, comm=MPI.COMM_SELF)
    x.set(0.0)
    return x


class newton_to:
    """A stand-in for the step solver: Newton moves x to [load, load] and converges for loads up
    to ``fails_above``."""

    def __init__(self, x: PETSc.Vec, fails_above: float):
        self.x, self.fails_above = x, fails_above

    def solve_at(self, load: float, energy_merit: bool = False) -> NewtonResult:
        self.x.set(load)
        ok = load <= self.fails_above + 1e-12
        return NewtonResult(ok, 2 if ok else -5, 3, [1.0, 1e-12], 1.0, 0, 1, failure="" if ok else "diverged")


def test_attempts_cut_back_and_grow_again():
    x = state()
    stepper = LoadStepping(2, adaptive=False, predictor=False)
    seen = []
    for attempt in stepper.attempts(newton_to(x, fails_above=0.5)):
        seen.append((attempt.load, attempt.converged, x.array[0], stepper.increment))
        if len(seen) == 4:
            break
    assert seen == [(0.5, True, 0.5, 0.5), (1.0, False, 0.5, 0.25), (0.75, False, 0.5, 0.125),
                    (0.625, False, 0.5, 0.0625)]
    assert stepper.load == 0.5

    stepper = LoadStepping(4, min_increment=0.125, adaptive=False, predictor=False)
    stepper.restore({"load": 0.0, "increment": 0.125, "streak": 0})
    loads = [(a.load, stepper.increment) for a in stepper.attempts(newton_to(x, fails_above=1.0))]
    assert loads == [(0.125, 0.125), (0.25, 0.25), (0.5, 0.25), (0.75, 0.25), (1.0, 0.25)]
    assert stepper.load == 1.0


def test_smallest_increment_failing_raises_after_the_attempt():
    x = state()
    stepper = LoadStepping(1, min_increment=0.25, adaptive=False, predictor=False)
    attempts = []
    with pytest.raises(SolveFailed, match="failed with the smallest increment 0.25.*last converged load factor 0"):
        for attempt in stepper.attempts(newton_to(x, fails_above=0.1)):
            attempts.append(attempt.load)
    assert attempts == [1.0, 0.5, 0.25] and stepper.load == 0.0 and np.all(x.array == 0.0)


class path_solver:
    """A stand-in for the step solver on the linear path x(λ) = λ (1, 2): Newton takes
    ``iterations(load, start)`` iterations from the state it starts at and reaches x(λ); it
    records where every solve started and rejects the loads ``rejected(load)`` says."""

    def __init__(self, iterations, rejected=lambda load: False, admissible=lambda load, start: True):
        self.x = state()
        self.iterations, self.rejected, self.admissible = iterations, rejected, admissible
        self.starts = []
        self.merits = []        # energy_merit of every solve

    def solve_at(self, load: float, energy_merit: bool = False) -> NewtonResult:
        start = self.x.array.copy()
        self.starts.append((load, start))
        self.merits.append(energy_merit)
        if not self.admissible(load, start):
            return NewtonResult(False, -3, 0, [], np.nan, -1, -1, failure="domain")
        if self.rejected(load):
            return NewtonResult(False, 2, 3, [1.0, 1e-12], 1.0, 0, 1, failure="solids overlap")
        self.x.setValues([0, 1], [load, 2 * load])
        return NewtonResult(True, 2, self.iterations(load, start), [1.0, 1e-12], 1.0, 0, 1)


def test_easy_steps_grow_the_increment_up_to_the_maximum():
    solver = path_solver(lambda load, start: 1)
    stepper = LoadStepping(16, max_increment=0.25, predictor=False, target_iterations=4)
    loads = [a.load for a in stepper.attempts(solver)]
    increments = np.diff([0.0] + loads)
    assert increments[:3] == pytest.approx([1 / 16, 1 / 8, 1 / 4]) and np.all(increments <= 0.25 + 1e-15)
    assert loads[-1] == 1.0 and len(loads) == 6


def test_hard_steps_shrink_the_increment_but_not_below_the_minimum():
    solver = path_solver(lambda load, start: 16)
    stepper = LoadStepping(4, min_increment=0.05, predictor=False, target_iterations=4)
    loads = [a.load for a in stepper.attempts(solver)]
    increments = np.diff([0.0] + loads)
    assert increments[:4] == pytest.approx([0.25, 0.125, 0.0625, 0.05])
    assert np.all(increments[3:-1] == pytest.approx(0.05)) and loads[-1] == 1.0


def test_only_the_first_step_asks_for_the_energy_merit():
    """The solves of the first step from λ = 0 (its cut-backs included) ask for the energy merit,
    no later one does."""
    solver = path_solver(lambda load, start: 2, rejected=lambda load: 0.2 < load < 0.3)
    attempts = list(LoadStepping(4).attempts(solver))
    first = [k for k, a in enumerate(attempts) if a.converged][0]
    assert attempts[0].load == 0.25 and first > 0, [a.load for a in attempts]
    assert solver.merits == [True] * (first + 1) + [False] * (len(attempts) - first - 1), solver.merits


def test_the_predictor_starts_from_the_secant_extrapolation():
    """On the linear path the secant prediction is the solution: from the third step on every
    solve starts at its own target; without the predictor every solve starts at the last state."""
    solver = path_solver(lambda load, start: 3)
    loads = [a.load for a in LoadStepping(8).attempts(solver)]
    for load, start in solver.starts[2:]:
        np.testing.assert_allclose(start, [load, 2 * load], rtol=1e-12)
    plain = path_solver(lambda load, start: 3)
    loads = [a.load for a in LoadStepping(8, predictor=False).attempts(plain)]
    for (load, start), before in zip(plain.starts[1:], loads):
        np.testing.assert_allclose(start, [before, 2 * before], rtol=1e-12)


def test_newton_starts_from_the_last_state_where_the_prediction_is_inadmissible():
    """Predictions of loads beyond 0.6 (exact on this path: the start is the target) are 'folded':
    Newton cannot start there (0 iterations), so the same step starts again from the last
    converged state and converges."""
    solver = path_solver(lambda load, start: 2,
                         admissible=lambda load, start: not (load > 0.6 and np.isclose(start[0], load)))
    attempts = list(LoadStepping(4, max_increment=0.5).attempts(solver))
    assert all(a.converged for a in attempts) and attempts[-1].load == 1.0
    retried = [(load, start, again) for (load, start), (next_load, again) in zip(solver.starts, solver.starts[1:])
               if next_load == load]
    assert retried and all(load > 0.6 and start[0] == load and again[0] < load for load, start, again in retried)


def test_a_rejected_step_is_cut_back_never_accepted():
    """Steps longer than 0.1 'overlap' once the load passes 0.5: they are rejected, the increment
    halves until a step is short enough, and no rejected load is ever the stepper's."""
    last = {"load": 0.0}

    def rejected(load):
        return load > 0.5 and load - last["load"] > 0.1
    solver = path_solver(lambda load, start: 1, rejected=rejected)
    stepper = LoadStepping(4)
    for attempt in stepper.attempts(solver):
        if attempt.converged:
            assert not rejected(attempt.load)
            last["load"] = attempt.load
        else:
            assert attempt.result.failure == "solids overlap" and stepper.load == last["load"]
    assert stepper.load == 1.0


def strip() -> sf.ContactProblem:
    mesh = sf.meshes.quad_rectangle(2.0, 0.2, 10, 2, tag=1)
    problem = sf.ContactProblem(mesh, {1: sf.Hyperelastic(K=5 / 3, mu=5 / 14)}, verbose=False)
    problem.fix(lambda x: np.isclose(x[0], 0.0), name="clamped")
    problem.prescribe(lambda x: np.isclose(x[0], 2.0), uy=-0.8, name="tip")
    return problem


def test_resume_in_the_middle_of_a_grown_increment(tmp_path):
    """A copy of the run directory taken after step 3 (the increment grown beyond 1/steps by
    then) resumes to the same load factors, Newton iterations and reactions as the run itself."""
    run, copy = tmp_path / "run", tmp_path / "copy"

    def keep(problem):                 # step 4's observer: the checkpoint on disk is step 3's
        if problem.load > 0 and len(list(run.glob("checkpoint.npz"))) and not copy.exists():
            if np.load(run / "checkpoint.npz")["control_increment"] > 1 / 20 + 1e-12:
                shutil.copytree(run, copy)
        return 0.0
    full = strip().solve(20, out=run, observers={"keep": keep})
    assert full.converged and copy.exists()
    resumed = strip().solve(20, out=copy, resume=True, observers={"keep": lambda problem: 0.0})
    assert resumed.converged
    assert [s["load"] for s in resumed.steps] == [s["load"] for s in full.steps]
    assert [s["newton_iterations"] for s in resumed.steps] == [s["newton_iterations"] for s in full.steps]
    np.testing.assert_allclose(resumed.steps[-1]["reaction"]["tip"], full.steps[-1]["reaction"]["tip"], rtol=1e-10)
    assert len(full.steps) < 20


@pytest.mark.parametrize("setting, value", [("min_increment", 1 / 64), ("max_increment", 0.5), ("adaptive", False),
                                            ("predictor", False), ("target_iterations", 4), ("grow_after", 3)])
def test_every_setting_that_changes_the_path_is_described(setting, value):
    """summary.json records the control's settings (``describe``): each one that changes the
    attempts (the cut-back's floor, the growth after successes, ...) changes the description."""
    assert LoadStepping(4, **{setting: value}).describe() != LoadStepping(4).describe()


def test_resume_with_another_smallest_increment_is_refused(tmp_path):
    """A resumed run keeps the stopped run's cut-back floor (default (1/2)/2^10)."""
    strip().solve(control=LoadStepping(2), out=tmp_path)
    with pytest.raises(ValueError, match=r"cannot resume.*control\.min_increment: saved 0\.00048828125, now 0\.001"):
        strip().solve(control=LoadStepping(2, min_increment=1e-3), out=tmp_path, resume=True)
