"""The contract every discretization (SFVEM, Lagrange FEM) fulfils, and what both share.

:class:`Discretization` lists every member that :class:`~dolfinx_sfvem.ContactProblem`, the
Newton solver and the controls, the run output, the contact checks, the loads and the refinement
indicators use (docs/architecture.md; what the loads on 3D faces need besides is
:class:`~dolfinx_sfvem.discretizations.load_host.LoadHost`). It also holds
what is the same for both methods: the unknowns' layout, the key-based state transfer of
checkpoints, the error norms and the Dirichlet constraints (:class:`Constraints`).

Layout of the unknowns (both methods): PETSc vectors with block size d (:attr:`Discretization.gdim`,
2 or 3), local index ``d * node + component``, nodes numbered owned first, then ghosts. A node's *key* is a
partition-independent integer (the same node has the same key on any number of ranks), so a
state saved on one partition can be read on another.
"""
from __future__ import annotations

import abc
import typing
from dataclasses import dataclass

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from dolfinx_sfvem.physics.energy import QUADRATURES, Energy
from dolfinx_sfvem.mesh.cell_mesh import CellMesh, CellOutlines
from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh

Marker = typing.Callable[[np.ndarray], np.ndarray]


@dataclass
class AssemblyInfo:
    """Diagnostics of one residual evaluation (global over ranks).

    Attributes
    ----------
    energy : float
        Total stored energy ∫ Ψ dΩ (Eq. 46).
    min_J : float
        Smallest J = det F over all quadrature points.
    min_J_cell : int
        Global index of the cell (polygon, polyhedron or FEM cell) where it occurs.
    min_J_tag : int
        Its region tag.
    folded : int
        Number of folded elements (:mod:`~dolfinx_sfvem.discretizations.injectivity`): deformed boundary
        through vertices and edge midpoints turned over or crossing itself.
    folded_cell : int
        Global index of one of them, a cell as in ``min_J_cell`` (-1 if none).
    kinked : int
        Number of kinked solid elements (boundary crossing itself, orientation kept): reported,
        not rejected.
    """
    energy: float
    min_J: float
    min_J_cell: int
    min_J_tag: int
    folded: int = 0
    folded_cell: int = -1
    kinked: int = 0

    @property
    def admissible(self) -> bool:
        """J > 0 at every quadrature point, no folded element and a finite energy."""
        return self.min_J > 0.0 and self.folded == 0 and bool(np.isfinite(self.energy))


#: why the SFVEM refuses :attr:`~dolfinx_sfvem.physics.energy.Energy.quadrature` "lobatto" and "reduced" (the
#: words after "is not available" in :func:`check_materials`' message)
SFVEM_NO_FEM_RULES = ("with the SFVEM (method='vem'), which integrates its projections with its own polygon and "
                    "polyhedron rules; the Gauss-Lobatto rule at the nodes is an option of method='fem' on Q2 cells, "
                    "the reduced rule one of method='fem' on P2 triangles and tetrahedra")


def check_materials(tags: np.ndarray, materials: typing.Mapping[int, Energy],
                    quadratures: typing.Collection[str] = QUADRATURES, unavailable: str = "") -> None:
    """Every region tag of the mesh has an energy, every energy's tag exists, and every energy's
    :attr:`~dolfinx_sfvem.physics.energy.Energy.quadrature` is one of ``quadratures``, those the
    discretization has (ValueError otherwise; ``unavailable`` says why the others are missing)."""
    present = set(np.unique(tags).tolist())
    missing = sorted(present - set(materials))
    if missing:
        raise ValueError(f"no material given for region tag(s) {missing}; mesh tags are {sorted(present)}")
    unknown = sorted(set(materials) - present)
    if unknown:
        raise ValueError(f"material given for region tag(s) {unknown} that the mesh does not have; "
                         f"mesh tags are {sorted(present)}")
    for tag, energy in materials.items():
        if not isinstance(energy, Energy):
            raise ValueError(f"material of region {tag} must be an Energy, got {type(energy).__name__}")
        if energy.quadrature not in quadratures:
            raise ValueError(f"{energy.name} of region {tag}: quadrature={energy.quadrature!r} is not available "
                             f"{unavailable}; available: {list(quadratures)}")


