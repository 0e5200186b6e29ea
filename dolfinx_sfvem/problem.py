"""A third-medium contact problem: mesh, region energies, boundary conditions, load path.

Example
-------
>>> import dolfinx_sfvem as sf
>>> mesh = sf.meshes.cbox(h_solid=0.05)                      # doctest: +SKIP
>>> problem = sf.ContactProblem(mesh, {
...     sf.meshes.SOLID: sf.Hyperelastic(K=5 / 3, mu=5 / 14),
...     sf.meshes.MEDIUM: sf.ThirdMedium(mu=5 / 14, gamma=1e-5, alpha_r=1.0)})
>>> problem.fix(lambda x: np.isclose(x[0], 0.0))
>>> problem.prescribe(lambda x: np.isclose(x[0], 1.0) & np.isclose(x[1], 0.5), uy=-0.5, name="load")
>>> result = problem.solve(steps=50, out="out/cbox")
"""
from __future__ import annotations

import dataclasses
import functools
import itertools
import pathlib
import time
import typing
from dataclasses import asdict, dataclass

import numpy as np
import numpy.typing as npt
from mpi4py import MPI
from petsc4py import PETSc

from . import post
from .adaptivity import Adaptivity
from .contact import OVERLAP_TOLERANCE, ContactPressure, Gap, SolidBoundary
from .energy import Energy
from .interrupt import StopRequest
from .polygon_mesh import PolygonMesh
from .refine import Refinement, refine_mesh, transfer_state
from .run_output import STOPPED_BY_SIGNAL, RunWriter, progress_line, read_checkpoint
from .solver import Attempt, LoadStepper, NewtonResult, NewtonSolver, SolveFailed, StepRecord

Marker = typing.Callable[[np.ndarray], np.ndarray]
#: an observer returns one number, or several named ones
Observer = typing.Callable[["ContactProblem"], typing.Union[float, typing.Mapping[str, float]]]
#: steps of the residual relaxation of :meth:`ContactProblem._rebalance` (cut back down to a quarter of one)
RELAX_STEPS = 4
Value = typing.Union[float, typing.Callable[[np.ndarray], np.ndarray]]


@dataclass
class BoundaryCondition:
    """Prescribed displacement components on the nodes selected by ``marker`` and/or ``tags``.

    ``values`` maps component (0 = x, 1 = y) to the value reached at load factor 1: a number
    or a function of the coordinates ``x`` (2, n) returning (n,); it is applied as
    ``load_factor * value``. At interior (mean) DOFs a function is averaged over the polygon.
    """
    name: str
    values: dict[int, Value]
    marker: Marker | None = None
    tags: tuple[int, ...] | None = None


@dataclass
class Result:
    """Outcome of :meth:`ContactProblem.solve`.

    Attributes
    ----------
    converged : bool
        The load factor ``until`` of :meth:`ContactProblem.solve` (default 1, the full load) was
        reached (and no solids overlap).
    load : float
        Largest load factor reached.
    steps : list of dict
        The converged steps, in order (``summary.json``'s records: ``load``, ``reaction``
        ``{name: [R_x, R_y]}``, ``gap``, ``extra`` (observers), ...).
    attempts : list of dict
        Every attempted step, failed ones included (``converged`` False, with ``failure``).
    wall_time_s : float
    summary : dict
        The content of summary.json.
    message : str
        Why the run stopped ("" if it converged).
    """
    converged: bool
    load: float
    steps: list[dict]
    attempts: list[dict]
    wall_time_s: float
    summary: dict
    message: str = ""


def _observe(problem: "ContactProblem", observers: typing.Mapping[str, Observer]) -> dict[str, float]:
    """The observers' values: ``name`` for a number, ``name.key`` for each entry of a mapping."""
    values: dict[str, float] = {}
    for name, f in observers.items():
        value = f(problem)
        if isinstance(value, typing.Mapping):
            values.update({f"{name}.{key}": float(v) for key, v in value.items()})
        else:
            values[name] = float(value)
    return values


def _component(c: int | str, name: str) -> int:
    """0 or 1 from 0 / 1 / "x" / "y"."""
    index = {0: 0, 1: 1, "x": 0, "y": 1}.get(c) if isinstance(c, (int, str, np.integer)) else None
    if index is None or isinstance(c, bool):
        raise ValueError(f"boundary condition {name!r}: component {c!r}; use 0 or 'x', 1 or 'y'")
    return index


