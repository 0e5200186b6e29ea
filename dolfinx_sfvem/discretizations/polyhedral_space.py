"""The order-2 SFVEM displacement space on a polyhedral mesh, hosted by DOLFINx and distributed over MPI.

Every polyhedron E carries, per displacement component, its vertex values, its edge-midpoint
values, the mean on each of its faces and its own mean (docs/method.md §8), n_d = n_v + n_e +
n_f + 1 DOFs. As the 2D :class:`~dolfinx_sfvem.discretizations.space.VEMSpace` does for polygons, the space sits
on the DOLFINx P2 space of a tetrahedral sub-mesh, the *fan mesh*:

- every face is fanned from its centroid into triangles (centroid, side), once per global face,
  so that the two cells of a face see the same triangles and the tetrahedral mesh is conforming;
- every polyhedron is fanned from its centroid into the tetrahedra (cell centroid, face
  triangle).

The P2 space of the fan mesh has a node at every polyhedron vertex, at the midpoint of every
polyhedron edge (a face side is a tetrahedron edge; hanging vertices of octree cells are ordinary
vertices), at every face centroid (it hosts the face mean) and at every cell centroid (it hosts the
cell mean); DOLFINx gives these nodes their owners and ghosts. The other P2 nodes (midpoints of the
spokes to the centres) are *not* unknowns: the numbering built here holds the SFVEM nodes only.
Each polyhedron's tetrahedra are owned by one rank (recursive coordinate bisection of the cell
centroids), so the element loops never cross ranks.

The fans start from the centroids where these see the whole face or cell (convex cells, octree
cells with hanging vertices, prisms over convex polygons, Voronoi cells); elsewhere from the centre
of the largest disc or ball inside the kernel of the face or cell (the points that see all of it).
A face or cell that is not star-shaped (empty kernel) raises ValueError naming the cell.

Local numbering: SFVEM *nodes* owned first, then ghosts; the unknowns are blocked by three
components, unknown ``3 * node + i`` for component ``i``. Node keys do not depend on the partition:
the point index of a vertex, ``n_points + e`` for the midpoint of edge ``e`` of
:meth:`PolyhedronMesh.edges`, ``n_points + n_edges + f`` for the mean on face ``f`` and
``n_points + n_edges + n_faces + c`` for the mean of cell ``c``.
"""
from __future__ import annotations

import logging
import typing

import numpy as np
import numpy.typing as npt
import scipy.sparse
from mpi4py import MPI
from petsc4py import PETSc
from scipy.optimize import linprog

import dolfinx
import dolfinx.fem

from dolfinx_sfvem import _compat
from dolfinx_sfvem.output.logs import say
from dolfinx_sfvem.mesh.polygon_mesh import coordinate_bisection
from dolfinx_sfvem.mesh.csr import concatenated_ranges, next_entries, segment_owner
from dolfinx_sfvem.discretizations.monomials3d import exponents3
from dolfinx_sfvem.mesh.polyhedron import energy_quadrature, tetrahedron_rule
from dolfinx_sfvem.discretizations.monomials import evaluate_monomials
from dolfinx_sfvem.mesh.polyhedron_mesh import PolyhedronMesh, plane_coordinates
from dolfinx_sfvem.discretizations.projection import pi_nabla_2, polygon_geometry
from dolfinx_sfvem.discretizations.projection3d import L_MIN, build_projections_3d
from dolfinx_sfvem.discretizations.quadrature import triangle_rule
from dolfinx_sfvem.discretizations.space import MIDPOINT, EdgeLookup, SFVEMNodes

#: kinds of SFVEM nodes on polyhedra beyond the vertices and edge midpoints (:data:`VERTEX`,
#: :data:`MIDPOINT`): the means on the faces and over the cells
FACE, CELL = 2, 3

#: the end vertices of the edges of the reference tetrahedron (basix): the P2 dof 4 + k sits on edge k
TET_EDGES = np.array([[2, 3], [1, 3], [1, 2], [0, 3], [0, 2], [0, 1]])

#: smallest fan tetrahedron or triangle, relative to its cell's volume or its face's area
_FAN_RTOL = 1e-10

