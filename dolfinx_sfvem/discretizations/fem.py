"""Degree-2 Lagrange FEM on the same UFL energy: the reference the SFVEM is compared with.

P2 on triangles, a triangulation of the polygon mesh's regions by default; or the cells of a
given mesh (``fem_mesh``): P2 on its triangles, Q2 on its quadrilaterals; in 3D the cells of a
:class:`~dolfinx_sfvem.mesh.cell_mesh.CellMesh` (:meth:`LagrangeDiscretization.from_cell_mesh`): P2
on tetrahedra, Q2 on hexahedra. The geometry is of degree 1 (affine simplices, bilinear
quadrilaterals and trilinear hexahedra, which need not be parallelograms/parallelepipeds) or 2
(curved cells: 10-node tetrahedra, 6-node triangles, 27-node hexahedra, 9-node quadrilaterals, e.g.
gmsh's second order). UFL differentiates the inverse Jacobian of a non-affine or curved cell, so G
below is right on it (a quadratic field is in the Q2 space of a degree-1 quadrilateral or hexahedron
and its G is exact; on curved cells the space is isoparametric, so a polynomial is interpolated,
not reproduced). The total energy
(paper Eq. 46 with the FEM interpolation in place of the projections)

    Π(u) = Σ_tag ∫_{Ω_tag} ψ_tag(F, G) dX,   F = I + ∇u,   G = ∇∇u (cell by cell),

is one UFL form with each region's parameters as ``fem.Constant`` s, so a single
FFCx-compiled form serves every parameter value. The residual is ``ufl.derivative`` of
Π and the tangent the derivative of the residual: no derivative is written by hand.
``G_ijk = ∂F_ij/∂X_k = ∂²u_i/∂X_j∂X_k`` is taken cell by cell (constant in a P2 triangle,
linear in each direction in a Q2 parallelogram, rational in a non-affine Q2 cell): the broken
second gradient, without
inter-element jump terms (as the SFVEM's G is polygon-wise).

The class fulfils the contract of :class:`~dolfinx_sfvem.discretizations.discretization.Discretization`, as
:class:`~dolfinx_sfvem.discretizations.vem.SFVEMDiscretization` does: node = blocked P2 dof.

Quadrature: degree 4 by default (6 points per triangle, 3 x 3 Gauss on quadrilaterals). F is
linear and G constant in a P2 triangle, so the small-strain part of every energy and the
linear-elastic tangent are polynomials of degree 2, the regularizations' G:G of degree 0 and the
P2 mass matrix (body forces) of degree 4: degree 4 integrates all of these exactly and leaves two
orders for the non-polynomial factors (ln J, J^(-2/3), exp(-βJ), atan); 3 x 3 Gauss is exact for
the Q2 linear-elastic part on parallelograms (on non-affine cells the integrands are rational and
the rule is not exact). A region whose energy asks for
``quadrature="lobatto"`` (:attr:`~dolfinx_sfvem.physics.energy.Energy.quadrature`) is integrated
with the Gauss-Lobatto rule :data:`LOBATTO_RULE` instead, whose points are the Q2 nodes
(quadrilaterals and hexahedra only): ψ and ln J are then evaluated at the cell's corners, where a
squeezed cell turns over first, and J > 0 there is what the guard asks of that region. A region
whose energy asks for ``quadrature="reduced"`` is integrated at degree :data:`REDUCED_DEGREE` (P2
triangles and tetrahedra only), the lowest rule exact for the linear-elastic stiffness.

The second gradient is cell-wise: a field that kinks along an element edge carries no
regularization energy there, so in strong compression the FEM medium can fold along element
edges where the SFVEM's (projected over whole polygons) does not. Option ``jump_penalty=eta``
adds C0 interior-penalty terms on the medium's interior facets
(:meth:`LagrangeDiscretization._jump_energy`), which stop such folds but change the model (the
regularization then acts across elements); off by default, as the paper's model is the
element-wise regularization. Measurements: docs/fem-reference.md.
"""
from __future__ import annotations

import logging
import typing

import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.fem
import dolfinx.fem.petsc

from dolfinx_sfvem import _compat
from dolfinx_sfvem.discretizations.compile_lock import compiled_form
from dolfinx_sfvem.discretizations.discretization import (
    AssemblyInfo, Discretization, EnergyTerm, Marker, check_materials)
from dolfinx_sfvem.physics.energy import Energy
from dolfinx_sfvem.discretizations.injectivity import folded_elements, gather_count
from dolfinx_sfvem.output.logs import say
from dolfinx_sfvem.discretizations.node_keys import lagrange_midpoint_keys, sfvem_unknowns
from dolfinx_sfvem.mesh.cell_mesh import (
    CELL_TYPES, TOLERANCE, CellMesh, gather_cells, jacobian_determinants, reference_edges, reference_facets,
    reference_vertices, vertices_first)
from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh, edge_key
from dolfinx_sfvem.mesh.remesh import matched_triangulation, triangulate

log = logging.getLogger(__name__)

#: default quadrature degree of the energy, residual and tangent (see the module docstring)
QUADRATURE_DEGREE = 4
#: degree of the rule used by :meth:`LagrangeDiscretization.error_norms`
ERROR_QUADRATURE_DEGREE = 8
#: FFCx's name and the degree of the rule of the energies with ``quadrature="lobatto"``
#: (:attr:`~dolfinx_sfvem.physics.energy.Energy.quadrature`): Gauss-Lobatto-Legendre with 3 points per
#: direction, the Q2 nodes, exact for degree 3 per direction
LOBATTO_RULE = ("GLL", 3)
#: degree of the Gauss rule of the energies with ``quadrature="reduced"`` on P2 simplices: the
#: linear-elastic stiffness (gradients of degree 1, their products of degree 2) exactly, 3 points
#: per triangle, 4 per tetrahedron
REDUCED_DEGREE = 2


class ElementRules(typing.NamedTuple):
    """The values of :attr:`~dolfinx_sfvem.physics.energy.Energy.quadrature` an element has.

    Attributes
    ----------
    element : str
        "P2" or "Q2", for messages.
    rules : dict
        ``quadrature`` -> FFCx's rule name and degree; None: basix's default rule of
        :attr:`LagrangeDiscretization.quadrature_degree`.
    elsewhere : str
        Where the other rules are: the end of :func:`check_materials`' message.
    """
    element: str
    rules: dict[str, tuple[str, int] | None]
    elsewhere: str


