"""A conforming mesh of one DOLFINx cell type in 2D or 3D, identical on every rank.

:class:`CellMesh` is the 3D counterpart of :class:`~dolfinx_sfvem.mesh.polygon_mesh.PolygonMesh`
as the Lagrange FEM's :attr:`~dolfinx_sfvem.discretizations.fem.LagrangeDiscretization.output_mesh`: the
points, the cells in DOLFINx's vertex order, a region tag per cell and the facets on the
boundary of the mesh and between regions (the surfaces the contact checks, the pictures and
the loads on faces use). Its cells are the images of the reference cell under the Lagrange map of
their geometry nodes, of degree 1 or 2:

- degree 1 (the cells' vertices): affine simplices; bilinear quadrilaterals and trilinear
  hexahedra, which need not be parallelograms/parallelepipeds (UFL differentiates the inverse
  Jacobian of such non-affine cells, so Q2's second derivatives are right on them too). A
  hexahedron's face may be non-planar: the bilinear surface through its four vertices.
- degree 2 (curved cells: gmsh's second-order 10-node tetrahedra, 6-node triangles, 27-node
  hexahedra, 9-node quadrilaterals): the vertices and a node on every edge (and, for
  quadrilaterals and hexahedra, on every face and inside), the quadratic map through them.

:attr:`CellMesh.points` and :attr:`CellMesh.cells` are the vertices in both cases (what the
polyhedral reading, the facets and the topology use: faces taken flat); :attr:`CellMesh.node_points`
and :attr:`CellMesh.nodes` the whole geometry (the vertices first, so ``node_points[:n_points]`` is
``points`` and ``nodes[:, :n_vertices]`` is ``cells``), and :meth:`CellMesh.edge_midpoints` /
:meth:`CellMesh.face_centres` the geometry's points in the middle of edges and quadrilateral faces.
A cell is valid when the Jacobian determinant of its map has one sign, not near zero, at every
geometry node and at the centre (:func:`jacobian_determinants`); a cell where it changes sign
(inverted, tangled) or vanishes (zero volume) is named in a ``ValueError``. A valid curved cell
whose determinant varies by more than a factor 1 / :data:`CURVED_RATIO_WARNING` between its nodes
is named in one warning: it is nearly tangled, and programs that invert its map (DOLFINx 0.5.2's
XDMF writer) may fail on it.

Vertex order (DOLFINx's, :func:`basix.geometry`): a tetrahedron's reference vertices
(0,0,0), (1,0,0), (0,1,0), (0,0,1); a hexahedron's in tensor-product order (0,0,0),
(1,0,0), (0,1,0), (1,1,0), (0,0,1), ...; the nodes of a degree-2 geometry in basix's order
(:func:`reference_nodes`). A cell whose map from the reference cell has a
negative Jacobian determinant (a left-handed tetrahedron, as gmsh may write) is reordered
(its reference axes 0 and 1 swapped, which changes the sign of the determinant everywhere in the
cell, affine or not), so every cell of a :class:`CellMesh` has a positive Jacobian determinant
at its vertices and centre, and a positive volume.
"""
from __future__ import annotations

import logging
import typing

import numpy as np
import numpy.typing as npt
from mpi4py import MPI

import basix

from dolfinx_sfvem import _compat
from dolfinx_sfvem.mesh.csr import edge_key
from dolfinx_sfvem.mesh.named_boundaries import boundary_names_check

log = logging.getLogger(__name__)

#: cell type -> (topological dimension, number of vertices)
CELL_TYPES = {"triangle": (2, 3), "quadrilateral": (2, 4), "tetrahedron": (3, 4), "hexahedron": (3, 8)}
#: cell type -> its plural, for messages
PLURAL = {"triangle": "triangles", "quadrilateral": "quadrilaterals", "tetrahedron": "tetrahedra",
          "hexahedron": "hexahedra"}
