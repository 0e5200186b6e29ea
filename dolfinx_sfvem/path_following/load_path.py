"""The load path driver: a control's attempts turned into records, output, continuation and adaptivity.

:class:`LoadPath` runs a problem (the definition and the state; what it reads of one is
:class:`Problem`, which a :class:`~dolfinx_sfvem.problem.ContactProblem` has) along a path with a control (:class:`~dolfinx_sfvem.path_following.stepping.LoadStepping` by
default, :class:`~dolfinx_sfvem.path_following.arclength.ArcLength`), the way FElupe's ``Job`` evaluates the
increments its ``Step`` yields::

    for each mesh level (a new one after an adaptive refinement):       # LoadPath._run_mesh
        step_solver = the solvers of the mesh                           # freed however the level ends
        for attempt in control.attempts(step_solver):                   # Newton (or arc-length) per attempt
            record it                                                   # gap, reactions, loads, observers
            if converged: progress line, write the step                 # run_output.RunWriter
            if adaptive: refine, next level                             # adaptivity.Adaptivity
            if a stop was requested: end                                # interrupt.StopRequest

A mesh level ends with a :class:`MeshOutcome`: the path ended, the mesh was refined (or its
refinement undone), a step failed, or an interrupt came; in each the problem holds its last
converged state.

The controls never see the problem: they talk to a :class:`StepSolver`, the equilibrium
solvers of the current mesh (Newton at a fixed load factor, and the balance with its load
vector for arc-length), which also applies the contact honesty rule: a converged state whose
solids overlap is rejected like a failed solve. ``ContactProblem.solve`` is this driver.
"""
from __future__ import annotations

import dataclasses
import enum
import itertools
import logging
import pathlib
import time
import typing
from dataclasses import asdict

import numpy as np
from petsc4py import PETSc

from dolfinx_sfvem.output import run_phase
from dolfinx_sfvem.discretizations.discretization import KeyedState
from dolfinx_sfvem.mesh.cell_mesh import CellMesh
from dolfinx_sfvem.mesh.cell_refine import CellRefinement
from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh, Refinement
from dolfinx_sfvem.path_following.adaptivity import Adaptivity, ProblemState
from dolfinx_sfvem.physics.contact import BoundaryNodes, ContactPressure, Gap
from dolfinx_sfvem.physics.equilibrium import Equilibrium
from dolfinx_sfvem.path_following.gamma_continuation import ContinuedStepSolver, GammaContinuation
from dolfinx_sfvem.path_following.interrupt import StopRequest, signal_of
from dolfinx_sfvem.output.logs import say, warn
from dolfinx_sfvem.physics.loads import VectorLoad
from dolfinx_sfvem.output.run_output import RunWriter, progress_line, read_checkpoint
from dolfinx_sfvem.output.run_summary import (
    STOPPED_BY_SIGNAL, Observer, Result, StepRecord, describe_economy, newton_economy)
from dolfinx_sfvem.path_following.snes import NewtonResult, SNESNewton, SolveFailed
from dolfinx_sfvem.path_following.stability import final_stability, instability, is_stable
from dolfinx_sfvem.path_following.step_solver import StepSolver
from dolfinx_sfvem.path_following.stepping import Attempt, Control, LoadStepping

log = logging.getLogger(__name__)

#: steps of the residual relaxation of :meth:`LoadPath._rebalance` (cut back down to a quarter of one)
RELAX_STEPS = 4


class PrescribedValues(typing.Protocol):
    """A problem's prescribed displacements on its current discretization."""
    dofs: np.ndarray                        # (k,) int64: constrained unknowns, local blocked numbering, sorted
    final: np.ndarray                       # (k_owned,): their values at load factor 1, the owned ones
    dofs_of: dict[str, np.ndarray]          # the unknowns of every boundary condition, by its name


class Problem(ProblemState, typing.Protocol):
    """What the driver reads and sets of a problem: its definition, its state (``x`` at load
    factor ``load``) and the queries on them, as :class:`~dolfinx_sfvem.problem.ContactProblem`
    has them."""
    boundary: BoundaryNodes
    load: float
    solved: bool
    verbose: bool
    petsc_options_prefix: str
    linear_solver: str

    def constraints(self) -> PrescribedValues: ...

    def equilibrium(self) -> Equilibrium: ...

    def reactions(self, force: PETSc.Vec | None = None,
                  dofs_of: typing.Mapping[str, np.ndarray] | None = None) -> dict[str, list[float]]: ...

    def max_displacement(self) -> float: ...

    def contact_state(self) -> tuple[Gap, ContactPressure]: ...

    def point_displacements(self) -> np.ndarray | None: ...

    def gathered_state(self) -> KeyedState: ...

    def move_to(self, refinement: Refinement | CellRefinement) -> None: ...

    def rebuild(self, mesh: PolygonMesh | CellMesh, state: KeyedState) -> None: ...

    def describe(self) -> dict: ...