class KeyedState(typing.NamedTuple):
    """A state by node key, on every rank: what a refinement carries to the refined mesh and
    :meth:`Discretization.set_state` takes.

    Attributes
    ----------
    keys : (k,) int64
        Node keys (module docstring), sorted.
    values : (k, d) float64
        The displacement at each.
    """
    keys: np.ndarray
    values: np.ndarray


def values_by_key(keys: np.ndarray, values: np.ndarray, wanted: np.ndarray) -> np.ndarray:
    """Rows of ``values`` (k, ...) whose ``keys`` (k,) are ``wanted`` (n,): a saved state on local nodes.

    Raises
    ------
    ValueError
        If a wanted key is missing (the state belongs to another mesh).
    """
    order = np.argsort(keys)
    pos = np.searchsorted(keys, wanted, sorter=order)
    found = order[np.minimum(pos, keys.size - 1)]
    if keys.size == 0 or not np.array_equal(keys[found], wanted):
        raise ValueError("the saved state does not belong to this mesh (node keys differ)")
    return values[found]


@dataclass
class EnergyTerm:
    """An energy ∫ ψ dΩ over one region added to the region's own (Eq. 46), e.g. the work of a
    cavity pressure (:class:`~dolfinx_sfvem.physics.energy.VolumeWork`).

    Attributes
    ----------
    tag : int
        The region.
    energy : Energy
        ψ; its parameter values are ``params``, not ``energy.params``.
    params : dict[str, float]
        The parameter values the residual, tangent and energy use (changed between solves, e.g.
        p = λ p_0 by the load that made the term).
    """
    tag: int
    energy: Energy
    params: dict[str, float]


class Constraints:
    """Dirichlet constraints u_c = g_c, imposed by symmetric elimination with lifting.

    Newton's step of a load step moves the constrained unknowns to their new values, δ_c =
    x_c - g_c (the residual of a constrained row), and the free rows carry the consistent
    response K_ff δ_f = F_f - K_fc δ_c (docs/method.md §6). The tangent keeps this symmetric:
    its rows *and columns* of the constrained unknowns become identity rows and columns, and the
    coupling K_fc δ_c moves to the right-hand side of the linear solve (the lifting,
    :meth:`eliminate`),

        [K_ff  0] [δ_f]   [F_f - K_fc δ_c]
        [0     I] [δ_c] = [δ_c           ]

    so that a symmetric factorization (MUMPS LDL^T) can be used and reports the tangent's
    inertia, while the step is the row elimination's. The residual itself is never lifted: its
    norm, the convergence test and the line search see ``[F_f; x_c - g_c]``. The state is never
    overwritten with the new boundary values before a solve. This class is the only place
    that knows how constraints enter the linear system.

    Parameters
    ----------
    dofs : (k,) int
        Constrained unknowns in local (blocked) numbering, owned and ghost, consistent across ranks.
    n_owned, n_local
        Owned and owned + ghost unknowns of this rank.
    """

    def __init__(self, dofs: np.ndarray, n_owned: int, n_local: int):
        dofs = np.asarray(dofs, dtype=np.int64)
        if dofs.size and (dofs.min() < 0 or dofs.max() >= n_local):
            raise ValueError(f"constrained unknowns must lie in [0, {n_local}), got {dofs.min()}..{dofs.max()}")
        self.mask = np.zeros(n_local, dtype=bool)
        self.mask[dofs] = True
        #: owned constrained and owned free unknowns (local indices)
        self.owned = np.flatnonzero(self.mask[:n_owned])
        self.owned_free = np.flatnonzero(~self.mask[:n_owned])

    def set_residual_rows(self, x: PETSc.Vec, b: PETSc.Vec, g: np.ndarray) -> None:
        """b_c = x_c - g_c on the owned constrained rows; ``g`` (len(owned),) the prescribed values."""
        with x.localForm() as xl:
            b.getArray()[self.owned] = xl.array_r[self.owned] - g

    def lift(self, A: PETSc.Mat, b: PETSc.Vec) -> None:
        """b_f -= K_fc b_c with the K_fc of A (not changed): the lifting :meth:`eliminate` does,
        for one more right-hand side of the same tangent (collective)."""
        v = b.duplicate()
        v.set(0.0)
        v.getArray()[self.owned] = b.getArray(readonly=True)[self.owned]
        w = b.duplicate()
        A.mult(v, w)
        b.getArray()[self.owned_free] -= w.getArray(readonly=True)[self.owned_free]
        v.destroy()
        w.destroy()

    def eliminate(self, A: PETSc.Mat, b: PETSc.Vec | None = None) -> None:
        """Constrained rows and columns of the assembled tangent A become identity rows and
        columns (symmetric elimination), and the right-hand side ``b`` gets the lifting.

        Parameters
        ----------
        A
            The tangent, assembled; keeps its nonzero pattern when rows are zeroed
            (``KEEP_NONZERO_PATTERN``) and holds its diagonal in the pattern.
        b
            None, or the residual at the same state with its constrained rows set
            (:meth:`set_residual_rows`): its free rows become F_f - K_fc δ_c with the K_fc of A
            before the elimination, its constrained rows stay δ_c (collective).
        """
        rows = (A.getOwnershipRange()[0] + self.owned).astype(PETSc.IntType)
        if b is None:
            A.zeroRowsColumns(rows, diag=1.0)
            return
        delta = b.copy()
        A.zeroRowsColumns(rows, 1.0, delta, b)
        delta.destroy()