#: tensor-product cells: their degree-1 map is multilinear, its Jacobian varies over the cell
_TENSOR = ("quadrilateral", "hexahedron")
#: relative tolerance of the Jacobian checks (of the cell's diameter to the power tdim)
TOLERANCE = 1e-9
#: a curved cell whose smallest Jacobian determinant at its nodes and centre is below this fraction
#: of its largest is named in a warning (module docstring); gmsh's high-order optimization
#: (``Mesh.HighOrderOptimize``) raises the ratio
CURVED_RATIO_WARNING = 0.05
#: 2-point Gauss-Legendre rule on [0, 1]: exact for degree 3, so the rule of its tensor product
#: integrates the multilinear map's Jacobian determinant (degree <= 2 per direction) exactly
_GAUSS_2 = (0.5 - 0.5 / np.sqrt(3.0), 0.5 + 0.5 / np.sqrt(3.0))
#: degree of the rule :attr:`CellMesh.volumes` integrates a degree-2 map's Jacobian determinant
#: with: exact (degree 3 on a tetrahedron, at most 5 per direction on a hexahedron)
_CURVED_VOLUME_DEGREE = 6


def reference_vertices(cell_type: str) -> np.ndarray:
    """Reference coordinates (n_vertices, tdim) of the cell's vertices, DOLFINx's order."""
    return np.asarray(basix.geometry(getattr(basix.CellType, cell_type)), dtype=np.float64)


def reference_nodes(cell_type: str, degree: int = 1) -> np.ndarray:
    """Reference coordinates (n_nodes, tdim) of the nodes of a geometry of ``degree`` (DOLFINx's
    order): the vertices (degree 1); then the edges' midpoints in the order of
    :func:`reference_edges`, and for quadrilaterals and hexahedra the faces' and the cell's centres
    (degree 2)."""
    if degree == 1:
        return reference_vertices(cell_type)
    return np.asarray(_compat.lagrange_element(cell_type, degree).points, dtype=np.float64)


def shape_gradients(cell_type: str, xi: npt.ArrayLike, degree: int = 1) -> np.ndarray:
    """Reference gradients of the Lagrange basis functions of a geometry of ``degree`` (one per
    node, DOLFINx's order).

    Parameters
    ----------
    xi : (n_points, tdim)
        Reference points.

    Returns
    -------
    (n_points, n_nodes, tdim)
        dφ_k/dξ_j at every point: for degree 1 constant on simplices, multilinear on
        quadrilaterals and hexahedra (φ_k = Π_d (r_kd ξ_d + (1 - r_kd)(1 - ξ_d)) for the reference
        vertex r_k); for degree 2 basix's quadratic basis.
    """
    xi = np.asarray(xi, dtype=np.float64).reshape(-1, CELL_TYPES[cell_type][0])
    if degree != 1:
        table = _compat.lagrange_element(cell_type, degree).tabulate(1, xi)      # (1 + tdim, n, k, 1)
        return np.moveaxis(np.asarray(table)[1:, :, :, 0], 0, -1)
    ref = reference_vertices(cell_type)                                   # (k, tdim)
    if cell_type not in _TENSOR:
        grad = np.vstack([-np.ones(ref.shape[1]), np.eye(ref.shape[1])])   # φ_0 = 1 - Σ ξ, φ_k = ξ_k
        return np.broadcast_to(grad, (xi.shape[0], *grad.shape)).copy()
    factor = ref[None] * xi[:, None] + (1.0 - ref[None]) * (1.0 - xi[:, None])     # (n, k, tdim)
    grad = np.empty_like(factor)
    for j in range(ref.shape[1]):
        others = np.prod(np.delete(factor, j, axis=2), axis=2)
        grad[:, :, j] = others * (2.0 * ref[:, j] - 1.0)
    return grad


def jacobian_determinants(x: np.ndarray, cell_type: str, xi: npt.ArrayLike | None = None) -> np.ndarray:
    """Jacobian determinants of the Lagrange maps of cells from their reference cell.

    Parameters
    ----------
    x : (n_cells, n_nodes, tdim)
        The cells' geometry nodes, DOLFINx's order: their vertices (degree-1 geometry) or all
        nodes of a degree-2 geometry (:func:`~dolfinx_sfvem._compat.geometry_degree` tells them apart).
    xi : (n_points, tdim), optional
        Reference points; default: the reference nodes and the centre (the points where
        :class:`CellMesh` checks its cells).

    Returns
    -------
    (n_cells, n_points)
        det(∂x/∂ξ) at every point (constant in an affine simplex; for a quadrilateral or
        hexahedron of degree 1 the determinant at a vertex is that of the cell's edges from the
        vertex along the reference axes).
    """
    degree = _compat.geometry_degree(cell_type, x.shape[1])
    if xi is None:
        ref = reference_nodes(cell_type, degree)
        xi = np.vstack([ref, reference_vertices(cell_type).mean(axis=0)])
    J = np.einsum("cki,pkj->cpij", x, shape_gradients(cell_type, xi, degree))
    return np.linalg.det(J) if J.size else np.zeros(J.shape[:2])