_P2_RULES = ElementRules("P2", {"gauss": None, "reduced": ("default", REDUCED_DEGREE)},
                         "the Gauss-Lobatto rule at the nodes is that of Q2 quadrilaterals and hexahedra")
_Q2_RULES = ElementRules("Q2", {"gauss": None, "lobatto": LOBATTO_RULE},
                         "the reduced rule is that of P2 triangles and tetrahedra")
#: cell type -> the quadratures its element has (the medium's "reduced" on P2 simplices, its
#: "lobatto" on Q2 cells): what :class:`LagrangeDiscretization` checks the energies against and
#: integrates them with (:meth:`LagrangeDiscretization._rule`)
ELEMENT_RULES = {"triangle": _P2_RULES, "tetrahedron": _P2_RULES, "quadrilateral": _Q2_RULES,
                 "hexahedron": _Q2_RULES}

#: cell type -> the vertices (DOLFINx's local numbering) of the reference edges that carry the
#: degree-2 dofs n_vertices + k (a triangle's dof 3 + k on the edge opposite vertex k; a Q2
#: quadrilateral's dof 8 is its centre; a Q2 hexahedron's dofs 20..25 are its face centres, 26
#: its centre)
_EDGE_VERTICES = {cell: tuple(map(tuple, reference_edges(cell))) for cell in CELL_TYPES}


def _boundary_loop(cell: str) -> np.ndarray:
    """Local dofs of a 2D cell's boundary in order: vertex, midpoint of the edge to the next
    vertex (counter-clockwise on the reference cell), next vertex, ..."""
    n_vertices = CELL_TYPES[cell][1]
    edge_dof = {frozenset(pair): n_vertices + k for k, pair in enumerate(_EDGE_VERTICES[cell])}
    ring = _compat.COUNTER_CLOCKWISE[n_vertices]
    return np.array([d for a, b in zip(ring, ring[1:] + ring[:1]) for d in (a, edge_dof[frozenset((a, b))])])


def _reference_nodes(cell: str) -> np.ndarray:
    """Reference coordinates (n_vertices + n_edges, tdim) of a cell's vertices and edge midpoints."""
    vertices = reference_vertices(cell)
    return np.concatenate([vertices, [vertices[list(pair)].mean(axis=0) for pair in _EDGE_VERTICES[cell]]])


def _cell_type(mesh: dolfinx.mesh.Mesh) -> str:
    return mesh.topology.cell_type.name


def _fem_cells(mesh: PolygonMesh, fem_h: float | None, fem_mesh: PolygonMesh | None
               ) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
    """The FEM cells for :meth:`LagrangeDiscretization.from_polygon_mesh`: (h, points (n, 2),
    cells (m, 3 or 4) counter-clockwise, tags (m,)); h is the longest cell edge of ``fem_mesh``."""
    if fem_mesh is None:
        h, tri = matched_triangulation(mesh) if fem_h is None else (float(fem_h), triangulate(mesh, fem_h))
        return h, tri.points, tri.triangles, tri.tags
    counts = np.unique(np.diff(fem_mesh.offsets))
    if counts.size != 1 or counts[0] not in (3, 4):
        raise ValueError("fem_mesh must be all triangles or all quadrilaterals without hanging nodes, "
                         f"not polygons with {', '.join(map(str, counts))} vertices")
    cells = fem_mesh.vertices.reshape(-1, counts[0]).astype(np.int64)
    x = fem_mesh.points[cells]
    if counts[0] == 4:                  # the bilinear map of a counter-clockwise quad: J > 0 iff convex
        det = jacobian_determinants(x[:, _compat.COUNTER_CLOCKWISE[4]], "quadrilateral")
        bad = np.flatnonzero(det.min(axis=1) <= TOLERANCE * np.abs(det).max(axis=1))
        if bad.size:
            raise ValueError(f"fem_mesh quadrilateral {int(bad[0])} is not strictly convex (the Jacobian "
                             f"determinant of its bilinear map is {det[bad[0]].min():.3g} at a corner)")
    for tag in np.union1d(mesh.tags, fem_mesh.tags):
        a, b = (float(m.areas[m.tags == tag].sum()) for m in (mesh, fem_mesh))
        if abs(a - b) > 1e-9 * max(a, b):
            raise ValueError(f"fem_mesh region {tag} has area {b:.10g}, the polygon mesh's {a:.10g}")
    h = float(np.linalg.norm(x - np.roll(x, -1, axis=1), axis=2).max())
    return h, fem_mesh.points, cells, fem_mesh.tags