log = logging.getLogger(__name__)


class FanMesh(typing.NamedTuple):
    """The fan tetrahedra of a :class:`PolyhedronMesh` (module docstring).

    Attributes
    ----------
    nodes : (n_points + n_faces + n_cells, 3) float64
        The mesh points, then the face centres, then the cell centres (the centroids, or kernel
        centres where the centroid does not see the whole face or cell).
    tetrahedra : (n_tet, 4) int64
        (cell centre, face centre, a, b) for every side (a, b) of every face of every cell, in
        cell order, positively oriented.
    tetrahedron_cell : (n_tet,) int64
        The polyhedron of each tetrahedron.
    triangles : (n_tri, 3) int64
        (face centre, a, b) for every side of every global face, in face order, oriented as the
        stored face.
    triangle_face : (n_tri,) int64
        The face of each triangle.
    """

    nodes: npt.NDArray[np.float64]
    tetrahedra: npt.NDArray[np.int64]
    tetrahedron_cell: npt.NDArray[np.int64]
    triangles: npt.NDArray[np.int64]
    triangle_face: npt.NDArray[np.int64]


def kernel_centre(normals: npt.NDArray[np.float64], points: npt.NDArray[np.float64],
                  plane: tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]] | None = None
                  ) -> tuple[npt.NDArray[np.float64], float]:
    """Centre (3,) and radius of the largest ball inside {x : normals_i . (x - points_i) <= 0} (the
    kernel of a cell given by its outward face normals and points on the faces; with ``plane`` =
    (normal, point) the largest disc in that plane: the kernel of a face given by its sides' outward
    in-plane normals). A linear program (scipy HiGHS); radius 0 when the kernel is empty or flat."""
    unit = normals / np.linalg.norm(normals, axis=1)[:, None]
    A_ub = np.column_stack([unit, np.ones(len(unit))])
    b_ub = np.einsum("ij,ij->i", unit, points)
    A_eq, b_eq = (None, None) if plane is None else (np.append(plane[0], 0.0)[None], [float(plane[0] @ plane[1])])
    result = linprog([0, 0, 0, -1], A_ub=A_ub, b_ub=b_ub, A_eq=A_eq, b_eq=b_eq,
                     bounds=[(None, None)] * 3 + [(0, None)], method="highs")
    return (result.x[:3], float(result.x[3])) if result.status == 0 else (points.mean(axis=0), 0.0)


