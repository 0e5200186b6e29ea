"""Arc-length path following (Crisfield/Riks): through limit points under force or pressure control.

The load factor λ becomes an unknown. A step from the converged point (u_n, λ_n) seeks
(u, λ) = (u_n + Δu, λ_n + Δλ) on the balance R(u; λ) = 0 at the distance Δs,

    ||Δu||² + ψ² c² Δλ² = Δs²,

with ψ = 0 the cylindrical constraint (default) and ψ = 1 the spherical one; c = ||δu_F|| at the
start of the path, the displacement of a unit load factor, makes both terms lengths.

Per Newton iteration the tangent K = ∂R/∂u is factorized once and solved twice (bordering):

    K a = -R,      K b = f̂,      f̂ = -∂R/∂λ (:meth:`Equilibrium.load_vector`),

and the update (a + δλ b, δλ) takes the root δλ of the quadratic constraint whose new increment
makes the smaller angle with the old one (Crisfield 1981). Prescribed displacements are scaled
by λ as well (mixed control): their rows of f̂ hold the values at λ = 1, so the constrained
unknowns move with δλ exactly. The predictor is Δu = Δλ b at the converged point, with
|Δλ| from the constraint and its sign that of the previous increment's projection on b (it
turns at a limit point, where the tangent's inertia changes: the negative pivots of the LDLᵀ
factorization are recorded per step, 0 on the stable branch, > 0 on the unstable one). The
arc length follows the Newton iterations: Δs ← Δs (target / iterations)^½ within [1/2, 2] per
step and within [``ds_min``, ``ds_max``]; a failed step (no real root, divergence, J <= 0, a
folded element, overlapping solids) is retried with half the arc length.

A path ends when λ reaches ``until`` (the last step is landed on it by Newton at fixed λ), when a
named quantity of the step records passes a value (``stop``), or after ``max_steps`` steps.

PETSc options: the bordered Newton iterations run outside SNES, on its linear solver (every KSP
and PC option applies) and with its tolerances ``snes_rtol``, ``snes_atol`` (default: the round-off
level, as in :mod:`~dolfinx_sfvem.path_following.snes`) and ``snes_max_it``; with ``snes_monitor`` they print
each residual norm as SNES's monitor does, and they take full steps. The other SNES options (line
search, ``snes_type``, ``snes_stol``, ...) apply to the landing on ``until`` only, which is a SNES
solve; a run given one of them says so (:data:`BORDERED_SNES_OPTIONS`). An attempt's
:class:`~dolfinx_sfvem.path_following.snes.NewtonResult` carries the SNES converged reason that describes its
end: ``CONVERGED_FNORM_ABS`` / ``_RELATIVE``, ``DIVERGED_FUNCTION_DOMAIN`` (J <= 0, a fold),
``DIVERGED_FNORM_NAN``, ``DIVERGED_LINEAR_SOLVE``, ``DIVERGED_MAX_IT``, and
``DIVERGED_LINE_SEARCH`` when the constraint has no real root (the step length along the
bordered direction cannot be chosen: the arc length is too long there).
"""
from __future__ import annotations

import logging
import math
import time
import typing

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from dolfinx_sfvem.output.logs import warn
from dolfinx_sfvem.output.run_summary import StepRecord
from dolfinx_sfvem.path_following.snes import NewtonResult, SolveFailed, negative_pivots, reason_name, state_failure
from dolfinx_sfvem.path_following.step_solver import StepSolver
from dolfinx_sfvem.path_following.stepping import Attempt, Control

log = logging.getLogger(__name__)

#: the SNES options (without prefix) that the bordered Newton iterations read (module docstring)
BORDERED_SNES_OPTIONS = frozenset({"snes_rtol", "snes_atol", "snes_max_it", "snes_monitor"})
#: SNES's converged reasons
REASON = PETSc.SNES.ConvergedReason