def mirror_permutation(cell_type: str, degree: int = 1) -> np.ndarray:
    """The node permutation (n_nodes,) that swaps the reference axes 0 and 1 (mirrors a cell, turns
    the sign of its Jacobian determinant everywhere): new node i is old node ``p[i]``."""
    ref = reference_nodes(cell_type, degree)
    swapped = ref.copy()
    swapped[:, [0, 1]] = ref[:, [1, 0]]
    return np.argmin(np.abs(swapped[:, None] - ref[None]).sum(axis=2), axis=1)


def vertices_first(points: np.ndarray, nodes: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray, int, np.ndarray]:
    """The geometry nodes renumbered so that the cells' vertices come first.

    Parameters
    ----------
    points : (n, gdim)
        Geometry node coordinates.
    nodes : (n_cells, k) int
        Every cell's geometry nodes, its ``n_vertices`` vertices first.

    Returns
    -------
    points : (n, gdim)
        The same points, the cells' vertices first, each part in the given order (a mesh whose
        vertices come first is returned unchanged).
    nodes : (n_cells, k) int64
        Renumbered.
    n_vertex_points : int
        How many points are vertices.
    new_index : (n,) int64
        The new index of every given point.
    """
    is_vertex = np.zeros(points.shape[0], dtype=bool)
    is_vertex[nodes[:, :n_vertices]] = True
    order = np.concatenate([np.flatnonzero(is_vertex), np.flatnonzero(~is_vertex)])
    new_index = np.empty(order.size, dtype=np.int64)
    new_index[order] = np.arange(order.size)
    return points[order], new_index[nodes], int(is_vertex.sum()), new_index


def reference_facets(cell_type: str) -> list[list[int]]:
    """The local vertices of every facet of the cell (DOLFINx's facet numbering); the
    vertices of a quadrilateral face in cyclic order (a, b, c, d) around it."""
    facets = basix.topology(getattr(basix.CellType, cell_type))[CELL_TYPES[cell_type][0] - 1]
    return [[f[0], f[1], f[3], f[2]] if len(f) == 4 else list(f) for f in facets]


def reference_edges(cell_type: str) -> list[list[int]]:
    """The local vertices of every edge of the cell (DOLFINx's edge numbering, which numbers
    the degree-2 Lagrange dofs on edges)."""
    return [list(e) for e in basix.topology(getattr(basix.CellType, cell_type))[1]]


def facet_normals(points: np.ndarray, facets: np.ndarray) -> np.ndarray:
    """Area-weighted normals (n, gdim) of facets (n, 2 | 3 | 4) given by their vertices in
    cyclic order: an edge (a, b) in 2D has the normal (b - a) turned clockwise; a triangle
    (a, b, c) ½ (b - a) x (c - a); a quadrilateral (a, b, c, d) ½ (c - a) x (d - b), its area
    vector if planar, else the integral of the normal over the bilinear face through its vertices
    (the same for every surface bounded by its four sides)."""
    x = points[facets]
    if facets.shape[1] == 2:
        d = x[:, 1] - x[:, 0]
        return np.stack([d[:, 1], -d[:, 0]], axis=1)
    if facets.shape[1] == 3:
        return 0.5 * np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
    return 0.5 * np.cross(x[:, 2] - x[:, 0], x[:, 3] - x[:, 1])


def note_flat(mesh: "CellMesh", reader: str) -> None:
    """Say in one logging warning that ``reader`` takes the cells of a curved ``mesh`` (degree-2
    geometry) by their vertices, with flat faces (straight edges in 2D); nothing for degree 1."""
    if mesh.geometry_degree > 1:
        faces = "faces" if mesh.tdim == 3 else "edges"
        log.warning(f"{reader}: the mesh has curved (degree-2) {PLURAL[mesh.cell_type]}; their vertices are kept and "
                    f"their {faces} taken {'flat' if mesh.tdim == 3 else 'straight'} (method='fem' on the "
                    f"CellMesh uses the curved geometry{'' if mesh.tdim == 3 else ' in 3D'})")


