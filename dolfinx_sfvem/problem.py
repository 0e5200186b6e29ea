"""A third-medium contact problem: the definition (mesh, region energies, boundary conditions,
loads) and its state (displacement, load factor), with the queries on them.

Example
-------
>>> import numpy as np
>>> import dolfinx_sfvem as sf
>>> box = sf.meshes.cbox(h_solid=0.1)
>>> problem = sf.ContactProblem(box.mesh, {
...     sf.meshes.SOLID: sf.Hyperelastic(K=5 / 3, mu=5 / 14),
...     sf.meshes.MEDIUM: sf.ThirdMedium(mu=5 / 14, gamma=1e-5, alpha_r=1.0)}, verbose=False)
>>> clamped = problem.fix(lambda x: np.isclose(x[0], 0.0))
>>> tip = problem.prescribe(lambda x: np.isclose(x[0], 1.0) & np.isclose(x[1], 0.5), uy=-0.5, name="load")
>>> result = problem.solve(steps=10)
>>> result.converged, result.load
(True, 1.0)
>>> problem.contact_gap().value > 0                    # the beams touch through the medium, apart
True
>>> u = problem.displacement()                         # a dolfinx.fem.Function
"""
from __future__ import annotations

import pathlib
import typing
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from mpi4py import MPI
from petsc4py import PETSc

from dolfinx_sfvem.output import post
from dolfinx_sfvem.path_following.adaptivity import Adaptivity
from dolfinx_sfvem.mesh.cell_mesh import CellMesh, note_flat
from dolfinx_sfvem.mesh.named_boundaries import facet_marker
from dolfinx_sfvem.physics.contact import OVERLAP_TOLERANCE, ContactPressure, Gap
from dolfinx_sfvem.physics.contact_checks import solid_boundary
from dolfinx_sfvem.physics.energy import Energy
from dolfinx_sfvem.physics.equilibrium import Equilibrium
from dolfinx_sfvem.path_following.linear_solvers import linear_solver_options
from dolfinx_sfvem.path_following.load_path import LoadPath
from dolfinx_sfvem.physics.bound_load import BoundLoad
from dolfinx_sfvem.physics.loads import BodyForce, CavityPressure, Load, PointForce, Pressure, Traction
from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh, Refinement
from dolfinx_sfvem.mesh.polyhedron_mesh import PolyhedronMesh
from dolfinx_sfvem.output.run_summary import Observer, Result
from dolfinx_sfvem.path_following.snes import DEFAULT_PREFIX
from dolfinx_sfvem.discretizations.discretization import KeyedState
from dolfinx_sfvem.discretizations.state_transfer import carry_state
from dolfinx_sfvem.mesh.cell_refine import CellRefinement, refine_mesh
from dolfinx_sfvem.path_following.stepping import Control, LoadStepping

Marker = typing.Callable[[np.ndarray], np.ndarray]
Value = typing.Union[float, typing.Callable[[np.ndarray], np.ndarray]]
#: where a load acts: a marker function of the coordinates, region tags / names, or names of the
#: mesh's boundaries (``mesh.boundary_names``)
Where = typing.Union[Marker, int, str, typing.Iterable[typing.Union[int, str]]]
#: the nodes a boundary condition selects: a marker function, or names of the mesh's boundaries
Selection = typing.Union[Marker, str, typing.Iterable[str]]


@dataclass
class BoundaryCondition:
    """Prescribed displacement components on the nodes selected by ``marker`` and/or ``tags``.

    ``values`` maps component (0 = x, 1 = y, 2 = z) to the value reached at load factor 1: a
    number or a function of the coordinates ``x`` (d, n) returning (n,); it is applied as
    ``load_factor * value``. At interior (mean) DOFs a function is averaged over the polygon.
    """
    name: str
    values: dict[int, Value]
    marker: Marker | None = None
    tags: tuple[int, ...] | None = None


class BoundaryValues(typing.NamedTuple):
    """The prescribed displacements of a problem on its current discretization.

    Attributes
    ----------
    dofs : (k,) int64
        Constrained unknowns (local blocked numbering, owned and ghost, sorted).
    final : (k_owned,)
        Their values at load factor 1, for the owned ones (in their order).
    dofs_of : dict name -> (m,) int64
        The unknowns of every boundary condition.
    """
    dofs: np.ndarray
    final: np.ndarray
    dofs_of: dict[str, np.ndarray]


#: the names of the displacement components
AXES = "xyz"


def _component(c: int | str, name: str, gdim: int = 2) -> int:
    """0, 1 (or 2 in 3D) from 0 / 1 / 2 / "x" / "y" / "z"."""
    names = {**{k: k for k in range(gdim)}, **{AXES[k]: k for k in range(gdim)}}
    index = names.get(c) if isinstance(c, (int, str, np.integer)) else None
    if index is None or isinstance(c, bool):
        known = ", ".join(f"{k} or {AXES[k]!r}" for k in range(gdim))
        raise ValueError(f"boundary condition {name!r}: component {c!r}; use {known}")
    return index