def _fan_triangles(mesh: PolyhedronMesh, centres: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Areas (n_sides,) of the triangles (face centre, side) in the stored faces' orientation."""
    side_face = segment_owner(mesh.face_offsets)
    a = mesh.points[mesh.face_vertices] - centres[side_face]
    b = mesh.points[mesh.face_vertices[next_entries(mesh.face_offsets)]] - centres[side_face]
    normal = mesh.face_area_vectors[side_face] / np.linalg.norm(mesh.face_area_vectors[side_face], axis=1)[:, None]
    return 0.5 * np.einsum("ij,ij->i", np.cross(a, b), normal)


def fan_mesh(mesh: PolyhedronMesh) -> FanMesh:
    """The conforming fan tetrahedra of ``mesh`` (module docstring).

    Each face is fanned from its centroid, or, where the centroid does not see the whole face, from
    the centre of the largest disc in its kernel (the points that see all of it); each cell likewise
    from its centroid or the centre of the largest ball in its kernel.

    Raises
    ------
    ValueError
        Naming the cell with a face or itself not star-shaped (empty kernel).
    """
    n_p, n_f = mesh.n_points, mesh.n_faces
    side_face = segment_owner(mesh.face_offsets)
    a, b = mesh.face_vertices, mesh.face_vertices[next_entries(mesh.face_offsets)]
    face_area = np.linalg.norm(mesh.face_area_vectors, axis=1)
    face_centres = mesh.face_centroids.copy()
    for f in np.unique(side_face[_fan_triangles(mesh, face_centres) <= _FAN_RTOL * face_area[side_face]]):
        ends = mesh.points[b[side_face == f]] - mesh.points[a[side_face == f]]
        face_centres[f], radius = kernel_centre(np.cross(ends, mesh.face_area_vectors[f]),
                                                mesh.points[a[side_face == f]],
                                                (mesh.face_area_vectors[f], mesh.face_centroids[f]))
    bad = np.flatnonzero(_fan_triangles(mesh, face_centres) <= _FAN_RTOL * face_area[side_face])
    if bad.size:
        f = int(side_face[bad[0]])
        raise ValueError(f"cell {int(mesh.face_cells[f].max())}: its face {f} (vertices {mesh.face(f).tolist()}) "
                         f"is not star-shaped: the fan mesh of the polyhedral space needs a point that sees it all")
    # cell fans: every side of every face of every cell, turned out of the cell
    entry_cell = segment_owner(mesh.cell_offsets)
    face = mesh.cell_faces
    count = np.diff(mesh.face_offsets)[face]
    sides = concatenated_ranges(mesh.face_offsets[face], count)
    cell = np.repeat(entry_cell, count)
    outward = np.repeat(mesh.cell_face_signs, count) > 0
    a_out, b_out = np.where(outward, a[sides], b[sides]), np.where(outward, b[sides], a[sides])
    tetrahedra = np.column_stack([n_p + n_f + cell, n_p + side_face[sides], a_out, b_out])

    def volumes(nodes):
        X = nodes[tetrahedra]
        return np.einsum("ij,ij->i", X[:, 1] - X[:, 0], np.cross(X[:, 2] - X[:, 0], X[:, 3] - X[:, 0])) / 6

    nodes = np.concatenate([mesh.points, face_centres, mesh.centroids])
    for c in np.unique(cell[volumes(nodes) <= _FAN_RTOL * mesh.volumes[cell]]):
        faces = mesh.cell_face_indices(c)
        signs = mesh.cell_face_signs[mesh.cell_offsets[c]:mesh.cell_offsets[c + 1]]
        nodes[n_p + n_f + c], _ = kernel_centre(signs[:, None] * mesh.face_area_vectors[faces], face_centres[faces])
    volume = volumes(nodes)
    bad = np.flatnonzero(volume <= _FAN_RTOL * mesh.volumes[cell])
    if bad.size:
        k = int(bad[0])
        raise ValueError(f"cell {int(cell[k])} is not star-shaped: no point sees all its faces from inside (the fan "
                         f"tetrahedron on the side ({int(a_out[k])}, {int(b_out[k])}) of its face "
                         f"{int(side_face[sides[k]])} has volume {volume[k]:.3g}); the fan mesh of the polyhedral "
                         f"space needs one")
    triangles = np.column_stack([n_p + side_face, a, b])
    return FanMesh(nodes, tetrahedra.astype(np.int64), cell.astype(np.int64), triangles.astype(np.int64),
                   side_face.astype(np.int64))


def n_unknowns(mesh: PolyhedronMesh) -> int:
    """Number of SFVEM displacement unknowns on ``mesh``: 3 x (vertices + edges + faces + cells)."""
    return 3 * (np.unique(mesh.face_vertices).size + mesh.edges().shape[0] + mesh.n_faces + mesh.n_cells)


def _simplex_means(f: typing.Callable[[np.ndarray], np.ndarray], X: np.ndarray, owner: np.ndarray, n: int,
                   degree: int) -> np.ndarray:
    """Means (n, value) of ``f`` over the unions of simplices ``X`` (m, k, 3) (k = 3 or 4) owned by
    ``owner`` (m,) in [0, n), by the Gauss rule of ``degree`` on each simplex (positive measures)."""
    k = X.shape[1]
    ref_points, ref_weights = (triangle_rule if k == 3 else tetrahedron_rule)(degree)
    J = X[:, 1:] - X[:, :1]                                                   # (m, k-1, 3)
    measure = (0.5 * np.linalg.norm(np.cross(J[:, 0], J[:, 1]), axis=1) if k == 3
               else np.abs(np.linalg.det(J)) / 6)
    x = X[:, None, 0] + np.einsum("qd,mdj->mqj", ref_points, J)              # (m, q, 3)
    values = np.asarray(f(x.reshape(-1, 3).T), dtype=np.float64).T.reshape(x.shape[0], x.shape[1], -1)
    w = measure[:, None] * ref_weights[None, :] / ref_weights.sum()
    integral = np.zeros((n, values.shape[2]))
    np.add.at(integral, owner, np.einsum("mq,mqv->mv", w, values))
    size = np.bincount(owner, weights=measure, minlength=n)
    return integral / size[:, None]


class PolyhedralSpace(SFVEMNodes):
    """SFVEM space of order 2 (vector valued, 3D) on a :class:`PolyhedronMesh`: its nodes, their
    parallel numbering and PETSc layout (module docstring).

    Parameters
    ----------
    mesh
        The polyhedral mesh (identical on every rank).
    comm
        Communicator; polyhedra are distributed by coordinate bisection of their centroids.
    l
        Degree of the gradient projection for every polyhedron; default the smallest sufficient
        one per polyhedron (the rank test of docs/method.md §8).
    l_min
        Smallest degree the automatic choice tries.
    quadrature
        The energy rule (:func:`~dolfinx_sfvem.mesh.polyhedron.energy_quadrature`), exact for degree
        2 l: ``"auto"`` (tensor rule on boxes, sub-tetrahedra elsewhere), ``"tetrahedra"`` or
        ``"compressed"``.
    verbose
        Print a summary on rank 0.

    Attributes
    ----------
    gdim : int
        The mesh's dimension: 3.
    mesh : dolfinx.mesh.Mesh
        The distributed fan mesh of tetrahedra.
    V : dolfinx.fem.FunctionSpace
        Vector P2 space on it (node layout, output).
    cell_polyhedron : (n_local_tets,) int64
        Global polyhedron of every local tetrahedron (owned first, then ghosts).
    cells : (n_local,) int64
        Global indices of the polyhedra owned by this rank (sorted).
    tags : (n_local,) int64
        Their region tags.
    dof_offsets, dofs : CSR arrays
        ``dofs[dof_offsets[k]:dof_offsets[k+1]]`` are the local SFVEM nodes of local polyhedron k in
        the element's DOF order: [vertices in the order of ``PolyhedronMesh.polyhedron(c)``, edges in
        ``polyhedron.polyhedron_edges`` order, faces in the cell's face order, the cell mean].
    index_map : dolfinx.cpp.common.IndexMap
        Owned/ghost layout of the SFVEM nodes (block size 3 for the unknowns).
    p2_node : (n_local_nodes,) int64
        Local P2 node hosting each SFVEM node.
    x_nodes : (n_local_nodes, 3) float64
        Coordinates of the SFVEM nodes (face and cell means at the fan centres hosting them: the
        centroids, or kernel centres, :func:`fan_mesh`).
    node_kind : (n_local_nodes,) int8
        VERTEX, MIDPOINT, FACE or CELL.
    node_key : (n_local_nodes,) int64
        Partition-independent node id (module docstring).
    global_nodes : (n_local_nodes,) int64
        Global SFVEM node index of every local node.
    projections : Projections
        Π^∇_2 and Π⁰_l∇ of the local polyhedra, in ``cells`` order
        (:func:`~dolfinx_sfvem.discretizations.projection3d.build_projections_3d`).
    quadrature : str
        The name of the energy rule.
    q_offsets, x_q, w_q
        Energy quadrature of the local polyhedra (:class:`SFVEMNodes`; weights [volume]).
    """

    def __init__(self, mesh: PolyhedronMesh, comm: MPI.Comm = MPI.COMM_WORLD, *, l: int | None = None,
                 l_min: int = L_MIN, quadrature: str = "auto", verbose: bool = True):
        self.polyhedron_mesh = mesh
        self.comm = comm
        self.gdim = mesh.gdim
        self.fan = fan_mesh(mesh)
        self._edges = mesh.edges()
        if comm.rank == 0:
            cells, x = self.fan.tetrahedra, self.fan.nodes
            destinations = coordinate_bisection(mesh.centroids, comm.size)[self.fan.tetrahedron_cell]
        else:
            cells, x = np.empty((0, 4), dtype=np.int64), np.empty((0, 3))
            destinations = np.empty(0, dtype=np.int32)
        self.mesh = _compat.create_tetrahedron_mesh(comm, cells, x, destinations)
        self.cell_polyhedron = self.fan.tetrahedron_cell[_compat.original_cell_index(self.mesh)]
        self.V = _compat.vector_function_space(self.mesh, 2)
        self.cells = np.unique(self.cell_polyhedron[:_compat.num_owned_cells(self.mesh)]).astype(np.int64)
        self.tags = mesh.tags[self.cells]
        self._number_nodes(*self._polyhedron_p2_nodes())
        self._to_p2: scipy.sparse.csr_matrix | None = None
        self._by_key: np.ndarray | None = None
        self._to_trace = None
        say(log, self.summary(), verbose, comm)
        self.projections = build_projections_3d(mesh.points, mesh.face_offsets, mesh.face_vertices, mesh.cell_offsets,
                                                mesh.cell_faces, mesh.cell_face_signs, cells=self.cells, l=l,
                                                l_min=l_min)
        self.quadrature = quadrature
        rules = [energy_quadrature(*mesh.polyhedron(c), 2 * int(self.projections.l[k]), quadrature)
                 for k, c in enumerate(self.cells)]
        self.q_offsets = np.concatenate([[0], np.cumsum([len(w) for _, w in rules])]).astype(np.int64)
        self.x_q = np.concatenate([x for x, _ in rules]) if rules else np.empty((0, 3))
        self.w_q = np.concatenate([w for _, w in rules]) if rules else np.empty(0)

    # ------------------------------------------------------------------ numbering
    def _polyhedron_p2_nodes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Local P2 node, kind and key of every DOF of the local polyhedra, in element order."""
        mesh = self.polyhedron_mesh
        n_p, n_e, n_f = mesh.n_points, self._edges.shape[0], mesh.n_faces
        inp = _compat.input_node_index(self.mesh)[_compat.cell_geometry_nodes(self.mesh)]
        p2 = _compat.cell_dofs(self.V)
        n_in = self.fan.nodes.shape[0]
        node_of_input = np.full(n_in, -1, dtype=np.int64)
        node_of_input[inp.ravel()] = p2[:, :4].ravel()
        edge_node = EdgeLookup(inp[:, TET_EDGES[:, 0]].ravel(), inp[:, TET_EDGES[:, 1]].ravel(),
                               p2[:, 4:].ravel(), n_in)

        P = self.cells
        n_faces = np.diff(mesh.cell_offsets)[P]
        entries = concatenated_ranges(mesh.cell_offsets[P], n_faces)
        face = mesh.cell_faces[entries]
        local = np.repeat(np.arange(P.size), n_faces)
        count = np.diff(mesh.face_offsets)[face]
        sides = concatenated_ranges(mesh.face_offsets[face], count)
        side_cell = np.repeat(local, count)
        a = mesh.face_vertices[sides]
        b = mesh.face_vertices[next_entries(mesh.face_offsets)[sides]]
        # vertices sorted by point index and edges by sorted pair, per cell: the element's orders
        vertices = np.unique(np.column_stack([side_cell, a]), axis=0)
        edges = np.unique(np.column_stack([side_cell, np.minimum(a, b), np.maximum(a, b)]), axis=0)
        n_v = np.bincount(vertices[:, 0], minlength=P.size)
        n_ed = np.bincount(edges[:, 0], minlength=P.size)

        nd = n_v + n_ed + n_faces + 1
        self.dof_offsets = np.concatenate([[0], np.cumsum(nd)]).astype(np.int64)
        first = self.dof_offsets[:-1]
        at = [concatenated_ranges(first, n_v), concatenated_ranges(first + n_v, n_ed),
              concatenated_ranges(first + n_v + n_ed, n_faces), first + n_v + n_ed + n_faces]
        edge_index = np.searchsorted(self._edges[:, 0] * n_p + self._edges[:, 1], edges[:, 1] * n_p + edges[:, 2])
        hosts = [node_of_input[vertices[:, 1]], edge_node(edges[:, 1], edges[:, 2]),
                 node_of_input[n_p + face], node_of_input[n_p + n_f + P]]
        keys = [vertices[:, 1], n_p + edge_index, n_p + n_e + face, n_p + n_e + n_f + P]
        nodes = np.empty(self.dof_offsets[-1], dtype=np.int64)
        kind = np.empty(self.dof_offsets[-1], dtype=np.int8)
        key = np.empty(self.dof_offsets[-1], dtype=np.int64)
        for k, (where, host, kk) in enumerate(zip(at, hosts, keys)):
            nodes[where], kind[where], key[where] = host, k, kk
        if np.any(nodes < 0):
            raise RuntimeError("a polyhedron node is missing from the fan mesh")
        return nodes, kind, key

    # ------------------------------------------------------------------ fields
    def interpolate(self, f: typing.Callable[[np.ndarray], np.ndarray], degree: int = 4) -> PETSc.Vec:
        """The SFVEM interpolant of a vector field: its values at the vertices and edge midpoints, its
        means on the faces and over the cells.

        Parameters
        ----------
        f
            ``f(x)`` with ``x`` (3, n) returns (3, n).
        degree
            Polynomial degree integrated exactly by the means (Gauss rules on the fan triangles and
            tetrahedra).

        Returns
        -------
        PETSc.Vec
            Ghosted vector (block size 3), every local node (owned and ghost) set.
        """
        mesh = self.polyhedron_mesh
        n_p, n_e, n_f = mesh.n_points, self._edges.shape[0], mesh.n_faces
        values = np.zeros((self.n_local_nodes, 3))
        point = self.node_kind <= MIDPOINT
        values[point] = np.asarray(f(self.x_nodes[point].T), dtype=np.float64).T
        for kind, offset, simplices, owner, n in (
                (FACE, n_p + n_e, self.fan.triangles, self.fan.triangle_face, n_f),
                (CELL, n_p + n_e + n_f, self.fan.tetrahedra, self.fan.tetrahedron_cell, mesh.n_cells)):
            nodes = np.flatnonzero(self.node_kind == kind)
            which = self.node_key[nodes] - offset
            used = np.isin(owner, which)
            renumber = np.full(n, -1, dtype=np.int64)
            renumber[which] = np.arange(which.size)
            values[nodes] = _simplex_means(f, self.fan.nodes[simplices[used]], renumber[owner[used]], which.size,
                                           degree)
        x = self.create_vector()
        with x.localForm() as xl:
            xl.array[:] = values.ravel()
        return x

    def p2_interpolation(self) -> scipy.sparse.csr_matrix:
        """The sparse map T (n_local_p2, n_local_nodes) from SFVEM node values to the values at the P2
        nodes of the owned fan tetrahedra (rows of the other P2 nodes are zero); built once.

        A P2 node at a polyhedron vertex or edge midpoint takes its DOF. A node on a face (its fan
        centre, the midpoints of the spokes to it) takes the face's own projection Π^∇_{2,f} of the
        trace (the 2D projection of docs/method.md §2 in the face's plane), which depends on the
        face's DOFs only: the same from both of its cells and on every partition. A node inside a
        polyhedron (its centre, the spokes to it) takes Π^∇_2 u of the polyhedron (Eq. 36).
        Quadratic fields are exact everywhere.
        """
        if self._to_p2 is not None:
            return self._to_p2
        mesh = self.polyhedron_mesh
        n_p, n_f = mesh.n_points, mesh.n_faces
        im = self.V.dofmap.index_map
        owned = _compat.num_owned_cells(self.mesh)
        p2 = _compat.cell_dofs(self.V)[:owned]
        inp = _compat.input_node_index(self.mesh)[_compat.cell_geometry_nodes(self.mesh)[:owned]]
        ends = np.concatenate([np.stack([inp, inp], axis=2),
                               np.stack([inp[:, TET_EDGES[:, 0]], inp[:, TET_EDGES[:, 1]]], axis=2)], axis=1)
        nodes, first = np.unique(p2.ravel(), return_index=True)
        a, b = ends.reshape(-1, 2)[first].T
        a, b = np.minimum(a, b), np.maximum(a, b)
        x = 0.5 * (self.fan.nodes[a] + self.fan.nodes[b])
        in_cell, on_face = b >= n_p + n_f, (b >= n_p) & (b < n_p + n_f)
        direct = ~in_cell & ~on_face
        keys = np.where(a == b, a, n_p + np.searchsorted(self._edges[:, 0] * n_p + self._edges[:, 1], a * n_p + b))
        rows, cols, vals = [nodes[direct]], [self._node_of_key(keys[direct])], [np.ones(int(direct.sum()))]
        for f in np.unique(b[on_face] - n_p):
            at = np.flatnonzero(on_face & (b == n_p + f))
            weights, dof_keys = self._face_trace(f, x[at])
            rows.append(np.repeat(nodes[at], dof_keys.size))
            cols.append(np.tile(self._node_of_key(dof_keys), at.size))
            vals.append(weights.ravel())
        exponents = exponents3(2)
        projections = self.projections
        cell = np.searchsorted(self.cells, b - n_p - n_f)
        for k in np.unique(cell[in_cell]):
            at = np.flatnonzero(in_cell & (cell == k))
            xi = (x[at] - projections.centroid[k]) / projections.diameter[k]
            m = np.prod(xi[:, None, :] ** exponents[None], axis=2)                  # (n, 10)
            dofs = self.cell_dofs(k)
            rows.append(np.repeat(nodes[at], dofs.size))
            cols.append(np.tile(dofs, at.size))
            vals.append((m @ projections.Pi_nabla_of(k)).ravel())
        self._to_p2 = scipy.sparse.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                                              shape=(im.size_local + im.num_ghosts, self.n_local_nodes))
        return self._to_p2

    def face_trace_interpolation(self) -> tuple[dolfinx.fem.FunctionSpace, scipy.sparse.csr_matrix]:
        """The space of loads on faces and the map from SFVEM node values into it (built once).

        The space W is the discontinuous vector P2 space of the fan mesh. On the face triangle of
        every owned fan tetrahedron its nodes take the face's projection Π^∇_{2,f} u (a quadratic on
        the whole face: the trace the face's DOFs define, whose mean is the face-mean DOF); its other
        nodes are left at zero, so a form on W may use only the traces on facets and their tangential
        derivatives (tractions, pressures, cof F N). A load ∫_f t · v dA on W is then
        ∫_f t · Π^∇_{2,f} v dA: a constant traction lands on the face-mean DOFs, as the element's own
        flux of a homogeneous stress does (docs/method.md §8).

        Returns
        -------
        W : dolfinx.fem.FunctionSpace
        T : (n_local_W_nodes, n_local_nodes) scipy.sparse.csr_matrix
            Rows of the face nodes of the owned tetrahedra (the other rows are zero).
        """
        if self._to_trace is not None:
            return self._to_trace
        mesh = self.polyhedron_mesh
        n_p, n_f = mesh.n_points, mesh.n_faces
        W = _compat.vector_function_space(self.mesh, 2, "DG")
        owned = _compat.num_owned_cells(self.mesh)
        dofs = _compat.cell_dofs(W)[:owned]                                        # (n, 10)
        x_w = W.tabulate_dof_coordinates()[:, :3]
        inp = _compat.input_node_index(self.mesh)[_compat.cell_geometry_nodes(self.mesh)[:owned]]
        face = np.where((inp >= n_p) & (inp < n_p + n_f), inp - n_p, -1).max(axis=1)
        centre = self.fan.nodes[inp.max(axis=1)]                                    # the cell centre
        # a node is on the face triangle when its distance to the face's plane vanishes
        corners = self.fan.nodes[np.sort(inp, axis=1)[:, :3]]
        normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        height = np.einsum("ij,ij->i", centre - corners[:, 0], normal)
        off_face = np.einsum("ikj,ij->ik", x_w[dofs] - corners[:, None, 0], normal) / height[:, None]
        on_face = np.abs(off_face) < 1e-8
        rows, cols, vals = [], [], []
        for f in np.unique(face):
            at = np.flatnonzero(face == f)
            nodes = dofs[at][on_face[at]]
            weights, keys = self._face_trace(f, x_w[nodes])
            rows.append(np.repeat(nodes, keys.size))
            cols.append(np.tile(self._node_of_key(keys), nodes.size))
            vals.append(weights.ravel())
        im = W.dofmap.index_map
        T = scipy.sparse.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                                    shape=(im.size_local + im.num_ghosts, self.n_local_nodes))
        self._to_trace = (W, T)
        return self._to_trace

    def _node_of_key(self, keys: np.ndarray) -> np.ndarray:
        """Local SFVEM nodes (n,) of the node keys (n,) (RuntimeError if one is not local)."""
        if self._by_key is None:
            self._by_key = np.argsort(self.node_key)
        pos = self._by_key[np.minimum(np.searchsorted(self.node_key, keys, sorter=self._by_key), self.node_key.size - 1)]
        if not np.array_equal(self.node_key[pos], keys):
            raise RuntimeError("a face or cell DOF is missing from this rank's nodes")
        return pos

    def _face_trace(self, f: int, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Weights (n, 2 N + 1) of Π^∇_{2,f} v at the points x (n, 3) of face f (N sides) and the
        keys (2 N + 1,) of the DOFs they weigh: the face's vertices in its cyclic order, its side
        midpoints (side i from vertex i to i + 1) and its mean."""
        mesh = self.polyhedron_mesh
        n_p = mesh.n_points
        vertices = mesh.face(f)
        normal = mesh.face_area_vectors[f] / np.linalg.norm(mesh.face_area_vectors[f])
        origin = mesh.face_centroids[f]
        xy = plane_coordinates(mesh.points, vertices, origin, normal)
        area, x_f, h_f = polygon_geometry(xy)
        Pi = pi_nabla_2(xy, x_f, h_f, area)                                          # (6, 2 N + 1)
        uv = plane_coordinates(np.ascontiguousarray(x), np.arange(len(x), dtype=np.int64), origin, normal)
        m, dm_dx, dm_dy = np.empty(6), np.empty(6), np.empty(6)
        weights = np.empty((len(x), Pi.shape[1]))
        for i in range(len(x)):
            evaluate_monomials(uv[i], x_f, h_f, 2, m, dm_dx, dm_dy)
            weights[i] = m @ Pi
        nxt = np.roll(vertices, -1)
        sides = np.searchsorted(self._edges[:, 0] * n_p + self._edges[:, 1],
                                np.minimum(vertices, nxt) * n_p + np.maximum(vertices, nxt))
        keys = np.concatenate([vertices, n_p + sides, [n_p + self._edges.shape[0] + f]]).astype(np.int64)
        return weights, keys

    def boundary_nodes(self) -> npt.NDArray[np.int64]:
        """Local SFVEM nodes on the boundary of the mesh: the vertices, edge midpoints and face means
        of the boundary faces."""
        mesh = self.polyhedron_mesh
        n_p = mesh.n_points
        faces = mesh.boundary_faces()
        sides = concatenated_ranges(mesh.face_offsets[faces], np.diff(mesh.face_offsets)[faces])
        a, b = mesh.face_vertices[sides], mesh.face_vertices[next_entries(mesh.face_offsets)[sides]]
        edge = np.searchsorted(self._edges[:, 0] * n_p + self._edges[:, 1],
                               np.minimum(a, b) * n_p + np.maximum(a, b))
        keys = np.concatenate([a, n_p + edge, n_p + self._edges.shape[0] + faces])
        return np.flatnonzero(np.isin(self.node_key, keys))

    # ------------------------------------------------------------------ reporting
    def summary(self) -> str:
        """Numbers of polyhedra, fan tetrahedra and unknowns (collective)."""
        n_tets = self.comm.allreduce(_compat.num_owned_cells(self.mesh))
        return (f"SFVEM space on polyhedra: {self.polyhedron_mesh.n_cells} polyhedra ({n_tets} fan tetrahedra), "
                f"{self.num_dofs_global} unknowns on {self.comm.size} rank(s)")
