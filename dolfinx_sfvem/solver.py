"""Newton's method through PETSc SNES, and load stepping with automatic cut-back.

Dirichlet conditions enter through the Newton update (docs/method.md §6), by the constraints
registered on the discretization (:class:`~dolfinx_sfvem.discretization.Constraints`): the
first Newton step of a load step moves the constrained unknowns to their new values ``g``
and the free rows of the tangent carry the consistent response. The state is never
overwritten with the new boundary values before a solve.

Default line search: ``bt`` (one residual per Newton iteration when the full step is
acceptable), and a solve that fails with it is repeated once from its start with
:data:`FALLBACK_LINE_SEARCH` ``l2`` (about three residuals per iteration, robust at contact
onset) before the caller cuts the increment back; measurements in docs/performance.md. Every
option can be changed on the command line or from Python; a line search given there has no
fallback.

Default absolute tolerance: unless ``snes_atol`` is given (command line or Python), it
follows the round-off level of the residual,

    atol = ATOL_ROUNDOFF_FACTOR * eps * F_c,
    F_c  = ||K||_inf * max(||x||_inf, ||g||_inf) + |λ| ||f_ext||_inf,

with ``||K||_inf`` the largest absolute row sum of the tangent over the free rows (taken at the
tangent of the start state of every solve), ``x`` the state, ``g`` the
prescribed values, ``λ f_ext`` the external force and ``eps`` machine epsilon; ``atol`` is
updated at every tangent. It is proportional to the moduli, so moduli and body forces scaled
together give the same Newton iterations and solution. Why and what was measured:
docs/method.md §6.
"""
from __future__ import annotations

import time
import typing
from dataclasses import dataclass, field

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from . import _compat
from .discretization import AssemblyInfo, Discretization

DEFAULT_PETSC_OPTIONS: dict[str, str] = {
    "snes_type": "newtonls",
    "snes_linesearch_type": "bt",
    "snes_rtol": "1e-9",
    "snes_stol": "0",
    "snes_max_it": "30",
    "ksp_type": "preonly",
    "pc_type": "cholesky",
    "pc_factor_mat_solver_type": "mumps",
    **_compat.PETSC_OPTION_DEFAULTS,
}
#: line search of the second try of a solve that failed with the default one (module docstring)
FALLBACK_LINE_SEARCH = "l2"
#: the default ``snes_atol`` in units of the round-off level ``eps * F_c`` of the residual (module docstring)
ATOL_ROUNDOFF_FACTOR = 1e4
#: a Newton stall whose smallest residual is more than this many times atol is not a round-off limit
STALL_FACTOR = 10.0


def set_petsc_options(tokens: typing.Sequence[str] | typing.Mapping[str, typing.Any]) -> None:
    """Put options into PETSc's global database.

    Parameters
    ----------
    tokens
        Command-line style tokens (``["-snes_monitor", "-ksp_type", "gmres"]``) or a
        mapping ``{"snes_monitor": None, "ksp_type": "gmres"}``.
    """
    opts = PETSc.Options()
    if isinstance(tokens, typing.Mapping):
        for key, value in tokens.items():
            opts[key.lstrip("-")] = "" if value is None else str(value)
        return
    tokens = list(tokens)
    for k, tok in enumerate(tokens):
        if not tok.startswith("-") or _is_number(tok):
            continue
        nxt = tokens[k + 1] if k + 1 < len(tokens) else None
        value = nxt if nxt is not None and (not nxt.startswith("-") or _is_number(nxt)) else ""
        opts[tok.lstrip("-")] = value


class _scoped_options:
    """Defaults and Python-given options applied only while a solver reads the database.

    Command-line options win over the defaults; options given from Python win over both.
    Afterwards the database is as before, so one solver's options never leak into another.
    """

    def __init__(self, options: typing.Mapping[str, typing.Any] | None):
        db = PETSc.Options()
        self._entries = {k: v for k, v in DEFAULT_PETSC_OPTIONS.items() if not db.hasName(k)}
        self._entries.update({k.lstrip("-"): "" if v is None else str(v) for k, v in (options or {}).items()})

    def __enter__(self):
        db = PETSc.Options()
        self._saved = {k: db.getString(k) if db.hasName(k) else None for k in self._entries}
        set_petsc_options(self._entries)
        return self

    def __exit__(self, *exc):
        db = PETSc.Options()
        for key, value in self._saved.items():
            if value is None:
                db.delValue(key)
            else:
                db[key] = value
        return False


def _is_number(s: str) -> bool:
    try:
        float(s)
        return True
    except ValueError:
        return False


