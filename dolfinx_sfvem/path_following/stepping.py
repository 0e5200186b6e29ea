"""How a load path advances: controls that yield attempted steps to the load-path driver.

A *control* decides the next point of the path and hands every attempt, converged or not, to
:class:`~dolfinx_sfvem.path_following.load_path.LoadPath`, in the manner of FElupe's ``Step`` feeding its
``Job``. Two controls exist:

- :class:`LoadStepping` (the default): the load factor λ is prescribed, ramped in increments
  with automatic cut-back; each step is a Newton solve at fixed λ;
- :class:`~dolfinx_sfvem.path_following.arclength.ArcLength`: λ is an unknown, each step a Newton solve of the
  balance and an arc-length constraint (limit points, snap-through).

A control talks to the equilibrium solvers of the current mesh through a
:class:`~dolfinx_sfvem.path_following.step_solver.StepSolver` (``solver.x`` the state, ``solver.solve_at(λ)``
Newton at fixed λ with the contact checks, and what arc-length needs); it keeps its own state
(:meth:`Control.state`) so that a checkpoint continues a stopped run exactly.
"""
from __future__ import annotations

import abc
import time
import typing
from dataclasses import dataclass

import numpy as np
from petsc4py import PETSc

from dolfinx_sfvem.path_following.snes import NewtonResult, SolveFailed
from dolfinx_sfvem.path_following.step_solver import StepSolver



@dataclass
class Attempt:
    """One attempted step of a control (or the re-balancing of a continued path)."""
    load: float                 # the load factor aimed at (arc-length: reached)
    result: NewtonResult
    wall_time_s: float          # of the solve
    rebalancing: bool = False   # equilibrium at the load already reached, not a new point of the path

    @property
    def converged(self) -> bool:
        return self.result.converged


class Control(abc.ABC):
    """The common part of the controls (module docstring).

    Attributes
    ----------
    load : float
        Load factor λ of the last converged step.
    until : float
        Load factor at which the path ends.
    finished : bool
        The path ended by another criterion than ``until`` (:meth:`passed`).
    previous : PETSc.Vec or None
        The converged state before the last one (predictors, directions; kept in checkpoints).
    traces_unstable_branches : bool
        The path may run on unstable branches (arc-length); otherwise a converged state with
        negative pivots is reported unstable (:mod:`~dolfinx_sfvem.path_following.stability`).
    """

    load: float
    until: float
    finished: bool = False
    previous: PETSc.Vec | None = None
    traces_unstable_branches: bool = False

    @abc.abstractmethod
    def start(self, load: float, until: float) -> None:
        """Begin a path at the converged load factor ``load`` that ends at ``until``."""

    @abc.abstractmethod
    def attempts(self, solver: StepSolver) -> typing.Iterator[Attempt]:
        """Run the path from the state ``solver.x``, yielding every attempted step.

        A converged attempt is yielded after the control has moved to its load; a failed one
        after ``solver.x`` is back at the last converged state. The caller may stop after any
        attempt (``break``): the control and ``solver.x`` are then at the last converged step.
        Raises :class:`SolveFailed` after yielding an attempt that cannot be retried.
        """

    @abc.abstractmethod
    def state(self) -> dict[str, float]:
        """What a checkpoint needs to continue the path exactly (numbers only)."""

    @abc.abstractmethod
    def restore(self, state: typing.Mapping[str, float]) -> None:
        """Continue from a :meth:`state`."""

    @abc.abstractmethod
    def describe(self) -> dict[str, typing.Any]:
        """The control and its settings (summary.json; a resumed run must use the same)."""

    def forget_history(self) -> None:
        """The mesh changed: what the control kept of earlier states no longer applies."""

    def passed(self, record: typing.Any) -> bool:
        """Whether the converged step ``record`` (a :class:`~dolfinx_sfvem.output.run_summary.StepRecord`)
        ends the path before ``until`` (sets :attr:`finished`)."""
        return False