class Discretization(abc.ABC):
    """A discretization of Σ_regions ∫ Ψ_r(F, ∇F) dΩ (Eq. 46) with the layout of the module
    docstring: what :class:`~dolfinx_sfvem.ContactProblem`, the solver and the controls, the run
    output, the contact checks, the loads and the refinement indicators use (module docstring).

    Attributes
    ----------
    method : str
        ``"vem"`` or ``"fem"`` (summary.json).
    comm : MPI.Comm
    materials : dict[int, Energy]
        Region tag -> the region's energy, by increasing tag.
    gdim : int
        The dimension d (2 or 3): d unknowns per node.
    x_nodes : (n_local_nodes, d)
        Reference coordinates of the local nodes.
    node_key : (n_local_nodes,) int64
        Partition-independent key of every local node (module docstring).
    node_point : (n_local_nodes,) int64
        The :attr:`output_mesh` point of every vertex node, -1 for the others.
    global_nodes : (n_local_nodes,) int64
        Global number of every local node (its unknowns are d n + component).
    element_loops : tuple of (n_el + 1,), (offsets[-1],), (n_el,) int64 arrays, or None in 3D
        ``(offsets, nodes, element)``: the boundary of every element this rank owns, element
        e's local nodes ``v_0, m_0, v_1, m_1, ...`` (vertices and edge midpoints,
        counter-clockwise) at ``nodes[offsets[e]:offsets[e + 1]]`` and its polygon (FEM: cell)
        in :attr:`output_mesh`.
    face_centre_keys : callable (a (n,), c (n,)) -> (n,) int64, or None
        Node keys of the nodes at the centres of the quadrilateral faces with the diagonal between
        the :attr:`output_mesh` points a and c, a the face's smallest point (the Q2 face centres,
        which the contact checks gather with the faces' corners); None where there are none.
    """

    method: str
    comm: MPI.Comm
    materials: dict[int, Energy]
    gdim: int
    x_nodes: np.ndarray
    node_key: np.ndarray
    node_point: np.ndarray
    global_nodes: np.ndarray
    element_loops: tuple[np.ndarray, np.ndarray, np.ndarray] | None
    face_centre_keys: typing.Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None

    # ------------------------------------------------------------------ sizes
    @property
    @abc.abstractmethod
    def n_owned_nodes(self) -> int:
        """Nodes owned by this rank."""

    @property
    @abc.abstractmethod
    def n_local_nodes(self) -> int:
        """Owned and ghost nodes of this rank."""

    @property
    @abc.abstractmethod
    def num_dofs_global(self) -> int:
        """Unknowns over all ranks (d per node)."""

    @property
    def n_owned_dofs(self) -> int:
        """Unknowns owned by this rank."""
        return self.gdim * self.n_owned_nodes

    @property
    def n_local_dofs(self) -> int:
        """Owned and ghost unknowns of this rank."""
        return self.gdim * self.n_local_nodes

    # ------------------------------------------------------------------ PETSc objects
    @abc.abstractmethod
    def create_vector(self) -> PETSc.Vec:
        """A ghosted vector of the unknowns (block size d)."""

    @abc.abstractmethod
    def create_matrix(self) -> PETSc.Mat:
        """An AIJ matrix with the tangent's pattern (diagonal included) that keeps its pattern
        when rows are zeroed."""

    def coarse_interpolation(self) -> PETSc.Mat:
        """The interpolation of a degree-1 space on the mesh's vertices into the unknowns: an
        assembled AIJ matrix (unknowns x d vertex nodes, block size d) that reproduces every
        linear displacement exactly; the coarse level of the ``"iterative"`` linear solver
        (:func:`~dolfinx_sfvem.path_following.linear_solvers.configure_ksp`)."""
        raise NotImplementedError(f"{type(self).__name__} has no degree-1 coarse space: use linear_solver='direct'")

    # ------------------------------------------------------------------ assembly
    @abc.abstractmethod
    def residual(self, x: PETSc.Vec, b: PETSc.Vec) -> AssemblyInfo:
        """Internal force b = ∂W/∂u at x (ghosts of x current; b's ghost contributions accumulated
        on their owners), constraints not applied, with the state's diagnostics (collective)."""

    @abc.abstractmethod
    def medium_force(self, x: PETSc.Vec, b: PETSc.Vec, regularization: bool = True) -> None:
        """b = ∂W_medium/∂u, the internal force of the third-medium regions alone, at x (ghost
        contributions accumulated on their owners; collective). With ``regularization=False``, the
        force of their material response alone (:meth:`Energy.unregularized_params`): the force
        whose normal traction on the solids is the contact pressure (docs/contact.md)."""

    @abc.abstractmethod
    def assemble_tangent(self, x: PETSc.Vec, A: PETSc.Mat) -> None:
        """Tangent ∂²W/∂u² at x into A, assembled, constraints not applied (collective)."""

    def jacobian(self, x: PETSc.Vec, A: PETSc.Mat) -> None:
        """Tangent at x into A with the rows of the constrained unknowns (:meth:`set_constraints`)
        eliminated by :class:`Constraints` (collective)."""
        self.assemble_tangent(x, A)
        self.constraints.eliminate(A)

    @abc.abstractmethod
    def body_force_vector(self, f: typing.Callable[[np.ndarray], np.ndarray]) -> PETSc.Vec:
        """External force vector of a body force ``f(x)`` (d, n) -> (d, n) per unit reference area
        (volume in 3D)."""

    # ------------------------------------------------------------------ energy terms
    @abc.abstractmethod
    def add_energy_term(self, tag: int, energy: Energy) -> EnergyTerm:
        """Add ∫ ψ dΩ over region ``tag`` to the energy: :meth:`residual`, :meth:`assemble_tangent`
        and :attr:`AssemblyInfo.energy` include it with the term's current ``params`` (initially
        ``energy.params``; collective)."""

    @abc.abstractmethod
    def term_force(self, term: EnergyTerm, x: PETSc.Vec, b: PETSc.Vec,
                   params: typing.Mapping[str, float] | None = None) -> float:
        """b = ∂/∂u ∫ ψ dΩ of the term alone at x with ``params`` (default: the term's), ghost
        contributions accumulated; returns ∫ ψ dΩ (collective)."""

    # ------------------------------------------------------------------ constraints
    def set_constraints(self, dofs: np.ndarray) -> None:
        """Register the constrained unknowns (local blocked numbering, owned and ghost, consistent
        across ranks) for :meth:`jacobian` and the solver's residual rows; replaces earlier ones."""
        self._constraints = Constraints(dofs, self.n_owned_dofs, self.n_local_dofs)

    @property
    def constraints(self) -> Constraints:
        """The registered constraints (none before :meth:`set_constraints`)."""
        if getattr(self, "_constraints", None) is None:
            self.set_constraints(np.empty(0, dtype=np.int64))
        return self._constraints

    # ------------------------------------------------------------------ locating unknowns
    @abc.abstractmethod
    def locate_nodes(self, marker: Marker | None = None, tags: typing.Iterable[int] | None = None) -> np.ndarray:
        """Local nodes (owned and ghost) selected by ``marker`` (a function of coordinates (d, n)
        returning a bool array (n,)) and/or region ``tags``, consistent across ranks."""

    def locate_dofs(self, marker: Marker | None = None, tags: typing.Iterable[int] | None = None,
                    component: int | None = None) -> np.ndarray:
        """Local blocked unknowns (sorted, int64) at the nodes of :meth:`locate_nodes`;
        ``component`` 0, ..., d - 1, or None for all."""
        nodes = self.locate_nodes(marker, tags)
        comps = range(self.gdim) if component is None else (component,)
        return np.sort(np.concatenate([self.gdim * nodes + c for c in comps])).astype(np.int64)

    def dof_coordinates(self, dofs: np.ndarray) -> np.ndarray:
        """Reference coordinates (k, d) of the nodes of the local unknowns ``dofs`` (k,)."""
        return self.x_nodes[dofs // self.gdim]

    @abc.abstractmethod
    def dof_values(self, value: typing.Callable[[np.ndarray], np.ndarray], dofs: np.ndarray) -> np.ndarray:
        """Values (k,) of the unknowns ``dofs`` (k,) of one component for the function
        ``value(x)`` (d, n) -> (n,)."""

    # ------------------------------------------------------------------ state (checkpoints, gathers)
    def get_state(self, x: PETSc.Vec) -> tuple[np.ndarray, np.ndarray]:
        """Owned nodal values with partition-independent keys: (keys (k,), values (k, d))."""
        n_owned = self.n_owned_nodes
        with x.localForm() as xl:
            values = xl.array_r.reshape(-1, self.gdim)[:n_owned].copy()
        return self.node_key[:n_owned].copy(), values

    def set_state(self, keys: np.ndarray, values: np.ndarray, x: PETSc.Vec) -> None:
        """Inverse of :meth:`get_state` for the full set of keys (any partition), ghosts included."""
        with x.localForm() as xl:
            xl.array[:] = values_by_key(keys, values, self.node_key).ravel()

    def output_state(self, v: PETSc.Vec) -> tuple[np.ndarray, np.ndarray]:
        """Owned values of the :attr:`output_mesh`'s nodes (its points, keyed by point index, and the
        edge midpoints of :meth:`midpoint_keys`): (keys (k,), values (k, d)), what the contact checks
        read. The state itself (:meth:`get_state`) where those nodes are the unknowns."""
        return self.get_state(v)

    def output_forces(self, f: PETSc.Vec) -> tuple[np.ndarray, np.ndarray]:
        """Nodal forces ``f`` (ghost contributions accumulated) on the nodes of :meth:`output_state`,
        for the contact pressure's recovery; the forces themselves where those nodes are the unknowns."""
        return self.get_state(f)

    @property
    def pressure_keys(self) -> np.ndarray | None:
        """Keys of the :meth:`output_state` nodes at which the contact pressure is recovered from
        the forces on their faces, the others interpolated (None: every node; docs/contact.md)."""
        return None

    @abc.abstractmethod
    def midpoint_keys(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Node keys of the midpoints of the edges between the :attr:`output_mesh` points a and b (n,)."""

    # ------------------------------------------------------------------ evaluation
    @abc.abstractmethod
    def displacement_at(self, x: PETSc.Vec, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Displacement at reference ``points`` (n, d) inside this rank's elements: (values (n, d),
        found (n,) bool); points elsewhere get zeros and False."""

    @abc.abstractmethod
    def quadrature_fields(self, x: PETSc.Vec) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The discrete displacement and its gradient at this rank's quadrature points of the error
        norms: (points (n, d), weights (n,) [area or volume], u_h (n, d), ∇u_h (n, d, d))."""

    def quadrature_cells(self) -> np.ndarray:
        """The :attr:`output_mesh` cell (n,) int64 of every point of :meth:`quadrature_fields`: what
        the refinement indicators read per cell (:mod:`~dolfinx_sfvem.path_following.adaptivity`)."""
        raise NotImplementedError(f"{type(self).__name__} does not name the cells of its quadrature points: "
                                  "adaptive refinement needs method='vem' on a 2D mesh or method='fem'")

    def error_norms(self, x: PETSc.Vec, u_exact: typing.Callable[[np.ndarray], np.ndarray],
                    grad_exact: typing.Callable[[np.ndarray], np.ndarray]) -> tuple[float, float]:
        """``‖u − u_h‖_L2`` and ``|u − u_h|_H1 = ‖∇u − ∇u_h‖_L2`` over the mesh (collective), with u_h and
        ∇u_h of :meth:`quadrature_fields`.

        ``u_exact(x)`` returns (d, n) and ``grad_exact(x)`` returns (d, d, n) for x of shape (d, n).
        """
        X, w, u_h, grad_h = self.quadrature_fields(x)
        e0 = np.sum(w * np.sum((np.asarray(u_exact(X.T)).T - u_h) ** 2, axis=1))
        e1 = np.sum(w * np.sum((np.moveaxis(np.asarray(grad_exact(X.T)), -1, 0) - grad_h) ** 2, axis=(1, 2)))
        return (float(np.sqrt(self.comm.allreduce(e0, op=MPI.SUM))),
                float(np.sqrt(self.comm.allreduce(e1, op=MPI.SUM))))

    # ------------------------------------------------------------------ output
    @property
    @abc.abstractmethod
    def output_mesh(self) -> PolygonMesh | CellMesh:
        """The mesh (identical on all ranks) that pictures and contact checks use: a polygon mesh in
        2D, a :class:`~dolfinx_sfvem.mesh.cell_mesh.CellMesh` in 3D."""

    @property
    def cell_outlines(self) -> CellOutlines | None:
        """The cells of the discretization as the pictures draw them where :attr:`output_mesh`
        subdivides them (the SFVEM's polyhedra over their fan tetrahedra): their edges and the cell
        of every output cell (:class:`~dolfinx_sfvem.mesh.cell_mesh.CellOutlines`); None where the
        output mesh's cells are the discretization's (their own edges drawn)."""
        return None

    @abc.abstractmethod
    def output_point_displacements(self, x: PETSc.Vec) -> tuple[np.ndarray, np.ndarray]:
        """(point indices (k,) of :attr:`output_mesh`, displacements (k, d)) known on this rank."""

    @abc.abstractmethod
    def output_function(self, x: PETSc.Vec, u=None):
        """The displacement as a DOLFINx Function (P2; written into ``u`` when given)."""

    @property
    @abc.abstractmethod
    def dolfinx_mesh(self):
        """The DOLFINx mesh of :meth:`output_function` (XDMF output)."""

    @abc.abstractmethod
    def cell_tags(self):
        """Region tag of every local cell of :attr:`dolfinx_mesh` (``dolfinx.mesh.MeshTags``)."""

    @abc.abstractmethod
    def cell_stress(self, x: PETSc.Vec) -> tuple[np.ndarray, np.ndarray]:
        """F and the first Piola stress P = ∂Ψ/∂F (Eq. 30) of the region's energy, (n, d, d) each,
        at the centre of every owned cell of :attr:`dolfinx_mesh` (ghosts of x current)."""

    def stress(self, x: PETSc.Vec, kind: str = "cauchy"):
        """The stress as a ``dolfinx.fem.Function``, constant in every cell of :attr:`dolfinx_mesh`
        (DG0, shape (d, d)): ``"cauchy"`` σ = P Fᵀ / J (in 2D the in-plane components) or ``"piola"``
        P (the first Piola-Kirchhoff stress), at the cell centres (:meth:`cell_stress`)."""
        import dolfinx.fem
        from dolfinx_sfvem import _compat
        if kind not in ("cauchy", "piola"):
            raise ValueError(f"stress kind {kind!r}: use 'cauchy' or 'piola'")
        F, P = self.cell_stress(x)
        if kind == "cauchy":
            P = np.einsum("nij,nkj->nik", P, F) / np.linalg.det(F)[:, None, None]
        V = _compat.cell_tensor_space(self.dolfinx_mesh)
        stress = dolfinx.fem.Function(V, name="sigma" if kind == "cauchy" else "P")
        dofs = _compat.cell_dofs(V)[:P.shape[0], 0]
        stress.x.array.reshape(-1, self.gdim ** 2)[dofs] = P.reshape(-1, self.gdim ** 2)
        stress.x.scatter_forward()
        return stress

    @abc.abstractmethod
    def describe(self) -> dict:
        """Mesh facts for summary.json (JSON-serialisable)."""