class SolveFailed(RuntimeError):
    """A load step could not be solved even with the smallest allowed increment."""


@dataclass
class NewtonResult:
    """Outcome of one Newton solve (one load step attempt).

    ``failure`` says why the state is not accepted ("" when ``converged``): SNES's reason,
    J <= 0, a folded element, or (set by :class:`~dolfinx_sfvem.ContactProblem`) overlapping solids.
    ``negative_pivots``: negative pivots of the last LDL^T factorization of the solve (MUMPS
    INFOG(12)), i.e. the number of negative eigenvalues of the tangent with the constraints
    eliminated, at the last state Newton factorized; None with another factorization.
    """
    converged: bool
    reason: int
    iterations: int
    residual_norms: list[float]
    min_J: float
    min_J_polygon: int
    min_J_tag: int
    folded: int = 0
    kinked: int = 0
    failure: str = ""
    negative_pivots: int | None = None


def _stall(norms: typing.Sequence[float], atol: float, roundoff: float | None) -> str:
    """Where Newton stalled: its smallest residual in units of ``atol`` and of the round-off level
    eps F_c (None when ``snes_atol`` was given), and what that suggests (docs/gamma-1e-6.md)."""
    floor = min(norms)
    text = f"smallest residual {floor:.3e} = {floor / atol:.3g} x atol {atol:.3e}"
    if roundoff:
        text += f" = {floor / roundoff:.3g} x round-off eps*F_c {roundoff:.3e}"
    if floor > STALL_FACTOR * atol:
        return text + ("; not a round-off limit: the Newton step leaves the region where the tangent predicts "
                       "the residual (e.g. a soft, strongly compressed medium; docs/gamma-1e-6.md)")
    return text + ("; stalled within 10 x atol: typical of a bifurcation or limit point of the load path "
                   "(docs/gamma-1e-6.md)")


def _failure(reason: int, info: AssemblyInfo, norms: typing.Sequence[float], atol: float, roundoff: float | None) -> str:
    """Why a solve that ended with SNES ``reason`` (residual norms ``norms``, final ``atol``) at a
    state with diagnostics ``info`` is rejected."""
    why = []
    if reason <= 0:
        name = next((k for k, v in vars(PETSc.SNES.ConvergedReason).items() if v == reason and not k.startswith("_")),
                    str(reason))
        why.append(f"SNES reason {reason} ({name})")
        stalled = reason in (PETSc.SNES.ConvergedReason.DIVERGED_MAX_IT, PETSc.SNES.ConvergedReason.DIVERGED_LINE_SEARCH)
        if stalled and info.admissible and norms and atol > 0:
            why.append(_stall(norms, atol, roundoff))
    if not (info.min_J > 0.0):
        why.append(f"J = {info.min_J:.3e} in polygon {info.min_J_polygon} of region {info.min_J_tag}")
    if info.folded:
        why.append(f"{info.folded} folded element(s), e.g. {info.folded_polygon}")
    if not np.isfinite(info.energy):
        why.append("non-finite energy")
    return "; ".join(why)


