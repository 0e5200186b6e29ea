"""Newton's method for the balance R(u; λ) = 0 at a fixed load factor, through PETSc SNES.

Dirichlet conditions enter through the Newton update (docs/method.md §6), by the constraints
registered on the discretization (:class:`~dolfinx_sfvem.discretizations.discretization.Constraints`): the
first Newton step of a load step moves the constrained unknowns to their new values ``g``
and the free rows of the tangent carry the consistent response. The state is never
overwritten with the new boundary values before a solve.

PETSc options
-------------
Every solver has its own options prefix (default :data:`DEFAULT_PREFIX`, ``tmc_``): its SNES,
KSP and PC read ``-tmc_snes_monitor``, ``-tmc_ksp_type`` ... from the command line, never the
unprefixed options a script sets for its own solvers. Options given from Python
(``petsc_options``) win over the command line, the command line over :data:`DEFAULT_PETSC_OPTIONS`;
they are put into PETSc's options database only while the solver reads them and removed
afterwards, so nothing of this library stays in the database.

Default line search: ``bt`` (one residual per Newton iteration when the full step is
acceptable), and a solve that fails with it is repeated once from its start with
:data:`FALLBACK_LINE_SEARCH` ``l2`` (about three residuals per iteration, robust at contact
onset) before the caller cuts the increment back. A line
search given on the command line or from Python has no fallback.

A solve that cannot succeed is abandoned early (:meth:`SNESNewton.abandon_reason`): when
its trial states left the energy's domain more than :data:`MAX_REJECTED` times (J <= 0, a fold,
NaN; each such trial state costs a residual and its line search then creeps along a direction
that leads out of the admissible states), or when its smallest residual fell by less than the
factor :data:`STALL_DECREASE` over the last :data:`STALL_WINDOW` iterations, from
:data:`STALL_MIN_ITERATIONS` on (Newton then wanders instead of converging). The rest of the solve
costs nothing: no residual, tangent or factorization is computed any more, SNES's line search
fails at once, and the caller cuts the increment back.

Default linear solver: MUMPS LDLᵀ (``pc_type cholesky``), which reports the inertia of the
tangent; :class:`~dolfinx_sfvem.physics.equilibrium.Equilibrium` says when the tangent is not symmetric
(a follower pressure on an open boundary), and then MUMPS LU (``pc_type lu``) is the default.

Default absolute tolerance: unless ``snes_atol`` is given (command line or Python), it
follows the round-off level of the residual (:class:`AbsoluteTolerance`),

    atol = max(ATOL_ROUNDOFF_FACTOR * eps * F_c, FLOOR_FACTOR * r_0),
    F_c  = ||K||_inf * max(||x||_inf, ||g||_inf) + ||f||_inf,
    r_0  = eps * ||K||_inf * h * sqrt(n),

with ``||K||_inf`` the largest absolute row sum of the tangent over the free rows (taken at the
tangent of the start state of every solve), ``x`` the state, ``g`` the prescribed values,
``f`` the external force at the load factor of the solve (body force and loads), ``h`` the
mesh's node spacing (:func:`node_spacing`), ``n`` the number of unknowns and ``eps`` machine
epsilon; ``atol`` is updated at every tangent. ``F_c`` is the size of the element forces the
residual is summed from. ``r_0`` is the residual's round-off floor near F = I, where the stress
terms are O(modulus) each and cancel: their round-off, eps times a force ``||K||_inf h`` per
row, does not shrink with the load (measured: Newton stagnates at 0.003 to 0.02 r_0, SFVEM and
FEM, 2.5e3 to 3.3e4 unknowns), so a tiny
load converges on the defaults. Both are proportional to the moduli, so moduli and loads scaled
together give the same Newton iterations and solution. Why and what was measured: docs/method.md §6.
"""
from __future__ import annotations

import typing
from dataclasses import dataclass

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from dolfinx_sfvem import _compat
from dolfinx_sfvem.discretizations.discretization import AssemblyInfo, Discretization
from dolfinx_sfvem.physics.equilibrium import Equilibrium
from dolfinx_sfvem.path_following.linear_solvers import configure_ksp, linear_solver_options, rigid_body_modes