def as_mesh(mesh: typing.Any) -> PolygonMesh | CellMesh | PolyhedronMesh:
    """The problem's mesh from what the user gives: a :class:`PolygonMesh`, a 3D :class:`CellMesh`,
    a :class:`PolyhedronMesh` (or an octree mesh, as its polyhedra), a 2D :class:`CellMesh` (turned
    into the polygon mesh of its cells, straight-sided) or a pair ``(dolfinx mesh, cell tags)``
    (gathered into a :class:`CellMesh` on every rank, collective, at its geometry degree)."""
    if hasattr(mesh, "polyhedra") and callable(mesh.polyhedra):       # OctreeMesh
        mesh = mesh.polyhedra()
    if isinstance(mesh, tuple) and len(mesh) == 2:
        mesh = CellMesh.from_dolfinx(*mesh)
    if isinstance(mesh, CellMesh) and mesh.tdim == 2:
        from dolfinx_sfvem._compat import COUNTER_CLOCKWISE
        note_flat(mesh, "the polygons of a 2D CellMesh")
        polygons = PolygonMesh(mesh.points, mesh.cells[:, COUNTER_CLOCKWISE[mesh.cells.shape[1]]], mesh.tags,
                               insert_hanging_nodes=False)
        polygons.region_names.update(mesh.region_names)
        polygons.boundary_names.update(mesh.boundary_names)
        return polygons
    if not isinstance(mesh, (PolygonMesh, CellMesh, PolyhedronMesh)):
        raise ValueError(f"mesh: give a PolygonMesh, a CellMesh, a PolyhedronMesh or a pair (dolfinx mesh, cell tags), not "
                         f"{type(mesh).__name__}")
    return mesh