def observe(problem: Problem, observers: typing.Mapping[str, Observer]) -> dict[str, float]:
    """The observers' values: ``name`` for a number, ``name.key`` for each entry of a mapping."""
    values: dict[str, float] = {}
    for name, f in observers.items():
        value = f(problem)
        if isinstance(value, typing.Mapping):
            values.update({f"{name}.{key}": float(v) for key, v in value.items()})
        else:
            values[name] = float(value)
    return values


class Ending(enum.Enum):
    """How the path on one mesh ended (:meth:`LoadPath._run_mesh`)."""
    #: the control's path ended (``until`` reached, its ``passed`` criterion) or a stop was requested
    ENDED = enum.auto()
    #: adaptive refinement after a converged step: the path goes on on the refined mesh, re-balanced first
    REFINED = enum.auto()
    #: re-balancing the refined mesh failed and the refinement was undone: the path goes on on the
    #: mesh before, without adaptivity
    UNREFINED = enum.auto()
    #: a step failed with the smallest increment, or re-balancing failed with nothing to undo (:class:`SolveFailed`)
    FAILED = enum.auto()
    #: a ``KeyboardInterrupt`` (Ctrl-C, or :class:`~dolfinx_sfvem.path_following.interrupt.Interrupted`)
    INTERRUPTED = enum.auto()


@dataclasses.dataclass(frozen=True)
class MeshStart:
    """How the path starts on one mesh (:meth:`LoadPath._run_mesh`).

    Attributes
    ----------
    new_mesh : bool
        Not the mesh the run started on: the run's outputs change mesh and the control forgets
        what it kept of earlier states before the first attempt.
    rebalance : bool
        Equilibrium at the load factor already reached (:meth:`LoadPath._rebalance`) before the
        control's attempts: a continued path, or a state transferred by refinement.
    before : (mesh, state) or None
        Of the adaptive refinement that made this mesh, the mesh and gathered state before it,
        where a failed re-balancing goes back to; None when the state was not transferred (it is
        then checked as a starting state).
    adapt : Adaptivity or None
        Adaptive refinement after the converged steps on this mesh.
    """
    new_mesh: bool = False
    rebalance: bool = False
    before: tuple[PolygonMesh | CellMesh, KeyedState] | None = None
    adapt: Adaptivity | None = None


@dataclasses.dataclass
class MeshOutcome:
    """How the path on one mesh ended; the problem then holds its last converged state
    (``problem.x`` at ``problem.load``) on the mesh the path goes on with.

    Attributes
    ----------
    ending : Ending
    before : (mesh, state) or None
        ``REFINED``: the mesh and gathered state before the refinement (:attr:`MeshStart.before`
        of the next mesh).
    error : SolveFailed or KeyboardInterrupt or None
        ``FAILED`` and ``INTERRUPTED``: the exception that ended the path.
    """
    ending: Ending
    before: tuple[PolygonMesh | CellMesh, KeyedState] | None = None
    error: SolveFailed | KeyboardInterrupt | None = None