class LagrangeDiscretization(Discretization):
    """Degree-2 Lagrange FEM discretization of Σ_tag ∫ ψ_tag(F, ∇F) dΩ: P2 on a DOLFINx
    triangle or tetrahedron mesh, Q2 on a quadrilateral or hexahedron mesh. The dimension d is
    the mesh's (:attr:`gdim`): F = I_d + ∇u, d unknowns per node (``d * node + component``).

    Parameters
    ----------
    mesh
        Triangle or tetrahedron mesh, or quadrilateral/hexahedron mesh, of degree-1 or degree-2
        (curved) geometry (any partition, ghosted or not); quadrilaterals and hexahedra need not be
        parallelograms/parallelepipeds. The :attr:`output_mesh` keeps the vertices (and, in 3D, the
        degree-2 geometry: :class:`~dolfinx_sfvem.mesh.cell_mesh.CellMesh`).
    cell_tags
        Region tag of every local cell (``dolfinx.mesh.meshtags`` of the cells' dimension).
    materials
        Region tag -> energy.
    comm
        Communicator (default: the mesh's).
    quadrature_degree
        Degree of the quadrature rule of Π, its residual and tangent (default 4), and of the
        face loads' forms (:attr:`face_quadrature_degree`).
    mesh_size
        The size the mesh was made with, reported by :meth:`describe` (None: unknown).
    jump_penalty
        η of the C0 interior-penalty terms (:meth:`_jump_energy`) on the interior facets of
        every region whose energy has gradient terms; None (default): none, the broken
        second gradient alone. In parallel the mesh must ghost its facet neighbours. 2D only.
    region_names
        Name -> tag of the regions, kept by the 3D :attr:`output_mesh`.
    """

    method = "fem"

    def __init__(self, mesh: dolfinx.mesh.Mesh, cell_tags, materials: typing.Mapping[int, Energy],
                 comm: MPI.Comm | None = None, *, quadrature_degree: int = QUADRATURE_DEGREE,
                 mesh_size: float | None = None, jump_penalty: float | None = None,
                 region_names: typing.Mapping[str, int] | None = None):
        if jump_penalty is not None and not (np.isfinite(jump_penalty) and jump_penalty > 0.0):
            raise ValueError(f"jump_penalty must be a positive number, not {jump_penalty!r}")
        self.comm = comm if comm is not None else mesh.comm
        _compat.settle_coordinate_element(mesh)          # module names independent of earlier compiles
        self.mesh = mesh
        self.quadrature_degree = int(quadrature_degree)
        self.mesh_size = mesh_size
        self.jump_penalty = jump_penalty
        tdim = mesh.topology.dim
        self.gdim = mesh.geometry.dim
        if self.gdim != tdim:
            raise ValueError(f"a mesh of {tdim}D cells in {self.gdim}D space: the cells must fill the space")
        n_local_cells = mesh.topology.index_map(tdim).size_local + mesh.topology.index_map(tdim).num_ghosts
        self.cell_tag = np.full(n_local_cells, np.iinfo(np.int32).min, dtype=np.int64)
        self.cell_tag[cell_tags.indices] = cell_tags.values
        points, cells, tags, point_of_node = gather_cells(mesh, self.cell_tag, self.comm)
        n_vertices = CELL_TYPES[_cell_type(mesh)][1]
        n_vertex_points = points.shape[0]
        if cells.shape[1] > n_vertices:                  # a curved geometry: its vertices are the output points
            points, cells, n_vertex_points, new_index = vertices_first(points, cells, n_vertices)
            point_of_node = new_index[point_of_node]
        if np.any(tags == np.iinfo(np.int32).min):
            raise ValueError(f"cell {int(np.argmin(tags))} has no region tag")
        element = ELEMENT_RULES[_cell_type(mesh)]
        check_materials(tags, materials, tuple(element.rules),
                        f"on {element.element} {_cell_type(mesh)}s: {element.elsewhere}")
        if tdim == 2:
            self._output_mesh = PolygonMesh(points[:n_vertex_points], cells[:, _compat.COUNTER_CLOCKWISE[n_vertices]],
                                            tags, insert_hanging_nodes=False)
        else:
            self._output_mesh = CellMesh(points, cells, tags, _cell_type(mesh), region_names)
        self.materials = dict(sorted(materials.items()))

        self.V = _compat.vector_function_space(mesh, 2)
        self.u = dolfinx.fem.Function(self.V, name="u")
        self._number_nodes(point_of_node)
        self._cell_tags = cell_tags
        #: energy terms (:meth:`add_energy_term`), each with the constants of its parameters
        self._terms: list[tuple[EnergyTerm, dict[str, dolfinx.fem.Constant]]] = []
        self._build_forms(cell_tags)

    # ------------------------------------------------------------------ set-up
    def _number_nodes(self, point_of_node: np.ndarray) -> None:
        """Coordinates, output point and partition-independent key of every local node.

        Key of a vertex node: its :attr:`output_mesh` point ``p``; of an edge node:
        ``n + edge_key(a, b)`` (:func:`~dolfinx_sfvem.mesh.polygon_mesh.edge_key`, in [0, n²), n
        the number of points) for the edge's points ``a``, ``b``; of a Q2 face-centre node of a
        hexahedron: ``n + n² + edge_key(a, c)`` for the face's diagonal (a, c) through its
        smallest point a; of a Q2 cell-centre node: ``n + n² + c`` (2D), ``n + 2 n² + c`` (3D)
        for the input index ``c`` of its cell.
        """
        im = self.V.dofmap.index_map
        n_nodes = im.size_local + im.num_ghosts
        dofs = _compat.cell_dofs(self.V)
        cell, tdim = _cell_type(self.mesh), self.mesh.topology.dim
        vertex_point = point_of_node[_compat.cell_geometry_nodes(self.mesh)[:, :CELL_TYPES[cell][1]]]
        n, n_vertices, n_edges = self._output_mesh.n_points, vertex_point.shape[1], len(_EDGE_VERTICES[cell])
        self.node_point = np.full(n_nodes, -1, dtype=np.int64)
        self.node_point[dofs[:, :n_vertices]] = vertex_point
        self.node_key = self.node_point.copy()
        for k, (a, b) in enumerate(_EDGE_VERTICES[cell]):
            self.node_key[dofs[:, n_vertices + k]] = self.midpoint_keys(vertex_point[:, a], vertex_point[:, b])
        if cell == "hexahedron":                                          # Q2 face centres
            for k, face in enumerate(reference_facets(cell)):
                corners = vertex_point[:, face]                           # cyclic: corner j's diagonal is j + 2
                j = np.argmin(corners, axis=1)
                rows = np.arange(corners.shape[0])
                self.node_key[dofs[:, n_vertices + n_edges + k]] = self.face_centre_keys(
                    corners[rows, j], corners[rows, (j + 2) % 4])
        if cell in ("quadrilateral", "hexahedron"):                       # Q2 cell centre
            self.node_key[dofs[:, -1]] = n + (tdim - 1) * n * n + _compat.original_cell_index(self.mesh)
        self.x_nodes = self.V.tabulate_dof_coordinates()[:n_nodes, :self.gdim].copy()
        self.global_nodes = np.asarray(im.local_to_global(np.arange(n_nodes, dtype=np.int32)), dtype=np.int64)

    def _rule(self, energy: Energy) -> tuple[str, int]:
        """(FFCx's rule name, degree) of the quadrature of a region with ``energy``, from
        :data:`ELEMENT_RULES`: basix's default rule of :attr:`quadrature_degree` for
        ``quadrature="gauss"``, :data:`LOBATTO_RULE` for ``quadrature="lobatto"`` (Q2), the
        default rule of :data:`REDUCED_DEGREE` for ``quadrature="reduced"`` (P2)."""
        rule = ELEMENT_RULES[_cell_type(self.mesh)].rules[energy.quadrature]
        return ("default", self.quadrature_degree) if rule is None else rule

    def _region_dx(self, cell_tags, tag: int) -> ufl.Measure:
        """The measure of region ``tag`` with its energy's rule (:meth:`_rule`)."""
        name, degree = self._rule(self.materials[tag])
        metadata = {"quadrature_degree": degree} if name == "default" else \
            {"quadrature_rule": name, "quadrature_degree": degree}
        return ufl.Measure("dx", domain=self.mesh, subdomain_data=cell_tags, metadata=metadata)(tag)

    def _build_forms(self, cell_tags) -> None:
        """Π, its residual and tangent as compiled forms; det F at the quadrature points."""
        mesh, q = self.mesh, self.quadrature_degree
        u, v, du = self.u, ufl.TestFunction(self.V), ufl.TrialFunction(self.V)
        F = ufl.variable(ufl.Identity(self.gdim) + ufl.grad(u))
        G = ufl.grad(ufl.grad(u))
        self.dx = ufl.Measure("dx", domain=mesh, subdomain_data=cell_tags, metadata={"quadrature_degree": q})
        self._dx = {tag: self._region_dx(cell_tags, tag) for tag in self.materials}
        self._constants = {tag: {name: dolfinx.fem.Constant(mesh, PETSc.ScalarType(value))
                                 for name, value in energy.params.items()}
                           for tag, energy in self.materials.items()}
        Pi = sum(energy.psi(F, G, self._constants[tag]) * self._dx[tag] for tag, energy in self.materials.items())
        Pi = Pi + sum(term.energy.psi(F, G, constants) * self._dx[term.tag] for term, constants in self._terms)
        medium = [energy.psi(F, G, self._constants[tag]) * self._dx[tag] for tag, energy in self.materials.items()
                  if energy.is_medium]
        self._medium_ufl = ufl.derivative(sum(medium), u, v) if medium else None
        self._medium_form = None                   # compiled when first used (:meth:`medium_force`)
        if self.jump_penalty is not None:
            Pi = Pi + self._jump_energy(self.jump_penalty)
        residual = ufl.derivative(Pi, u, v)
        self._energy_form = compiled_form(Pi)
        self._residual_form = compiled_form(residual)
        self._tangent_form = compiled_form(ufl.derivative(residual, u, du))
        cell = _cell_type(mesh)
        self._owned_cells = np.arange(_compat.num_owned_cells(mesh), dtype=np.int32)
        points, self._own_points = self._quadrature_points()
        self._det_F = _compat.CompiledExpression(ufl.det(F), mesh, np.concatenate([points, _reference_nodes(cell)]))
        self._solid = np.isin(self.cell_tag[self._owned_cells],
                              [tag for tag, energy in self.materials.items() if not energy.is_medium])
        self._cell_input_index = _compat.original_cell_index(mesh)
        self.element_loops = None
        if mesh.topology.dim == 2:
            # injectivity guard: boundary loop of every owned cell, solids also checked for crossings
            dofs = _compat.cell_dofs(self.V)[:self._owned_cells.size]
            loop = _boundary_loop(cell)
            self._loop = dofs[:, loop].astype(np.int64).ravel()
            self._loop_offsets = np.arange(0, self._loop.size + 1, loop.size, dtype=np.int64)
            self.element_loops = (self._loop_offsets, self._loop,
                                  self._cell_input_index[self._owned_cells].astype(np.int64))
        self._error_terms = None
        self._term_forms: dict[int, tuple] = {}       # the terms' own forms (:meth:`term_force`)
        self._stress_expressions = None                # F and P per region (:meth:`cell_stress`)

    def _quadrature_points(self) -> tuple[np.ndarray, np.ndarray]:
        """The reference points of the rules of all regions (:meth:`_rule`), stacked (n, tdim), and
        which of them are the rule of each owned cell's region ((n_owned_cells, n) bool)."""
        rule_of_tag = {tag: self._rule(energy) for tag, energy in self.materials.items()}
        rules = sorted(set(rule_of_tag.values()))
        points = [_compat.reference_quadrature(self.mesh, degree, name)[0] for name, degree in rules]
        rule_of_point = np.repeat(np.arange(len(rules)), [p.shape[0] for p in points])
        rule_of_cell = np.array([rules.index(rule_of_tag[tag]) for tag in self.cell_tag[self._owned_cells]],
                                dtype=np.int64).reshape(-1)
        return np.concatenate(points), rule_of_cell[:, None] == rule_of_point[None, :]

    def module_names(self) -> dict[str, str]:
        """The FFCx module of each form compiled at set-up: ``"energy"``, ``"residual"``,
        ``"tangent"`` -> ``libffcx_forms_<hash>``. The names depend on the regions' energies,
        the cell type and the quadrature degree only: the same in every process, whatever it
        compiled before, for any mesh of those cells and any parameter values (Constants), so a
        second run finds the modules in the cache."""
        return {name: _compat.form_module_name(form) for name, form in
                (("energy", self._energy_form), ("residual", self._residual_form), ("tangent", self._tangent_form))}

    def _jump_energy(self, eta: float) -> ufl.Form:
        """C0 interior-penalty energy on the interior facets e of each gradient region:

            Σ_e ∫_e -{T} ⋮ ([[F]] ⊗ n) + η / h_e (ψ({F}, [[F]] ⊗ n) - ψ({F}, 0)) ds,

        with [[F]] = F⁺ - F⁻, n = n⁺, {·} the average of both sides, T = ∂ψ/∂G and h_e the
        mean diameter of the two cells. The first term removes the facet part of ∫ T ⋮ ∇F that
        the broken second gradient misses (consistency); the second penalises the kinks of
        F across facets with the region's own regularization (for ψ_r = α/2 G ⋮ G it is
        η α / (2 h_e) |[[F]]|²). Both vanish where ∇u is continuous.
        """
        u, mesh, q = self.u, self.mesh, self.quadrature_degree
        facets, cells = _compat.interior_facets(mesh)
        tag = self.cell_tag[cells]
        gradient_tags = [t for t, energy in self.materials.items() if energy.uses_gradient]
        inside = (tag[:, 0] == tag[:, 1]) & np.isin(tag[:, 0], gradient_tags)
        facet_tags = _compat.create_facet_tags(mesh, facets[inside], tag[inside, 0].astype(np.int32))
        dS = ufl.Measure("dS", domain=mesh, subdomain_data=facet_tags, metadata={"quadrature_degree": q})
        n = ufl.FacetNormal(mesh)("+")
        h = ufl.CellDiameter(mesh)
        h_e = (h("+") + h("-")) / 2
        i, j, k = ufl.indices(3)
        F_side = {side: ufl.Identity(self.gdim) + ufl.grad(u)(side) for side in "+-"}
        jump = ufl.as_tensor((F_side["+"] - F_side["-"])[i, j] * n[k], (i, j, k))
        F_avg = (F_side["+"] + F_side["-"]) / 2
        energy_terms = []
        for t in gradient_tags:
            psi, c = self.materials[t].psi, self._constants[t]

            def T(side):
                G = ufl.variable(ufl.grad(ufl.grad(u))(side))
                return ufl.diff(psi(F_side[side], G, c), G)
            T_avg = (T("+") + T("-")) / 2
            energy_terms.append((-ufl.inner(T_avg, jump)
                                 + eta / h_e * (psi(F_avg, jump, c) - psi(F_avg, 0 * jump, c))) * dS(t))
        return sum(energy_terms)

    def _set_state(self, x: PETSc.Vec, regularization: bool = True) -> None:
        """u <- x (ghosts included), the region constants <- the energies' parameters (those of
        :meth:`Energy.unregularized_params` when ``regularization`` is False) and the energy
        terms' constants <- the terms' parameters."""
        with x.localForm() as xl:
            self.u.x.array[:] = xl.array_r
        for tag, energy in self.materials.items():
            params = energy.params if regularization else energy.unregularized_params()
            for name, value in energy.validate(params).items():
                self._constants[tag][name].value = value
        for term, constants in self._terms:
            for name, value in term.energy.validate(term.params).items():
                constants[name].value = value

    # ------------------------------------------------------------------ energy terms
    def add_energy_term(self, tag: int, energy: Energy) -> EnergyTerm:
        """Add ∫ ψ dΩ over region ``tag`` (:meth:`Discretization.add_energy_term`): the forms are
        compiled again with the term."""
        if tag not in self.materials:
            raise ValueError(f"energy term on region {tag}, which the mesh does not have")
        term = EnergyTerm(tag, energy, dict(energy.params))
        constants = {name: dolfinx.fem.Constant(self.mesh, PETSc.ScalarType(value)) for name, value in term.params.items()}
        self._terms.append((term, constants))
        self._build_forms(self._cell_tags)
        return term

    def term_force(self, term: EnergyTerm, x: PETSc.Vec, b: PETSc.Vec,
                   params: typing.Mapping[str, float] | None = None) -> float:
        """b = ∂/∂u ∫ ψ dΩ of the term alone with ``params``; returns ∫ ψ dΩ."""
        index = next(k for k, (t, _) in enumerate(self._terms) if t is term)
        if index not in self._term_forms:
            unit = {name: dolfinx.fem.Constant(self.mesh, PETSc.ScalarType(0.0)) for name in term.params}
            F = ufl.variable(ufl.Identity(self.gdim) + ufl.grad(self.u))
            energy = term.energy.psi(F, ufl.grad(ufl.grad(self.u)), unit) * self._dx[term.tag]
            self._term_forms[index] = (unit, compiled_form(energy),
                                       compiled_form(ufl.derivative(energy, self.u, ufl.TestFunction(self.V))))
        unit, energy_form, force_form = self._term_forms[index]
        for name, value in term.energy.validate(params if params is not None else term.params).items():
            unit[name].value = value
        self._set_state(x)
        with b.localForm() as bl:
            bl.set(0.0)
        dolfinx.fem.petsc.assemble_vector(b, force_form)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        return float(self.comm.allreduce(dolfinx.fem.assemble_scalar(energy_form), op=MPI.SUM))

    # ------------------------------------------------------------------ construction from a polygon mesh
    @classmethod
    def from_polygon_mesh(cls, mesh: PolygonMesh, materials: typing.Mapping[int, Energy],
                          comm: MPI.Comm = MPI.COMM_WORLD, *, fem_h: float | None = None,
                          fem_mesh: PolygonMesh | None = None, quadrature_degree: int = QUADRATURE_DEGREE,
                          jump_penalty: float | None = None, verbose: bool = True) -> "LagrangeDiscretization":
        """The degree-2 FEM discretization of the geometry and regions of a polygon mesh.

        By default the regions are meshed again with triangles
        (:func:`~dolfinx_sfvem.mesh.remesh.triangulate`, on rank 0) keeping every
        boundary/interface vertex of ``mesh``.

        Parameters
        ----------
        fem_h
            Triangle size. None: the size at which the P2 unknowns match the SFVEM unknowns
            of ``mesh`` within 5 % (:func:`~dolfinx_sfvem.mesh.remesh.matched_triangulation`),
            i.e. a comparison at matched DOFs.
        fem_mesh
            The FEM's own mesh of the same regions instead: its polygons, all triangles (P2)
            or all strictly convex quadrilaterals (Q2, parallelograms or not), are the cells (e.g.
            :func:`~dolfinx_sfvem.meshes.cbox_grid`).
            Its region areas must equal those of ``mesh``.
        jump_penalty
            η of the optional interior-penalty terms (class docstring).
        """
        if fem_mesh is not None and fem_h is not None:
            raise ValueError("give fem_h (a triangulation of the polygon mesh) or fem_mesh, not both")
        result, error = None, None
        if comm.rank == 0:
            try:
                result = _fem_cells(mesh, fem_h, fem_mesh)
            except ValueError as err:       # raised on every rank, not only where gmsh ran
                error = err
        result, error = comm.bcast((result, error), root=0)
        if error is not None:
            raise ValueError(str(error))
        h, points, cells, tags = result
        if comm.rank != 0:                  # rank 0 holds the input mesh, DOLFINx distributes it
            cells, points = np.empty((0, cells.shape[1]), np.int64), np.empty((0, 2))
        dmesh = _compat.create_mesh_partitioned(comm, cells, points, ghost_facet_neighbours=jump_penalty is not None)
        cell_tags = _compat.create_cell_tags(dmesh, tags[_compat.original_cell_index(dmesh)])
        disc = cls(dmesh, cell_tags, materials, comm, quadrature_degree=quadrature_degree, mesh_size=h,
                   jump_penalty=jump_penalty)
        kind = {3: "P2 FEM", 4: "Q2 FEM"}[cells.shape[1]]
        origin = "own mesh; SFVEM:" if fem_mesh is not None else \
            ("chosen to match" if fem_h is None else "given; SFVEM would have")
        say(log, f"{kind}: {cells.shape[0]} cells, h = {h:.4g} ({origin} {sfvem_unknowns(mesh)} SFVEM "
                 f"unknowns), {disc.num_dofs_global} unknowns on {comm.size} rank(s), quadrature degree "
                 f"{disc.quadrature_degree}", verbose, comm)
        return disc

    @classmethod
    def from_cell_mesh(cls, mesh: CellMesh, materials: typing.Mapping[int, Energy],
                       comm: MPI.Comm = MPI.COMM_WORLD, *, quadrature_degree: int = QUADRATURE_DEGREE,
                       jump_penalty: float | None = None, verbose: bool = True) -> "LagrangeDiscretization":
        """The degree-2 Lagrange discretization on the cells of ``mesh`` (P2 on simplices, Q2 on
        quadrilaterals and hexahedra, affine or not, at the mesh's geometry degree, 1 or 2), distributed
        by DOLFINx's partitioner from rank 0's copy; its :attr:`output_mesh` is ``mesh`` again
        (gathered back; the same points, nodes and cells).
        ``jump_penalty``: as in :class:`LagrangeDiscretization` (the cells across the partition's
        faces are then ghosted)."""
        cells, points = mesh.nodes, mesh.node_points
        if comm.rank != 0:
            cells, points = np.empty((0, cells.shape[1]), np.int64), np.empty((0, mesh.gdim))
        dmesh = _compat.create_mesh_partitioned(comm, cells, points, cell=mesh.cell_type,
                                                ghost_facet_neighbours=jump_penalty is not None)
        cell_tags = _compat.create_cell_tags(dmesh, mesh.tags[_compat.original_cell_index(dmesh)])
        x = mesh.points[mesh.cells]
        h = float(np.linalg.norm(x[:, :, None] - x[:, None], axis=3).max()) if mesh.n_cells else 0.0
        disc = cls(dmesh, cell_tags, materials, comm, quadrature_degree=quadrature_degree, mesh_size=h,
                   jump_penalty=jump_penalty, region_names=mesh.region_names)
        kind = "P2" if mesh.cell_type in ("triangle", "tetrahedron") else "Q2"
        curved = " curved (degree-2 geometry)" if mesh.geometry_degree > 1 else ""
        say(log, f"{kind} FEM: {mesh.n_cells}{curved} {mesh.cell_type}s, {disc.num_dofs_global} unknowns on {comm.size} "
                 f"rank(s), quadrature degree {disc.quadrature_degree}", verbose, comm)
        return disc

    # ------------------------------------------------------------------ PETSc objects
    def create_vector(self) -> PETSc.Vec:
        """A ghosted PETSc vector of the P2 unknowns (block size d, local index d node + component)."""
        return _compat.create_petsc_vector(self.V.dofmap.index_map, self.V.dofmap.index_map_bs)

    def create_matrix(self) -> PETSc.Mat:
        """AIJ matrix with the sparsity of the tangent form (the pattern survives zeroed rows)."""
        A = dolfinx.fem.petsc.create_matrix(self._tangent_form)
        A.setOption(PETSc.Mat.Option.KEEP_NONZERO_PATTERN, True)
        return A

    def coarse_interpolation(self) -> PETSc.Mat:
        """The P1/Q1 vector space on the same mesh interpolated into the P2/Q2 unknowns
        (:meth:`Discretization.coarse_interpolation`)."""
        return _compat.interpolation_matrix(_compat.vector_function_space(self.mesh, 1), self.V)

    # ------------------------------------------------------------------ assembly
    def residual(self, x: PETSc.Vec, b: PETSc.Vec) -> AssemblyInfo:
        """Internal force b = ∂Π/∂u at x (ghosts of x must be current); ghost contributions
        accumulated on their owners. J is checked at the quadrature points of the owned cells."""
        self._set_state(x)
        with b.localForm() as bl:
            bl.set(0.0)
        dolfinx.fem.petsc.assemble_vector(b, self._residual_form)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        energy = self.comm.allreduce(dolfinx.fem.assemble_scalar(self._energy_form), op=MPI.SUM)
        J_all = self._det_F(self._owned_cells)[:, :, 0]
        n_points = self._own_points.shape[1]
        J, J_nodes = np.where(self._own_points, J_all[:, :n_points], np.inf), J_all[:, n_points:]
        cell = int(np.argmin(J.min(axis=1))) if J.size else -1
        local_min = float(J[cell].min()) if J.size else np.inf
        min_J, rank = self.comm.allreduce((local_min, self.comm.rank), op=MPI.MINLOC)
        where = (int(self._cell_input_index[cell]), int(self.cell_tag[cell])) if cell >= 0 else (-1, -1)
        polygon, tag = self.comm.bcast(where, root=rank)
        folded, kinked = self._folded(x)
        folded |= self._solid & ~(J_nodes.min(axis=1, initial=np.inf) > 0.0)
        return AssemblyInfo(float(energy), float(min_J), polygon, tag,
                            *gather_count(self.comm, folded, self._cell_input_index[self._owned_cells]),
                            gather_count(self.comm, kinked, self._cell_input_index[self._owned_cells])[0])

    def _folded(self, x: PETSc.Vec) -> tuple[np.ndarray, np.ndarray]:
        """Folded and kinked owned cells (:func:`~dolfinx_sfvem.discretizations.injectivity.folded_elements`) from
        their boundary loops in 2D; in 3D none (the guard there is J > 0 at the quadrature points
        and at the nodes of the solids' cells, :meth:`residual`)."""
        if self.element_loops is None:
            return np.zeros((2, self._owned_cells.size), dtype=bool)
        with x.localForm() as xl:
            return folded_elements(self._loop_offsets, self._loop, self.x_nodes, xl.array_r.reshape(-1, 2),
                                   self._owned_cells.astype(np.int64), self._solid)

    def medium_force(self, x: PETSc.Vec, b: PETSc.Vec, regularization: bool = True) -> None:
        """b = ∂Π_medium/∂u, the internal force of the third-medium regions alone, at x; without
        their regularization when ``regularization`` is False (the same form, the parameters of
        :meth:`Energy.unregularized_params`)."""
        with b.localForm() as bl:
            bl.set(0.0)
        if self._medium_ufl is None:
            return
        if self._medium_form is None:
            self._medium_form = compiled_form(self._medium_ufl)
        self._set_state(x, regularization)
        dolfinx.fem.petsc.assemble_vector(b, self._medium_form)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)

    def assemble_tangent(self, x: PETSc.Vec, A: PETSc.Mat) -> None:
        """Tangent ∂²Π/∂u² at x into A, constraints not applied."""
        self._set_state(x)
        A.zeroEntries()
        dolfinx.fem.petsc.assemble_matrix(A, self._tangent_form)
        A.assemble()

    # ------------------------------------------------------------------ loads and fields
    def body_force_vector(self, f: typing.Callable[[np.ndarray], np.ndarray]) -> PETSc.Vec:
        """External force vector ∫ f_h · v dΩ of a body force, f_h its P2 interpolant.

        Parameters
        ----------
        f
            Body force per unit reference area (volume in 3D): ``f(x)`` with ``x`` of shape (d, n)
            returns (d, n).
        """
        d = self.gdim
        f_h = dolfinx.fem.Function(self.V)
        f_h.interpolate(lambda x: np.broadcast_to(np.asarray(f(x[:d]), dtype=np.float64), (d, x.shape[1])))
        b = self.create_vector()
        with b.localForm() as bl:
            bl.set(0.0)
        dolfinx.fem.petsc.assemble_vector(b, compiled_form(ufl.inner(f_h, ufl.TestFunction(self.V)) * self.dx))
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        return b

    def quadrature_fields(self, x: PETSc.Vec) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Points (n, d) and weights (n,) of a rule of degree :data:`ERROR_QUADRATURE_DEGREE` on the
        owned cells with u_h (n, d) and ∇u_h (n, d, d) there: the fields of :meth:`error_norms`."""
        d = self.gdim
        points, weights = _compat.reference_quadrature(self.mesh, ERROR_QUADRATURE_DEGREE)
        if self._error_terms is None:
            X = ufl.SpatialCoordinate(self.mesh)
            terms = [X[i] for i in range(d)] + [self.u[i] for i in range(d)]
            terms += [ufl.grad(self.u)[i, j] for i in range(d) for j in range(d)]
            terms.append(abs(ufl.JacobianDeterminant(self.mesh)))
            self._error_terms = _compat.CompiledExpression(ufl.as_vector(terms), self.mesh, points)
        self._set_state(x)
        values = self._error_terms(self._owned_cells).reshape(-1, 2 * d + d * d + 1)
        w = np.tile(weights, self._owned_cells.size) * values[:, -1]
        return values[:, :d], w, values[:, d:2 * d], values[:, 2 * d:-1].reshape(-1, d, d)

    def quadrature_cells(self) -> np.ndarray:
        """The :attr:`output_mesh` cell (n,) int64 of every point of :meth:`quadrature_fields`."""
        n_points = _compat.reference_quadrature(self.mesh, ERROR_QUADRATURE_DEGREE)[0].shape[0]
        return np.repeat(self._cell_input_index[self._owned_cells], n_points).astype(np.int64)

    # ------------------------------------------------------------------ locating unknowns
    def locate_nodes(self, marker: Marker | None = None, tags: typing.Iterable[int] | None = None) -> np.ndarray:
        """Local P2 nodes (owned and ghost) selected by marker and/or tags.

        Parameters
        ----------
        marker
            Function of node coordinates ``x`` (d, n) returning a bool array (n,).
        tags
            Region tags: all nodes of the cells with these tags (also the nodes this rank holds
            only through cells of other ranks, so the selection is consistent across ranks).
        """
        if marker is None and tags is None:
            raise ValueError("give a marker function, region tags, or both")
        selected = np.ones(self.x_nodes.shape[0], dtype=bool)
        if marker is not None:
            selected &= np.asarray(marker(self.x_nodes.T), dtype=bool).reshape(-1)
        if tags is not None:
            cells = np.flatnonzero(np.isin(self.cell_tag, np.fromiter(tags, dtype=np.int64))).astype(np.int32)
            in_tags = np.zeros_like(selected)
            tdim = self.mesh.topology.dim
            self.mesh.topology.create_connectivity(tdim, tdim)      # DOLFINx 0.11 asks for it first
            in_tags[dolfinx.fem.locate_dofs_topological(self.V, tdim, cells)] = True
            selected &= in_tags
        return np.flatnonzero(selected)

    @property
    def n_owned_nodes(self) -> int:
        return self.V.dofmap.index_map.size_local

    @property
    def n_local_nodes(self) -> int:
        im = self.V.dofmap.index_map
        return im.size_local + im.num_ghosts

    @property
    def num_dofs_global(self) -> int:
        return self.gdim * self.V.dofmap.index_map.size_global

    def displacement_at(self, x: PETSc.Vec, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """u_h at ``points`` (n, d) inside this rank's owned cells: (values (n, d), found (n,) bool);
        points elsewhere get zeros and False."""
        d = self.gdim
        points = np.asarray(points, dtype=np.float64).reshape(-1, d)
        if d == 2:
            local_of = np.full(self._output_mesh.n_polygons + 1, -1, dtype=np.int32)      # [-1]: outside
            local_of[self._cell_input_index[self._owned_cells]] = self._owned_cells
            local = local_of[self._output_mesh.locate(points)]
        else:
            local = _compat.locate_cells(self.mesh, points, self._owned_cells.size)
        found = local >= 0
        values = np.zeros((len(points), d))
        if found.any():
            self._set_state(x)
            xyz = np.zeros((int(found.sum()), 3))
            xyz[:, :d] = points[found]
            values[found] = self.u.eval(xyz, local[found])
        return values, found

    def dof_values(self, value: typing.Callable[[np.ndarray], np.ndarray], dofs: np.ndarray) -> np.ndarray:
        """Values of ``value(x) -> (n,)`` (one component) at the nodes of the unknowns ``dofs``."""
        return np.asarray(value(self.x_nodes[dofs // self.gdim].T), dtype=np.float64).reshape(-1)

    # ------------------------------------------------------------------ the load host (:class:`LoadHost`)
    #: the face loads' traces are continuous across the faces' edges (:mod:`~dolfinx_sfvem.physics.face_loads`)
    continuous_face_traces = True

    @property
    def face_quadrature_degree(self) -> int:
        """Degree of the rule of the face loads' forms: that of the energy, :attr:`quadrature_degree`."""
        return self.quadrature_degree

    @property
    def load_space(self) -> dolfinx.fem.FunctionSpace:
        """The space the face loads' forms live on (:mod:`~dolfinx_sfvem.physics.face_loads`): this one."""
        return self.V

    def to_host(self, u: np.ndarray) -> np.ndarray:
        """The values on the host space of the face loads (:mod:`~dolfinx_sfvem.physics.face_loads`): the
        local nodal values u themselves, flattened."""
        return np.asarray(u).reshape(-1)

    def add_from_host(self, host: PETSc.Vec, f: np.ndarray) -> None:
        """f += an assembled vector of the host (its local entries, ghosts not accumulated): the
        host's nodes are the unknowns' nodes."""
        with host.localForm() as hl:
            f.reshape(-1)[:] += hl.array_r

    def add_host_matrix(self, A: PETSc.Mat, form: dolfinx.fem.Form, scale: float = 1.0) -> None:
        """A += scale K, K the assembled bilinear ``form`` of the host space (this space): added
        into A's entries when ``scale`` is 1 (A assembled by the caller), else assembled apart
        and added to A, which is then assembled (collective)."""
        if scale == 1.0:
            dolfinx.fem.petsc.assemble_matrix(A, form)
            return
        K = dolfinx.fem.petsc.create_matrix(form)
        dolfinx.fem.petsc.assemble_matrix(K, form)
        K.assemble()
        A.assemble()
        A.axpy(scale, K, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        K.destroy()

    def nodes_of_host(self, nodes: np.ndarray) -> np.ndarray:
        """The local nodes hosted by the host nodes ``nodes``: the same."""
        return np.asarray(nodes, dtype=np.int64)

    # ------------------------------------------------------------------ node keys
    def midpoint_keys(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Node keys (:meth:`get_state`) of the midpoints of the edges between the
        :attr:`output_mesh` points a and b (n,)."""
        return lagrange_midpoint_keys(self._output_mesh.n_points, a, b)

    def face_centre_keys(self, a: np.ndarray, c: np.ndarray) -> np.ndarray:
        """Node keys of the Q2 centres of the quadrilateral faces with the diagonal between the
        :attr:`output_mesh` points a and c (n,), a the face's smallest point."""
        n = self._output_mesh.n_points
        return n + n * n + edge_key(a, c, n)

    # ------------------------------------------------------------------ output
    @property
    def output_mesh(self) -> PolygonMesh | CellMesh:
        """The cells (identical on all ranks), for pictures and the contact checks: a polygon mesh
        in 2D, a :class:`~dolfinx_sfvem.mesh.cell_mesh.CellMesh` in 3D."""
        return self._output_mesh

    def output_point_displacements(self, x: PETSc.Vec) -> tuple[np.ndarray, np.ndarray]:
        """(point indices of ``output_mesh``, displacements (k, d)) of the vertex nodes on this rank."""
        vertex = np.flatnonzero(self.node_point >= 0)
        with x.localForm() as xl:
            return self.node_point[vertex], xl.array_r.reshape(-1, self.gdim)[vertex].copy()

    def output_function(self, x: PETSc.Vec, u: dolfinx.fem.Function | None = None) -> dolfinx.fem.Function:
        """The solution as a P2 :class:`dolfinx.fem.Function` (ghost values of x must be current)."""
        u = u if u is not None else dolfinx.fem.Function(self.V, name="u")
        with x.localForm() as xl:
            u.x.array[:] = xl.array_r
        return u

    @property
    def dolfinx_mesh(self) -> dolfinx.mesh.Mesh:
        """The mesh of the cells: :attr:`mesh`, also the mesh of the load space."""
        return self.mesh

    def cell_tags(self):
        """The region tags of the cells (``dolfinx.mesh.MeshTags``)."""
        return self._cell_tags

    def cell_stress(self, x: PETSc.Vec) -> tuple[np.ndarray, np.ndarray]:
        """F and P = ∂ψ/∂F of every owned cell's region at the cell's centre."""
        d = self.gdim
        if self._stress_expressions is None:
            centre = reference_vertices(_cell_type(self.mesh)).mean(axis=0, keepdims=True)
            F = ufl.variable(ufl.Identity(d) + ufl.grad(self.u))
            G = ufl.grad(ufl.grad(self.u))
            self._stress_expressions = {
                tag: _compat.CompiledExpression(ufl.as_vector([F[i, j] for i in range(d) for j in range(d)] + [
                    P[i, j] for P in [ufl.diff(energy.psi(F, G, self._constants[tag]), F)] for i in range(d)
                    for j in range(d)]), self.mesh, centre)
                for tag, energy in self.materials.items()}
        self._set_state(x)
        F, P = np.zeros((self._owned_cells.size, d, d)), np.zeros((self._owned_cells.size, d, d))
        for tag, expression in self._stress_expressions.items():
            cells = self._owned_cells[self.cell_tag[self._owned_cells] == tag]
            values = expression(cells).reshape(-1, 2 * d * d)
            F[cells], P[cells] = values[:, :d * d].reshape(-1, d, d), values[:, d * d:].reshape(-1, d, d)
        return F, P

    def describe(self) -> dict:
        """Mesh facts for summary.json."""
        n_cells = self._output_mesh.n_polygons if self.gdim == 2 else self._output_mesh.n_cells
        return {"cells": int(n_cells), "cell_type": self.mesh.topology.cell_type.name,
                "quadrature_degree": self.quadrature_degree,
                "mesh_size": self.mesh_size, "jump_penalty": self.jump_penalty}
