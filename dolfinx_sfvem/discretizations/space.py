"""The order-2 SFVEM displacement space on a polygon mesh, distributed over MPI.

Every polygon ``E`` with ``N`` vertices carries ``nd = 2N + 1`` scalar DOFs per
displacement component (paper §4.1, χ¹–χ³): the values at its vertices, the values at
its edge midpoints and its mean. The space sits on a DOLFINx P2 space over the
quadrature sub-triangulation (docs/method.md §1): that space already has a node at every
polygon vertex and polygon-edge midpoint, with parallel ownership and ghosts handled
by DOLFINx, and the interior DOF sits on one interior P2 node of the polygon (its fan
centre or the midpoint of an interior diagonal). The remaining interior P2 nodes are
*not* unknowns: the numbering built here holds the SFVEM unknowns only.

Local numbering: SFVEM *nodes* are numbered owned first, then ghosts; the unknowns are
blocked by two components, dof ``2 * node + i`` for component ``i``.
"""
from __future__ import annotations

import abc
import logging
import typing

import numpy as np
import numpy.typing as npt
import scipy.sparse
from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.fem

from dolfinx_sfvem import _compat
from dolfinx_sfvem.output.logs import say
from dolfinx_sfvem.discretizations.assemble import coo_pattern
from dolfinx_sfvem.discretizations.monomials import evaluate_monomials
from dolfinx_sfvem.discretizations.node_keys import mean_keys, midpoint_keys
from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh
from dolfinx_sfvem.mesh.csr import concatenated_ranges, edge_key
from dolfinx_sfvem.discretizations.cell_projection import Projections
from dolfinx_sfvem.discretizations.projection import build_projections
from dolfinx_sfvem.discretizations.quadrature import compressed_polygon_quadrature, polygon_quadrature

#: energy quadratures of :class:`VEMSpace`
QUADRATURES = ("compressed", "subtriangles")

#: kinds of SFVEM nodes: at a vertex, at an edge midpoint, a polygon's mean (on polyhedra: the
#: first two, then the means of faces and cells)
VERTEX, MIDPOINT, INTERIOR = 0, 1, 2

log = logging.getLogger(__name__)