class LoadPath:
    """A run of a problem along a load path (module docstring); the parameters are those of
    :meth:`ContactProblem.solve <dolfinx_sfvem.problem.ContactProblem.solve>`."""

    def __init__(self, problem: Problem, control: Control, out: str | pathlib.Path | None = None, *,
                 petsc_options: typing.Mapping[str, typing.Any] | None = None,
                 observers: typing.Mapping[str, Observer] | None = None, raise_on_failure: bool = False,
                 resume: bool = False, from_current_state: bool = False, until: float = 1.0,
                 adapt: Adaptivity | None = None, pressure_at: typing.Iterable[float] = (),
                 handle_signals: bool | None = None, gamma_start: float | None = None):
        self.problem = problem
        self.control = control
        self.out = pathlib.Path(out) if out is not None else None
        self.petsc_options = petsc_options
        self.observers = dict(observers or {})
        self.raise_on_failure = raise_on_failure
        self.resume = resume
        self.from_current_state = from_current_state
        self.until = until
        self.adapt = adapt
        self.pressure_at = tuple(pressure_at)
        self.handle_signals = handle_signals
        self.continuation = None
        if gamma_start is not None:
            if control.traces_unstable_branches:
                raise ValueError("gamma_start needs a prescribed load factor (LoadStepping): under arc-length "
                                 "the load factor is an unknown")
            self.continuation = GammaContinuation(problem.materials, gamma_start, until)
            self.observers["gamma"] = lambda _: self.continuation.current()
        self.earlier_wall_time = 0.0          # of the stopped run a resumed path continues
        self.records: list[dict] = []

    # ------------------------------------------------------------------ the run
    def run(self) -> Result:
        """Solve the path; returns its :class:`Result` (see :meth:`ContactProblem.solve`). A
        continued gamma (``gamma_start``) is back at the asked values afterwards.

        Raises
        ------
        SolveFailed
            With ``raise_on_failure``, when a step fails with the smallest increment (the outputs
            are written first).
        KeyboardInterrupt
            Ctrl-C or a second signal (:class:`~dolfinx_sfvem.path_following.interrupt.Interrupted`)
            interrupted the run: the problem is back at its last converged state and the outputs
            say so before the exception goes on.
        """
        try:
            return self._run()
        finally:
            if self.continuation is not None:
                self.continuation.restore()

    def _run(self) -> Result:
        """The path over its mesh levels: :meth:`_run_mesh` on each, a level after every adaptive
        refinement (and after an undone one), then the outputs and the result."""
        p = self.problem
        start = MeshStart(rebalance=self.from_current_state and p.solved and not self.resume, adapt=self.adapt)
        if self.adapt is not None:
            self.adapt.level = None                 # levels count from the mesh this solve starts on
        p.solved = True
        self.t_start = time.perf_counter()
        self.control.start(p.load if self.from_current_state else 0.0, self.until)
        if self.resume:
            if self.out is None:
                raise ValueError("resume needs the output directory of the stopped run")
            p.disc.set_constraints(p.constraints().dofs)
            self.records = self._restore_checkpoint()
        writer = RunWriter(p.comm, p.disc, p.x, self.out, self.control, self.summary, append=self.resume,
                           pressure_at=self.pressure_at) if self.out is not None else None
        message = ""
        with StopRequest(self.handle_signals) as stop:
            while True:
                outcome = self._run_mesh(start, writer, stop)
                if outcome.ending is Ending.REFINED:
                    start = MeshStart(new_mesh=True, rebalance=True, before=outcome.before, adapt=start.adapt)
                elif outcome.ending is Ending.UNREFINED:
                    start = MeshStart(new_mesh=True)
                else:
                    break
            if outcome.ending is Ending.INTERRUPTED:
                interrupt = outcome.error
                self._finish(writer, f"{STOPPED_BY_SIGNAL} {signal_of(interrupt)} "
                                     f"({str(interrupt) or 'KeyboardInterrupt'}, at once) at load factor {p.load:.6g}")
                raise interrupt
            if outcome.ending is Ending.FAILED:
                failure = outcome.error
                n_done = sum(r["converged"] for r in self.records)
                message = f"step {n_done + 1}: {failure}"
                failure.args = (message,)
                if self.raise_on_failure:
                    self._finish(writer, message)
                    raise failure
        signalled = stop.requested(p.comm)
        if signalled:
            message = f"{STOPPED_BY_SIGNAL} {signalled} at load factor {p.load:.6g}"
        return self._finish(writer, message)

    def _run_mesh(self, start: MeshStart, writer: RunWriter | None, stop: StopRequest) -> MeshOutcome:
        """The path on the problem's current mesh: its step solver, the re-balancing ``start``
        asks for, then the control's attempts (:meth:`_take`) until the control's path ends, a stop
        is requested, the mesh is refined or its refinement undone (:class:`Ending`).

        The problem holds its last converged state on every ending: a converged attempt becomes
        its state, a failed one leaves it there, and an interrupt puts it back there. The step
        solver and the copy of the converged state are freed on every ending. :class:`SolveFailed`
        and ``KeyboardInterrupt`` end the path on this mesh as outcomes; any other exception goes
        on (collective)."""
        p = self.problem
        solver: StepSolver | None = None
        converged: PETSc.Vec | None = None      # the last converged state on this mesh
        try:
            if start.new_mesh:
                if writer is not None:
                    writer.new_mesh(p.disc, p.x)
                self.control.forget_history()
            solver = self._step_solver()
            converged = p.x.copy()
            if start.before is None:
                self._check_initial_state()     # a transferred state is checked by re-balancing
            rebalancing = [self._rebalance(solver)] if start.rebalance else []
            for attempt in itertools.chain(rebalancing, self.control.attempts(solver)):
                rec = self._take(attempt, solver, converged, writer)
                refined, before = 0, None
                if attempt.converged:
                    if self.control.passed(rec):
                        return MeshOutcome(Ending.ENDED)
                    if start.adapt is not None and not attempt.rebalancing and not stop.requested(p.comm):
                        refined, before = self._adapt(start.adapt)
                        self.records[-1]["refined_polygons"] = refined
                elif attempt.rebalancing:
                    if start.before is None:
                        raise SolveFailed(f"re-balancing at load factor {p.load:.6g} failed ({rec.failure})")
                    self._undo_adaptation(*start.before)
                run_phase.phase(f"the load step after load {p.load:.6g} ({rec.step} converged steps)")
                if not attempt.converged and attempt.rebalancing:
                    return MeshOutcome(Ending.UNREFINED)
                if refined:
                    return MeshOutcome(Ending.REFINED, before=before)
                if stop.requested(p.comm):
                    return MeshOutcome(Ending.ENDED)
            return MeshOutcome(Ending.ENDED)
        except SolveFailed as err:
            return MeshOutcome(Ending.FAILED, error=err)
        except KeyboardInterrupt as err:
            if converged is not None and p.x is solver.x:   # not moved to a refined mesh (its state is converged)
                converged.copy(p.x)
                p.x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
            return MeshOutcome(Ending.INTERRUPTED, error=err)
        finally:
            if solver is not None:
                solver.destroy()
            if converged is not None:
                converged.destroy()

    def _take(self, attempt: Attempt, solver: StepSolver, converged: PETSc.Vec,
              writer: RunWriter | None) -> StepRecord:
        """Record ``attempt`` (appended to :attr:`records`); a converged one becomes the problem's
        state at its load and is copied into ``converged``, then its progress line, a warning when
        the path enters unstable states and its step in the outputs; a failed one is reported
        (collective)."""
        p = self.problem
        n_converged = sum(r["converged"] for r in self.records) + attempt.converged
        rec = self._record(attempt, n_converged, solver)
        self.records.append(asdict(rec))
        if attempt.converged:
            p.load = attempt.load
            p.x.copy(converged)
            self._progress(rec)
            self._warn_instability(rec)
            if writer is not None:
                writer.step(self.records, self._wall(), solver.contact[1], p.boundary)
        else:
            then = "re-balancing failed" if attempt.rebalancing else "cutting the increment"
            say(log, f"  step to load {attempt.load:.5g} failed ({rec.failure}; "
                     f"{rec.newton_iterations} its); {then}", p.verbose, p.comm)
        return rec

    def _step_solver(self) -> StepSolver:
        """The solvers of the problem's current mesh, its constraints registered."""
        p = self.problem
        constraints = p.constraints()
        p.disc.set_constraints(constraints.dofs)
        equilibrium = p.equilibrium()
        newton = SNESNewton(equilibrium, self.petsc_options, p.petsc_options_prefix, p.linear_solver)
        parts = (equilibrium, newton, p.x,
                 constraints.final, constraints.dofs_of, p.contact_state, p.boundary.tolerance)
        if self.continuation is None:
            return StepSolver(*parts)
        return ContinuedStepSolver(*parts, continuation=self.continuation)

    def _wall(self) -> float:
        return time.perf_counter() - self.t_start + self.earlier_wall_time

    # ------------------------------------------------------------------ continuation and adaptivity
    def _rebalance(self, solver: StepSolver) -> Attempt:
        """Equilibrium at the load factor already reached, ``problem.load``, from the current state
        (a transferred one after a refinement): Newton's method at that load; if it fails (a
        state far from equilibrium can fold the soft medium), the residual r_0 of the starting
        state is relaxed instead, R(u) = (1 - s) r_0 for s ramped from 0 to 1 with cut-back
        (prescribed values unchanged throughout), and the last solve at s = 1 is Newton's at the
        load (docs/refinement-local.md). Without loads only; with loads the first solve decides."""
        p = self.problem
        t0 = time.perf_counter()
        start = p.x.copy()
        result = solver.solve_at(p.load)
        if not result.converged and not solver.equilibrium.has_loads:
            start.copy(p.x)
            p.x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
            result = self._relax(solver, result.iterations)
        if not result.converged:
            start.copy(p.x)
            p.x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        start.destroy()
        return Attempt(p.load, result, time.perf_counter() - t0, rebalancing=True)

    def _relax(self, solver: StepSolver, iterations: int) -> NewtonResult:
        """The homotopy of :meth:`_rebalance` from the current state; ``iterations`` done before
        are added to the result's."""
        p = self.problem
        r0 = p.disc.create_vector()
        p.disc.residual(p.x, r0)
        homotopy = _Relaxation(solver, r0, self.petsc_options)
        ramp = LoadStepping(RELAX_STEPS, min_increment=1.0 / RELAX_STEPS / 4)
        try:
            for attempt in ramp.attempts(homotopy):
                iterations += attempt.result.iterations
            result = solver.solve_at(p.load)
        except SolveFailed as err:
            result = dataclasses.replace(attempt.result, iterations=0, failure=f"relaxing the residual: {err}")
        finally:
            homotopy.destroy()
            r0.destroy()
        result.iterations += iterations
        return result

    def _undo_adaptation(self, mesh, state: KeyedState) -> None:
        """Back to ``mesh`` and ``state`` from before the adaptive refinement whose
        re-balancing failed, adaptivity off for the rest of the path: the last converged step is
        kept as it was, nothing is lost (collective)."""
        p = self.problem
        self.records[-1]["failure"] += "; refinement undone, adaptivity off for the rest of the path"
        say(log, f"  re-balancing the refined mesh at load {p.load:.5g} failed: back to the mesh before "
                 "(adaptivity off for the rest of the path)", p.verbose, p.comm)
        p.rebuild(mesh, state)
        last = next(r for r in reversed(self.records) if r["converged"])
        last["refined_polygons"] = 0

    def _adapt(self, adapt: Adaptivity) -> tuple[int, tuple | None]:
        """Refine where ``adapt`` says at the current (converged) state: the number of polygons
        (cells) split (0: nothing to refine, or a limit reached) and the mesh and state before (collective)."""
        p = self.problem
        refinement = adapt.refinement(p)
        if refinement is None:
            return 0, None
        before = (p.mesh, p.gathered_state())
        p.move_to(refinement)
        adapt.refined(refinement)
        say(log, f"  adapt at load {p.load:.5g}: {refinement.describe()}, {p.disc.num_dofs_global} unknowns",
            p.verbose, p.comm)
        return int(refinement.selected.sum()), before

    # ------------------------------------------------------------------ records
    def _record(self, attempt: Attempt, step: int, solver: StepSolver) -> StepRecord:
        """The record of an attempt; a converged one with its gap, contact pressure, reactions
        (from the force the Newton solver has at the converged state), loads, largest
        displacement and the observers' values (collective)."""
        p = self.problem
        res = attempt.result
        rec = StepRecord(step=step, load=attempt.load, newton_iterations=res.iterations,
                         residual_norms=res.residual_norms, converged=res.converged, min_J=res.min_J,
                         kinked_elements=res.kinked, negative_pivots=res.negative_pivots, failure=res.failure,
                         wall_time_s=attempt.wall_time_s, rejected_trial_states=res.rejected)
        if attempt.converged:
            rec.stable = is_stable(res.negative_pivots, self.control.traces_unstable_branches)
            gap, pressure = solver.contact
            rec.gap = gap.as_dict()
            rec.contact = [pair.as_dict() for pair in pressure.pairs]
            solver.newton.force_at(p.x)
            rec.reaction = p.reactions(force=solver.newton.force, dofs_of=solver.dofs_of)
            rec.loads = {load.name: load.measure(p.x, attempt.load) for load in solver.equilibrium.loads}
            rec.max_displacement = p.max_displacement()
            rec.extra = observe(p, self.observers)
            rec.dofs = int(p.disc.num_dofs_global)
        return rec

    def _check_initial_state(self) -> None:
        """Reject a starting state with J <= 0 (inverted elements), folded elements, a non-finite
        energy or overlapping solids."""
        p = self.problem
        b = p.disc.create_vector()
        p.x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        info = p.disc.residual(p.x, b)
        b.destroy()
        if not info.admissible:
            raise ValueError(f"inverted or degenerate element in the initial configuration: J = {info.min_J:.3e} "
                             f"in cell {info.min_J_cell} of region {info.min_J_tag}; {info.folded} folded "
                             f"element(s), e.g. {info.folded_cell}")
        gap = p.contact_gap()
        if gap.overlapping:
            raise ValueError(f"the solids overlap in the initial configuration: {gap.describe()}")

    def _restore_checkpoint(self) -> list[dict]:
        """Load state, control state and converged records of the stopped run in ``out``."""
        p = self.problem
        saved = read_checkpoint(self.out, self.summary([], 0.0, False))
        p.disc.set_state(saved.keys, saved.values, p.x)
        p.x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        self.control.restore(saved.control)
        if saved.previous is not None:
            self.control.previous = p.disc.create_vector()
            p.disc.set_state(saved.keys, saved.previous, self.control.previous)
        p.load = self.control.load
        self.earlier_wall_time = saved.wall_time_s
        records = [r for r in saved.records if r["load"] <= self.control.load + 1e-14]
        say(log, f"resuming from load factor {self.control.load:.6g} after {len(records)} converged steps",
            p.verbose, p.comm)
        return records

    def _warn_instability(self, rec: StepRecord) -> None:
        """A warning when the path enters unstable states (:mod:`~dolfinx_sfvem.path_following.stability`): at the
        first unstable converged step after a stable one (or the start)."""
        previous = [r for r in self.records[:-1] if r["converged"]]
        if rec.stable is False and (not previous or previous[-1].get("stable") is not False) \
                and self.problem.comm.rank == 0:
            warn(log, f"step {rec.step}: {instability(rec.load, rec.negative_pivots)}")

    def summary(self, records: list[dict], wall: float, converged: bool, message: str = "") -> dict:
        """The content of summary.json (``stable``: of the last converged state, :mod:`~dolfinx_sfvem.path_following.stability`)."""
        p = self.problem
        if self.continuation is None:
            description = p.describe()
        else:
            with self.continuation.as_asked():
                description = p.describe()
            description["parameters"]["gamma_continuation"] = self.continuation.describe()
        return {
            "method": description.pop("method"),
            "dofs": description.pop("dofs"),
            **description.pop("discretization"),
            "ranks": int(p.comm.size),
            "wall_time_s": wall,
            "converged": bool(converged),
            "stable": final_stability(records),
            "message": message,
            "newton": newton_economy(records),
            "parameters": {**description.pop("parameters"), "control": self.control.describe()},
            "steps": records,
        }

    def _finish(self, writer: RunWriter | None, message: str) -> Result:
        """Write the final outputs and return the result."""
        p = self.problem
        wall = self._wall()
        converged = (p.load >= self.until - 1e-12 or self.control.finished) and not message
        summary = self.summary(self.records, wall, converged, message)
        if writer is not None:
            writer.finish(summary, p.point_displacements(), p.contact_pressure(), p.boundary)
        if message:
            say(log, f"run stopped: {message}", True, p.comm)
        say(log, describe_economy(summary["newton"]), p.verbose, p.comm)
        stable = summary["stable"]
        if stable is False and p.comm.rank == 0:
            last = [r for r in self.records if r["converged"]][-1]
            warn(log, f"the path {'reached' if converged else 'stopped at'} load factor {p.load:.6g}, but "
                      f"{instability(last['load'], last['negative_pivots'])}: not an answer")
        return Result(converged, p.load, [r for r in self.records if r["converged"]], self.records, wall, summary,
                      message, stable)

    def _progress(self, rec: StepRecord) -> None:
        """The progress line of a converged step (:func:`~dolfinx_sfvem.output.run_output.progress_line`)."""
        say(log, progress_line(rec), self.problem.verbose, self.problem.comm)


class _Relaxation:
    """The homotopy R(u) = (1 - s) r_0 of :meth:`LoadPath._rebalance` as a step solver for
    :class:`LoadStepping`: r_0 a dead load at the load factor 1 - s (prescribed values fixed)."""

    def __init__(self, solver: StepSolver, r0: PETSc.Vec, petsc_options: typing.Mapping[str, typing.Any] | None):
        disc = solver.equilibrium.disc
        self.x = solver.x
        self.equilibrium = Equilibrium(disc, [VectorLoad("relaxation", disc, r0, 1.0)])
        self.newton = SNESNewton(self.equilibrium, petsc_options, solver.newton.prefix,
                                 solver.newton.linear_solver)
        self.g = solver.equilibrium.load * solver.final

    def solve_at(self, s: float, energy_merit: bool = False) -> NewtonResult:
        return self.newton.solve(self.x, self.g, 1.0 - s, energy_merit)

    def destroy(self) -> None:
        self.newton.destroy()
        self.equilibrium.destroy()