def _materials_by_tag(mesh: PolygonMesh | CellMesh, materials: typing.Mapping[int | str, Energy]) -> dict[int, Energy]:
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
    """Finite-strain (third medium) contact problem on a polygon mesh (2D) or a mesh of
    tetrahedra or hexahedra (3D): the dimension is the mesh's.

    Parameters
    ----------
    mesh
        Polygon mesh with region tags; or a :class:`~dolfinx_sfvem.mesh.cell_mesh.CellMesh`; or a pair
        ``(dolfinx mesh, cell tags)`` of a DOLFINx mesh of tetrahedra or hexahedra (degree-1 or curved
        degree-2 geometry, e.g. gmsh's second order through ``gmshio``) and its region tags
        (:func:`as_mesh`); or a :class:`~dolfinx_sfvem.mesh.polyhedron_mesh.PolyhedronMesh`
        (octree, Voronoi, extruded polygons; ``method="vem"`` only).
    materials
        Region tag -> energy (:class:`Hyperelastic`, :class:`ThirdMedium`, :class:`UserEnergy`).
    method
        ``"vem"`` (order-2 SFVEM on the polygons; in 3D on the polyhedra, a tetrahedral or hexahedral
        mesh's cells read as polyhedra, :class:`~dolfinx_sfvem.discretizations.vem3d.PolyhedralDiscretization`) or
        ``"fem"`` (P2 Lagrange triangles on the same geometry and regions,
        :class:`~dolfinx_sfvem.discretizations.fem.LagrangeDiscretization`; in 3D P2 on tetrahedra, Q2 on
        hexahedra, the cells of the mesh).
    comm
        MPI communicator.
    overlap_tolerance
        A converged state in which a boundary node of a solid lies deeper inside a solid than
        this fraction of the local boundary edge length is rejected like a failed step
        (:mod:`~dolfinx_sfvem.physics.contact`; the run stops when cutting the increment does not help).
    petsc_options
        PETSc options of this problem's solvers, keys without prefix (e.g. ``{"snes_monitor":
        None, "ksp_type": "gmres"}``); they win over the command line, which wins over the
        defaults (:mod:`~dolfinx_sfvem.path_following.snes`). Never put into PETSc's global database beyond
        the moment a solver reads them.
    petsc_options_prefix
        Options prefix of this problem's solvers: command-line options reach them as
        ``-<prefix>snes_monitor`` (default ``tmc_``), unprefixed ones never do.
    linear_solver
        ``"direct"`` (default: MUMPS LDLᵀ, with the tangent's negative pivots) or ``"iterative"``
        (GMRES + p-multigrid: MUMPS on the degree-1 coarse space, for large 3D problems; no
        negative pivots; :mod:`~dolfinx_sfvem.path_following.linear_solvers`, docs/guide/solving.md);
        ``petsc_options`` and the command line win over it.
    **options
        Passed to the discretization: ``verbose`` for both; ``quadrature_degree`` (the degree of the
        energy's rule) for ``"fem"`` and for ``"vem"`` on a 2D mesh; ``l``, ``l_min`` and ``quadrature``
        (the energy's rule) for ``"vem"``; ``fem_h`` for ``"fem"`` on a 2D mesh (triangle size;
        default None: matched to the SFVEM unknowns of ``mesh``, see
        :func:`~dolfinx_sfvem.mesh.remesh.matched_triangulation`).

    Attributes
    ----------
    mesh : PolygonMesh, CellMesh or PolyhedronMesh
    gdim : int
        The dimension d: 2 or 3.
    disc : Discretization
        The discretization of the current mesh.
    x : PETSc.Vec
        The state: nodal displacements (layout of :mod:`~dolfinx_sfvem.discretizations.discretization`).
    load : float
        Load factor λ of the state (0 in the reference state; set by :meth:`solve`).
    bcs : list of BoundaryCondition
    loads : list of Load
    solved : bool
        Whether a load path has been run from the reference state (:meth:`reset` clears it).
    parameters : dict
        Anything to be kept in summary.json's "parameters" (the demos put their options here).
    """

    def __init__(self, mesh: PolygonMesh | CellMesh | tuple, materials: typing.Mapping[int, Energy],
                 method: str = "vem",
                 comm: MPI.Comm = MPI.COMM_WORLD, *, overlap_tolerance: float = OVERLAP_TOLERANCE,
                 petsc_options: typing.Mapping[str, typing.Any] | None = None,
                 petsc_options_prefix: str = DEFAULT_PREFIX, linear_solver: str = "direct", **options):
        if method not in ("vem", "fem"):
            raise ValueError(f"unknown method {method!r}; use 'vem' or 'fem'")
        if not (isinstance(petsc_options_prefix, str) and petsc_options_prefix and not petsc_options_prefix.startswith("-")):
            raise ValueError(f"petsc_options_prefix must be a non-empty string without a leading '-', "
                             f"got {petsc_options_prefix!r}")
        mesh = as_mesh(mesh)
        self.gdim = mesh.gdim
        if isinstance(mesh, PolyhedronMesh) and method == "fem":
            raise ValueError("method='fem' needs tetrahedra or hexahedra: give a CellMesh (a PolyhedronMesh is for "
                             "method='vem')")
        self.method = method
        self.comm = comm
        self.verbose = options.get("verbose", True)
        self.petsc_options = {k.lstrip("-"): v for k, v in (petsc_options or {}).items()}
        self.petsc_options_prefix = petsc_options_prefix
        linear_solver_options(linear_solver)                                   # checks the name
        self.linear_solver = linear_solver
        self._options = dict(options, overlap_tolerance=overlap_tolerance)   # to rebuild in :meth:`refine`
        self.materials = _materials_by_tag(mesh, materials)
        self.bcs: list[BoundaryCondition] = []
        self.loads: list[Load] = []
        self._build(mesh)
        self.solved = False
        self.load = 0.0
        self.parameters: dict[str, typing.Any] = {}

    def _build(self, mesh: PolygonMesh) -> None:
        """The discretization of ``mesh`` (materials and options of the problem), the solids'
        boundary for the contact checks and a zero state vector."""
        self.mesh = mesh
        options = {k: v for k, v in self._options.items() if k != "overlap_tolerance"}
        if self.method == "vem" and self.gdim == 3:
            from dolfinx_sfvem.discretizations.vem3d import PolyhedralDiscretization
            polyhedra = mesh if isinstance(mesh, PolyhedronMesh) else PolyhedronMesh.from_cell_mesh(mesh)
            self.disc = PolyhedralDiscretization(polyhedra, self.materials, self.comm, **options)
        elif self.method == "vem":
            from dolfinx_sfvem.discretizations.vem import SFVEMDiscretization
            self.disc = SFVEMDiscretization(mesh, self.materials, self.comm, **options)
        elif isinstance(mesh, CellMesh):
            from dolfinx_sfvem.discretizations.fem import LagrangeDiscretization
            unknown = sorted(set(options) - {"verbose", "quadrature_degree", "jump_penalty"})
            if unknown:
                raise ValueError(f"option(s) {', '.join(unknown)} not available on a 3D mesh (its cells are the "
                                 "FEM's cells); give verbose, quadrature_degree and jump_penalty only")
            self.disc = LagrangeDiscretization.from_cell_mesh(mesh, self.materials, self.comm, **options)
        else:
            from dolfinx_sfvem.discretizations.fem import LagrangeDiscretization
            self.disc = LagrangeDiscretization.from_polygon_mesh(mesh, self.materials, self.comm, **options)
        self.boundary = solid_boundary(self.disc.output_mesh,
                                       [tag for tag, energy in self.materials.items() if not energy.is_medium],
                                       self.disc.midpoint_keys, self._options["overlap_tolerance"],
                                       face_centre_keys=self.disc.face_centre_keys,
                                       pressure_keys=self.disc.pressure_keys)
        self.x = self.disc.create_vector()
        self.x.set(0.0)
        self._bound: list[tuple[Load, BoundLoad]] = []     # the loads bound to this discretization

    def reset(self) -> None:
        """Back to the reference state (u = 0, load factor 0), so that :meth:`solve` may run again."""
        self.x.set(0.0)
        self.solved = False
        self.load = 0.0

    # ------------------------------------------------------------------ boundary conditions
    def fix(self, marker: Selection | None = None, tags: typing.Iterable[int] | None = None,
            components: typing.Iterable[int | str] | str | None = None, name: str = "fixed") -> BoundaryCondition:
        """u_i = 0 for the given components (0 or "x", 1 or "y", 2 or "z"; a string such as
        ``"xz"`` names several; None: all) on the selected nodes: those where ``marker(x)`` is
        true, or, for a name or names of the mesh's ``boundary_names`` (the physical curves or
        surfaces of :func:`~dolfinx_sfvem.meshes.read_gmsh`), those on these boundaries; and/or
        those of the regions ``tags``."""
        components = range(self.gdim) if components is None else components
        return self._add(BoundaryCondition(name, {_component(c, name, self.gdim): 0.0 for c in components},
                                           self._selection(marker, name), None if tags is None else tuple(tags)))

    def prescribe(self, marker: Selection | None = None, tags: typing.Iterable[int] | None = None, *,
                  ux: Value | None = None, uy: Value | None = None, uz: Value | None = None,
                  name: str = "load") -> BoundaryCondition:
        """u_x = λ ux, u_y = λ uy and/or u_z = λ uz (3D) on the selected nodes (as in :meth:`fix`),
        λ the load factor.

        ``ux``/``uy``/``uz`` are numbers or functions of the coordinates ``x`` (d, n) returning (n,).
        """
        if uz is not None and self.gdim < 3:
            raise ValueError(f"boundary condition {name!r}: uz on a 2D mesh")
        values = {c: v if callable(v) else float(v) for c, v in ((0, ux), (1, uy), (2, uz)) if v is not None}
        if not values:
            raise ValueError(f"boundary condition {name!r}: give " + ("ux and/or uy" if self.gdim == 2 else
                                                                        "ux, uy and/or uz"))
        if not all(callable(v) or np.isfinite(v) for v in values.values()):
            raise ValueError(f"boundary condition {name!r}: prescribed values must be finite, got {values}")
        return self._add(BoundaryCondition(name, values, self._selection(marker, name),
                                           None if tags is None else tuple(tags)))

    def _add(self, bc: BoundaryCondition) -> BoundaryCondition:
        if bc.marker is None and bc.tags is None:
            raise ValueError(f"boundary condition {bc.name!r}: give a marker function and/or region tags")
        self._check_name(bc.name)
        self.bcs.append(bc)
        return bc

    def _check_name(self, name: str) -> None:
        """Boundary conditions and loads have distinct names (their records are keyed by them)."""
        if not isinstance(name, str) or not name:
            raise ValueError(f"a boundary condition or load needs a non-empty name, got {name!r}")
        if any(b.name == name for b in self.bcs) or any(load.name == name for load in self.loads):
            raise ValueError(f"boundary condition or load name {name!r} used twice")

    def constraints(self) -> BoundaryValues:
        """The prescribed displacements on the current discretization (collective; ValueError
        for a condition that selects nothing or two conditions that disagree on a node)."""
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
        return BoundaryValues(np.flatnonzero(by >= 0), final[owned], dofs_of)

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
                     AXES[dofs[i] % self.gdim], float(final[dofs[i]]), float(values[i]))
        found = [w for w in self.comm.allgather(where) if w is not None]
        if found:
            other, x, comp, a, b = found[0]
            raise ValueError(f"boundary conditions {other!r} and {self.bcs[k].name!r} prescribe different u_{comp} "
                             f"({a:g} and {b:g}) at the node ({', '.join(f'{c:g}' for c in x)}); equal values on shared nodes "
                             "are allowed")

    def set_displacement(self, ux: Value = 0.0, uy: Value = 0.0, uz: Value = 0.0) -> None:
        """Set the current state (e.g. an initial guess or a pre-deformation): ``ux``/``uy``/``uz``
        (3D) are numbers or functions of the coordinates ``x`` (d, n) returning (n,)."""
        all_dofs = np.arange(self.disc.n_local_dofs)
        with self.x.localForm() as xl:
            for comp, value in list(enumerate((ux, uy, uz)))[:self.gdim]:
                dofs = all_dofs[comp::self.gdim]
                xl.array[dofs] = self.disc.dof_values(value, dofs) if callable(value) else float(value)

    # ------------------------------------------------------------------ loads
    def body_force(self, f: typing.Callable[[np.ndarray], np.ndarray], name: str = "body_force") -> BodyForce:
        """Body force per unit reference area, ``f(x)`` (2, n) -> (2, n), scaled by the load factor."""
        return self._add_load(BodyForce(name, f))

    def traction(self, where: Where, t: typing.Sequence[float], name: str = "traction") -> Traction:
        """Dead traction ``t`` = (t_x, t_y) per unit reference length, λ t at load factor λ, on the
        boundary edges of ``where``: a marker function of the coordinates (2, n) -> (n,) bool
        (the edges whose vertices and midpoint it selects), region tags/names (the boundary
        edges of those regions) or names of the mesh's ``boundary_names`` (the edges on those
        boundaries, :func:`~dolfinx_sfvem.meshes.read_gmsh`). Paper Eq. 1, the t̄ term. In 3D ``t`` = (t_x, t_y, t_z) per unit
        reference area on the boundary faces (:mod:`~dolfinx_sfvem.physics.face_loads`)."""
        t = self._finite_vector(t, name, "t")
        return self._add_load(Traction(name, self._where(where, name), t))

    def pressure(self, where: Where, p: float, follower: bool = True, name: str = "pressure") -> Pressure:
        """Pressure λ p on the boundary edges of ``where`` (as in :meth:`traction`), pushing into
        the body for p > 0. ``follower=True``: on the deformed boundary (direction and length
        follow the deformation, with its load stiffness in the tangent); False: a dead load on the
        reference normal. For a pressure inside a closed cavity of the mesh, fill it with third
        medium and use :meth:`cavity_pressure` (docs/guide/loads.md says when to use which)."""
        return self._add_load(Pressure(name, self._where(where, name), self._finite(p, name, "p"), bool(follower)))

    def point_force(self, point: typing.Sequence[float], fx: float = 0.0, fy: float = 0.0, fz: float = 0.0,
                    name: str = "force") -> PointForce:
        """Force λ (fx, fy) (λ (fx, fy, fz) in 3D) at the mesh node at ``point`` (a polygon vertex or
        an edge midpoint of the mesh, in 3D any node; an error names the nearest node otherwise)."""
        point = self._finite_vector(point, name, "point")
        if self.gdim == 2 and fz != 0.0:
            raise ValueError(f"load {name!r}: fz on a 2D mesh")
        f = tuple(self._finite(v, name, what) for v, what in zip((fx, fy, fz), ("fx", "fy", "fz")))[:self.gdim]
        return self._add_load(PointForce(name, point, f))

    def cavity_pressure(self, region: int | str, p: float, name: str = "cavity") -> CavityPressure:
        """Pressure λ p of a gas in a closed cavity that the third-medium region ``region`` (tag
        or name) fills: the energy term -λ p ∫ (J - 1) dΩ over the region (Faltus et al. 2024),
        the exact follower load of the cavity's area with a symmetric tangent. The region must be
        a third medium enclosed by other regions, or by symmetry lines x = const / y = const with
        the normal displacement fixed there (a half or quarter model; checked when solving)."""
        tag = self._region_tags(region, name)
        if len(tag) != 1:
            raise ValueError(f"cavity pressure {name!r}: give one region, got {region!r}")
        return self._add_load(CavityPressure(name, tag[0], self._finite(p, name, "p")))

    def _add_load(self, load: Load) -> Load:
        """Bound at once, so that bad input is named here (collective)."""
        self._check_name(load.name)
        self._bound.append((load, load.bind(self.disc, self.materials)))
        self.loads.append(load)
        return load

    @staticmethod
    def _finite(value: typing.Any, name: str, what: str) -> float:
        try:
            value = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"load {name!r}: {what} must be a number, got {value!r}") from None
        if not np.isfinite(value):
            raise ValueError(f"load {name!r}: {what} must be finite, got {value}")
        return value

    def _finite_vector(self, values: typing.Any, name: str, what: str) -> tuple[float, ...]:
        values = tuple(values) if isinstance(values, (list, tuple, np.ndarray)) else (values,)
        if len(values) != self.gdim:
            shape = "a pair (x, y)" if self.gdim == 2 else "a triple (x, y, z)"
            raise ValueError(f"load {name!r}: {what} must be {shape}, got {values!r}")
        return tuple(self._finite(v, name, what) for v in values)

    def _region_tags(self, regions: int | str | typing.Iterable[int | str], name: str) -> tuple[int, ...]:
        """Region tags from tags or names of :attr:`mesh`'s regions (ValueError naming the unknown)."""
        items = [regions] if isinstance(regions, (int, str, np.integer)) else list(regions)
        tags = []
        for item in items:
            if isinstance(item, str):
                if item not in self.mesh.region_names:
                    raise ValueError(f"load {name!r}: {item!r} is not a region name of the mesh "
                                     f"(its names: {sorted(self.mesh.region_names)})")
                item = self.mesh.region_names[item]
            if int(item) not in set(np.unique(self.mesh.tags).tolist()):
                raise ValueError(f"load {name!r}: the mesh has no region {item!r}")
            tags.append(int(item))
        return tuple(tags)

    def _where(self, where: Where, name: str) -> Marker | tuple[int, ...]:
        """A marker for a marker or names of boundaries, region tags for region tags or names
        (ValueError for a name of neither or of both, or for boundaries mixed with regions)."""
        if callable(where):
            return where
        items = [where] if isinstance(where, (int, str, np.integer)) else list(where)
        boundaries = getattr(self.mesh, "boundary_names", {})
        named = [item for item in items if isinstance(item, str) and item in boundaries]
        both = [item for item in named if item in self.mesh.region_names]
        if both:
            raise ValueError(f"load {name!r}: {both[0]!r} names a region and a boundary of the mesh; give the "
                             "region by its tag or the boundary by a marker")
        unknown = [item for item in items if isinstance(item, str) and item not in boundaries
                   and item not in self.mesh.region_names]
        if unknown:
            raise ValueError(f"load {name!r}: {unknown[0]!r} is neither a region name (the mesh's: "
                             f"{sorted(self.mesh.region_names)}) nor a boundary name (the mesh's: {sorted(boundaries)})")
        if not named:
            return self._region_tags(items, name)
        if len(named) < len(items):
            raise ValueError(f"load {name!r}: give boundaries or regions, not both ({items!r})")
        return self._boundary_marker(named, name)

    def _selection(self, marker: Selection | None, name: str) -> Marker | None:
        """The marker of a boundary condition: ``marker`` itself, or that of the named boundaries."""
        if marker is None or callable(marker):
            return marker
        names = [marker] if isinstance(marker, str) else list(marker)
        if not all(isinstance(item, str) for item in names):
            raise ValueError(f"boundary condition {name!r}: give a marker function or boundary names, not {marker!r}")
        return self._boundary_marker(names, name)

    def _boundary_marker(self, names: list[str], name: str) -> Marker:
        """A marker true on the boundaries ``names`` of the mesh, on a degree-2 mesh their curved
        facets' edge and face nodes included (ValueError naming an unknown one and listing the mesh's)."""
        boundaries = getattr(self.mesh, "boundary_names", {})
        unknown = [item for item in names if item not in boundaries]
        if unknown or not names:
            raise ValueError(f"{name!r}: {unknown[0] if unknown else names!r} is not a named boundary of the mesh "
                             f"(its boundaries: {sorted(boundaries) or 'none; meshes.read_gmsh names them'})")
        facets = np.concatenate([boundaries[item] for item in names])
        curved = self.mesh.facet_nodes(facets) if getattr(self.mesh, "geometry_degree", 1) > 1 else None
        return facet_marker(self.mesh.points, facets, "+".join(names), curved)

    def equilibrium(self) -> Equilibrium:
        """The balance R(u; λ) with the loads bound to the current discretization (collective;
        :mod:`~dolfinx_sfvem.physics.equilibrium`)."""
        bound = dict((id(load), b) for load, b in self._bound)
        for load in self.loads:
            if id(load) not in bound:
                b = load.bind(self.disc, self.materials)
                self._bound.append((load, b))
                bound[id(load)] = b
        return Equilibrium(self.disc, [bound[id(load)] for load in self.loads])

    # ------------------------------------------------------------------ results
    def reactions(self, force: PETSc.Vec | None = None,
                  dofs_of: typing.Mapping[str, np.ndarray] | None = None) -> dict[str, list[float]]:
        """Reaction force [R_x, R_y] ([R_x, R_y, R_z] in 3D) on every boundary condition at the current state and load
        factor: the sum over its unknowns of internal minus external force (collective).

        ``force`` and ``dofs_of`` are for the load path, which has both at hand (the Newton
        solver's force at the converged state, :meth:`constraints`' unknowns); by default they
        are assembled here."""
        dofs_of = self.constraints().dofs_of if dofs_of is None else dofs_of
        b = force
        if b is None:
            equilibrium = self.equilibrium()
            equilibrium.set_load(self.load)
            b = self.disc.create_vector()
            self.x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
            equilibrium.residual(self.x, b)
            equilibrium.destroy()
        n_owned = self.disc.n_owned_dofs
        with b.localForm() as bl:
            r = bl.array_r
            out = {}
            for name, dofs in dofs_of.items():
                own = dofs[dofs < n_owned]
                out[name] = [self.comm.allreduce(float(r[own[own % self.gdim == c]].sum()), op=MPI.SUM)
                             for c in range(self.gdim)]
        if force is None:
            b.destroy()
        return out

    def displacement(self):
        """The displacement as a ``dolfinx.fem.Function`` (a new one at every call): P2 on the
        quadrature sub-triangles of the polygons for the SFVEM (vertex and edge-midpoint values
        are the SFVEM's, the others those of Π^∇_2 u, Eq. 36), the FEM's own P2/Q2 function
        (collective)."""
        self.x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        return self.disc.output_function(self.x)

    def stress(self, kind: str = "cauchy"):
        """The stress of the current state as a ``dolfinx.fem.Function`` on the mesh of
        :meth:`displacement`, constant per cell: ``"cauchy"`` (σ, in-plane components) or
        ``"piola"`` (first Piola-Kirchhoff P = ∂Ψ/∂F, Eq. 30) (collective)."""
        self.x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        return self.disc.stress(self.x, kind)

    def region_tags(self):
        """The region tag of every cell of the mesh of :meth:`displacement`, as
        ``dolfinx.mesh.MeshTags`` (e.g. for ``ufl.Measure("dx", subdomain_data=...)``)."""
        return self.disc.cell_tags()

    def max_displacement(self) -> float:
        """Largest nodal displacement magnitude ``max |u|`` over all ranks (collective)."""
        with self.x.localForm() as xl:
            u = xl.array_r.reshape(-1, self.gdim)[:self.disc.n_owned_nodes]
            local = float(np.sqrt((u ** 2).sum(axis=1)).max(initial=0.0))
        return self.comm.allreduce(local, op=MPI.MAX)

    def contact_gap(self) -> Gap:
        """The smallest signed gap between the deformed solids at the current state, with where
        it occurs (collective; :mod:`~dolfinx_sfvem.physics.contact`)."""
        return self.boundary.gap_of_state(self.comm, *self.disc.output_state(self.x))

    def contact_pressure(self) -> ContactPressure:
        """Normal pressure of the medium on the solids at every boundary node (from the medium's
        material response, its regularization left out; docs/contact.md), and per pair of
        bodies facing each other across the medium the total contact force, the largest pressure,
        the contact zone's length and the smallest gap, at the current state (collective; the
        result on every rank; :mod:`~dolfinx_sfvem.physics.contact`)."""
        return self.contact_state()[1]

    def contact_state(self) -> tuple[Gap, ContactPressure]:
        """:meth:`contact_gap` and :meth:`contact_pressure` from one gather (collective)."""
        f, f_material = self.disc.create_vector(), self.disc.create_vector()
        self.disc.medium_force(self.x, f)
        self.disc.medium_force(self.x, f_material, regularization=False)
        u = self.boundary.gather(self.comm, *self.disc.output_state(self.x))
        forces, material = (self.boundary.gather(self.comm, *self.disc.output_forces(v)) for v in (f, f_material))
        f.destroy()
        f_material.destroy()
        return self.comm.bcast(self.boundary.gap_and_pressure(u, forces, material) if self.comm.rank == 0 else None,
                               root=0)

    def displacement_at(self, points: npt.ArrayLike) -> np.ndarray:
        """Displacement (n, d) at reference ``points`` (n, d) on every rank (collective): the SFVEM's
        Π^∇_2 u of the polygon holding the point (Eq. 36), the FEM's u_h; NaN outside the mesh.
        With :meth:`PolygonMesh.boundary_points` it gives displacements along a boundary, curved
        ones included (their vertices and edge midpoints are the nodes)."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, self.gdim)
        values, found = self.disc.displacement_at(self.x, points)
        count = self.comm.allreduce(found.astype(np.int64), op=MPI.SUM)
        total = self.comm.allreduce(values, op=MPI.SUM)
        return np.where(count[:, None] > 0, total / np.maximum(count, 1)[:, None], np.nan)

    def point_displacements(self) -> np.ndarray | None:
        """Displacement (n_points, d) of every point of ``disc.output_mesh``, on rank 0 (None elsewhere)."""
        indices, values = self.disc.output_point_displacements(self.x)
        return post.gather_to_root(self.comm, indices, values, self.disc.output_mesh.n_points)

    # ------------------------------------------------------------------ local refinement
    @property
    def adaptable(self) -> bool:
        """Whether :meth:`refine` and ``solve(..., adapt=...)`` work here: the SFVEM on polygons, the
        FEM on tetrahedra."""
        if self.method == "vem":
            return self.gdim == 2
        return isinstance(self.mesh, CellMesh) and self.mesh.cell_type == "tetrahedron"

    def refine(self, where: Marker | npt.ArrayLike | None = None, levels: int = 1, *,
               tags: typing.Iterable[int | str] | None = None, max_l: int = 6) -> Refinement | CellRefinement:
        """Refine the mesh locally and carry the current state over, so that a following
        ``solve(..., from_current_state=True)`` continues from it (collective): the SFVEM on a 2D
        polygon mesh (hanging nodes) and the FEM on tetrahedra (P2; DOLFINx's refinement of the
        marked cells, conforming).

        The discretization is rebuilt on the refined mesh (same materials and options), the
        boundary conditions are kept (markers are evaluated again on the new nodes, tags select
        the same regions, named boundaries take the new facets on them) and the state is
        transferred: exactly for quadratic fields on polygons
        (:func:`~dolfinx_sfvem.discretizations.state_transfer.transfer_state`, docs/refinement-local.md),
        by interpolation of the P2 field on tetrahedra, exact for every P2 field
        (:func:`~dolfinx_sfvem.discretizations.state_transfer.transfer_lagrange_state`).

        Parameters
        ----------
        where, levels, tags, max_l
            As :meth:`PolygonMesh.refine` (``where`` marks polygon or cell centroids; ``max_l`` for
            polygons only), :func:`~dolfinx_sfvem.mesh.cell_refine.refine_cells`.

        Returns
        -------
        Refinement or CellRefinement
            The new mesh (also ``self.mesh``) and the parent polygon (cell) of each new one.

        Raises
        ------
        ValueError
            For the FEM on a 2D mesh or on hexahedra, and for the SFVEM in 3D.
        """
        if self.gdim == 3 and self.method == "vem":
            raise ValueError("refine: the 3D SFVEM is not refined in place yet; refine the octree "
                             "(sf.meshes.octree_box(...).refine(where, levels)) and build the problem on it")
        if self.method == "fem" and not isinstance(self.mesh, CellMesh):
            raise ValueError("refine: on a 2D mesh only method='vem' can be refined (with hanging nodes); the 2D "
                             "FEM's triangulation of the polygon mesh is not refined in place: build a finer problem")
        refinement = refine_mesh(self.mesh, where, levels, tags=tags, max_l=max_l)
        self.move_to(refinement)
        return refinement

    def move_to(self, refinement: Refinement | CellRefinement) -> None:
        """Rebuild on ``refinement.mesh`` and carry the state over (collective)."""
        self.rebuild(refinement.mesh, carry_state(refinement, self.gathered_state()))

    def gathered_state(self) -> KeyedState:
        """The state by node key, on every rank (collective)."""
        keys, values = (np.concatenate(part) for part in zip(*self.comm.allgather(self.disc.get_state(self.x))))
        order = np.argsort(keys)
        return KeyedState(keys[order], values[order])

    def rebuild(self, mesh: PolygonMesh | CellMesh, state: KeyedState) -> None:
        """The problem on ``mesh`` at ``state`` (collective)."""
        self.x.destroy()
        self._build(mesh)
        self.disc.set_state(state.keys, state.values, self.x)
        self.x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)

    # ------------------------------------------------------------------ solve
    def solve(self, steps: int | None = None, out: str | pathlib.Path | None = None, *,
              control: Control | None = None,
              petsc_options: typing.Mapping[str, typing.Any] | None = None,
              min_increment: float | None = None,
              observers: typing.Mapping[str, Observer] | None = None,
              raise_on_failure: bool = False, resume: bool = False, from_current_state: bool = False,
              until: float = 1.0, adapt: Adaptivity | None = None,
              pressure_at: typing.Iterable[float] = (), handle_signals: bool | None = None,
              gamma_start: float | None = None) -> Result:
        """Follow the load path from load factor 0 (or the current one) to ``until``.

        Prescribed displacements and loads are ramped together by the load factor λ. The
        control decides how: by default λ is prescribed in ``steps`` increments with Newton's
        method at each (:class:`~dolfinx_sfvem.path_following.stepping.LoadStepping`); with
        ``control=ArcLength(...)`` λ follows from an arc-length constraint, through limit points
        (:class:`~dolfinx_sfvem.path_following.arclength.ArcLength`). The driver is
        :class:`~dolfinx_sfvem.path_following.load_path.LoadPath`.

        Parameters
        ----------
        steps
            Number of nominal load increments over the whole path, load factor 0 to 1 (a path
            continued from load factor λ_0 takes about ``(until - λ_0) * steps`` of them); for the
            default control only.
        out
            Output directory (summary.json, load_path.csv, XDMF, PNG); None writes nothing.
        control
            How the path advances; default ``LoadStepping(steps, min_increment=min_increment)``.
        petsc_options
            PETSc options for this solve, keys without prefix (over the problem's
            ``petsc_options`` and the command line's ``-<prefix>...`` options).
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
            control the result equals that of an uninterrupted run. Not with ``adapt``.
        from_current_state
            Continue the load path from the current state and its load factor :attr:`load`
            (e.g. after :meth:`refine`): the first step re-balances the state at that load, the
            following ones go on to ``until``; the cut-back never goes below the load already
            reached. A problem solved once refuses to solve again unless this is True;
            :meth:`reset` returns to the reference state instead.
        until
            Load factor at which the path stops, in (0, 1]; ``converged`` means it was reached.
        adapt
            Refine the medium during the path where ``adapt.indicator`` says, after converged
            steps (:class:`~dolfinx_sfvem.path_following.adaptivity.Adaptivity`, docs/refinement-local.md; the
            SFVEM on polygons, the FEM on tetrahedra: as :meth:`refine`). Each refinement is followed by a re-balancing step at the same load.
        pressure_at
            Load factors at which ``out`` gets a plot of the contact pressure along the solids'
            boundaries (``contact_pressure_<load>.png``, at the first converged step reaching each);
            the last state's is always written (``contact_pressure.png``).
        handle_signals
            Ctrl-C and SIGTERM stop the path after the current step (a second Ctrl-C interrupts
            at once); None (default): in a script's main thread, not in a Jupyter kernel, where
            Ctrl-C interrupts at once (:mod:`~dolfinx_sfvem.path_following.interrupt`). An interrupted path keeps
            its converged steps: the state is put back to the last one and the outputs written.
        gamma_start
            Continuation in the third medium's gamma (:mod:`~dolfinx_sfvem.path_following.gamma_continuation`):
            every :class:`ThirdMedium` starts the path at this gamma, which falls log-linearly with
            the load factor to the medium's own gamma at ``until``; for a very weak medium that
            otherwise stalls or ends on an unstable state (docs/guide/medium.md). Default: off.
        """
        if self.solved and not (from_current_state or resume):
            raise ValueError("this problem has been solved already; call reset() to start again from the "
                             "reference state, or solve(..., from_current_state=True) to continue the load path "
                             "from the current state")
        if not (0.0 < until <= 1.0):
            raise ValueError(f"until must be a load factor in (0, 1], got {until!r}")
        if adapt is not None and (resume or not self.adaptable):
            raise ValueError("adapt: adaptive refinement needs method='vem' on a 2D mesh or method='fem' on "
                             "tetrahedra, and cannot resume a stopped run")
        if from_current_state and until < self.load - 1e-12:
            raise ValueError(f"until = {until:g} lies below the load factor {self.load:g} already reached")
        if control is None:
            if steps is None:
                raise ValueError("give the number of load steps, or a control (e.g. control=sf.ArcLength(...))")
            control = LoadStepping(steps, min_increment=min_increment)
        elif steps is not None or min_increment is not None:
            raise ValueError("steps and min_increment belong to the default load stepping; with a control "
                             "give them to the control")
        options = {**self.petsc_options, **{k.lstrip("-"): v for k, v in (petsc_options or {}).items()}}
        return LoadPath(self, control, out, petsc_options=options, observers=observers,
                        raise_on_failure=raise_on_failure, resume=resume, from_current_state=from_current_state,
                        until=until, adapt=adapt, pressure_at=pressure_at, handle_signals=handle_signals,
                        gamma_start=gamma_start).run()

    def describe(self) -> dict:
        """The problem's identity for summary.json: ``method``, ``dofs``, ``discretization`` (the
        mesh facts of the discretization) and ``parameters`` (:attr:`parameters`, materials,
        boundary conditions, loads)."""
        return {
            "method": self.method,
            "dofs": int(self.disc.num_dofs_global),
            "discretization": self.disc.describe(),
            "parameters": {
                **self.parameters,
                "materials": {str(tag): {"energy": e.name, **e.params} for tag, e in self.materials.items()},
                "boundary_conditions": {bc.name: {"values": {c: getattr(v, "__name__", "function") if callable(v) else v
                                                             for c, v in bc.values.items()}, "tags": bc.tags}
                                        for bc in self.bcs},
                **({"loads": {load.name: load.describe() for load in self.loads}} if self.loads else {}),
            },
        }