class EdgeLookup:
    """Map an (unordered) pair of input node indices to the local P2 node at its midpoint
    (pairs given as the two end nodes of every local cell edge, with that edge's P2 node)."""

    def __init__(self, a: np.ndarray, b: np.ndarray, nodes: np.ndarray, n: int):
        self._n = n
        self._keys, first = np.unique(edge_key(a, b, n), return_index=True)
        self._nodes = nodes[first]

    def __call__(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        if a.size == 0:
            return np.empty(0, dtype=self._nodes.dtype)
        keys = edge_key(a, b, self._n)
        pos = np.searchsorted(self._keys, keys)
        pos = np.minimum(pos, self._keys.size - 1)
        if not np.all(self._keys[pos] == keys):
            raise RuntimeError("a cell edge (polygon or polyhedron edge) is missing from its sub-mesh")
        return self._nodes[pos]


def number_sfvem_nodes(V: dolfinx.fem.FunctionSpace, comm: MPI.Comm, p2_nodes: npt.NDArray[np.int64]
                       ) -> tuple[dolfinx.cpp.common.IndexMap, npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """Number the SFVEM nodes, a subset of the nodes of a Lagrange space: owned first, then ghosts.

    Collective. A P2 node is an SFVEM node when some local cell (polygon, polyhedron) lists it; its
    owner is the owner of the P2 node, which must itself list it (else RuntimeError).

    Parameters
    ----------
    V
        The Lagrange space hosting the nodes (its index map gives ownership and ghosts).
    p2_nodes : (n,) int64
        Local P2 node of every DOF entry of the local cells (repeats allowed).

    Returns
    -------
    index_map : dolfinx.cpp.common.IndexMap
        Owned/ghost layout of the SFVEM nodes (block size 1).
    p2_node : (n_local_nodes,) int64
        Local P2 node of every local SFVEM node.
    dofs : (n,) int64
        ``p2_nodes`` as local SFVEM node indices.
    """
    im = V.dofmap.index_map
    n_owned_p2, n_local_p2 = im.size_local, im.size_local + im.num_ghosts
    is_sfvem = np.zeros(n_local_p2, dtype=bool)
    is_sfvem[p2_nodes] = True
    owned = np.flatnonzero(is_sfvem[:n_owned_p2])
    ghosts = n_owned_p2 + np.flatnonzero(is_sfvem[n_owned_p2:])
    offset = comm.exscan(owned.size) or 0

    global_index = _compat.create_petsc_vector(im, 1)
    with global_index.localForm() as g:
        g.set(-1.0)
        g.array[owned] = offset + np.arange(owned.size)
    global_index.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
    with global_index.localForm() as g:
        ghost_global = g.array[ghosts].astype(np.int64)
    global_index.destroy()
    if np.any(ghost_global < 0):
        raise RuntimeError("SFVEM ghost node not owned by any rank")
    ghost_owners = np.asarray(im.owners, dtype=np.int32)[ghosts - n_owned_p2]
    index_map = _compat.create_index_map(comm, owned.size, ghost_global, ghost_owners)
    p2_node = np.concatenate([owned, ghosts])
    sfvem_of_p2 = np.full(n_local_p2, -1, dtype=np.int64)
    sfvem_of_p2[p2_node] = np.arange(p2_node.size)
    return index_map, p2_node, sfvem_of_p2[p2_nodes]


class SFVEMNodes(abc.ABC):
    """The nodes of an SFVEM space, numbered by :func:`number_sfvem_nodes`, with their sizes and PETSc
    objects: what the spaces on polygons and on polyhedra share.

    Subclasses set ``comm``, ``gdim`` (the mesh's dimension d: d displacement components, unknown
    ``d * node + i``), ``V`` (the hosting vector P2 space), ``cells`` (global indices of the local
    cells: polygons, polyhedra), ``tags`` (one per local cell), the CSR ``dof_offsets``, ``dofs``
    of the local cells' nodes, the energy's ``projections`` of the local cells and its quadrature
    (``q_offsets``, ``x_q``, ``w_q``), and number the nodes by :meth:`_number_nodes`.

    Attributes
    ----------
    index_map : dolfinx.cpp.common.IndexMap
        Owned/ghost layout of the nodes (block size 1; d for the unknowns).
    p2_node : (n_local_nodes,) int64
        Local P2 node of ``V`` hosting each node.
    node_kind : (n_local_nodes,) int8
        :data:`VERTEX`, :data:`MIDPOINT`, or the kinds of the cell's other means.
    node_key : (n_local_nodes,) int64
        Partition-independent node id (the point index of a vertex).
    node_point : (n_local_nodes,) int64
        The mesh point of every VERTEX node, -1 for the others.
    x_nodes : (n_local_nodes, d) float64
        Coordinates of the nodes (a mean at the P2 node hosting it).
    global_nodes : (n_local_nodes,) int64
        Global node index of every local node.
    q_offsets : (n_local + 1,) int64
        The quadrature points of local cell k are ``q_offsets[k]:q_offsets[k + 1]``.
    x_q : (n_q, d) float64
        Points of the energy quadrature of the local cells.
    w_q : (n_q,) float64
        Their weights [area or volume].
    """

    comm: MPI.Comm
    gdim: int
    V: dolfinx.fem.FunctionSpace
    cells: np.ndarray
    tags: np.ndarray
    dof_offsets: np.ndarray
    dofs: np.ndarray

    def _number_nodes(self, p2_nodes: np.ndarray, kind: np.ndarray, key: np.ndarray) -> None:
        """Number the nodes (:func:`number_sfvem_nodes`) from the P2 node, kind and key (n,) of every
        DOF entry of the local cells (in ``dofs`` order), and set the attributes of the nodes."""
        self.index_map, self.p2_node, self.dofs = number_sfvem_nodes(self.V, self.comm, p2_nodes)
        self.node_kind = np.empty(self.p2_node.size, dtype=np.int8)
        self.node_kind[self.dofs] = kind
        self.node_key = np.empty(self.p2_node.size, dtype=np.int64)
        self.node_key[self.dofs] = key
        self.node_point = np.where(self.node_kind == VERTEX, self.node_key, -1)
        self.x_nodes = self.V.tabulate_dof_coordinates()[self.p2_node, :self.gdim].copy()
        self.global_nodes = np.asarray(self.index_map.local_to_global(np.arange(self.n_local_nodes, dtype=np.int32)),
                                       dtype=np.int64)

    def cell_dofs(self, k: int) -> np.ndarray:
        """Local nodes of local cell ``k`` in the element's DOF order."""
        return self.dofs[self.dof_offsets[k]:self.dof_offsets[k + 1]]

    @property
    def n_owned_nodes(self) -> int:
        return self.index_map.size_local

    @property
    def n_local_nodes(self) -> int:
        return self.index_map.size_local + self.index_map.num_ghosts

    @property
    def num_dofs_global(self) -> int:
        """Number of SFVEM unknowns (d per node) over all ranks."""
        return self.gdim * self.index_map.size_global

    def create_vector(self) -> PETSc.Vec:
        """A ghosted PETSc vector of SFVEM unknowns (block size d)."""
        return _compat.create_petsc_vector(self.index_map, self.gdim)

    def create_matrix(self) -> PETSc.Mat:
        """AIJ matrix (block size d) with the COO pattern of the dense cell blocks (node-major: row
        ``d * node + i``), in local cell order, then the owned diagonal; values are given to
        ``MatSetValuesCOO`` in that order (:meth:`coo_offsets`). It keeps its pattern when rows are
        zeroed and refuses new nonzeros."""
        d = self.gdim
        n_owned, n_global = d * self.n_owned_nodes, self.num_dofs_global
        A = PETSc.Mat().create(self.comm)
        A.setSizes(((n_owned, n_global), (n_owned, n_global)))
        A.setType(PETSc.Mat.Type.AIJ)
        A.setBlockSize(d)
        rows, cols = coo_pattern(self.dof_offsets, self.dofs, self.global_nodes, self.coo_offsets(), d)
        start = d * self.index_map.local_range[0]
        diagonal = np.arange(start, start + n_owned, dtype=np.int32)
        _compat.mat_set_preallocation_coo(A, np.concatenate([rows, diagonal]), np.concatenate([cols, diagonal]))
        A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, True)
        A.setOption(PETSc.Mat.Option.KEEP_NONZERO_PATTERN, True)
        return A

    def coo_offsets(self) -> npt.NDArray[np.int64]:
        """Start (n_local + 1,) of each local cell's (d n_d)^2 values in the COO order of
        :meth:`create_matrix` (the owned diagonal's d n_owned entries follow)."""
        nd = np.diff(self.dof_offsets)
        return np.concatenate([[0], np.cumsum(self.gdim ** 2 * nd * nd)]).astype(np.int64)

    def locate_nodes(self, marker: typing.Callable[[np.ndarray], np.ndarray] | None = None,
                     tags: typing.Iterable[int] | None = None) -> np.ndarray:
        """Local SFVEM nodes (owned and ghost) selected geometrically and/or by region tag.

        Parameters
        ----------
        marker
            Function of coordinates ``x`` of shape (gdim, n) returning a bool array (n,), as in
            ``dolfinx.fem.locate_dofs_geometrically``. Mean nodes are located at the node
            hosting the mean (``x_nodes``).
        tags
            Region tags: all nodes of the cells (polygons, polyhedra) with these tags.

        The selection is made consistent across ranks (a node selected on one rank is
        selected on every rank that holds it).
        """
        if marker is None and tags is None:
            raise ValueError("give a marker function, region tags, or both")
        selected = np.ones(self.n_local_nodes, dtype=bool)
        if marker is not None:
            selected &= np.asarray(marker(self.x_nodes.T), dtype=bool).reshape(-1)
        if tags is not None:
            in_tags = np.zeros(self.n_local_nodes, dtype=bool)
            chosen = np.isin(self.tags, np.fromiter(tags, dtype=np.int64))
            counts = np.diff(self.dof_offsets)
            in_tags[self.dofs[np.repeat(chosen, counts)]] = True
            selected &= in_tags
        return np.flatnonzero(self.make_consistent(selected.astype(np.float64)) > 0)

    @abc.abstractmethod
    def p2_interpolation(self) -> scipy.sparse.csr_matrix:
        """The sparse map (n_local_p2, n_local_nodes) from the node values to the values at the nodes
        of ``V`` (the SFVEM function's P2 representation, per space)."""

    def to_function(self, x: PETSc.Vec, u: dolfinx.fem.Function | None = None) -> dolfinx.fem.Function:
        """The P2 :class:`dolfinx.fem.Function` of an SFVEM state on ``V`` (output; in 3D the loads on
        faces): the values of :meth:`p2_interpolation` at the P2 nodes.

        Parameters
        ----------
        x
            Ghosted SFVEM vector (ghost values up to date).
        u
            Function on ``V`` to fill; created when omitted.
        """
        T = self.p2_interpolation()
        u = u if u is not None else dolfinx.fem.Function(self.V, name="u")
        with x.localForm() as xl:
            values = xl.array_r.reshape(-1, self.gdim)
        u.x.array[:] = (T @ values).ravel()
        u.x.scatter_forward()
        return u

    def make_consistent(self, node_values: np.ndarray) -> np.ndarray:
        """Max-combine a per-node indicator over all ranks that hold the node."""
        vec = _compat.create_petsc_vector(self.index_map, 1)
        with vec.localForm() as v:
            v.array[:] = node_values
        vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        vec.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        with vec.localForm() as v:
            out = v.array.copy()
        vec.destroy()
        return out


class VEMSpace(SFVEMNodes):
    """SFVEM space of order 2 (vector valued, plane) on a :class:`PolygonMesh`.

    Parameters
    ----------
    mesh
        The polygon mesh (identical on every rank).
    comm
        Communicator; polygons are distributed by ``mesh.partition(comm.size)``.
    l
        Order of the gradient projection Π⁰_l∇ (Eq. 39): ``None`` chooses the smallest
        sufficient l ≥ ``l_min`` per polygon (docs/method.md §3); an int or a per-polygon array
        (global polygon numbering) imposes it and raises if rank-deficient.
    l_min
        Smallest automatic l (3, as in the paper).
    quadrature_degree
        Degree integrated exactly by the energy quadrature; default ``2 l`` per polygon.
    quadrature
        ``"compressed"`` (default): the small rules of :mod:`dolfinx_sfvem.discretizations.quadrature`
        (tensor Gauss on parallelograms, compressed sub-triangle rules on the other polygons);
        ``"subtriangles"``: Gauss rules on every sub-triangle (the reference, about 1.7×
        the points).
    verbose
        Print the distribution of l on rank 0.

    Attributes
    ----------
    mesh : dolfinx.mesh.Mesh
        The distributed quadrature sub-triangulation.
    V : dolfinx.fem.FunctionSpace
        Vector P2 space on it (output and node layout).
    gdim : int
        The mesh's dimension: 2.
    cells : (n_local,) int64
        Global indices of the polygons assembled on this rank.
    tags : (n_local,) int32
        Their region tags.
    dof_offsets, dofs : CSR arrays
        ``dofs[dof_offsets[k]:dof_offsets[k+1]]`` are the local SFVEM node indices of
        local polygon k, in the order [vertices, edge midpoints, interior].
    index_map : dolfinx.cpp.common.IndexMap
        Owned/ghost layout of the SFVEM nodes (block size 2 for the unknowns).
    x_nodes : (n_local_nodes, 2)
        Coordinates of the SFVEM nodes (interior ones at the node hosting the mean).
    node_kind : (n_local_nodes,) int8
        VERTEX, MIDPOINT or INTERIOR.
    node_point : (n_local_nodes,) int64
        Index of the polygon-mesh point at each VERTEX node, -1 for the others.
    node_key : (n_local_nodes,) int64
        Partition-independent node id (:mod:`~dolfinx_sfvem.discretizations.node_keys`): the point index of a
        vertex, ``n_points`` + global edge index of a midpoint, ``n_points + n_edges`` + global
        polygon index of an interior node.
    projections : Projections
        Π^∇_2 and Π⁰_l∇ of the local polygons.
    q_offsets, x_q, w_q
        Energy quadrature of the local polygons (:class:`SFVEMNodes`; weights [area]).
    """

    def __init__(self, mesh: PolygonMesh, comm: MPI.Comm = MPI.COMM_WORLD, *,
                 l: int | npt.ArrayLike | None = None, l_min: int = 3,
                 quadrature_degree: int | None = None, quadrature: str = "compressed",
                 verbose: bool = True):
        if quadrature not in QUADRATURES:
            raise ValueError(f"unknown quadrature {quadrature!r}; use one of {QUADRATURES}")
        self.polygon_mesh = mesh
        self.comm = comm
        self.gdim = mesh.gdim
        self.mesh, cell_polygon = mesh.to_dolfinx(comm)
        self.V = _compat.vector_function_space(self.mesh, 2)
        #: polygon of every local sub-triangle (owned cells first)
        self.cell_polygon = np.asarray(cell_polygon, dtype=np.int64)
        self.cells = np.unique(self.cell_polygon[:_compat.num_owned_cells(self.mesh)]).astype(np.int64)
        self.tags = mesh.tags[self.cells]
        self._number_nodes(*self._polygon_p2_nodes())

        l_local = l if (l is None or np.isscalar(l)) else np.asarray(l)[self.cells]
        self.projections: Projections = build_projections(mesh.points, mesh.offsets, mesh.vertices,
                                                          polygons=self.cells, l=l_local, l_min=l_min)
        degrees = (2 * self.projections.l if quadrature_degree is None
                   else np.full(self.cells.size, quadrature_degree))
        triangles = (mesh.nodes, mesh.quadrature_triangles, mesh.quadrature_triangle_offsets, self.cells, degrees)
        self.q_offsets, self.x_q, self.w_q = (
            polygon_quadrature(*triangles) if quadrature == "subtriangles"
            else compressed_polygon_quadrature(mesh.points, mesh.offsets, mesh.vertices, *triangles))
        self._to_p2 = None
        say(log, self.summary(), verbose, comm)

    # ------------------------------------------------------------------ numbering
    def _polygon_p2_nodes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Local P2 node, kind and partition-independent key of every SFVEM DOF of the local polygons."""
        mesh = self.polygon_mesh
        inp = _compat.input_node_index(self.mesh)[_compat.cell_geometry_nodes(self.mesh)]
        p2 = _compat.cell_dofs(self.V)
        n_in = mesh.nodes.shape[0]
        node_of_input = np.full(n_in, -1, dtype=np.int64)
        node_of_input[inp.ravel()] = p2[:, :3].ravel()
        # P2 edge dof 3 + k sits on the reference edge opposite vertex k
        edge_node = EdgeLookup(inp[:, [1, 0, 0]].ravel(), inp[:, [2, 2, 1]].ravel(), p2[:, 3:].ravel(), n_in)

        P = self.cells
        N = mesh.offsets[P + 1] - mesh.offsets[P]
        nd = 2 * N + 1
        self.dof_offsets = np.concatenate([[0], np.cumsum(nd)]).astype(np.int64)
        first = self.dof_offsets[:-1]
        this = concatenated_ranges(mesh.offsets[P], N)
        v, v_next = mesh.sides.start[this], mesh.sides.end[this]
        a, b = mesh.interior_node[P, 0], mesh.interior_node[P, 1]
        interior = node_of_input[a]
        diagonal = a != b
        interior[diagonal] = edge_node(a[diagonal], b[diagonal])

        nodes = np.empty(self.dof_offsets[-1], dtype=np.int64)
        kind = np.empty(self.dof_offsets[-1], dtype=np.int8)
        at_vertex = concatenated_ranges(first, N)
        at_mid = concatenated_ranges(first + N, N)
        nodes[at_vertex], kind[at_vertex] = node_of_input[v], VERTEX
        nodes[at_mid], kind[at_mid] = edge_node(v, v_next), MIDPOINT
        # partition-independent key of every DOF node (checkpoints)
        key = np.empty(self.dof_offsets[-1], dtype=np.int64)
        key[at_vertex] = v
        key[at_mid] = midpoint_keys(mesh, v, v_next)
        key[first + 2 * N] = mean_keys(mesh, P)
        nodes[first + 2 * N], kind[first + 2 * N] = interior, INTERIOR
        if np.any(nodes < 0):
            raise RuntimeError("a polygon node is missing from the sub-triangulation")
        return nodes, kind, key

    def coarse_interpolation(self) -> PETSc.Mat:
        """The vertex values of a coarse field into the SFVEM unknowns: a vertex node keeps its
        value, an edge midpoint takes the mean of its edge's two vertices, the mean of a polygon
        the weights of its vertices that reproduce the area centroid with the least norm; so every
        linear field is reproduced exactly (AIJ, unknowns x 2 vertex nodes, block size 2)."""
        weights = self._coarse_weights()                # (local node, local vertex node, weight)
        is_vertex = self.node_kind == VERTEX
        n_owned = self.n_owned_nodes
        owned_vertices = np.flatnonzero(is_vertex[:n_owned])
        offset = self.comm.exscan(owned_vertices.size) or 0
        coarse = _compat.create_petsc_vector(self.index_map, 1)    # global coarse index of each vertex node
        with coarse.localForm() as c:
            c.set(-1.0)
            c.array[owned_vertices] = offset + np.arange(owned_vertices.size)
        coarse.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        with coarse.localForm() as c:
            coarse_of_node = c.array.astype(np.int64)
        coarse.destroy()
        row, col, w = weights
        W = scipy.sparse.csr_matrix((w, (row, coarse_of_node[col])),
                                    shape=(n_owned, self.comm.allreduce(owned_vertices.size)))
        P = scipy.sparse.kron(W, scipy.sparse.identity(2), format="csr")
        P.sort_indices()
        return PETSc.Mat().createAIJ(((2 * n_owned, PETSc.DETERMINE), (2 * owned_vertices.size, PETSc.DETERMINE)),
                                     bsize=2, csr=(P.indptr.astype(PETSc.IntType), P.indices.astype(PETSc.IntType),
                                                   P.data), comm=self.comm)

    def _coarse_weights(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(node, vertex node, weight) triplets of :meth:`coarse_interpolation` for the owned
        nodes, each pair once (a node shared by polygons gets the same weights from each)."""
        mesh = self.polygon_mesh
        N = mesh.offsets[self.cells + 1] - mesh.offsets[self.cells]
        first = self.dof_offsets[:-1]
        vertex = self.dofs[concatenated_ranges(first, N)]                    # (sum N,) vertex nodes
        v_first = np.concatenate([[0], np.cumsum(N)[:-1]])
        k = np.arange(vertex.size) - np.repeat(v_first, N)
        v_next = vertex[np.repeat(v_first, N) + (k + 1) % np.repeat(N, N)]
        mid = self.dofs[concatenated_ranges(first + N, N)]
        rows = [vertex, mid, mid]
        cols = [vertex, vertex, v_next]
        vals = [np.ones(vertex.size), np.full(mid.size, 0.5), np.full(mid.size, 0.5)]
        for n in np.unique(N):                      # the polygon means, by vertex count
            polys = np.flatnonzero(N == n)
            verts = vertex[(v_first[polys][:, None] + np.arange(n)).reshape(-1)].reshape(-1, n)
            X = self.x_nodes[verts]                                            # (m, n, 2)
            Xn = np.roll(X, -1, axis=1)
            cross = X[..., 0] * Xn[..., 1] - Xn[..., 0] * X[..., 1]
            centroid = ((X + Xn) * cross[..., None]).sum(axis=1) / (3 * cross.sum(axis=1))[:, None]
            B = np.concatenate([np.ones((polys.size, 1, n)), X.transpose(0, 2, 1)], axis=1)  # (m, 3, n)
            rhs = np.concatenate([np.ones((polys.size, 1)), centroid], axis=1)
            w = np.einsum("mij,mi->mj", B, np.linalg.solve(B @ B.transpose(0, 2, 1), rhs[..., None])[..., 0])
            rows.append(np.repeat(self.dofs[first[polys] + 2 * n], n))
            cols.append(verts.reshape(-1))
            vals.append(w.reshape(-1))
        row, col, val = np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)
        owned = row < self.n_owned_nodes
        row, col, val = row[owned], col[owned], val[owned]
        entry = np.unique(row * self.n_local_nodes + col, return_index=True)[1]   # a shared node once
        return row[entry], col[entry], val[entry]

    # ------------------------------------------------------------------ output
    def p2_interpolation(self) -> scipy.sparse.csr_matrix:
        """Sparse map (n_local_p2, n_local_nodes) from local SFVEM node values to local P2 node values;
        built once.

        Boundary and interior-DOF nodes of the P2 space that are SFVEM vertices/midpoints
        take their DOF value; every other P2 node (fan centre, spoke midpoints) takes the
        value of Π^∇_2 u (Eq. 36) of its polygon at that point.
        """
        if self._to_p2 is not None:
            return self._to_p2
        im = self.V.dofmap.index_map
        n_p2 = im.size_local + im.num_ghosts
        owned_cells = _compat.num_owned_cells(self.mesh)
        p2 = _compat.cell_dofs(self.V)[:owned_cells]
        x_p2 = self.V.tabulate_dof_coordinates()[:, :2]
        cell_local_polygon = np.searchsorted(self.cells, self.cell_polygon[:owned_cells])
        # one owning polygon per P2 node of the owned cells (any polygon containing it gives
        # the same value for boundary nodes; interior nodes belong to exactly one polygon);
        # nodes seen only by ghost cells get their values from their owner by a scatter
        owner = np.full(n_p2, -1, dtype=np.int64)
        owner[p2.ravel()] = np.repeat(cell_local_polygon, p2.shape[1])
        direct = np.zeros(n_p2, dtype=bool)
        direct[self.p2_node[self.node_kind != INTERIOR]] = True
        rows, cols, vals = [np.flatnonzero(direct)], [], [np.ones(int(direct.sum()))]
        sfvem_of_p2 = np.full(n_p2, -1, dtype=np.int64)
        sfvem_of_p2[self.p2_node] = np.arange(self.p2_node.size)
        cols.append(sfvem_of_p2[rows[0]])
        proj = self.projections
        m, dm_dx, dm_dy = np.empty(6), np.empty(6), np.empty(6)
        for node in np.flatnonzero(~direct & (owner >= 0)):
            k = owner[node]
            evaluate_monomials(x_p2[node], proj.centroid[k], proj.diameter[k], 2, m, dm_dx, dm_dy)
            rows.append(np.full(self.dof_offsets[k + 1] - self.dof_offsets[k], node))
            cols.append(self.cell_dofs(k))
            vals.append(m @ proj.Pi_nabla_of(k))
        self._to_p2 = scipy.sparse.csr_matrix(
            (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
            shape=(n_p2, self.n_local_nodes))
        return self._to_p2

    # ------------------------------------------------------------------ reporting
    def l_histogram(self) -> dict[int, int]:
        """Projection order l -> number of polygons, over all ranks (collective)."""
        total: dict[int, int] = {}
        for h in self.comm.allgather(self.projections.histogram()):
            for l, n in h.items():
                total[int(l)] = total.get(int(l), 0) + int(n)
        return dict(sorted(total.items()))

    def summary(self) -> str:
        """Number of unknowns, polygons and the distribution of l (collective)."""
        ls = ", ".join(f"l={l}: {n}" for l, n in self.l_histogram().items())
        return (f"SFVEM space: {self.polygon_mesh.n_polygons} polygons, {self.num_dofs_global} unknowns "
                f"on {self.comm.size} rank(s); projection order {ls}")