class ArcLength(Control):
    """Crisfield's arc-length control (module docstring).

    Parameters
    ----------
    load_step
        Load factor increment of the first step: it sets the first arc length Δs_0.
    psi
        Weight ψ of the load factor in the constraint (0: cylindrical, 1: spherical).
    target_iterations
        Newton iterations per step that the arc-length adaptation aims at.
    max_growth, min_shrink
        ``ds_max = max_growth Δs_0`` and ``ds_min = min_shrink Δs_0``: bounds of the arc length.
    stop
        ``(quantity, value)``: end the path when the quantity passes ``value`` (from the side
        it starts on). ``quantity`` is a load's name (its work-conjugate displacement), a load's
        ``name.magnitude``, or an observer's name.
    max_steps
        Converged steps after which the path ends unfinished.
    """

    traces_unstable_branches = True       # the branch between limit points is part of the path

    def __init__(self, load_step: float = 0.05, *, psi: float = 0.0, target_iterations: int = 6,
                 max_growth: float = 8.0, min_shrink: float = 2.0 ** -12,
                 stop: tuple[str, float] | None = None, max_steps: int = 1000):
        if not (math.isfinite(load_step) and load_step > 0.0):
            raise ValueError(f"ArcLength: load_step must be a positive load factor increment, got {load_step!r}")
        if not (math.isfinite(psi) and psi >= 0.0):
            raise ValueError(f"ArcLength: psi must be >= 0, got {psi!r}")
        if not (isinstance(target_iterations, int) and target_iterations >= 1):
            raise ValueError(f"ArcLength: target_iterations must be an integer >= 1, got {target_iterations!r}")
        if not (max_growth >= 1.0 and 0.0 < min_shrink <= 1.0):
            raise ValueError(f"ArcLength: need max_growth >= 1 and 0 < min_shrink <= 1, got {max_growth!r}, "
                             f"{min_shrink!r}")
        if stop is not None and not (len(stop) == 2 and isinstance(stop[0], str) and math.isfinite(stop[1])):
            raise ValueError(f"ArcLength: stop must be (quantity name, value), got {stop!r}")
        if not (isinstance(max_steps, int) and max_steps >= 1):
            raise ValueError(f"ArcLength: max_steps must be an integer >= 1, got {max_steps!r}")
        self.load_step = float(load_step)
        self.psi = float(psi)
        self.target_iterations = target_iterations
        self.max_growth, self.min_shrink = float(max_growth), float(min_shrink)
        self.stop = stop
        self.max_steps = max_steps
        self.previous: PETSc.Vec | None = None
        self.start(0.0, 1.0)

    # ------------------------------------------------------------------ the control's state
    def start(self, load: float, until: float) -> None:
        self.load, self.until = float(load), until
        self.ds = 0.0                  # the arc length of the next step (0: set by the first predictor)
        self.ds0 = 0.0                 # the first arc length
        self.scale = 0.0               # c² of the constraint
        self.dload = 0.0               # Δλ of the last converged step
        self.steps = 0
        self.stop_side = 0.0           # sign of (quantity - value) at the start; 0 before the first step
        self.finished = False
        self.forget_history()

    def state(self) -> dict[str, float]:
        return {"load": self.load, "ds": self.ds, "ds0": self.ds0, "scale": self.scale, "dload": self.dload,
                "steps": self.steps, "stop_side": self.stop_side}

    def restore(self, state: typing.Mapping[str, float]) -> None:
        self.load, self.ds, self.ds0 = float(state["load"]), float(state["ds"]), float(state["ds0"])
        self.scale, self.dload = float(state["scale"]), float(state["dload"])
        self.steps, self.stop_side = int(state["steps"]), float(state["stop_side"])

    def describe(self) -> dict[str, typing.Any]:
        return {"control": "arc length", "load_step": self.load_step, "psi": self.psi,
                "target_iterations": self.target_iterations, "max_growth": self.max_growth,
                "min_shrink": self.min_shrink, "stop": list(self.stop) if self.stop else None,
                "max_steps": self.max_steps}

    def forget_history(self) -> None:
        if self.previous is not None:
            self.previous.destroy()
        self.previous = None

    def passed(self, record: StepRecord) -> bool:
        """Whether the step ``record`` ends the path by the ``stop`` criterion (and records the
        side the quantity starts on)."""
        if self.stop is None:
            return False
        name, value = self.stop
        quantity = _quantity(record, name)
        side = math.copysign(1.0, quantity - value) if quantity != value else 0.0
        if self.stop_side == 0.0:
            self.stop_side = side if side != 0.0 else 1.0
            return side == 0.0
        self.finished = side != self.stop_side
        return self.finished

    # ------------------------------------------------------------------ the path
    def attempts(self, solver: StepSolver) -> typing.Iterator[Attempt]:
        bordered = _Bordered(solver)
        if not bordered.scales_anything():
            raise ValueError("arc-length control without any load to scale: define a load (pressure, traction, "
                             "point force, cavity pressure, body force) or a non-zero prescribed displacement")
        try:
            while not self.finished and self.load < self.until - 1e-12:
                if self.steps >= self.max_steps:
                    raise SolveFailed(f"arc length: {self.max_steps} steps without reaching the end of the path "
                                      f"(load factor {self.load:.6g})")
                yield from self._step(solver, bordered)
        finally:
            bordered.destroy()

    def _step(self, solver: StepSolver, bordered: _Bordered) -> typing.Iterator[Attempt]:
        """One step: attempts with the arc length halved until one converges (or the smallest fails).
        The start state and each attempt's increment are freed however the step ends."""
        x = solver.x
        start = x.copy()
        try:
            while True:
                t0 = time.perf_counter()
                result, load, increment = self._corrector(solver, bordered, start)
                try:
                    if result.converged and load > self.until + 1e-12:
                        result, load = self._land(solver, start, increment, load)
                finally:
                    increment.destroy()
                elapsed = time.perf_counter() - t0
                if result.converged:
                    self._advance(start, load, result.iterations, solver)
                    yield Attempt(load, result, elapsed)
                    return
                start.copy(x)
                x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
                smallest = self.ds / 2 < self.min_shrink * self.ds0 * (1 - 1e-12)
                if not smallest:
                    self.ds /= 2
                yield Attempt(load, result, elapsed)
                if smallest:
                    raise SolveFailed(f"arc-length step from load factor {self.load:.6g} failed with the smallest "
                                      f"arc length {self.ds:.3g} ({result.failure}; {result.iterations} Newton "
                                      f"iterations)")
        finally:
            start.destroy()

    def _advance(self, start: PETSc.Vec, load: float, iterations: int, solver: StepSolver) -> None:
        """The step to ``load`` converged: keep the increment's direction, adapt the arc length."""
        if self.previous is None:
            self.previous = start.duplicate()
        start.copy(self.previous)
        self.dload, self.load = load - self.load, load
        self.steps += 1
        factor = min(2.0, max(0.5, math.sqrt(self.target_iterations / max(iterations, 1))))
        self.ds = min(self.max_growth * self.ds0, max(self.min_shrink * self.ds0, self.ds * factor))

    def _direction(self, b: PETSc.Vec, x: PETSc.Vec) -> float:
        """The predictor's sign: that of the last increment's projection on the tangent b (+1 first)."""
        if self.previous is None:
            return 1.0 if self.dload >= 0.0 else -1.0
        du = x.copy()
        du.axpy(-1.0, self.previous)
        projection = du.dot(b) + self.psi ** 2 * self.scale * self.dload
        du.destroy()
        return 1.0 if projection >= 0.0 else -1.0

    def _corrector(self, solver: StepSolver, bordered: _Bordered, start: PETSc.Vec
                   ) -> tuple[NewtonResult, float, PETSc.Vec]:
        """Predictor and Newton iterations on balance and constraint from the converged ``start``;
        returns the result, the load factor reached and the increment Δu (a new vector)."""
        x = solver.x
        load = self.load
        bordered.residual(x, load)
        pivots = bordered.factorize(x, load)
        b = bordered.solve_load()
        why = bordered.linear_solve_failure()
        if why:                              # at the converged start: a shorter arc length cannot help
            raise SolveFailed(f"arc length: the tangent at load factor {self.load:.6g}: {why}")
        if self.ds0 == 0.0:                  # the first step: Δλ = load_step sets Δs_0 and c
            self.scale = b.dot(b)
            self.ds = self.ds0 = self.load_step * math.sqrt(self.scale * (1.0 + self.psi ** 2))
        dload = self._direction(b, x) * self.ds / math.sqrt(b.dot(b) + self.psi ** 2 * self.scale)
        du = b.copy()
        du.scale(dload)
        x.axpy(1.0, du)
        load += dload
        norms: list[float] = []
        info = None
        reason, iterations = REASON.CONVERGED_ITERATING, 0
        while True:
            x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
            norm, info = bordered.residual(x, load)
            norms.append(norm)
            bordered.monitor(iterations, norm)
            atol = bordered.atol(x, load)
            if not info.admissible:
                reason, why = REASON.DIVERGED_FUNCTION_DOMAIN, "; ".join(state_failure(info))
            elif not math.isfinite(norm):
                reason, why = REASON.DIVERGED_FNORM_NAN, "non-finite residual"
            elif norm <= max(atol, bordered.rtol * norms[0]):
                reason = REASON.CONVERGED_FNORM_ABS if norm <= atol else REASON.CONVERGED_FNORM_RELATIVE
            elif iterations == bordered.max_it:
                reason, why = REASON.DIVERGED_MAX_IT, f"no convergence in {bordered.max_it} iterations (residual {norm:.3e})"
            if reason:
                break
            iterations += 1
            pivots = bordered.factorize(x, load)
            a, b = bordered.solve_residual(), bordered.solve_load()
            why = bordered.linear_solve_failure()
            if why:
                reason = REASON.DIVERGED_LINEAR_SOLVE
                break
            delta = _constraint_root(du, a, b, dload, self.psi ** 2 * self.scale, self.ds)
            if delta is None:
                reason = REASON.DIVERGED_LINE_SEARCH
                why = "the arc-length constraint has no real root (the arc length is too long here)"
                break
            du.axpy(1.0, a)
            du.axpy(delta, b)
            dload += delta
            x.axpy(1.0, a)
            x.axpy(delta, b)
            load += delta
        solver.newton.forget_force()
        converged = reason > 0
        result = NewtonResult(converged, int(reason), iterations, norms,
                              info.min_J if info else math.nan, info.min_J_cell if info else -1,
                              info.min_J_tag if info else -1, info.folded if info else 0, info.kinked if info else 0,
                              "" if converged else f"arc length: SNES reason {int(reason)} ({reason_name(reason)}): {why}",
                              pivots)
        return solver.accept(result), load, du

    def _land(self, solver: StepSolver, start: PETSc.Vec, du: PETSc.Vec, load: float) -> tuple[NewtonResult, float]:
        """The step passed ``until``: Newton at λ = until from the increment scaled to end there."""
        x = solver.x
        start.copy(x)
        x.axpy((self.until - self.load) / (load - self.load), du)
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        return solver.solve_at(self.until), self.until