class LoadStepping(Control):
    """The load factor λ prescribed, from ``start`` to ``until`` (default 0 to 1), one Newton solve
    per step, the last increment shortened to land on ``until``.

    Increments (``adaptive``, the default): the first is ``1 / steps``; after a converged step
    that took n Newton iterations the increment is multiplied by (n_target / n)^½, within
    [1/2, 2], and kept within [``min_increment``, ``max_increment``]: easy stretches of the path
    are crossed in long steps, contact onset in short ones. With ``adaptive=False`` every
    increment is ``1 / steps`` unless cut back, and a cut increment is doubled again after
    ``grow_after`` successes in a row (never beyond ``1 / steps``).

    Predictor (``predictor``, the default): a step starts from the secant extrapolation of the
    last two converged states, x_n + (Δλ / Δλ_prev)(x_n - x_{n-1}), not from x_n; prescribed
    displacements are then at their new values already. Where Newton cannot even start from the
    prediction (a fold or J <= 0 in it), the step starts from x_n instead.

    The first step from λ = 0 (no converged step yet) judges Newton's steps by the total
    potential while far from the solution, where there is one and no prescribed displacement
    moves in it (:meth:`StepSolver.solve_at`): from the stress-free state the residual's norm is a
    poor merit, and the default line search crept at a few percent of Newton's step for tens of
    iterations.

    A step that is not accepted (SNES divergence, J <= 0, a folded element, NaN, or a rejection
    by the caller such as overlapping solids) is retried from the last converged state with half
    the increment, down to ``min_increment``; when even that fails, :class:`SolveFailed` is
    raised after the attempt has been yielded. The control's state (:meth:`state`, and
    :attr:`previous` for the predictor) is what a checkpoint needs to continue exactly.

    Parameters
    ----------
    steps
        1 / steps is the first increment (and, without adaptivity, every increment).
    min_increment
        Smallest increment of the cut-back (default (1/steps)/2¹⁰).
    max_increment
        Largest increment (default max(1/steps, 0.1)): the path has at least
        (until - start) / max_increment converged points.
    adaptive, predictor
        Adaptive increments and the secant predictor (both on by default).
    target_iterations
        Newton iterations per step that the adaptive increment aims at.
    """

    def __init__(self, steps: int, *, min_increment: float | None = None, max_increment: float | None = None,
                 adaptive: bool = True, predictor: bool = True, target_iterations: int = 6, grow_after: int = 2,
                 max_attempts: int = 10_000, start: float = 0.0, until: float = 1.0):
        if not (isinstance(steps, (int, np.integer)) and not isinstance(steps, bool) and steps >= 1):
            raise ValueError(f"steps must be a positive integer, got {steps!r}")
        self.steps = int(steps)
        self.nominal = 1.0 / steps
        self.min_increment = min_increment if min_increment is not None else self.nominal / 2 ** 10
        if not (0 < self.min_increment <= self.nominal):
            raise ValueError(f"min_increment must be in (0, 1/steps], got {self.min_increment}")
        self.max_increment = max_increment if max_increment is not None else max(self.nominal, 0.1)
        if not (self.nominal <= self.max_increment <= 1.0):
            raise ValueError(f"max_increment must be in [1/steps, 1], got {self.max_increment}")
        if not (isinstance(target_iterations, int) and target_iterations >= 1):
            raise ValueError(f"target_iterations must be an integer >= 1, got {target_iterations!r}")
        self.adaptive, self.predictor = bool(adaptive), bool(predictor)
        self.target_iterations = target_iterations
        self.grow_after = grow_after
        self.max_attempts = max_attempts
        self.previous = None
        self.start(start, until)

    def start(self, load: float, until: float) -> None:
        if not (0.0 <= load <= until <= 1.0):
            raise ValueError(f"need 0 <= start <= until <= 1, got start = {load}, until = {until}")
        self.until = until
        self.load, self.increment, self.streak = float(load), self.nominal, 0
        self.previous_load = float(load)
        self.forget_history()

    def state(self) -> dict[str, float]:
        return {"load": self.load, "increment": self.increment, "streak": self.streak,
                "previous_load": self.previous_load}

    def restore(self, state: typing.Mapping[str, float]) -> None:
        self.load, self.increment, self.streak = float(state["load"]), float(state["increment"]), int(state["streak"])
        self.previous_load = float(state.get("previous_load", self.load))

    def describe(self) -> dict[str, typing.Any]:
        return {"control": "load stepping", "steps": self.steps, "adaptive": self.adaptive,
                "predictor": self.predictor, "min_increment": self.min_increment,
                "max_increment": self.max_increment, "target_iterations": self.target_iterations,
                "grow_after": self.grow_after}

    def forget_history(self) -> None:
        if self.previous is not None:
            self.previous.destroy()
        self.previous = None

    def _predict(self, x: PETSc.Vec, target: float) -> bool:
        """x moved to the secant prediction at ``target``; whether there was one to make."""
        if not self.predictor or self.previous is None or self.load <= self.previous_load:
            return False
        x.scale(1.0 + (target - self.load) / (self.load - self.previous_load))
        x.axpy(-(target - self.load) / (self.load - self.previous_load), self.previous)
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        return True

    def _grow(self, iterations: int) -> None:
        """The next increment after a converged step that took ``iterations``."""
        if self.adaptive:
            factor = min(2.0, max(0.5, (self.target_iterations / max(iterations, 1)) ** 0.5))
            self.increment = min(self.max_increment, max(self.min_increment, self.increment * factor))
        else:
            self.streak += 1
            if self.increment < self.nominal and self.streak >= self.grow_after:
                self.increment, self.streak = min(2 * self.increment, self.nominal), 0

    def attempts(self, solver: StepSolver) -> typing.Iterator[Attempt]:
        x = solver.x
        for _ in range(self.max_attempts):
            if self.load >= self.until - 1e-12:
                return
            target = min(self.load + self.increment, self.until)
            saved = x.copy()
            t0 = time.perf_counter()
            if self._predict(x, target):
                result = solver.solve_at(target)
                if not result.converged and result.iterations == 0:      # Newton could not start there
                    saved.copy(x)
                    x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
                    result = solver.solve_at(target)
            else:
                result = solver.solve_at(target, energy_merit=self.load == 0.0 and self.previous is None)
            elapsed = time.perf_counter() - t0
            if result.converged:
                self.forget_history()
                self.previous, saved = saved, None
                self.previous_load, self.load = self.load, target
                self._grow(result.iterations)
            else:
                saved.copy(x)
                x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
                saved.destroy()
                self.streak = 0
            smallest = not result.converged and self.increment / 2 < self.min_increment * (1 - 1e-12)
            if not (result.converged or smallest):
                self.increment /= 2
            yield Attempt(target, result, elapsed)
            if smallest:
                raise SolveFailed(
                    f"load step to load factor {target:.6g} failed with the smallest increment "
                    f"{self.increment:.3g} ({result.failure}; {result.iterations} Newton iterations, "
                    f"last residuals {', '.join(f'{r:.3e}' for r in result.residual_norms[-3:])}, "
                    f"min J {result.min_J:.3e} in cell {result.min_J_cell} of region {result.min_J_tag}); "
                    f"last converged load factor {self.load:.6g}")
        raise SolveFailed(f"load path not finished after {self.max_attempts} attempts (load factor {self.load:.6g})")