def _materials_by_tag(mesh: PolygonMesh, materials: typing.Mapping[int | str, Energy]) -> dict[int, Energy]:
    """Materials keyed by region tag; names are looked up in ``mesh.region_names``."""
    out: dict[int, Energy] = {}
    for key, energy in materials.items():
        if isinstance(key, str):
            if key not in mesh.region_names:
                known = ", ".join(f"{n!r} = {t}" for n, t in mesh.region_names.items()) or "none"
                raise ValueError(f"material key {key!r} is not a region name of the mesh (its names: {known}); "
                                 "key materials by region name or by integer region tag")
            key = mesh.region_names[key]
        if int(key) in out:
            raise ValueError(f"two materials given for region {int(key)}")
        out[int(key)] = energy
    return out


class ContactProblem:
    """Finite-strain (third medium) contact problem on a polygon mesh.

    Parameters
    ----------
    mesh
        Polygon mesh with region tags.
    materials
        Region tag -> energy (:class:`Hyperelastic`, :class:`ThirdMedium`, :class:`UserEnergy`).
    method
        ``"vem"`` (order-2 SFVEM on the polygons) or ``"fem"`` (P2 Lagrange triangles on the
        same geometry and regions, :class:`~dolfinx_sfvem.fem.LagrangeDiscretization`).
    comm
        MPI communicator.
    overlap_tolerance
        A converged state in which a boundary node of a solid lies deeper inside a solid than
        this fraction of the local boundary edge length is rejected like a failed step
        (:mod:`~dolfinx_sfvem.contact`; the run stops when cutting the increment does not help).
    **options
        Passed to the discretization: ``verbose`` and ``quadrature_degree`` for both;
        ``l``, ``l_min`` for ``"vem"``; ``fem_h`` for ``"fem"`` (triangle size; default
        None: matched to the SFVEM unknowns of ``mesh``, see
        :func:`~dolfinx_sfvem.remesh.matched_triangulation`).
    """

    def __init__(self, mesh: PolygonMesh, materials: typing.Mapping[int, Energy], method: str = "vem",
                 comm: MPI.Comm = MPI.COMM_WORLD, *, overlap_tolerance: float = OVERLAP_TOLERANCE, **options):
        if method not in ("vem", "fem"):
            raise ValueError(f"unknown method {method!r}; use 'vem' or 'fem'")
        self.method = method
        self.comm = comm
        self.verbose = options.get("verbose", True)
        self._options = dict(options, overlap_tolerance=overlap_tolerance)   # to rebuild in :meth:`refine`
        self.materials = _materials_by_tag(mesh, materials)
        self._build(mesh)
        self.bcs: list[BoundaryCondition] = []
        self.f_ext = None
        self._earlier_wall_time = 0.0      # of the stopped run a resumed solve continues
        self._attempt_contact: tuple[Gap, ContactPressure] | None = None   # of the last converged attempt
        self._solved = False
        #: load factor of the current state (0 in the reference state; set by :meth:`solve`)
        self.load = 0.0
        self.parameters: dict[str, typing.Any] = {}

    def _build(self, mesh: PolygonMesh) -> None:
        """The discretization of ``mesh`` (materials and options of the problem), the solids'
        boundary for the contact checks and a zero state vector."""
        self.mesh = mesh
        options = {k: v for k, v in self._options.items() if k != "overlap_tolerance"}
        if self.method == "vem":
            from .vem import SFVEMDiscretization
            self.disc = SFVEMDiscretization(mesh, self.materials, self.comm, **options)
        else:
            from .fem import LagrangeDiscretization
            self.disc = LagrangeDiscretization.from_polygon_mesh(mesh, self.materials, self.comm, **options)
        self.boundary = SolidBoundary(self.disc.output_mesh,
                                      [tag for tag, energy in self.materials.items() if not energy.is_medium],
                                      self.disc.midpoint_keys, self._options["overlap_tolerance"])
        self.x = self.disc.create_vector()
        self.x.set(0.0)

    def reset(self) -> None:
        """Back to the reference state (u = 0, load factor 0), so that :meth:`solve` may run again."""
        self.x.set(0.0)
        self._solved = False
        self.load = 0.0

    # ------------------------------------------------------------------ boundary conditions
    def fix(self, marker: Marker | None = None, tags: typing.Iterable[int] | None = None,
            components: typing.Iterable[int | str] = (0, 1), name: str = "fixed") -> BoundaryCondition:
        """u_i = 0 for the given components (0 or "x", 1 or "y") on the selected nodes."""
        return self._add(BoundaryCondition(name, {_component(c, name): 0.0 for c in components}, marker,
                                           None if tags is None else tuple(tags)))

    def prescribe(self, marker: Marker | None = None, tags: typing.Iterable[int] | None = None, *,
                  ux: Value | None = None, uy: Value | None = None, name: str = "load") -> BoundaryCondition:
        """u_x = λ ux and/or u_y = λ uy on the selected nodes, λ the load factor.

        ``ux``/``uy`` are numbers or functions of the coordinates ``x`` (2, n) returning (n,).
        """
        values = {c: v if callable(v) else float(v) for c, v in ((0, ux), (1, uy)) if v is not None}
        if not values:
            raise ValueError(f"boundary condition {name!r}: give ux and/or uy")
        if not all(callable(v) or np.isfinite(v) for v in values.values()):
            raise ValueError(f"boundary condition {name!r}: prescribed values must be finite, got {values}")
        return self._add(BoundaryCondition(name, values, marker, None if tags is None else tuple(tags)))

    def _add(self, bc: BoundaryCondition) -> BoundaryCondition:
        if bc.marker is None and bc.tags is None:
            raise ValueError(f"boundary condition {bc.name!r}: give a marker function and/or region tags")
        if any(b.name == bc.name for b in self.bcs):
            raise ValueError(f"boundary condition name {bc.name!r} used twice")
        self.bcs.append(bc)
        return bc

    def _constraints(self) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """The constrained unknowns (k,) (local, sorted), the values at load factor 1 of the owned
        ones (in their order) and the unknowns of every condition."""
        n_local = self.disc.n_local_dofs
        by = np.full(n_local, -1)                  # index of the condition that set each unknown
        final = np.zeros(n_local)
        dofs_of = {}
        for k, bc in enumerate(self.bcs):
            all_dofs = []
            for comp, value in bc.values.items():
                dofs = self.disc.locate_dofs(bc.marker, bc.tags, comp)
                values = self.disc.dof_values(value, dofs) if callable(value) else np.full(dofs.size, value)
                self._check_agreement(by, final, dofs, values, k)
                by[dofs], final[dofs] = k, values
                all_dofs.append(dofs)
            dofs_of[bc.name] = np.concatenate(all_dofs)
            if self.comm.allreduce(dofs_of[bc.name].size, op=MPI.SUM) == 0:
                raise ValueError(f"boundary condition {bc.name!r} selects no degree of freedom")
        owned = np.flatnonzero(by[:self.disc.n_owned_dofs] >= 0)
        return np.flatnonzero(by >= 0), final[owned], dofs_of

    def _check_agreement(self, by: np.ndarray, final: np.ndarray, dofs: np.ndarray, values: np.ndarray,
                         k: int) -> None:
        """Two conditions may share unknowns only with the same values (collective; ValueError
        naming both conditions and a node otherwise)."""
        earlier = by[dofs] >= 0
        clash = earlier & ~np.isclose(final[dofs], values, rtol=1e-12, atol=1e-14)
        where = None
        if clash.any():
            i = int(np.argmax(clash))
            where = (self.bcs[by[dofs[i]]].name, tuple(self.disc.dof_coordinates(dofs[i:i + 1])[0]),
                     "xy"[dofs[i] % 2], float(final[dofs[i]]), float(values[i]))
        found = [w for w in self.comm.allgather(where) if w is not None]
        if found:
            other, x, comp, a, b = found[0]
            raise ValueError(f"boundary conditions {other!r} and {self.bcs[k].name!r} prescribe different u_{comp} "
                             f"({a:g} and {b:g}) at the node ({x[0]:g}, {x[1]:g}); equal values on shared nodes "
                             "are allowed")

    def set_displacement(self, ux: Value = 0.0, uy: Value = 0.0) -> None:
        """Set the current state (e.g. an initial guess or a pre-deformation): ``ux``/``uy`` are
        numbers or functions of the coordinates ``x`` (2, n) returning (n,)."""
        all_dofs = np.arange(self.disc.n_local_dofs)
        with self.x.localForm() as xl:
            for comp, value in ((0, ux), (1, uy)):
                dofs = all_dofs[comp::2]
                xl.array[dofs] = self.disc.dof_values(value, dofs) if callable(value) else float(value)

    def body_force(self, f: typing.Callable[[np.ndarray], np.ndarray]) -> None:
        """Body force per unit reference area, ``f(x)`` (2, n) -> (2, n), scaled by the load factor."""
        self.f_ext = self.disc.body_force_vector(f)

    # ------------------------------------------------------------------ results
    def reactions(self, dofs_of: dict[str, np.ndarray], load: float = 1.0,
                  force: PETSc.Vec | None = None) -> dict[str, list[float]]:
        """Reaction force [R_x, R_y] on every boundary condition: the sum over its unknowns of
        internal minus external force at the current state and load factor (``force``, that
        vector if the caller has it already, e.g. the Newton solver's; else assembled here)."""
        b = force
        if b is None:
            b = self.disc.create_vector()
            self.disc.residual(self.x, b)
            if self.f_ext is not None:
                b.axpy(-load, self.f_ext)
        n_owned = self.disc.n_owned_dofs
        with b.localForm() as bl:
            r = bl.array_r
            out = {}
            for name, dofs in dofs_of.items():
                own = dofs[dofs < n_owned]
                out[name] = [self.comm.allreduce(float(r[own[own % 2 == c]].sum()), op=MPI.SUM) for c in (0, 1)]
        if force is None:
            b.destroy()
        return out

    def max_displacement(self) -> float:
        """Largest nodal displacement magnitude max |u| over all ranks (collective)."""
        with self.x.localForm() as xl:
            u = xl.array_r.reshape(-1, 2)[:self.disc.n_owned_dofs // 2]
            local = float(np.sqrt((u ** 2).sum(axis=1)).max(initial=0.0))
        return self.comm.allreduce(local, op=MPI.MAX)

    def contact_gap(self) -> Gap:
        """The smallest signed gap between the deformed solids at the current state, with where
        it occurs (collective; :mod:`~dolfinx_sfvem.contact`)."""
        return self.boundary.gap_of_state(self.comm, *self.disc.get_state(self.x))

    def contact_pressure(self) -> ContactPressure:
        """Normal pressure of the medium on the solids at every boundary node, and per pair of
        bodies facing each other across the medium the total contact force, the largest pressure,
        the contact zone's length and the smallest gap, at the current state (collective; the
        result on every rank; :mod:`~dolfinx_sfvem.contact`)."""
        return self._contact()[1]

    def _contact(self) -> tuple[Gap, ContactPressure]:
        """:meth:`contact_gap` and :meth:`contact_pressure` from one gather (collective)."""
        f, f_material = self.disc.create_vector(), self.disc.create_vector()
        self.disc.medium_force(self.x, f)
        self.disc.medium_force(self.x, f_material, regularization=False)
        u, forces, material = (self.boundary.gather(self.comm, *self.disc.get_state(v)) for v in (self.x, f, f_material))
        f.destroy()
        f_material.destroy()
        return self.comm.bcast(self.boundary.gap_and_pressure(u, forces, material) if self.comm.rank == 0 else None,
                               root=0)

    def displacement_at(self, points: npt.ArrayLike) -> np.ndarray:
        """Displacement (n, 2) at reference ``points`` (n, 2) on every rank (collective): the SFVEM's
        Π^∇_2 u of the polygon holding the point (Eq. 36), the FEM's u_h; NaN outside the mesh.
        With :meth:`PolygonMesh.boundary_points` it gives displacements along a boundary, curved
        ones included (their vertices and edge midpoints are the nodes)."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        values, found = self.disc.displacement_at(self.x, points)
        count = self.comm.allreduce(found.astype(np.int64), op=MPI.SUM)
        total = self.comm.allreduce(values, op=MPI.SUM)
        return np.where(count[:, None] > 0, total / np.maximum(count, 1)[:, None], np.nan)

    def point_displacements(self) -> np.ndarray | None:
        """Displacement (n_points, 2) of every point of ``disc.output_mesh``, on rank 0 (None elsewhere)."""
        indices, values = self.disc.output_point_displacements(self.x)
        return post.gather_to_root(self.comm, indices, values, self.disc.output_mesh.n_points)

    # ------------------------------------------------------------------ local refinement
    def refine(self, where: Marker | npt.ArrayLike | None = None, levels: int = 1, *,
               tags: typing.Iterable[int | str] | None = None, max_l: int = 6) -> Refinement:
        """Refine the mesh locally and carry the current state over, so that a following
        ``solve(..., from_current_state=True)`` continues from it (collective; SFVEM only).

        The discretization is rebuilt on the refined mesh (same materials and options), the
        boundary conditions are kept (markers are evaluated again on the new nodes, tags select
        the same regions) and the state is transferred exactly for quadratic fields
        (:func:`~dolfinx_sfvem.refine.transfer_state`, docs/refinement-local.md).

        Parameters
        ----------
        where, levels, tags, max_l
            As :meth:`PolygonMesh.refine`.

        Returns
        -------
        Refinement
            The new mesh (also ``self.mesh``) and the parent polygon of each new polygon.
        """
        if self.method != "vem":
            raise ValueError("refine: only method='vem' can be refined with hanging nodes; for the FEM build a "
                             "finer problem instead")
        if self.f_ext is not None:
            raise ValueError("refine: a problem with a body force cannot be refined (the force vector belongs "
                             "to the old mesh); refine first, then call body_force")
        refinement = refine_mesh(self.mesh, where, levels, tags=tags, max_l=max_l)
        self._move_to(refinement)
        return refinement

    def _move_to(self, refinement: Refinement) -> None:
        """Rebuild on ``refinement.mesh`` and carry the state over (collective)."""
        self._rebuild(refinement.mesh, transfer_state(refinement, self._gathered_state()))

    def _gathered_state(self) -> np.ndarray:
        """The state (n_nodes, 2) by node key, on every rank (collective)."""
        keys, values = (np.concatenate(part) for part in zip(*self.comm.allgather(self.disc.get_state(self.x))))
        state = np.full((int(keys.max()) + 1, 2), np.nan)
        state[keys] = values
        return state

    def _rebuild(self, mesh: PolygonMesh, state: np.ndarray) -> None:
        """The problem on ``mesh`` at ``state`` (n_nodes, 2) by node key (collective)."""
        self.x.destroy()
        self._build(mesh)
        self.disc.set_state(np.arange(state.shape[0]), state, self.x)
        self.x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)

    # ------------------------------------------------------------------ solve
    def solve(self, steps: int, out: str | pathlib.Path | None = None, *,
              petsc_options: typing.Mapping[str, typing.Any] | None = None,
              min_increment: float | None = None,
              observers: typing.Mapping[str, Observer] | None = None,
              raise_on_failure: bool = False, resume: bool = False, from_current_state: bool = False,
              until: float = 1.0, adapt: Adaptivity | None = None,
              pressure_at: typing.Iterable[float] = ()) -> Result:
        """Ramp the prescribed displacements in ``steps`` load steps with Newton's method.

        Parameters
        ----------
        steps
            Number of nominal load increments over the whole path, load factor 0 to 1 (a path
            continued from load factor λ_0 takes about ``(until - λ_0) * steps`` of them).
        out
            Output directory (summary.json, load_path.csv, XDMF, PNG); None writes nothing.
        petsc_options
            PETSc options for SNES/KSP/PC (the command line works too).
        min_increment
            Smallest load-factor increment of the automatic cut-back (default (1/steps)/2¹⁰).
        observers
            ``{name: f}``, each ``f(problem)`` called once per converged step (collectively, on every
            rank) and returning a number, recorded as ``name``, or a mapping ``{key: number}``,
            recorded as ``name.key`` (several values from one computation, e.g. a gap profile).
            They go to ``steps[i]["extra"]`` of summary.json and to load_path.csv.
        raise_on_failure
            Raise :class:`SolveFailed` instead of returning a non-converged result.
        resume
            Continue the run saved in ``out`` (``checkpoint.npz`` and ``summary.json``, written
            after every converged step) from its last converged step. With the same
            ``steps`` the result equals that of an uninterrupted run. Not with ``adapt``.
        from_current_state
            Continue the load path from the current state and its load factor :attr:`load`
            (e.g. after :meth:`refine`): the first step re-balances the state at that load
            (:meth:`_rebalance`), the following ones go on to ``until``; the cut-back never goes
            below the load already reached. A problem solved once refuses to solve again unless
            this is True; :meth:`reset` returns to the reference state instead.
        until
            Load factor at which the path stops, in (0, 1]; ``converged`` means it was reached.
        adapt
            Refine the medium during the path where ``adapt.indicator`` says, after converged
            steps (:class:`~dolfinx_sfvem.adaptivity.Adaptivity`, docs/refinement-local.md; SFVEM
            only). Each refinement is followed by a re-balancing step at the same load.
        pressure_at
            Load factors at which ``out`` gets a plot of the contact pressure along the solids'
            boundaries (``contact_pressure_<load>.png``, at the first converged step reaching each);
            the last state's is always written (``contact_pressure.png``).
        """
        if self._solved and not (from_current_state or resume):
            raise ValueError("this problem has been solved already; call reset() to start again from the "
                             "reference state, or solve(..., from_current_state=True) to continue the load path "
                             "from the current state")
        if not (0.0 < until <= 1.0):
            raise ValueError(f"until must be a load factor in (0, 1], got {until!r}")
        if adapt is not None and (resume or self.method != "vem"):
            raise ValueError("adapt: adaptive refinement needs method='vem' and cannot resume a stopped run")
        if from_current_state and until < self.load - 1e-12:
            raise ValueError(f"until = {until:g} lies below the load factor {self.load:g} already reached")
        rebalance = from_current_state and self._solved and not resume
        if adapt is not None:
            adapt.level = None                 # levels count from the mesh this solve starts on
        self._solved = True
        t_start = time.perf_counter()
        stepper = LoadStepper(steps, min_increment=min_increment, start=self.load if from_current_state else 0.0,
                              until=until)
        records: list[dict] = []
        if resume:
            if out is None:
                raise ValueError("resume needs the output directory of the stopped run")
            self.disc.set_constraints(self._constraints()[0])
            records = self._restore_checkpoint(pathlib.Path(out), stepper, steps)
        writer = RunWriter(self, out, stepper, append=resume, pressure_at=pressure_at) if out is not None else None
        observers = dict(observers or {})
        message = ""
        refined, transferred = 0, False        # polygons split after the last converged step; state transferred
        undo = None                            # mesh and state before the last adaptive refinement
        with StopRequest() as stop:
            try:
                while True:
                    constrained, final, dofs_of = self._constraints()
                    self.disc.set_constraints(constrained)
                    if not transferred:
                        self._check_initial_state()      # a transferred state is checked by re-balancing
                    newton = NewtonSolver(self.disc, petsc_options, self.f_ext)
                    path = [self._rebalance(newton, final, petsc_options)] if rebalance else []
                    path = itertools.chain(path, stepper.attempts(functools.partial(self._solve_to, newton, final),
                                                                  self.x))
                    for attempt in path:
                        rec = self._record(attempt, sum(r["converged"] for r in records) + attempt.converged,
                                           dofs_of, observers, newton)
                        records.append(asdict(rec))
                        if attempt.converged:
                            advanced, self.load = attempt.load > self.load, attempt.load
                            self._progress(rec)
                            if writer is not None:
                                writer.step(records, time.perf_counter() - t_start + self._earlier_wall_time,
                                            self._attempt_contact[1])
                            if adapt is not None and advanced and not stop.requested(self.comm):
                                refined, undo = self._adapt(adapt)
                                records[-1]["refined_polygons"] = refined
                        elif self.verbose and self.comm.rank == 0:
                            then = "cutting the increment" if attempt.load > self.load else "re-balancing failed"
                            print(f"  step to load {attempt.load:.5g} failed ({rec.failure}; "
                                  f"{rec.newton_iterations} its); {then}", flush=True)
                        if not attempt.converged and attempt.load == self.load:
                            if undo is None:
                                raise SolveFailed(f"re-balancing at load factor {self.load:.6g} failed "
                                                  f"({rec.failure})")
                            self._undo_adaptation(*undo, records)
                            undo, adapt, refined = None, None, -1
                        if refined or stop.requested(self.comm):
                            break
                    if not refined:
                        break
                    if writer is not None:
                        writer.new_mesh()
                    rebalance, transferred, refined = refined > 0, refined > 0, 0
            except SolveFailed as err:
                n_done = sum(r["converged"] for r in records)
                message = f"step {n_done + 1}: {err}"
                err.args = (message,)
                if raise_on_failure:
                    self._finish(writer, records, t_start, until, message)
                    raise
        signalled = stop.requested(self.comm)
        if signalled:
            message = f"{STOPPED_BY_SIGNAL} {signalled} at load factor {self.load:.6g}"
        return self._finish(writer, records, t_start, until, message)

    # ------------------------------------------------------------------ continuation and adaptivity
    def _rebalance(self, newton: NewtonSolver, final: np.ndarray,
                   petsc_options: typing.Mapping[str, typing.Any] | None) -> Attempt:
        """Equilibrium at the load factor already reached, :attr:`load`, from the current state
        (a transferred one after :meth:`refine`): Newton's method at that load; if it fails (a
        state far from equilibrium can fold the soft medium), the residual r_0 of the starting
        state is relaxed instead, R(u) = (1 - s) r_0 for s ramped from 0 to 1 with cut-back
        (prescribed values unchanged throughout), and the last solve at s = 1 is Newton's at the
        load (docs/refinement-local.md). Without a body force only; with one the first solve decides."""
        t0 = time.perf_counter()
        start = self.x.copy()
        result = self._solve_to(newton, final, self.load)
        if not result.converged and self.f_ext is None:
            start.copy(self.x)
            self.x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
            result = self._relax(newton, final, petsc_options, result.iterations)
        if not result.converged:
            start.copy(self.x)
            self.x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        start.destroy()
        return Attempt(self.load, result, time.perf_counter() - t0)

    def _relax(self, newton: NewtonSolver, final: np.ndarray, petsc_options: typing.Mapping[str, typing.Any] | None,
               iterations: int) -> NewtonResult:
        """The homotopy of :meth:`_rebalance` from the current state; ``iterations`` done before
        are added to the result's."""
        r0 = self.disc.create_vector()
        self.disc.residual(self.x, r0)
        homotopy = NewtonSolver(self.disc, petsc_options, r0)
        ramp = LoadStepper(RELAX_STEPS, min_increment=1.0 / RELAX_STEPS / 4)
        g = self.load * final
        try:
            for attempt in ramp.attempts(lambda s: homotopy.solve(self.x, g, 1.0 - s), self.x):
                iterations += attempt.result.iterations
            result = self._solve_to(newton, final, self.load)
        except SolveFailed as err:
            result = dataclasses.replace(attempt.result, iterations=0, failure=f"relaxing the residual: {err}")
        finally:
            r0.destroy()
        result.iterations += iterations
        return result

    def _undo_adaptation(self, mesh: PolygonMesh, state: np.ndarray, records: list[dict]) -> None:
        """Back to ``mesh`` and ``state`` (n_nodes, 2) from before the adaptive refinement whose
        re-balancing failed, adaptivity off for the rest of the path: the last converged step is
        kept as it was, nothing is lost (collective)."""
        records[-1]["failure"] += "; refinement undone, adaptivity off for the rest of the path"
        if self.verbose and self.comm.rank == 0:
            print(f"  re-balancing the refined mesh at load {self.load:.5g} failed: back to the mesh before "
                  "(adaptivity off for the rest of the path)", flush=True)
        self._rebuild(mesh, state)
        last = next(r for r in reversed(records) if r["converged"])
        last["refined_polygons"] = 0

    def _adapt(self, adapt: Adaptivity) -> tuple[int, tuple[PolygonMesh, np.ndarray] | None]:
        """Refine where ``adapt`` says at the current (converged) state: the number of polygons
        split (0: nothing to refine, or a limit reached) and the mesh and state before (collective)."""
        refinement = adapt.refinement(self)
        if refinement is None:
            return 0, None
        before = (self.mesh, self._gathered_state())
        self._move_to(refinement)
        adapt.refined(refinement)
        if self.verbose and self.comm.rank == 0:
            print(f"  adapt at load {self.load:.5g}: {refinement.describe()}, {self.disc.num_dofs_global} unknowns",
                  flush=True)
        return int(refinement.selected.sum()), before

    def _solve_to(self, newton: NewtonSolver, final: np.ndarray, load: float) -> NewtonResult:
        """Newton's solve for the load factor ``load`` (constrained values ``load * final``); a
        converged state whose solids overlap is rejected. Keeps the converged state's contact
        quantities for :meth:`_record`."""
        result = newton.solve(self.x, load * final, load)
        if result.converged:
            self._attempt_contact = self._contact()
            gap = self._attempt_contact[0]
            if gap.overlapping:
                result.converged = False
                result.failure = (f"solids overlap: {gap.describe()} (more than {self.boundary.tolerance:g} "
                                  "times the local edge length)")
        return result

    def _record(self, attempt: Attempt, step: int, dofs_of: dict[str, np.ndarray],
                observers: typing.Mapping[str, Observer], newton: NewtonSolver) -> StepRecord:
        """The record of an attempt; a converged one with its gap, contact pressure, reactions
        (from the force ``newton`` has at the converged state), largest displacement and the
        observers' values (collective)."""
        res = attempt.result
        rec = StepRecord(step=step, load=attempt.load, newton_iterations=res.iterations,
                         residual_norms=res.residual_norms, converged=res.converged, min_J=res.min_J,
                         kinked_elements=res.kinked, negative_pivots=res.negative_pivots, failure=res.failure,
                         wall_time_s=attempt.wall_time_s)
        if attempt.converged:
            gap, pressure = self._attempt_contact
            rec.gap = gap.as_dict()
            rec.contact = [pair.as_dict() for pair in pressure.pairs]
            newton.force_at(self.x)
            rec.reaction = self.reactions(dofs_of, attempt.load, newton.force)
            rec.max_displacement = self.max_displacement()
            rec.extra = _observe(self, observers)
            rec.dofs = int(self.disc.num_dofs_global)
        return rec

    def _check_initial_state(self) -> None:
        """Reject a starting state with J <= 0 (inverted elements), folded elements, a non-finite
        energy or overlapping solids."""
        b = self.disc.create_vector()
        self.x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        info = self.disc.residual(self.x, b)
        b.destroy()
        if not info.admissible:
            raise ValueError(f"inverted or degenerate element in the initial configuration: J = {info.min_J:.3e} "
                             f"in polygon {info.min_J_polygon} of region {info.min_J_tag}; {info.folded} folded "
                             f"element(s), e.g. {info.folded_polygon}")
        gap = self.contact_gap()
        if gap.overlapping:
            raise ValueError(f"the solids overlap in the initial configuration: {gap.describe()}")

    def _restore_checkpoint(self, out: pathlib.Path, stepper: LoadStepper, steps: int) -> list[dict]:
        """Load state, stepper state and converged records of the stopped run in ``out``."""
        saved = read_checkpoint(out, steps, self.summary([], 0.0, False))
        self.disc.set_state(saved.keys, saved.values, self.x)
        self.x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        stepper.restore(saved.stepper)
        self.load = stepper.load
        self._earlier_wall_time = saved.wall_time_s
        records = [r for r in saved.records if r["load"] <= stepper.load + 1e-14]
        if self.comm.rank == 0 and self.verbose:
            print(f"resuming from load factor {stepper.load:.6g} after {len(records)} converged steps", flush=True)
        return records

    def _finish(self, writer: RunWriter | None, records: list[dict], t_start: float, until: float,
                message: str) -> Result:
        """Write the final outputs and return the result of a run that aimed at the load factor ``until``."""
        wall = time.perf_counter() - t_start + self._earlier_wall_time
        converged = self.load >= until - 1e-12 and not message
        summary = self.summary(records, wall, converged, message)
        if writer is not None:
            writer.finish(summary)
        if message and self.comm.rank == 0:
            print(f"run stopped: {message}", flush=True)
        return Result(converged, self.load, [r for r in records if r["converged"]], records, wall, summary, message)

    def summary(self, records: list[dict], wall: float, converged: bool, message: str = "") -> dict:
        """The content of summary.json."""
        return {
            "method": self.method,
            "dofs": int(self.disc.num_dofs_global),
            **self.disc.describe(),
            "ranks": int(self.comm.size),
            "wall_time_s": wall,
            "converged": bool(converged),
            "message": message,
            "parameters": {
                **self.parameters,
                "materials": {str(tag): {"energy": e.name, **e.params} for tag, e in self.materials.items()},
                "boundary_conditions": {bc.name: {"values": {c: getattr(v, "__name__", "function") if callable(v) else v
                                                             for c, v in bc.values.items()}, "tags": bc.tags}
                                        for bc in self.bcs},
            },
            "steps": records,
        }

    def _progress(self, rec: StepRecord) -> None:
        """The progress line of a converged step (:func:`~dolfinx_sfvem.run_output.progress_line`)."""
        if self.verbose and self.comm.rank == 0:
            print(progress_line(rec), flush=True)