def _constraint_root(du: PETSc.Vec, a: PETSc.Vec, b: PETSc.Vec, dload: float, weight: float, ds: float) -> float | None:
    """δλ with ||du + a + δλ b||² + weight (dload + δλ)² = ds² whose new increment makes the smaller
    angle with (du, dload); None without a real root (collective)."""
    w = du.copy()
    w.axpy(1.0, a)
    q2 = b.dot(b) + weight
    q1 = 2.0 * (w.dot(b) + weight * dload)
    q0 = w.dot(w) + weight * dload ** 2 - ds ** 2
    old = (w.dot(du), b.dot(du))
    w.destroy()
    discriminant = q1 * q1 - 4.0 * q2 * q0
    if discriminant < 0.0:
        return None
    root = math.sqrt(discriminant)
    roots = ((-q1 + root) / (2.0 * q2), (-q1 - root) / (2.0 * q2))
    # cosine numerator of the new increment with the old one: (w + δλ b)·du + weight (dload + δλ) dload
    return max(roots, key=lambda d: old[0] + d * old[1] + weight * (dload + d) * dload)


def _quantity(record: StepRecord, name: str) -> float:
    """A load's displacement (``name``) or magnitude (``name.magnitude``), or an observer's value."""
    base, _, part = name.partition(".")
    if base in record.loads and part in ("", "magnitude", "displacement"):
        return float(record.loads[base][part or "displacement"])
    if name in record.extra:
        return float(record.extra[name])
    known = sorted(record.loads) + sorted(f"{n}.magnitude" for n in record.loads) + sorted(record.extra)
    raise ValueError(f"ArcLength stop: no quantity {name!r} in the step record (known: {known})")