#: options prefix of a problem's solvers unless the user gives another
DEFAULT_PREFIX = "tmc_"
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
#: the default ``snes_atol`` is at least this many times the round-off floor r_0 of the residual (module docstring)
FLOOR_FACTOR = 10.0
#: with the energy merit, Newton takes full steps once the residual is below this fraction of its
#: initial value (the potential's decrease then nears its round-off; :meth:`SNESNewton.solve`)
MERIT_SWITCH = 1e-2
#: the most halvings of a Newton step in search of a lower potential
MERIT_HALVINGS = 20
#: a Newton stall whose smallest residual is more than this many times atol is not a round-off limit
STALL_FACTOR = 10.0
#: a solve is abandoned once more of its trial states than this left the energy's domain (module docstring)
MAX_REJECTED = 40
#: a solve is abandoned from this iteration on when its residual stalls (module docstring) ...
STALL_MIN_ITERATIONS = 10
#: ... i.e. when the last STALL_WINDOW residuals ...
STALL_WINDOW = 10
#: ... stay above STALL_DECREASE times the smallest residual before them
STALL_DECREASE = 0.9

Options = typing.Mapping[str, typing.Any]


def options_from_tokens(tokens: typing.Sequence[str], prefix: str = DEFAULT_PREFIX) -> dict[str, str]:
    """PETSc options from command-line tokens (``["-tmc_snes_monitor", "-tmc_ksp_type", "gmres"]``),
    keyed without the leading ``-`` and without ``prefix``: ``{"snes_monitor": "", "ksp_type": "gmres"}``.

    Raises
    ------
    ValueError
        For an option that does not carry ``prefix`` (it would be meant for another solver).
    """
    tokens = list(tokens)
    options = {}
    for k, token in enumerate(tokens):
        if not token.startswith("-") or _is_number(token):
            continue
        name = token.lstrip("-")
        if not name.startswith(prefix):
            raise ValueError(f"PETSc option {token!r}: this library's options carry the prefix {prefix!r} "
                             f"(e.g. -{prefix}snes_monitor, -{prefix}ksp_type gmres)")
        following = tokens[k + 1] if k + 1 < len(tokens) else None
        value = following if following is not None and (not following.startswith("-") or _is_number(following)) else ""
        options[name[len(prefix):]] = value
    return options


def _is_number(s: str) -> bool:
    try:
        float(s)
        return True
    except ValueError:
        return False


class prefixed_options:
    """Context manager: ``options`` (keys without prefix) in PETSc's database under ``prefix``
    while a solver reads them, with :data:`DEFAULT_PETSC_OPTIONS` beneath them where the
    command line gives nothing; afterwards the database is as before.

    Attributes
    ----------
    given : set of str
        The option names (without prefix) given on the command line or in ``options``.
    """

    def __init__(self, prefix: str, options: Options | None, defaults: Options = DEFAULT_PETSC_OPTIONS):
        db = PETSc.Options()
        self.prefix = prefix
        on_command_line = {k for k in defaults if db.hasName(prefix + k)}
        self._entries = {k: v for k, v in defaults.items() if k not in on_command_line}
        given = {k.lstrip("-"): "" if v is None else str(v) for k, v in (options or {}).items()}
        self._entries.update(given)
        self.given = on_command_line | set(given) | {name for name in _names_with_prefix(db, prefix)}

    def __enter__(self) -> "prefixed_options":
        db = PETSc.Options()
        self._saved = {k: db.getString(self.prefix + k) if db.hasName(self.prefix + k) else None
                       for k in self._entries}
        for key, value in self._entries.items():
            db[self.prefix + key] = value
        return self

    def __exit__(self, *exc) -> bool:
        db = PETSc.Options()
        for key, value in self._saved.items():
            if value is None:
                db.delValue(self.prefix + key)
            else:
                db[self.prefix + key] = value
        return False


