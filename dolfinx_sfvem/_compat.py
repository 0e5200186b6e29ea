"""Every call that is specific to DOLFINx 0.5.2 / PETSc 3.18 lives here.

A port to a newer DOLFINx (0.9/0.10) should only need to touch this module:

- mesh creation with a user-given cell partitioner,
- the mapping of local cells / geometry nodes back to their input indices,
- JIT compilation of a UFL expression into a C function pointer (FFCx),
- PETSc functions that petsc4py 3.18 does not wrap (COO assembly, SNES
  domain errors), called through ctypes on the object handles,
- for the P2 FEM reference: mesh creation with DOLFINx's own partitioner, cell
  tags, vector spaces, basix quadrature rules and compiled expressions.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import functools

import numpy as np
import numpy.typing as npt
import ufl
from mpi4py import MPI
from petsc4py import PETSc

import basix
import dolfinx
import dolfinx.cpp
import dolfinx.fem
import dolfinx.jit
import dolfinx.mesh

DOLFINX_VERSION = dolfinx.__version__

#: PETSc InsertMode values (petscsystypes.h)
INSERT_VALUES = 1
ADD_VALUES = 2


# --------------------------------------------------------------------------- mesh
def _facet_ghost_destinations(cells: np.ndarray, owner: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Destinations [owner, ranks of facet neighbours owned elsewhere] of every cell (CSR)."""
    n = cells.shape[0]
    edges = np.sort(np.vstack([cells[:, [1, 2]], cells[:, [0, 2]], cells[:, [0, 1]]]), axis=1)
    cell = np.tile(np.arange(n), 3)
    key = edges[:, 0] * (int(cells.max(initial=0)) + 1) + edges[:, 1]
    order = np.argsort(key, kind="stable")
    key, cell = key[order], cell[order]
    twin = np.flatnonzero(key[1:] == key[:-1])
    a, b = cell[twin], cell[twin + 1]
    cross = owner[a] != owner[b]
    ghost_cell = np.concatenate([a[cross], b[cross]])
    ghost_rank = np.concatenate([owner[b[cross]], owner[a[cross]]])
    pairs = np.unique(np.stack([np.concatenate([np.arange(n), ghost_cell]),
                                np.concatenate([np.full(n, -1), ghost_rank])], axis=1), axis=0)
    # the owner comes first: it was entered with rank -1, which sorts first within a cell
    data = np.where(pairs[:, 1] < 0, owner[pairs[:, 0]], pairs[:, 1]).astype(np.int32)
    offsets = np.concatenate([[0], np.cumsum(np.bincount(pairs[:, 0], minlength=n))]).astype(np.int32)
    return data, offsets


def create_triangle_mesh(comm: MPI.Comm, cells: npt.NDArray[np.int64], x: npt.NDArray[np.float64],
                         destinations: npt.NDArray[np.int32]) -> dolfinx.mesh.Mesh:
    """Create a distributed affine triangle mesh with a prescribed cell distribution.

    Parameters
    ----------
    comm
        Communicator of the new mesh.
    cells : (n_cells, 3) int64
        Input cells (indices into ``x``) held by this rank (usually all on rank 0).
    x : (n_nodes, 2) float64
        Input node coordinates held by this rank.
    destinations : (n_cells,) int32
        Rank that shall own each input cell of this rank.

    Returns
    -------
    dolfinx.mesh.Mesh
        The owned cells of each rank come first (``topology.index_map(2).size_local``);
        in parallel they are followed by one layer of ghost cells.

    Notes
    -----
    DOLFINx 0.5.2 finds the vertices shared between ranks through the ghost cells the
    partitioner returns (FEniCS/dolfinx#1991): a partitioner that returns owners only,
    with ``GhostMode.none``, silently yields disconnected pieces. So in parallel every
    cell is also sent, as a ghost, to the owners of its facet neighbours.
    """
    cells = np.ascontiguousarray(cells, dtype=np.int64)
    owner = np.ascontiguousarray(destinations, dtype=np.int32)
    if comm.size == 1:
        data, offsets = owner, np.arange(owner.size + 1, dtype=np.int32)
        ghost_mode = dolfinx.mesh.GhostMode.none
    else:
        data, offsets = _facet_ghost_destinations(cells, owner)
        ghost_mode = dolfinx.mesh.GhostMode.shared_facet

    def partitioner(_comm, n_parts, tdim, graph, _ghost_mode):
        assert graph.num_nodes == owner.size
        return dolfinx.cpp.graph.AdjacencyList_int32(data, offsets)

    domain = ufl.Mesh(ufl.VectorElement("Lagrange", ufl.triangle, 1))
    return dolfinx.mesh.create_mesh(comm, cells, np.ascontiguousarray(x, dtype=np.float64), domain,
                                    ghost_mode=ghost_mode, partitioner=partitioner)