class NewtonSolver:
    """SNES Newton solver for ``R(x) = 0`` with constrained rows ``x_c = g_c``.

    Parameters
    ----------
    disc
        The discretization, its constraints registered (:meth:`Discretization.set_constraints`)
        before :meth:`solve`.
    options
        PETSc options for this solver (override defaults and the command line). Without
        ``snes_atol`` (here or on the command line) the absolute tolerance follows the
        round-off level of the residual (:meth:`absolute_tolerance`).
    f_ext
        External force vector at load factor 1 (scaled by the load factor of each solve).
    """

    def __init__(self, disc: Discretization, options: typing.Mapping[str, typing.Any] | None = None,
                 f_ext: PETSc.Vec | None = None):
        self.disc = disc
        self.comm = disc.comm
        self.g = np.zeros(0)        # prescribed values of the owned constrained unknowns, of the current solve
        self.f_ext = f_ext
        self._f_ext_norm = f_ext.norm(PETSc.NormType.INFINITY) if f_ext is not None else 0.0
        self._stiffness = 0.0       # ||K||_inf of the free rows, at the tangent of the start state of the current solve
        self.load = 1.0
        self.A = disc.create_matrix()
        self.b = disc.create_vector()
        #: internal minus external force at the state ``_force_state``, constraints not applied
        #: (the last residual SNES evaluated, or :meth:`force_at`'s)
        self.force = disc.create_vector()
        self._force_state = disc.create_vector()
        self._force_info = None
        self._unlifted = disc.create_vector()  # SNES's residual before the lifting of _jacobian
        self._lifted = False                   # b holds the lifted right-hand side of the linear solve
        self._start_state = disc.create_vector()
        self._start_state_current = False     # A holds the tangent at _start_state, constraints not applied
        self.history: list[float] = []
        self.worst_info = None      # smallest J met at any trial point of the current solve

        self.snes = snes = PETSc.SNES().create(self.comm)
        snes.setFunction(self._residual, self.b)
        snes.setJacobian(self._jacobian, self.A)
        snes.setMonitor(lambda _snes, it, norm: self.history.append(float(norm)))
        self.options = dict(options or {})
        self.fallback = not (PETSc.Options().hasName("snes_linesearch_type")
                             or any(k.lstrip("-") == "snes_linesearch_type" for k in self.options))
        with _scoped_options(options):
            snes.setFromOptions()
            self.scaled_atol = not PETSc.Options().hasName("snes_atol")
        snes.setLineSearchPreCheck(self._unlift)

    def _residual(self, snes: PETSc.SNES, x: PETSc.Vec, b: PETSc.Vec) -> None:
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        info = self.disc.residual(x, b)
        if self.worst_info is None or not (info.min_J >= self.worst_info.min_J):
            self.worst_info = info
        if self.f_ext is not None:
            b.axpy(-self.load, self.f_ext)
        b.copy(self.force)
        x.copy(self._force_state)
        self._force_info = info
        self._lifted = False
        self.disc.constraints.set_residual_rows(x, b, self.g)
        if not info.admissible:
            _compat.snes_set_function_domain_error(snes)

    def _jacobian(self, snes: PETSc.SNES, x: PETSc.Vec, A: PETSc.Mat, P: PETSc.Mat) -> None:
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        if not self._start_tangent_at(x):
            self.disc.assemble_tangent(x, A)
        self._start_state_current = False
        if self.scaled_atol:
            snes.setTolerances(atol=self.absolute_tolerance(x))
        # SNES solves A y = F with its F at x (self.b, just evaluated): the constraints' lifting goes
        # into F for the linear solve, and :meth:`_unlift` puts the residual back before the line search
        self.b.copy(self._unlifted)
        self.disc.constraints.eliminate(A, self.b)
        self._lifted = True

    def _unlift(self, x: PETSc.Vec, y: PETSc.Vec, *args) -> bool:
        """Line-search pre-check: SNES's residual F at x back in place of the lifted right-hand
        side of the linear solve, so that the line search works with the residual whose norm SNES
        tests (its slope F·(A y) is then exact up to F_f·K_fc δ_c, zero when F_f or δ_c is); the
        step y is left unchanged. Nothing to do after a lagged Jacobian (F was not lifted)."""
        if self._lifted:
            self._unlifted.copy(self.b)
            self._lifted = False
        return False

    def _start(self, x: PETSc.Vec) -> None:
        """The tangent at the start state ``x`` of a solve into :attr:`A`, constraints not applied:
        its free-row norm sets the absolute tolerance before the first iteration, and the first
        Jacobian evaluation (at this state) uses it as it is (collective)."""
        self.disc.assemble_tangent(x, self.A)
        self._stiffness = self._free_row_norm(self.A)
        x.copy(self._start_state)
        self._start_state_current = True

    def _start_tangent_at(self, x: PETSc.Vec) -> bool:
        """Whether :attr:`A` holds the start tangent and ``x`` is the start state (collective)."""
        if not self._start_state_current:
            return False
        diff = self._start_state.copy()
        diff.axpy(-1.0, x)
        same = diff.norm(PETSc.NormType.NORM_INFINITY) == 0.0
        diff.destroy()
        return same

    def _free_row_norm(self, A: PETSc.Mat) -> float:
        """Largest sum of absolute values over the free rows of A (collective)."""
        indptr, _, values = A.getValuesCSR()
        rows = np.repeat(np.arange(indptr.size - 1), np.diff(indptr))
        sums = np.bincount(rows, weights=np.abs(values), minlength=indptr.size - 1)
        free = self.disc.constraints.owned_free
        return self.comm.allreduce(float(sums[free].max(initial=0.0)), op=MPI.MAX)

    def absolute_tolerance(self, x: PETSc.Vec) -> float:
        """The default absolute tolerance at the state x (collective).

        ``ATOL_ROUNDOFF_FACTOR * eps * (||K||_inf max(||x||_inf, ||g||_inf) + |λ| ||f_ext||_inf)``
        with ``||K||_inf`` of the free rows from the tangent at the start state of the current
        solve (0 before any) and ``g``, ``λ`` of the current solve; see the module docstring.
        """
        g = self.comm.allreduce(float(np.abs(self.g).max(initial=0.0)), op=MPI.MAX)
        force = self._stiffness * max(x.norm(PETSc.NormType.INFINITY), g) + abs(self.load) * self._f_ext_norm
        return ATOL_ROUNDOFF_FACTOR * float(np.finfo(np.float64).eps) * force

    def solve(self, x: PETSc.Vec, g: np.ndarray, load: float = 1.0) -> NewtonResult:
        """Solve from the state ``x`` (updated in place) with the values ``g`` of the owned
        constrained unknowns (``disc.constraints.owned``) and the external force scaled by
        ``load``; a failed solve with the default line search
        is repeated from the same start with :data:`FALLBACK_LINE_SEARCH` (its iterations are
        counted in the result's, its residual norms and failure are the result's)."""
        start = x.copy() if self.fallback else None
        result = self._solve_once(x, g, load)
        if start is None:
            return result
        if result.converged:
            start.destroy()
            return result
        start.copy(x)
        start.destroy()
        self._set_line_search(FALLBACK_LINE_SEARCH)
        try:
            retry = self._solve_once(x, g, load)
        finally:
            self._set_line_search(DEFAULT_PETSC_OPTIONS["snes_linesearch_type"])
        retry.iterations += result.iterations
        return retry

    def force_at(self, x: PETSc.Vec) -> AssemblyInfo:
        """Internal minus external force at ``x`` (ghosts current) into :attr:`force`, constraints
        not applied, with the state's diagnostics: the last residual's if SNES evaluated it at
        exactly this state, else assembled (collective)."""
        self._force_state.axpy(-1.0, x)
        same = self._force_info is not None and self._force_state.norm(PETSc.NormType.NORM_INFINITY) == 0.0
        if not same:
            self._force_info = self.disc.residual(x, self.force)
            if self.f_ext is not None:
                self.force.axpy(-self.load, self.f_ext)
        x.copy(self._force_state)
        return self._force_info

    def _set_line_search(self, kind: str) -> None:
        """Set SNES up again from this solver's options with the line search ``kind``."""
        with _scoped_options({**self.options, "snes_linesearch_type": kind}):
            self.snes.setFromOptions()
        self.snes.setLineSearchPreCheck(self._unlift)

    def _solve_once(self, x: PETSc.Vec, g: np.ndarray, load: float) -> NewtonResult:
        """One SNES solve from ``x`` with the line search as set (see :meth:`solve`)."""
        self.g = np.asarray(g, dtype=np.float64)
        self.load = load
        self.history = []
        self.worst_info = None
        self._start(x)
        if self.scaled_atol:
            self.snes.setTolerances(atol=self.absolute_tolerance(x))
        self.snes.solve(None, x)
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        reason = self.snes.getConvergedReason()
        info = self.force_at(x)                   # state diagnostics at the final iterate
        ok = reason > 0 and info.admissible
        if not ok and self.worst_info is not None:
            info = self.worst_info                # where it went wrong, not where it started
        atol = self.snes.getTolerances()[1]
        failure = "" if ok else _failure(reason, info, self.history, atol,
                                         atol / ATOL_ROUNDOFF_FACTOR if self.scaled_atol else None)
        return NewtonResult(bool(ok), int(reason), int(self.snes.getIterationNumber()), list(self.history),
                            info.min_J, info.min_J_polygon, info.min_J_tag, info.folded, info.kinked, failure,
                            self.negative_pivots())

    def negative_pivots(self) -> int | None:
        """Negative pivots of the last factorization if it was MUMPS LDL^T (``pc_type cholesky``,
        the default): INFOG(12), the number of negative eigenvalues of the factorized tangent
        (Sylvester's law of inertia); None for any other linear solver or before a factorization."""
        pc = self.snes.getKSP().getPC()
        if pc.getType() != "cholesky" or pc.getFactorSolverType() != "mumps" or self.snes.getIterationNumber() == 0:
            return None
        return int(pc.getFactorMatrix().getMumpsInfog(12))