def _names_with_prefix(db: PETSc.Options, prefix: str) -> list[str]:
    """Option names (without prefix) that the database holds under ``prefix``."""
    return [name[len(prefix):] for name in db.getAll() if name.startswith(prefix)]


class SolveFailed(RuntimeError):
    """A load step could not be solved even with the smallest allowed increment."""


@dataclass
class NewtonResult:
    """Outcome of one Newton solve (one load step attempt).

    ``failure`` says why the state is not accepted ("" when ``converged``): SNES's reason,
    J <= 0, a folded element, or (set by the load path) overlapping solids.
    ``negative_pivots``: negative pivots of the last LDL^T factorization of the solve (MUMPS
    INFOG(12)), i.e. the number of negative eigenvalues of the tangent with the constraints
    eliminated, at the last state Newton factorized; None with another factorization.
    ``rejected``: trial states of the solve (both line searches) outside the energy's domain.
    """
    converged: bool
    reason: int
    iterations: int
    residual_norms: list[float]
    min_J: float
    min_J_cell: int
    min_J_tag: int
    folded: int = 0
    kinked: int = 0
    failure: str = ""
    negative_pivots: int | None = None
    rejected: int = 0


def stalled(norms: typing.Sequence[float]) -> bool:
    """Whether Newton's residual norms ``norms`` (r_0, ..., r_k) have stalled: k >=
    :data:`STALL_MIN_ITERATIONS` and min(r_{k-W+1}, ..., r_k) > :data:`STALL_DECREASE` min(r_0, ...,
    r_{k-W}) with W = :data:`STALL_WINDOW`."""
    k = len(norms) - 1
    if k < STALL_MIN_ITERATIONS:
        return False
    return min(norms[-STALL_WINDOW:]) > STALL_DECREASE * min(norms[:-STALL_WINDOW])


def _stall(norms: typing.Sequence[float], atol: float, roundoff: float | None) -> str:
    """Where Newton stalled: its smallest residual in units of ``atol`` and of the round-off level
    eps F_c (None when ``snes_atol`` was given), and what that suggests."""
    floor = min(norms)
    text = f"smallest residual {floor:.3e} = {floor / atol:.3g} x atol {atol:.3e}"
    if roundoff:
        text += f" = {floor / roundoff:.3g} x round-off eps*F_c {roundoff:.3e}"
    if floor > STALL_FACTOR * atol:
        return text + ("; not a round-off limit: the Newton step leaves the region where the tangent predicts "
                       "the residual (e.g. a soft, strongly compressed medium; docs/guide/troubleshooting.md)")
    return text + ("; stalled within 10 x atol: typical of a bifurcation or limit point of the load path "
                   "(docs/guide/troubleshooting.md)")


def state_failure(info: AssemblyInfo) -> list[str]:
    """Why a state with diagnostics ``info`` is not admissible (empty if it is)."""
    why = []
    if not (info.min_J > 0.0):
        why.append(f"J = {info.min_J:.3e} in cell {info.min_J_cell} of region {info.min_J_tag}")
    if info.folded:
        why.append(f"{info.folded} folded element(s) (turned over at a vertex or edge midpoint), e.g. "
                   f"{info.folded_cell}")
    if not np.isfinite(info.energy):
        why.append("non-finite energy")
    return why


def _worse(info: AssemblyInfo, than: AssemblyInfo) -> bool:
    """Whether the trial state of ``info`` is worse than that of ``than``: inadmissible against
    admissible, else a smaller J (a NaN J counts as worst)."""
    if info.admissible != than.admissible:
        return not info.admissible
    return not (info.min_J >= than.min_J)


def reason_name(reason: int, reasons: type = PETSc.SNES.ConvergedReason) -> str:
    """PETSc's name of the converged reason ``reason`` (``"DIVERGED_MAX_IT"``) of SNES, or of
    another solver's ``reasons`` (``PETSc.KSP.ConvergedReason``)."""
    return next((k for k, v in vars(reasons).items() if v == reason and not k.startswith("_")), str(reason))