def num_owned_cells(mesh: dolfinx.mesh.Mesh) -> int:
    """Number of cells owned by this rank (they come before the ghost cells)."""
    return mesh.topology.index_map(mesh.topology.dim).size_local


def original_cell_index(mesh: dolfinx.mesh.Mesh) -> npt.NDArray[np.int64]:
    """Input index of every local cell, shape (n_local_cells,)."""
    return np.asarray(mesh.topology.original_cell_index, dtype=np.int64)


def input_node_index(mesh: dolfinx.mesh.Mesh) -> npt.NDArray[np.int64]:
    """Input index of every local geometry node, shape (n_local_nodes,)."""
    return np.asarray(mesh.geometry.input_global_indices, dtype=np.int64)


def cell_geometry_nodes(mesh: dolfinx.mesh.Mesh) -> npt.NDArray[np.int32]:
    """Geometry node indices of each local cell, shape (n_local_cells, 3 or 4), in DOLFINx's
    vertex order (:data:`COUNTER_CLOCKWISE` turns it counter-clockwise)."""
    dofmap = mesh.geometry.dofmap
    return dofmap.array.reshape(dofmap.num_nodes, -1)


def cell_dofs(V: dolfinx.fem.FunctionSpace) -> npt.NDArray[np.int32]:
    """Blocked dof (node) indices of each local cell of a Lagrange space, shape (n_cells, n_dofs)."""
    dm = V.dofmap
    return dm.list.array.reshape(dm.list.num_nodes, -1)


# --------------------------------------------------------------------------- JIT
_KERNEL_SIGNATURE = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p,
                                     ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p)


def compile_pointwise_expression(comm: MPI.Comm, expression: ufl.core.expr.Expr):
    """Compile a spatially constant UFL expression of ``ufl.Constant`` s with FFCx.

    The generated C function has the ufcx signature
    ``void f(double* A, const double* w, const double* c, const double* x,
    const int* entity_local_index, const uint8_t* perm)``; it *adds* the
    expression's flattened (row-major) components to ``A``. ``c`` holds the
    constants that survive derivative expansion, in UFL count order; pass a single
    vector Constant to keep the packing explicit.

    Returns
    -------
    (function, module)
        A ctypes function (callable from numba nopython code) and the
        compiled module (keep it alive as long as the function is used).
    """
    point = np.zeros((1, 2))
    compiled, module, _ = dolfinx.jit.ffcx_jit(comm, (expression, point))
    address = int(module.ffi.cast("uintptr_t", compiled.tabulate_tensor_float64))
    return _KERNEL_SIGNATURE(address), module


# --------------------------------------------------------------------------- PETSc
@functools.lru_cache(maxsize=None)
def _libpetsc() -> ctypes.CDLL:
    for name in ("petsc_real", "petsc"):
        path = ctypes.util.find_library(name)
        if path:
            lib = ctypes.CDLL(path)
            lib.MatSetPreallocationCOO.argtypes = [ctypes.c_void_p, ctypes.c_int64, ctypes.c_void_p,
                                                   ctypes.c_void_p]
            lib.MatSetValuesCOO.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int]
            lib.SNESSetFunctionDomainError.argtypes = [ctypes.c_void_p]
            return lib
    raise RuntimeError("cannot locate the PETSc shared library")


def _check(err: int, what: str) -> None:
    if err != 0:
        raise RuntimeError(f"PETSc error {err} in {what}")


def mat_set_preallocation_coo(A: PETSc.Mat, rows: npt.NDArray, cols: npt.NDArray) -> None:
    """``MatSetPreallocationCOO`` with global row/column indices (negative entries are ignored)."""
    rows = np.ascontiguousarray(rows, dtype=PETSc.IntType)
    cols = np.ascontiguousarray(cols, dtype=PETSc.IntType)
    _check(_libpetsc().MatSetPreallocationCOO(A.handle, rows.size, rows.ctypes.data, cols.ctypes.data),
           "MatSetPreallocationCOO")


def mat_set_values_coo(A: PETSc.Mat, values: npt.NDArray[np.float64], mode: int = INSERT_VALUES) -> None:
    """``MatSetValuesCOO``: values in the order of the COO preallocation; duplicates are summed."""
    values = np.ascontiguousarray(values, dtype=PETSc.ScalarType)
    _check(_libpetsc().MatSetValuesCOO(A.handle, values.ctypes.data, mode), "MatSetValuesCOO")


def snes_set_function_domain_error(snes: PETSc.SNES) -> None:
    """Tell SNES that the last trial point is outside the domain of the residual (e.g. J <= 0)."""
    _check(_libpetsc().SNESSetFunctionDomainError(snes.handle), "SNESSetFunctionDomainError")


# --------------------------------------------------------------------------- P2 FEM reference
#: vertex count -> the ufl cell of an affine mesh of such cells
_UFL_CELL = {3: ufl.triangle, 4: ufl.quadrilateral}
#: vertex count -> the columns that put DOLFINx's cell vertices counter-clockwise (DOLFINx
#: numbers a quadrilateral's vertices in tensor-product order: (0, 0), (1, 0), (0, 1), (1, 1));
#: the permutation is its own inverse
COUNTER_CLOCKWISE = {3: [0, 1, 2], 4: [0, 1, 3, 2]}