class _Bordered:
    """Residual, tangent factorization and the two solves of one bordered Newton iteration, on
    the step solver's equilibrium, constraints and linear solver."""

    def __init__(self, solver: StepSolver):
        self.solver = solver
        self.newton = newton = solver.newton
        self.equilibrium = solver.equilibrium
        self.constraints = self.equilibrium.disc.constraints
        self.final = solver.final
        disc = self.equilibrium.disc
        self.R, self.f, self.a, self.b = (disc.create_vector() for _ in range(4))
        self.rhs_R, self.rhs_f = disc.create_vector(), disc.create_vector()
        rtol, atol, _, max_it = newton.snes.getTolerances()
        self.rtol, self.given_atol, self.max_it = rtol, atol, max_it
        self._stiffness = 0.0
        self._monitor = "snes_monitor" in newton.given
        elsewhere = sorted(name for name in newton.given if name.startswith("snes_") and name not in BORDERED_SNES_OPTIONS)
        if elsewhere and newton.comm.rank == 0:
            warn(log, f"arc length: the options {', '.join('-' + newton.prefix + n for n in elsewhere)} do not apply to "
                      f"its bordered Newton iterations, only to the landing on the final load factor (they read "
                      f"{', '.join(sorted(BORDERED_SNES_OPTIONS))} and every KSP/PC option)")

    def scales_anything(self) -> bool:
        """Whether λ scales a load or a non-zero prescribed displacement (collective)."""
        prescribed = bool(np.any(self.final != 0.0))
        return self.equilibrium.has_loads or self.newton.comm.allreduce(prescribed, op=MPI.LOR)

    def residual(self, x: PETSc.Vec, load: float) -> tuple[float, typing.Any]:
        """R(x; load) with the constrained rows x_c - load final_c into :attr:`R`: its norm and the
        state's diagnostics."""
        self.equilibrium.set_load(load)
        info = self.equilibrium.residual(x, self.R)
        self.constraints.set_residual_rows(x, self.R, load * self.final)
        return self.R.norm(), info

    def atol(self, x: PETSc.Vec, load: float) -> float:
        """The Newton solver's absolute tolerance: the given ``snes_atol``, or its default policy
        (:class:`~dolfinx_sfvem.path_following.snes.AbsoluteTolerance`) at x, the prescribed values
        at ``load`` and the last factorized tangent."""
        if not self.newton.scaled_atol:
            return self.given_atol
        return self.newton.tolerance(x, load * self.final, self._stiffness)

    def factorize(self, x: PETSc.Vec, load: float) -> int | None:
        """Tangent at x (load factor ``load``), the right-hand sides -R and f̂ lifted, the constraints
        eliminated, the factorization made; returns its negative pivots (LDLᵀ only)."""
        A = self.newton.A
        self.equilibrium.set_load(load)
        self.equilibrium.tangent(x, A)
        self._stiffness = self.newton.tolerance.free_row_norm(A)
        self.equilibrium.load_vector(x, self.f)
        owned = self.constraints.owned
        self.f.getArray()[owned] = self.final            # constrained unknowns move by δλ final
        self.R.copy(self.rhs_R)
        self.rhs_R.scale(-1.0)
        self.f.copy(self.rhs_f)
        self.constraints.lift(A, self.rhs_R)
        self.constraints.lift(A, self.rhs_f)
        self.constraints.eliminate(A)
        self.newton.solve_linear_to_tolerance()
        ksp = self.newton.ksp
        ksp.setOperators(A)
        ksp.setUp()
        return negative_pivots(ksp.getPC())

    def solve_residual(self) -> PETSc.Vec:
        """a with K a = -R (the lifted right-hand side)."""
        self.newton.ksp.solve(self.rhs_R, self.a)
        return self.a

    def solve_load(self) -> PETSc.Vec:
        """b with K b = f̂ (lifted; constrained rows: the prescribed values at λ = 1)."""
        self.newton.ksp.solve(self.rhs_f, self.b)
        return self.b

    def monitor(self, iteration: int, norm: float) -> None:
        """With ``snes_monitor``: the residual norm in the line SNES's default monitor prints (not
        SNESMonitor itself, which PETSc 3.25 cannot call outside a solve)."""
        if self._monitor:
            PETSc.Sys.Print(f"{iteration:3d} SNES Function norm {norm:14.12e}", comm=self.newton.comm)

    def linear_solve_failure(self) -> str:
        """Why the last linear solve failed ("" if it did not): the KSP's converged reason."""
        reason = self.newton.ksp.getConvergedReason()
        if reason >= 0:
            return ""
        return f"linear solve failed (KSP reason {reason}, {reason_name(reason, PETSc.KSP.ConvergedReason)})"

    def destroy(self) -> None:
        for v in (self.R, self.f, self.a, self.b, self.rhs_R, self.rhs_f):
            v.destroy()