def _failure(reason: int, info: AssemblyInfo, norms: typing.Sequence[float], atol: float, roundoff: float | None,
             rejected: int = 0) -> str:
    """Why a solve that ended with SNES ``reason`` (residual norms ``norms``, final ``atol``) at a
    state with diagnostics ``info`` is rejected; ``rejected`` trial states of the solve were
    outside the energy's domain (``info`` then describes one of them)."""
    why = []
    if reason <= 0:
        why.append(f"SNES reason {reason} ({reason_name(reason)})")
        stalled = reason in (PETSc.SNES.ConvergedReason.DIVERGED_MAX_IT, PETSc.SNES.ConvergedReason.DIVERGED_LINE_SEARCH)
        if stalled and info.admissible and norms and atol > 0:
            why.append(_stall(norms, atol, roundoff))
    outside = state_failure(info)
    if rejected and outside:
        outside = [f"Newton's steps lead out of the admissible states ({rejected} trial state"
                   f"{'' if rejected == 1 else 's'} rejected; the worst: {', '.join(outside)})"]
    return "; ".join(why + outside)


def negative_pivots(pc: PETSc.PC) -> int | None:
    """Negative pivots of the last factorization of ``pc`` if it was MUMPS LDL^T (``pc_type
    cholesky``): INFOG(12), the number of negative eigenvalues of the factorized matrix
    (Sylvester's law of inertia); None for any other linear solver."""
    if pc.getType() != "cholesky" or pc.getFactorSolverType() != "mumps":
        return None
    return int(pc.getFactorMatrix().getMumpsInfog(12))


def node_spacing(disc: Discretization) -> float:
    """The mean spacing of the nodes of ``disc``, (|B| / n)^(1/d) with |B| the measure of the
    bounding box of the nodes, n their number over all ranks and d the dimension of
    :attr:`~Discretization.x_nodes` (a length in any dimension; collective).

    It scales the round-off floor of the residual: near F = I the residual's stress terms are
    O(modulus) each and cancel, and their round-off is eps times a force of that size,
    ``||K||_inf h`` per row, however small the displacement (module docstring).
    """
    X = disc.x_nodes[:disc.n_owned_nodes]
    low, high = X.min(axis=0, initial=np.inf), X.max(axis=0, initial=-np.inf)
    disc.comm.Allreduce(MPI.IN_PLACE, low, op=MPI.MIN)      # elementwise (the pickled allreduce of arrays
    disc.comm.Allreduce(MPI.IN_PLACE, high, op=MPI.MAX)     # compares them as wholes and fails on 2 ranks)
    n = disc.comm.allreduce(disc.n_owned_nodes, op=MPI.SUM)
    extent = (high - low)[high > low]
    return float(np.prod(extent) / n) ** (1.0 / extent.size) if extent.size else 0.0


class AbsoluteTolerance:
    """The default absolute tolerance of the residual of one balance, which follows its round-off
    level (module docstring)::

        atol = max(ATOL_ROUNDOFF_FACTOR * eps * F_c, FLOOR_FACTOR * eps * ||K||_inf h sqrt(n))

    A policy without per-solve state: the caller passes the state, the prescribed values and the
    stiffness ``||K||_inf`` of the tangent it holds. Both Newton's method
    (:class:`SNESNewton`) and the arc-length's bordered iterations use it.

    Parameters
    ----------
    equilibrium
        The balance: its discretization (node spacing, free rows, communicator) and its
        external force.

    Attributes
    ----------
    floor_length : float
        ``h sqrt(n)`` of the residual's round-off floor ``r_0 = eps ||K||_inf h sqrt(n)``
        (:func:`node_spacing`; computed once, collective).
    roundoff : float
        The round-off level ``eps F_c`` of the last call (0 before any).
    """

    def __init__(self, equilibrium: Equilibrium):
        self.equilibrium = equilibrium
        disc = equilibrium.disc
        self.disc = disc
        self.floor_length = node_spacing(disc) * float(np.sqrt(disc.num_dofs_global))
        self.roundoff = 0.0

    def free_row_norm(self, A: PETSc.Mat) -> float:
        """``||K||_inf`` of the free rows: the largest sum of absolute values over the free rows
        of ``A`` (collective)."""
        indptr, _, values = A.getValuesCSR()
        rows = np.repeat(np.arange(indptr.size - 1), np.diff(indptr))
        sums = np.bincount(rows, weights=np.abs(values), minlength=indptr.size - 1)
        free = self.disc.constraints.owned_free
        return self.disc.comm.allreduce(float(sums[free].max(initial=0.0)), op=MPI.MAX)

    def __call__(self, x: PETSc.Vec, g: np.ndarray, stiffness: float) -> float:
        """The absolute tolerance at the state ``x`` with the values ``g`` of the owned
        constrained unknowns and the free-row norm ``stiffness`` of the tangent:
        ``F_c = stiffness max(||x||_inf, ||g||_inf) + ||f||_inf`` with ``f`` the external force at
        the balance's load factor. Sets :attr:`roundoff` to ``eps F_c`` (collective)."""
        g_norm = self.disc.comm.allreduce(float(np.abs(g).max(initial=0.0)), op=MPI.MAX)
        force = stiffness * max(x.norm(PETSc.NormType.INFINITY), g_norm) + self.equilibrium.external_force_norm()
        eps = float(np.finfo(np.float64).eps)
        self.roundoff = eps * force
        return max(ATOL_ROUNDOFF_FACTOR * eps * force, FLOOR_FACTOR * eps * stiffness * self.floor_length)