class CellOutlines(typing.NamedTuple):
    """The cells that the cells of a :class:`CellMesh` subdivide, for drawing: the SFVEM's polyhedra
    over their fan tetrahedra (:attr:`~dolfinx_sfvem.discretizations.discretization.Discretization.cell_outlines`).

    Attributes
    ----------
    edges : (n_edges, 2) int64
        The edges of the cells (the sides of their faces), as pairs of the mesh's points.
    cell : (n_cells of the mesh,) int64
        The cell that each cell of the mesh lies in.
    """

    edges: npt.NDArray[np.int64]
    cell: npt.NDArray[np.int64]


class CellMesh:
    """A conforming mesh of one cell type with a region tag per cell (module docstring).

    Parameters
    ----------
    points : (n_points, gdim) float
        Geometry node coordinates, gdim = 2 or 3 (3 columns for a 2D cell type with z = 0 are cut).
    cells : (n_cells, k) int
        Geometry node indices of every cell in DOLFINx's order of ``cell_type``: its vertices
        (k = 4 for a tetrahedron, ...: degree-1 geometry), or all nodes of a degree-2 geometry
        (k = 10 for a tetrahedron, 27 for a hexahedron, 6 for a triangle, 9 for a quadrilateral).
    tags : (n_cells,) int
        Region tag of every cell.
    cell_type
        ``"tetrahedron"``, ``"hexahedron"``, ``"triangle"`` or ``"quadrilateral"``.
    region_names
        Name -> tag of named regions (every tag must be one of ``tags``).
    boundary_names
        Name -> facets (m, 2 | 3 | 4) of a named boundary (the physical surfaces of a gmsh model, the
        curves in 2D), as vertex indices; every row must be a facet of the mesh. Boundary
        conditions and loads take them by name (:mod:`~dolfinx_sfvem.mesh.named_boundaries`).

    Raises
    ------
    ValueError
        Naming the cell: a cell of (nearly) zero volume, an inverted or tangled cell (its Jacobian
        determinant changes sign over its vertices and centre), a facet shared by more than two
        cells, a named boundary facet that is no facet of the mesh, bad shapes or indices.

    Attributes
    ----------
    points : (n_points, gdim) float
        The vertices (the given points for degree 1; for degree 2 the points that are vertices of
        a cell, in the given order).
    cells : (n_cells, n_vertices) int64
        The cells' vertices, indices into ``points`` (cells with a negative orientation reordered,
        module docstring).
    node_points : (n_nodes, gdim) float
        All geometry nodes, ``points`` first (the same array for degree 1).
    nodes : (n_cells, k) int64
        Every cell's geometry nodes, indices into ``node_points``; ``nodes[:, :n_vertices]`` is ``cells``.
    geometry_degree : int
        1 or 2.
    tags, region_names, boundary_names, cell_type
        As given (boundary facets as vertex indices).
    gdim, tdim : int
    """

    def __init__(self, points: npt.ArrayLike, cells: npt.ArrayLike, tags: npt.ArrayLike, cell_type: str,
                 region_names: typing.Mapping[str, int] | None = None,
                 boundary_names: typing.Mapping[str, npt.ArrayLike] | None = None):
        if cell_type not in CELL_TYPES:
            raise ValueError(f"cell type {cell_type!r}: use one of {', '.join(CELL_TYPES)}")
        self.cell_type = cell_type
        self.tdim, n_vertices = CELL_TYPES[cell_type]
        points = np.array(points, dtype=np.float64, ndmin=2)
        if points.shape[1] == 3 and self.tdim == 2 and np.all(points[:, 2] == 0.0):
            points = points[:, :2].copy()
        if points.shape[1] != self.tdim:
            raise ValueError(f"{cell_type} mesh: points must have {self.tdim} columns, got shape {points.shape}")
        self.gdim = self.tdim
        cells = np.array(cells, dtype=np.int64, ndmin=2)
        try:
            self.geometry_degree = _compat.geometry_degree(cell_type, cells.shape[1])
        except ValueError as err:
            raise ValueError(f"{err} (got shape {cells.shape})") from None
        if cells.size and (cells.min() < 0 or cells.max() >= points.shape[0]):
            bad = int(np.flatnonzero((cells < 0).any(axis=1) | (cells >= points.shape[0]).any(axis=1))[0])
            raise ValueError(f"{cell_type} {bad} has vertex indices {cells[bad].tolist()} outside [0, {points.shape[0]})")
        tags = np.asarray(tags, dtype=np.int64).reshape(-1)
        if tags.shape != (cells.shape[0],):
            raise ValueError(f"one tag per cell expected: {tags.size} tags for {cells.shape[0]} cells")
        if self.geometry_degree > 1:
            points, cells, n_vertex_points, _ = vertices_first(points, cells, n_vertices)
        else:
            n_vertex_points = points.shape[0]
        self.node_points = points
        self.nodes = self._oriented(cells)
        self.points = points[:n_vertex_points]
        self.cells = self.nodes[:, :n_vertices]
        self._edge_nodes: tuple[np.ndarray, np.ndarray] | None = None      # :meth:`edge_midpoints`
        self.tags = tags
        self.region_names = {str(name): int(tag) for name, tag in (region_names or {}).items()}
        unknown = {name: tag for name, tag in self.region_names.items() if tag not in set(tags.tolist())}
        if unknown:
            raise ValueError(f"region names {unknown} name tags that no cell has")
        self._facets = self._all_facets()
        self.boundary_names = self._named_facets(boundary_names or {})

    # ------------------------------------------------------------------ validation
    def _oriented(self, cells: np.ndarray) -> np.ndarray:
        """The cells (geometry nodes) with a positive Jacobian determinant at their nodes and centre
        (mirrored where it is negative there); ValueError naming a cell where it vanishes or changes sign."""
        x = self.node_points[cells]                                 # (n, k, d)
        det = jacobian_determinants(x, self.cell_type)              # (n, k + 1)
        corners = x[:, :CELL_TYPES[self.cell_type][1]]
        size = np.linalg.norm(corners[:, :, None] - corners[:, None], axis=3).max(axis=(1, 2)) if len(x) \
            else np.zeros(0)
        tol = TOLERANCE * size[:, None] ** self.tdim
        positive, negative = np.all(det > tol, axis=1), np.all(det < -tol, axis=1)
        bad = np.flatnonzero(~positive & ~negative)
        if bad.size:
            c = int(bad[0])
            n_vertices = CELL_TYPES[self.cell_type][1]
            nodes = "vertices" if self.geometry_degree == 1 else "nodes"
            where = [f"vertex {k}" if k < n_vertices else f"node {k}" for k in range(det.shape[1] - 1)] + ["the centre"]
            lo, hi = int(np.argmin(det[c])), int(np.argmax(det[c]))
            what = "has zero volume" if np.all(np.abs(det[c]) <= tol[c]) else \
                (f"is inverted or degenerate: the Jacobian determinant of its map from the reference cell is "
                 f"{det[c, lo]:.3g} at its {where[lo]} and {det[c, hi]:.3g} at its {where[hi]} (it must "
                 f"have one sign, away from zero, at the {nodes} and the centre)")
            raise ValueError(f"{self.cell_type} {c} ({nodes} {cells[c].tolist()}, points "
                             f"{np.round(self.node_points[cells[c]], 12).tolist()}) {what}")
        if self.geometry_degree > 1 and len(det):
            ratio = np.abs(det).min(axis=1) / np.abs(det).max(axis=1)
            worst = int(np.argmin(ratio))
            if ratio[worst] < CURVED_RATIO_WARNING:
                log.warning("%d curved %s(s) nearly tangled: the Jacobian determinant of %s %d varies by a factor "
                            "%.3g between its nodes (a valid cell, but programs that invert its map may fail on it; "
                            "gmsh's Mesh.HighOrderOptimize straightens such cells)",
                            int(np.sum(ratio < CURVED_RATIO_WARNING)), self.cell_type, self.cell_type, worst,
                            1 / ratio[worst])
        cells = cells.copy()
        cells[negative] = cells[negative][:, mirror_permutation(self.cell_type, self.geometry_degree)]
        return cells

    def _all_facets(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every facet once: (vertices (m, 2|3|4) oriented out of ``cell``, cell (m,), neighbour (m,)
        or -1); ValueError for a facet of more than two cells."""
        local = reference_facets(self.cell_type)
        n_cells = self.cells.shape[0]
        facets = np.concatenate([self.cells[:, f] for f in local]) if n_cells else \
            np.empty((0, len(local[0])), np.int64)
        cell = np.tile(np.arange(n_cells), len(local))
        # out of the cell: the normal points away from the cell's centre
        centre = self.points[self.cells].mean(axis=1) if n_cells else np.zeros((0, self.gdim))
        inward = np.einsum("ij,ij->i", facet_normals(self.points, facets),
                           self.points[facets].mean(axis=1) - centre[cell]) < 0
        facets[inward] = facets[inward][:, ::-1]
        _, first, inverse, counts = np.unique(np.sort(facets, axis=1), axis=0, return_index=True,
                                              return_inverse=True, return_counts=True)
        inverse = inverse.reshape(-1)
        if counts.size and counts.max() > 2:
            f = int(np.argmax(counts))
            cells = np.sort(cell[inverse == f]).tolist()
            raise ValueError(f"{self.cell_type} mesh is not conforming: the facet with vertices "
                             f"{np.sort(facets[first[f]]).tolist()} belongs to the cells {cells}")
        neighbour = np.full(first.size, -1, dtype=np.int64)
        other = np.flatnonzero(np.arange(inverse.size) != first[inverse])   # the second cell of a shared facet
        neighbour[inverse[other]] = cell[other]
        return facets[first], cell[first], neighbour

    def _named_facets(self, names: typing.Mapping[str, npt.ArrayLike]) -> dict[str, np.ndarray]:
        """``boundary_names`` checked: every row a facet of the mesh (ValueError naming one that is not)."""
        k = len(reference_facets(self.cell_type)[0])
        named = boundary_names_check(names, self.n_points, (k,))
        known = {tuple(f) for f in np.sort(self._facets[0], axis=1).tolist()}
        for name, facets in named.items():
            stray = [f for f in facets.tolist() if tuple(sorted(f)) not in known]
            if stray:
                raise ValueError(f"boundary {name!r}: {len(stray)} of its facets are no facets of the {self.cell_type} "
                                 f"mesh, e.g. the one with vertices {stray[0]}")
        return named

    # ------------------------------------------------------------------ queries
    @property
    def n_points(self) -> int:
        return int(self.points.shape[0])

    @property
    def n_cells(self) -> int:
        return int(self.cells.shape[0])

    @property
    def centroids(self) -> np.ndarray:
        """The mean of every cell's vertices (n_cells, gdim): the centroid of a simplex."""
        return self.points[self.cells].mean(axis=1)

    @property
    def volumes(self) -> np.ndarray:
        """Volume (area in 2D) of every cell (n_cells,), exact: the Jacobian determinant integrated
        over the reference cell (constant on an affine simplex; 2-point Gauss per direction on a
        degree-1 quadrilateral or hexahedron; a rule of degree 6 on curved cells)."""
        if self.geometry_degree > 1:
            xi, w = _compat.reference_quadrature(self.cell_type, _CURVED_VOLUME_DEGREE)
            return jacobian_determinants(self.node_points[self.nodes], self.cell_type, xi) @ w
        x = self.points[self.cells]
        if self.cell_type not in _TENSOR:
            return jacobian_determinants(x, self.cell_type)[:, 0] / (6.0 if self.tdim == 3 else 2.0)
        xi = np.stack(np.meshgrid(*[_GAUSS_2] * self.tdim, indexing="ij"), axis=-1).reshape(-1, self.tdim)
        return jacobian_determinants(x, self.cell_type, xi).sum(axis=1) / xi.shape[0]

    def boundary_facets(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The facets on the boundary of the mesh or between two different region tags.

        Returns
        -------
        facets : (nf, 2 | 3 | 4) int64
            Vertex indices, ordered so that the normal (:func:`facet_normals`) points out of
            ``cell``; quadrilateral faces in cyclic order.
        cell : (nf,) int64
            The cell the facet is oriented out of: its only cell on the outer boundary; on an
            interface the cell with the smaller region tag (e.g. the solid, ``SOLID = 1``,
            facing the medium, ``MEDIUM = 2``; :meth:`region_surface` gives either side).
        neighbour : (nf,) int64
            The cell on the other side, -1 on the outer boundary.
        """
        facets, cell, neighbour = self._facets
        other = np.where(neighbour >= 0, neighbour, cell)
        chosen = (neighbour < 0) | (self.tags[cell] != self.tags[other])
        facets, cell, neighbour = facets[chosen], cell[chosen], neighbour[chosen]
        flip = (neighbour >= 0) & (self.tags[np.maximum(neighbour, 0)] < self.tags[cell])
        facets[flip] = facets[flip][:, ::-1]
        cell[flip], neighbour[flip] = neighbour[flip], cell[flip]
        return facets, cell, neighbour

    def region_surface(self, tags: typing.Iterable[int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The surface of the union of the regions ``tags``: (facets oriented out of it, the cell
        inside, the cell outside or -1), as :meth:`boundary_facets`."""
        inside = np.isin(self.tags, np.fromiter(tags, dtype=np.int64))
        facets, cell, neighbour = (a.copy() for a in self._facets)
        out_in = (neighbour >= 0) & ~inside[cell] & inside[np.maximum(neighbour, 0)]
        facets[out_in] = facets[out_in][:, ::-1]
        cell[out_in], neighbour[out_in] = neighbour[out_in], cell[out_in]
        chosen = inside[cell] & ((neighbour < 0) | ~inside[np.maximum(neighbour, 0)])
        return facets[chosen], cell[chosen], neighbour[chosen]

    def edge_midpoints(self, a: npt.ArrayLike, b: npt.ArrayLike) -> np.ndarray:
        """The geometry's points (m, gdim) in the middle of the edges between the points ``a`` and
        ``b`` (m,): the edge's node of a degree-2 geometry (on the curved edge), the mean of
        the two points for degree 1. ValueError for a pair that is no edge (degree 2)."""
        a, b = np.asarray(a, dtype=np.int64).reshape(-1), np.asarray(b, dtype=np.int64).reshape(-1)
        if self.geometry_degree == 1:
            return 0.5 * (self.points[a] + self.points[b])
        if self._edge_nodes is None:
            n_vertices = CELL_TYPES[self.cell_type][1]
            pairs = reference_edges(self.cell_type)
            keys = np.concatenate([edge_key(self.cells[:, i], self.cells[:, j], self.n_points) for i, j in pairs])
            node = np.concatenate([self.nodes[:, n_vertices + k] for k in range(len(pairs))])
            keys, first = np.unique(keys, return_index=True)
            self._edge_nodes = keys, node[first]
        return self.node_points[self._lookup(*self._edge_nodes, edge_key(a, b, self.n_points), "edge")]

    def face_centres(self, faces: npt.ArrayLike) -> np.ndarray:
        """The geometry's points (m, gdim) at the centres of the quadrilateral faces (m, 4) (vertex
        indices in cyclic order): the face's node of a degree-2 geometry, the image of the
        reference face's centre (the mean of the four vertices) for degree 1."""
        faces = np.asarray(faces, dtype=np.int64).reshape(-1, 4)
        if self.geometry_degree == 1:
            return self.points[faces].mean(axis=1)
        local = [f for f in reference_facets(self.cell_type) if len(f) == 4] if self.tdim == 3 else []
        if not local:
            raise ValueError(f"a {self.cell_type} mesh has no quadrilateral faces")
        first = CELL_TYPES[self.cell_type][1] + len(reference_edges(self.cell_type))
        keys = np.concatenate([edge_key(self.cells[:, f[0]], self.cells[:, f[2]], self.n_points) for f in local])
        node = np.concatenate([self.nodes[:, first + k] for k in range(len(local))])
        keys, unique = np.unique(keys, return_index=True)
        return self.node_points[self._lookup(keys, node[unique], edge_key(faces[:, 0], faces[:, 2], self.n_points),
                                             "face")]

    def facet_nodes(self, facets: npt.ArrayLike) -> np.ndarray:
        """The geometry's nodes (k, gdim) of the facets beyond their vertices: their edges' nodes
        (:meth:`edge_midpoints`) and the centres of quadrilateral faces (:meth:`face_centres`); on a
        degree-2 geometry these lie on the curved facets, off the flat ones through the vertices.

        Parameters
        ----------
        facets : (m, 2 | 3 | 4) int
            Vertex indices: edges (2D), triangles or quadrilaterals in cyclic order (3D).
        """
        facets = np.asarray(facets, dtype=np.int64)
        k = facets.shape[1]
        sides = facets[:, [0, 1]] if k == 2 else np.stack([facets, np.roll(facets, -1, axis=1)], axis=2).reshape(-1, 2)
        nodes = [self.edge_midpoints(sides[:, 0], sides[:, 1])]
        if k == 4:
            nodes.append(self.face_centres(facets))
        return np.concatenate(nodes)

    @staticmethod
    def _lookup(keys: np.ndarray, values: np.ndarray, wanted: np.ndarray, what: str) -> np.ndarray:
        """``values`` at the sorted ``keys`` equal to ``wanted``; ValueError for a key not found."""
        at = np.minimum(np.searchsorted(keys, wanted), max(keys.size - 1, 0))
        if keys.size == 0 or np.any(keys[at] != wanted):
            raise ValueError(f"a requested {what} is no {what} of the mesh")
        return values[at]

    def edges(self) -> np.ndarray:
        """Every edge once, (n_edges, 2) int64 point indices, the lower first."""
        pairs = np.concatenate([self.cells[:, e] for e in reference_edges(self.cell_type)])
        return np.unique(np.sort(pairs, axis=1), axis=0)

    # ------------------------------------------------------------------ DOLFINx
    @classmethod
    def from_dolfinx(cls, mesh, cell_tags, region_names: typing.Mapping[str, int] | None = None) -> "CellMesh":
        """The mesh of a (distributed) DOLFINx mesh and its cell tags, on every rank (collective), at
        the geometry degree the mesh has (1 or 2). Points are ordered by their input index (for
        degree 2 the vertices first), cells by their input index; every cell must be tagged
        (ValueError naming an untagged one)."""
        tag = np.full(_compat.num_owned_cells(mesh) + mesh.topology.index_map(mesh.topology.dim).num_ghosts,
                      np.iinfo(np.int64).min, dtype=np.int64)
        tag[cell_tags.indices] = cell_tags.values
        points, cells, tags, _ = gather_cells(mesh, tag, mesh.comm)
        if np.any(tags == np.iinfo(np.int64).min):
            raise ValueError(f"cell {int(np.argmin(tags))} (input index) has no region tag")
        return cls(points, cells, tags, mesh.topology.cell_type.name, region_names)


def gather_cells(mesh, cell_tag: np.ndarray, comm: MPI.Comm
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The global mesh on every rank, from the owned cells of each rank (collective).

    Parameters
    ----------
    cell_tag : (n_local_cells,)
        A value per local cell (the region tags).

    Returns
    -------
    points : (n_points, gdim)
        The geometry nodes used by cells, ordered by input index.
    cells : (n_cells, k) int64
        Indices into ``points`` in DOLFINx's vertex order, ordered by input cell index.
    tags : (n_cells,)
        ``cell_tag`` of every cell.
    point_of_node : (n_local_geometry_nodes,) int64
        Index in ``points`` of every local geometry node.
    """
    gdim = mesh.geometry.dim
    n_owned = _compat.num_owned_cells(mesh)
    geometry = _compat.cell_geometry_nodes(mesh)
    inp = _compat.input_node_index(mesh)
    local = (_compat.original_cell_index(mesh)[:n_owned], inp[geometry[:n_owned]],
             mesh.geometry.x[geometry[:n_owned], :gdim], cell_tag[:n_owned])
    cell, nodes, x, tags = (np.concatenate(part) for part in zip(*comm.allgather(local)))
    inputs, first, cells = np.unique(nodes.ravel(), return_index=True, return_inverse=True)
    order = np.argsort(cell)
    cells = cells.reshape(-1, geometry.shape[1])[order]
    return x.reshape(-1, gdim)[first], cells.astype(np.int64), tags[order], np.searchsorted(inputs, inp)