@dataclass
class Attempt:
    """One attempted load step of :meth:`LoadStepper.attempts`."""
    load: float                 # the load factor aimed at
    result: NewtonResult
    wall_time_s: float          # of the Newton solve

    @property
    def converged(self) -> bool:
        return self.result.converged


@dataclass
class StepRecord:
    """One attempted load step (entry of ``summary.json``'s ``steps``)."""
    step: int
    load: float
    newton_iterations: int
    residual_norms: list[float]
    converged: bool
    reaction: dict[str, list[float]] = field(default_factory=dict)
    min_J: float = float("nan")
    kinked_elements: int = 0
    negative_pivots: int | None = None
    failure: str = ""
    gap: dict | None = None
    contact: list[dict] = field(default_factory=list)
    max_displacement: float = float("nan")
    wall_time_s: float = 0.0
    extra: dict[str, typing.Any] = field(default_factory=dict)
    dofs: int = 0                   # unknowns of the mesh the step was solved on
    refined_polygons: int = 0       # polygons split after this step by adaptive refinement


class LoadStepper:
    """Ramp the load factor λ from ``start`` to ``until`` (default 0 to 1) in increments of
    ``1 / steps``, the last one shortened to land on ``until``.

    A step that is not accepted (SNES divergence, J <= 0, a folded element, NaN, or a rejection
    by the caller such as overlapping solids) is retried from the last
    converged state with half the increment, down to ``min_increment``; after
    ``grow_after`` consecutive successes a cut increment is doubled again (never beyond
    the nominal one). When even the smallest increment fails, :class:`SolveFailed` is
    raised; every attempt has already been yielded by :meth:`attempts`. The stepper's
    own state (:meth:`state`) is what a checkpoint needs to continue exactly.
    """

    def __init__(self, steps: int, *, min_increment: float | None = None, grow_after: int = 2,
                 max_attempts: int = 10_000, start: float = 0.0, until: float = 1.0):
        if not (isinstance(steps, (int, np.integer)) and steps >= 1):
            raise ValueError(f"steps must be a positive integer, got {steps!r}")
        self.nominal = 1.0 / steps
        self.min_increment = min_increment if min_increment is not None else self.nominal / 2 ** 10
        if not (0 < self.min_increment <= self.nominal):
            raise ValueError(f"min_increment must be in (0, 1/steps], got {self.min_increment}")
        if not (0.0 <= start <= until <= 1.0):
            raise ValueError(f"need 0 <= start <= until <= 1, got start = {start}, until = {until}")
        self.grow_after = grow_after
        self.max_attempts = max_attempts
        self.until = until
        self.load, self.increment, self.streak = float(start), self.nominal, 0

    def state(self) -> dict[str, float]:
        return {"load": self.load, "increment": self.increment, "streak": self.streak}

    def restore(self, state: typing.Mapping[str, float]) -> None:
        self.load, self.increment, self.streak = float(state["load"]), float(state["increment"]), int(state["streak"])

    def attempts(self, solve_to: typing.Callable[[float], NewtonResult], x: PETSc.Vec) -> typing.Iterator[Attempt]:
        """Run the load path from the state ``x``, yielding every attempted step.

        ``solve_to(load)`` solves for the load factor ``load`` from ``x`` (updated in place). A
        converged attempt is yielded after the stepper has moved to its load; a failed one after
        ``x`` is back at the last converged state and the increment is halved. The caller may stop
        after any attempt (``break``): the stepper and ``x`` are then at the last converged step.
        Raises :class:`SolveFailed` after yielding an attempt that failed with the smallest
        increment.
        """
        for _ in range(self.max_attempts):
            if self.load >= self.until - 1e-12:
                return
            target = min(self.load + self.increment, self.until)
            saved = x.copy()
            t0 = time.perf_counter()
            result = solve_to(target)
            elapsed = time.perf_counter() - t0
            if result.converged:
                self.load = target
                self.streak += 1
                if self.increment < self.nominal and self.streak >= self.grow_after:
                    self.increment, self.streak = min(2 * self.increment, self.nominal), 0
            else:
                saved.copy(x)
                x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
                self.streak = 0
            saved.destroy()
            smallest = not result.converged and self.increment / 2 < self.min_increment * (1 - 1e-12)
            if not (result.converged or smallest):
                self.increment /= 2
            yield Attempt(target, result, elapsed)
            if smallest:
                raise SolveFailed(
                    f"load step to load factor {target:.6g} failed with the smallest increment "
                    f"{self.increment:.3g} ({result.failure}; {result.iterations} Newton iterations, "
                    f"last residuals {', '.join(f'{r:.3e}' for r in result.residual_norms[-3:])}, "
                    f"min J {result.min_J:.3e} in polygon {result.min_J_polygon} of region {result.min_J_tag}); "
                    f"last converged load factor {self.load:.6g}")
        raise SolveFailed(f"load path not finished after {self.max_attempts} attempts (load factor {self.load:.6g})")