def create_mesh_partitioned(comm: MPI.Comm, cells: npt.NDArray[np.int64], x: npt.NDArray[np.float64], *,
                            ghost_facet_neighbours: bool = False) -> dolfinx.mesh.Mesh:
    """Distributed mesh of triangles or quadrilaterals partitioned by DOLFINx's graph partitioner.

    Parameters
    ----------
    cells : (n_cells, 3 or 4) int64
        Input cells held by this rank (usually all on rank 0, none elsewhere), vertices
        counter-clockwise. Quadrilaterals must be parallelograms for second derivatives of
        the geometry-mapped fields to be exact.
    x : (n_nodes, 2) float64
        Input node coordinates held by this rank.
    ghost_facet_neighbours
        Ghost the cells across the partition's facets (``GhostMode.shared_facet``), as interior
        facet integrals need; otherwise no ghost cells.
    """
    n_vertices = cells.shape[1]
    if n_vertices not in _UFL_CELL:
        raise ValueError(f"cells must have 3 or 4 vertices, not {n_vertices}")
    domain = ufl.Mesh(ufl.VectorElement("Lagrange", _UFL_CELL[n_vertices], 1))
    ghost_mode = dolfinx.mesh.GhostMode.shared_facet if ghost_facet_neighbours else dolfinx.mesh.GhostMode.none
    return dolfinx.mesh.create_mesh(comm, np.ascontiguousarray(cells[:, COUNTER_CLOCKWISE[n_vertices]], dtype=np.int64),
                                    np.ascontiguousarray(x, dtype=np.float64), domain, ghost_mode=ghost_mode)


def interior_facets(mesh: dolfinx.mesh.Mesh) -> tuple[npt.NDArray[np.int32], npt.NDArray[np.int32]]:
    """Local facets with two local cells: (facets (n,), their two cells (n, 2))."""
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    f2c = mesh.topology.connectivity(tdim - 1, tdim)
    counts = np.diff(f2c.offsets)
    facets = np.flatnonzero(counts == 2).astype(np.int32)
    cells = f2c.array[f2c.offsets[facets][:, None] + np.arange(2)].astype(np.int32)
    return facets, cells


def create_facet_tags(mesh: dolfinx.mesh.Mesh, facets: npt.NDArray[np.int32], values: npt.NDArray[np.int32]):
    """Facet tags (dimension tdim - 1) of the given local facets (sorted, as DOLFINx requires)."""
    order = np.argsort(facets)
    return dolfinx.mesh.meshtags(mesh, mesh.topology.dim - 1, np.ascontiguousarray(facets[order], dtype=np.int32),
                                 np.ascontiguousarray(values[order], dtype=np.int32))


def create_cell_tags(mesh: dolfinx.mesh.Mesh, values: npt.NDArray[np.int32]):
    """Cell tags of all local cells, ``values`` (n_local_cells,) in local cell order."""
    cells = np.arange(values.size, dtype=np.int32)
    return dolfinx.mesh.meshtags(mesh, mesh.topology.dim, cells, np.ascontiguousarray(values, dtype=np.int32))


def vector_function_space(mesh: dolfinx.mesh.Mesh, degree: int) -> dolfinx.fem.FunctionSpace:
    """Vector Lagrange space of ``degree`` (block size = geometric dimension)."""
    return dolfinx.fem.VectorFunctionSpace(mesh, ("Lagrange", degree))


def reference_quadrature(mesh: dolfinx.mesh.Mesh, degree: int
                         ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Basix's default rule on the reference cell of ``mesh`` exact for ``degree`` (the rule FFCx
    uses for ``metadata={"quadrature_degree": degree}``): points (n, 2) and weights (n,)."""
    cell = basix.cell.string_to_type(mesh.topology.cell_type.name)
    points, weights = basix.make_quadrature(cell, degree)
    return np.asarray(points), np.asarray(weights)


class CompiledExpression:
    """A UFL expression compiled for evaluation at fixed reference points of the cells."""

    def __init__(self, expression: ufl.core.expr.Expr, mesh: dolfinx.mesh.Mesh, points: npt.NDArray[np.float64]):
        self._expression = dolfinx.fem.Expression(expression, np.ascontiguousarray(points, dtype=np.float64))
        self._mesh = mesh               # DOLFINx >= 0.7 takes it in eval
        self._n_points = points.shape[0]

    def __call__(self, cells: npt.NDArray[np.int32]) -> npt.NDArray[np.float64]:
        """Values (n_cells, n_points, value_size) on the local ``cells``."""
        values = self._expression.eval(np.ascontiguousarray(cells, dtype=np.int32))
        return values.reshape(cells.size, self._n_points, -1)