class SNESNewton:
    """PETSc SNES (Newton with line search) for ``R(x; λ) = 0`` with constrained rows ``x_c = g_c``.

    Parameters
    ----------
    equilibrium
        The balance R(u; λ) and its tangent; the constraints of its discretization registered
        (:meth:`Discretization.set_constraints`) before :meth:`solve`.
    options
        PETSc options for this solver, keys without prefix (override the command line and the
        defaults; module docstring). Without ``snes_atol`` the absolute tolerance follows the
        round-off level of the residual (:class:`AbsoluteTolerance`).
    prefix
        Options prefix of the SNES, KSP and PC.
    linear_solver
        A preset of :data:`~dolfinx_sfvem.path_following.linear_solvers.LINEAR_SOLVERS` over the defaults
        (``"direct"``: MUMPS; ``"iterative"``: GMRES + p-multigrid over the discretization's
        degree-1 coarse space, :meth:`Discretization.coarse_interpolation`); the command line and
        ``options`` win over it. The tangent always carries the rigid-body near-nullspace (for
        GAMG, chosen by options).
    """

    def __init__(self, equilibrium: Equilibrium, options: Options | None = None, prefix: str = DEFAULT_PREFIX,
                 linear_solver: str = "direct"):
        self.equilibrium = equilibrium
        disc = equilibrium.disc
        self.disc = disc
        self.comm = disc.comm
        self.prefix = prefix
        self.g = np.zeros(0)        # prescribed values of the owned constrained unknowns, of the current solve
        self._stiffness = 0.0       # ||K||_inf of the free rows, at the tangent of the start state of the current solve
        #: the default absolute tolerance (used unless ``snes_atol`` is given: :attr:`scaled_atol`)
        self.tolerance = AbsoluteTolerance(equilibrium)
        self.A = disc.create_matrix()
        self.A.setNearNullSpace(rigid_body_modes(disc.x_nodes, disc.n_owned_nodes, disc.create_vector))
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
        self.worst_info = None      # the worst trial state of the current solve (:func:`_worse`)
        self.rejected = 0           # trial states of the current solve outside the energy's domain
        self.abandoned = ""         # why the current solve was abandoned ("" while it is not)

        self.snes = snes = PETSc.SNES().create(self.comm)
        snes.setOptionsPrefix(prefix)
        snes.setFunction(self._residual, self.b)
        snes.setJacobian(self._jacobian, self.A)
        self._merit_asked = False   # the current solve asked for the energy merit (:meth:`solve`)
        self._merit = False         # its steps are judged by the potential now
        snes.setMonitor(self._monitor)
        self.options = dict(options or {})
        self.linear_solver = linear_solver
        self.defaults = {**DEFAULT_PETSC_OPTIONS, **linear_solver_options(linear_solver)}
        if not equilibrium.symmetric:            # LDLᵀ would be wrong: LU, for the tangent or the coarse level
            self.options.setdefault("pc_type" if linear_solver == "direct" else "mg_coarse_pc_type", "lu")
        with prefixed_options(prefix, self.options, self.defaults) as scoped:
            if PETSc.Options().getString(prefix + "pc_type", "") == PETSc.PC.Type.MG:
                configure_ksp(self.ksp, disc.coarse_interpolation())
            snes.setFromOptions()
            #: the KSP's relative tolerance of the options, for solves outside SNES (:meth:`solve_linear_to_tolerance`)
            self.ksp_rtol = self.ksp.getTolerances()[0]
            #: the option names (without prefix) given on the command line or from Python
            self.given = frozenset(scoped.given)
            self.scaled_atol = "snes_atol" not in scoped.given
            self.fallback = "snes_linesearch_type" not in scoped.given
        snes.setLineSearchPreCheck(self._unlift)

    @property
    def ksp(self) -> PETSc.KSP:
        """The linear solver of the Newton steps (its factorization serves the arc-length's bordering too)."""
        return self.snes.getKSP()

    def solve_linear_to_tolerance(self) -> None:
        """Let :attr:`ksp`'s own solves (outside SNES: the arc-length's bordering) stop at the
        options' relative tolerance: the Eisenstat-Walker tolerances (``snes_ksp_ew``, the
        iterative preset's), which PETSc applies to every solve of SNES's KSP and leaves set after
        a SNES solve, off until SNES reads its options again (collective)."""
        self.snes.setUseEW(False)
        self.ksp.setTolerances(rtol=self.ksp_rtol)

    def _residual(self, snes: PETSc.SNES, x: PETSc.Vec, b: PETSc.Vec) -> None:
        if self.abandoned:                    # the rest of an abandoned solve: fail at once
            _compat.snes_set_function_domain_error(snes)
            return
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        info = self.equilibrium.residual(x, b)
        self.rejected += not info.admissible
        self.abandoned = self.abandoned or self.abandon_reason()
        if self.worst_info is None or _worse(info, self.worst_info):
            self.worst_info = info
        b.copy(self.force)
        x.copy(self._force_state)
        self._force_info = info
        self._lifted = False
        self.disc.constraints.set_residual_rows(x, b, self.g)
        if not info.admissible:
            _compat.snes_set_function_domain_error(snes)

    def _jacobian(self, snes: PETSc.SNES, x: PETSc.Vec, A: PETSc.Mat, P: PETSc.Mat) -> None:
        if self.abandoned:                    # A unchanged: the linear solve reuses its factorization
            return
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        if not self._start_tangent_at(x):
            self.equilibrium.tangent(x, A)
        self._start_state_current = False
        if self.scaled_atol:
            snes.setTolerances(atol=self.tolerance(x, self.g, self._stiffness))
        # SNES solves A y = F with its F at x (self.b, just evaluated): the constraints' lifting goes
        # into F for the linear solve, and :meth:`_unlift` puts the residual back before the line search
        self.b.copy(self._unlifted)
        self.disc.constraints.eliminate(A, self.b)
        self._lifted = True

    def _unlift(self, x: PETSc.Vec, y: PETSc.Vec, *args) -> bool:
        """Line-search pre-check: SNES's residual F at x back in place of the lifted right-hand
        side of the linear solve, so that the line search works with the residual whose norm SNES
        tests (its slope F·(A y) is then exact up to F_f·K_fc δ_c, zero when F_f or δ_c is); the
        step y is left unchanged but in the energy merit's phase (:meth:`_descend`). Nothing to undo
        after a lagged Jacobian (F was not lifted)."""
        if self._lifted:
            self._unlifted.copy(self.b)
            self._lifted = False
        return self._descend(x, y) if self._merit and not self.abandoned else False

    def _start(self, x: PETSc.Vec) -> None:
        """The tangent at the start state ``x`` of a solve into :attr:`A`, constraints not applied:
        its free-row norm sets the absolute tolerance before the first iteration, and the first
        Jacobian evaluation (at this state) uses it as it is (collective)."""
        self.equilibrium.tangent(x, self.A)
        self._stiffness = self.tolerance.free_row_norm(self.A)
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

    def solve(self, x: PETSc.Vec, g: np.ndarray, load: float = 1.0, energy_merit: bool = False) -> NewtonResult:
        """Solve from the state ``x`` (updated in place) with the values ``g`` of the owned
        constrained unknowns (``disc.constraints.owned``) at the load factor ``load``; a failed
        solve with the default line search is repeated from the same start with
        :data:`FALLBACK_LINE_SEARCH` (its iterations are counted in the result's, its residual
        norms and failure are the result's).

        ``energy_merit``: while the residual is above :data:`MERIT_SWITCH` of its initial value,
        a Newton step is shortened (halved) until it lowers the total potential
        (:meth:`Equilibrium.potential`) and then taken as it is (line search ``basic``); closer to
        the solution full Newton steps. Only where the balance has a potential
        (:attr:`Equilibrium.conservative`), the constrained unknowns are at ``g`` already (the
        potential is then minimal at the solution) and the line search is the default one. From
        a stress-free state the residual's norm rises along Newton's step (its linearized
        rotations stretch stiff material) while the potential falls, and the norm-based line
        search creeps at a few percent of every step."""
        with x.localForm() as xl:
            moved = bool(np.any(xl.array_r[self.disc.constraints.owned] != np.asarray(g)))
        moved = self.comm.allreduce(moved, op=MPI.LOR)
        self._merit_asked = energy_merit and self.fallback and self.equilibrium.conservative and not moved
        if not self._merit_asked:
            return self._solve_with_fallback(x, g, load)
        self._set_line_search("basic")
        try:
            return self._solve_with_fallback(x, g, load)
        finally:
            self._merit_asked = self._merit = False
            self._set_line_search(DEFAULT_PETSC_OPTIONS["snes_linesearch_type"])

    def _monitor(self, snes: PETSc.SNES, iteration: int, norm: float) -> None:
        """Records the residual norms; ends the energy merit's phase (:meth:`solve`) once the
        residual fell below :data:`MERIT_SWITCH` of its initial value: near the solution the
        potential's decrease along a step, about |R|²/K, nears its round-off."""
        self.history.append(float(norm))
        if self._merit and norm < MERIT_SWITCH * self.history[0]:
            self._merit = False
        self.abandoned = self.abandoned or self.abandon_reason()

    def abandon_reason(self) -> str:
        """Why the current solve is abandoned, or "" (module docstring): too many trial states
        outside the energy's domain, or a stalled residual (:func:`stalled`)."""
        if self.rejected > MAX_REJECTED:
            return (f"abandoned after {self.rejected} trial states outside the energy's domain (more than "
                    f"{MAX_REJECTED}) in {len(self.history)} Newton iterations")
        if stalled(self.history):
            return (f"abandoned at Newton iteration {len(self.history) - 1}: the residual fell by less than "
                    f"{1 - STALL_DECREASE:.0%} over the last {STALL_WINDOW} iterations "
                    f"(smallest {min(self.history):.3e})")
        return ""

    def _descend(self, x: PETSc.Vec, y: PETSc.Vec) -> bool:
        """The Newton step x - y halved until it lowers the total potential (at most
        :data:`MERIT_HALVINGS` times; y scaled in place); whether y changed (collective)."""
        trial = x.duplicate()
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        start = self.equilibrium.potential(x)
        scale = 1.0
        for _ in range(MERIT_HALVINGS):
            x.copy(trial)
            trial.axpy(-scale, y)
            trial.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
            if self.equilibrium.potential(trial) <= start:
                break
            scale /= 2
        trial.destroy()
        if scale < 1.0:
            y.scale(scale)
        return scale < 1.0

    def _solve_with_fallback(self, x: PETSc.Vec, g: np.ndarray, load: float) -> NewtonResult:
        """:meth:`solve` with the line search as set up."""
        start = x.copy() if self.fallback else None
        result = self._solve_once(x, g, load)
        if start is None:
            return result
        if result.converged:
            start.destroy()
            return result
        start.copy(x)                             # owned values only: the ghosts hold the failed iterate's
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        start.destroy()
        self._set_line_search(FALLBACK_LINE_SEARCH)
        try:
            retry = self._solve_once(x, g, load)
        finally:
            self._set_line_search(DEFAULT_PETSC_OPTIONS["snes_linesearch_type"])
        retry.iterations += result.iterations
        retry.rejected += result.rejected
        return retry

    def force_at(self, x: PETSc.Vec) -> AssemblyInfo:
        """Internal minus external force at ``x`` (ghosts current) and the current load factor
        into :attr:`force`, constraints not applied, with the state's diagnostics: the last
        residual's if SNES evaluated it at exactly this state, else assembled (collective)."""
        self._force_state.axpy(-1.0, x)
        same = self._force_info is not None and self._force_state.norm(PETSc.NormType.NORM_INFINITY) == 0.0
        if not same:
            self._force_info = self.equilibrium.residual(x, self.force)
        x.copy(self._force_state)
        return self._force_info

    def forget_force(self) -> None:
        """The kept force no longer belongs to its state (the load factor or the loads changed)."""
        self._force_info = None

    def _set_line_search(self, kind: str) -> None:
        """Set SNES up again from this solver's options with the line search ``kind``."""
        with prefixed_options(self.prefix, {**self.options, "snes_linesearch_type": kind}, self.defaults):
            self.snes.setFromOptions()
        self.snes.setLineSearchPreCheck(self._unlift)

    def _solve_once(self, x: PETSc.Vec, g: np.ndarray, load: float) -> NewtonResult:
        """One SNES solve from ``x`` with the line search as set (see :meth:`solve`)."""
        self.g = np.asarray(g, dtype=np.float64)
        if load != self.equilibrium.load:
            self.equilibrium.set_load(load)
            self.forget_force()
        self.history = []
        self.worst_info = None
        self.rejected = 0
        self.abandoned = ""
        self._merit = self._merit_asked
        self._start(x)
        if not np.isfinite(self._stiffness):          # e.g. a predicted state with J <= 0: no Newton from there
            return NewtonResult(False, int(PETSc.SNES.ConvergedReason.DIVERGED_FUNCTION_DOMAIN), 0, [], float("nan"),
                                -1, -1, failure="the start state is outside the energy's domain (non-finite tangent)")
        if self.scaled_atol:
            self.snes.setTolerances(atol=self.tolerance(x, self.g, self._stiffness))
        self.snes.solve(None, x)
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        reason = self.snes.getConvergedReason()
        info = self.force_at(x)                   # state diagnostics at the final iterate
        ok = reason > 0 and info.admissible
        if not ok and self.worst_info is not None:
            info = self.worst_info                # where it went wrong, not where it started
        atol = self.snes.getTolerances()[1]
        roundoff = self.tolerance.roundoff if self.scaled_atol else None
        failure = "" if ok else _failure(reason, info, self.history, atol, roundoff, self.rejected)
        if self.abandoned:
            failure = f"{self.abandoned}; {failure}"
        return NewtonResult(bool(ok), int(reason), len(self.history) - 1 if self.abandoned else
                            int(self.snes.getIterationNumber()), list(self.history), info.min_J, info.min_J_cell,
                            info.min_J_tag, info.folded, info.kinked, failure, self.negative_pivots(), self.rejected)

    def negative_pivots(self) -> int | None:
        """Negative pivots of the last factorization of this solve if it was MUMPS LDL^T (the
        default with a symmetric tangent; :func:`negative_pivots`); None before a factorization."""
        if self.snes.getIterationNumber() == 0:
            return None
        return negative_pivots(self.ksp.getPC())

    def destroy(self) -> None:
        """Free the PETSc objects."""
        for obj in (self.snes, self.A, self.b, self.force, self._force_state, self._unlifted, self._start_state):
            obj.destroy()
