"""Every call that differs between the supported DOLFINx stacks lives here.

Supported: DOLFINx 0.5.2 with PETSc 3.18 (Debian 12) and DOLFINx 0.11 with PETSc 3.25 (the
``dolfinx-solver-real`` wheel; conda-forge's 0.10/0.11 offer the same API). Each function picks
its code path by what the installed API offers (an attribute, a parameter name, the generated
kernel's argument count), never by comparing version strings. The rest of the package calls:

- mesh creation with a user-given cell distribution (:func:`create_triangle_mesh`) or DOLFINx's
  own partitioner (:func:`create_mesh_partitioned`, geometry of degree 1 or 2), the ufl domain of a
  mesh (:func:`coordinate_domain`), basix's Lagrange element of a geometry (:func:`lagrange_element`,
  :func:`geometry_degree`), gmsh's node order (:func:`gmsh_node_permutation`), and the maps of local
  cells / geometry nodes / dofs back to their input indices,
- vector spaces, index maps and ghosted PETSc vectors (:func:`vector_function_space`,
  :func:`create_index_map`, :func:`create_petsc_vector`), ``atan2`` in UFL,
- JIT compilation of a UFL expression into a C function and the call of that function from
  Python and numba (:func:`compile_pointwise_expression`, :func:`call_kernel`), the FFCx module
  of a compiled form (:func:`form_module_name`) and the coordinate element FFCx 0.5 would change
  under the forms' signatures (:func:`settle_coordinate_element`),
- PETSc functions that petsc4py 3.18 does not wrap (COO assembly, SNES domain errors), called
  through ctypes on the object handles, and option defaults that keep PETSc's behaviour
  (:data:`PETSC_OPTION_DEFAULTS`),
- the VTX (ADIOS2) writer, where DOLFINx was built with ADIOS2 (:func:`vtx_writer`),
- for the P2 FEM reference: cell and facet tags, basix quadrature rules and compiled expressions.

With the ``dolfinx-solver-real`` wheel, ``dolfinx_solver`` must be imported before any
dolfinx or petsc4py import (it loads the wheel's MPI library first); this module does so, and
``import dolfinx_sfvem`` imports this module first.
"""
from __future__ import annotations

import contextlib
import ctypes
import functools
import inspect
import pathlib
import typing

with contextlib.suppress(ImportError):
    import dolfinx_solver  # noqa: F401  (the dolfinx-solver-* wheels: MPI before the bindings)

import numba
import numba.extending
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
import dolfinx.la
import dolfinx.mesh

from dolfinx_sfvem.discretizations.compile_lock import compiling

try:
    import basix.ufl as _basix_ufl     # the elements of DOLFINx 0.11 (0.5 uses UFL's)
except ImportError:
    _basix_ufl = None

DOLFINX_VERSION = dolfinx.__version__

#: PETSc InsertMode values (petscsystypes.h)
INSERT_VALUES = 1


def jit_cache_dir() -> pathlib.Path:
    """The directory of DOLFINx's JIT cache (its ``cache_dir`` parameter or option)."""
    options = dolfinx.jit.get_options() if hasattr(dolfinx.jit, "get_options") else dolfinx.jit.get_parameters()
    return pathlib.Path(options["cache_dir"]).expanduser()


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
    return _destinations_csr(owner, np.concatenate([a[cross], b[cross]]),
                             np.concatenate([owner[b[cross]], owner[a[cross]]]))


def _vertex_ghost_destinations(cells: np.ndarray, owner: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Destinations [owner, ranks owning a cell that shares a vertex with it] of every cell (CSR).

    In 3D two ranks' cells may share an edge or a vertex only; ghosting every cell to the owners of
    all its vertex neighbours lets DOLFINx 0.5.2 see every shared vertex (:func:`create_triangle_mesh`)."""
    n, k = cells.shape
    entry_cell = np.repeat(np.arange(n), k)
    n_ranks = int(owner.max(initial=0)) + 1
    vertex_rank = np.unique(cells.ravel() * n_ranks + owner[entry_cell])       # sorted by vertex, then rank
    vertex = vertex_rank // n_ranks
    start = np.searchsorted(vertex, cells.ravel(), "left")
    count = np.searchsorted(vertex, cells.ravel(), "right") - start
    ranks = vertex_rank[np.repeat(start - np.cumsum(count) + count, count) + np.arange(count.sum())] % n_ranks
    ghost_cell = np.repeat(entry_cell, count)
    other = ranks != owner[ghost_cell]
    return _destinations_csr(owner, ghost_cell[other], ranks[other])


def _destinations_csr(owner: np.ndarray, ghost_cell: np.ndarray, ghost_rank: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
    """CSR (data, offsets) of the ranks of every cell: its owner first, then the distinct ranks
    ``ghost_rank`` of the entries ``ghost_cell`` (ranks other than the owner)."""
    n = owner.size
    span = int(max(owner.max(initial=0), np.max(ghost_rank, initial=0))) + 2
    pairs = np.unique(np.concatenate([np.arange(n) * span, np.asarray(ghost_cell, dtype=np.int64) * span
                                      + np.asarray(ghost_rank, dtype=np.int64) + 1]))
    cell, rank = pairs // span, pairs % span - 1
    # the owner comes first: it was entered with rank -1, which sorts first within a cell
    data = np.where(rank < 0, owner[cell], rank).astype(np.int32)
    offsets = np.concatenate([[0], np.cumsum(np.bincount(cell, minlength=n))]).astype(np.int32)
    return data, offsets


#: whether ``dolfinx.mesh.create_mesh`` takes ``(comm, cells, x, domain, ghost_mode, partitioner)``
#: with a partitioner ``(comm, n_parts, tdim, graph, ghost_mode)`` (DOLFINx 0.5); DOLFINx 0.11 takes
#: ``(comm, cells, e, x, partitioner)`` with a partitioner ``(comm, n_parts, cell_types, cells)``
#: that carries the ghost mode
_CREATE_MESH_TAKES_GHOST_MODE = "ghost_mode" in inspect.signature(dolfinx.mesh.create_mesh).parameters


def coordinate_domain(cell: str, gdim: int = 2, degree: int = 1) -> ufl.Mesh:
    """The ufl domain of a mesh of ``cell`` s (``"triangle"``, ``"quadrilateral"``,
    ``"tetrahedron"``, ``"hexahedron"``) in ``gdim`` dimensions with geometry of ``degree``: 1 for
    affine simplices, bilinear quadrilaterals and trilinear hexahedra, 2 for curved (quadratic) cells."""
    if _basix_ufl is None:             # UFL's own elements (DOLFINx 0.5)
        return ufl.Mesh(ufl.VectorElement("Lagrange", cell, degree, dim=gdim))
    return ufl.Mesh(_basix_ufl.element("Lagrange", cell, degree, shape=(gdim,)))


def lagrange_element(cell: str, degree: int):
    """Basix's scalar Lagrange element of ``degree`` on ``cell``, variant equispaced: the coordinate
    element of a geometry of that degree (its ``points`` (n_nodes, tdim) are the reference
    positions of the geometry nodes in DOLFINx's order; ``tabulate(n, xi)`` its derivatives)."""
    return basix.create_element(basix.ElementFamily.P, getattr(basix.CellType, cell), degree,
                                basix.LagrangeVariant.equispaced)


#: the geometry degrees a mesh may have
GEOMETRY_DEGREES = (1, 2)


def geometry_degree(cell: str, n_nodes: int) -> int:
    """The degree (1 or 2) of a geometry of ``cell`` s with ``n_nodes`` nodes each (tetrahedron 4 or
    10, hexahedron 8 or 27, triangle 3 or 6, quadrilateral 4 or 9); ValueError for another count
    (e.g. gmsh's 20-node serendipity hexahedra)."""
    counts = {lagrange_element(cell, degree).dim: degree for degree in GEOMETRY_DEGREES}
    if n_nodes not in counts:
        raise ValueError(f"{cell} mesh: cells must have {' or '.join(map(str, counts))} nodes each (geometry of "
                         f"degree {' or '.join(map(str, counts.values()))}), got {n_nodes}")
    return counts[n_nodes]


def mesh_geometry_degree(mesh: dolfinx.mesh.Mesh) -> int:
    """The degree (1 or 2) of a DOLFINx mesh's geometry (its coordinate element)."""
    return geometry_degree(mesh.topology.cell_type.name, cell_geometry_nodes(mesh).shape[1])


def gmsh_node_permutation(cell: str, n_nodes: int) -> npt.NDArray[np.int64]:
    """``p`` with ``nodes_dolfinx = nodes_gmsh[:, p]`` for gmsh's ``cell`` s of ``n_nodes`` nodes
    (DOLFINx's ``perm_gmsh``)."""
    return np.asarray(dolfinx.cpp.io.perm_gmsh(getattr(dolfinx.cpp.mesh.CellType, cell), n_nodes), dtype=np.int64)


def _equispaced(element: ufl.VectorElement) -> ufl.VectorElement:
    """The UFL vector element ``element`` with the Lagrange variant "equispaced", built as FFCx 0.5
    builds it (``ffcx/analysis.py``), so that its repr is the one FFCx would give it."""
    sub = element.sub_elements()[0]
    return ufl.VectorElement(ufl.FiniteElement(sub.family(), sub.cell(), sub.degree(), sub.quadrature_scheme(),
                                               variant="equispaced"), dim=element.value_shape()[0])


def settle_coordinate_element(mesh: dolfinx.mesh.Mesh) -> None:
    """Give the coordinate element of ``mesh`` the Lagrange variant FFCx would give it, before any
    form on the mesh is built.

    Contract: afterwards the signature of every form and expression on ``mesh``, and so its FFCx
    module name, depends on the form alone, not on what the process compiled before.

    FFCx 0.5 (DOLFINx 0.5.2), when it compiles a form from scratch (not when it finds the
    module in its cache), sets the variant of a UFL coordinate element that has none to
    "equispaced", in place (``ffcx/analysis.py``, ``ffcx/ir/representation.py``). The element's
    repr is part of every signature, so without this call a form's module name would depend on
    whether an earlier form of the process missed the cache. For a degree-1 element every variant
    has the same basis, and for degree 2 the same nodes (vertices and midpoints): the geometry does not
    change. Basix's elements (DOLFINx 0.11) carry
    their variant and FFCx leaves them alone: nothing to do there.
    """
    domain = mesh.ufl_domain()
    element = domain.ufl_coordinate_element()
    if _basix_ufl is None and element.variant() is None:
        domain._ufl_coordinate_element = _equispaced(element)


def _create_mesh(comm: MPI.Comm, cells: npt.NDArray[np.int64], x: npt.NDArray[np.float64], cell: str,
                 ghost_mode: dolfinx.mesh.GhostMode,
                 destinations: tuple[npt.NDArray[np.int32], npt.NDArray[np.int32]] | None = None
                 ) -> dolfinx.mesh.Mesh:
    """Distributed mesh of ``cell`` s, its coordinate element settled (:func:`settle_coordinate_element`).

    Parameters
    ----------
    cells, x
        Input cells (indices into ``x``, DOLFINx's node order) and node coordinates of this rank; the
        number of nodes per cell gives the geometry's degree (:func:`geometry_degree`; a rank
        without cells still passes the right number of columns).
    ghost_mode
        Ghost cells of DOLFINx's graph partitioner (ignored with ``destinations``).
    destinations
        CSR (data, offsets) of the ranks of each input cell: owner first, then the ranks that
        hold it as a ghost; None for DOLFINx's graph partitioner.
    """
    cells = np.ascontiguousarray(cells, dtype=np.int64)
    x = np.ascontiguousarray(x, dtype=np.float64)
    domain = coordinate_domain(cell, x.shape[1], geometry_degree(cell, cells.shape[1]))
    if destinations is not None:
        adjacency = dolfinx.cpp.graph.AdjacencyList_int32(*destinations)

        def partitioner(*_args):       # the arguments differ between versions and are not needed
            return adjacency
    elif _CREATE_MESH_TAKES_GHOST_MODE:
        partitioner = dolfinx.mesh.create_cell_partitioner()      # given the ghost mode by create_mesh
    else:
        partitioner = dolfinx.mesh.create_cell_partitioner(ghost_mode, 2)
    if _CREATE_MESH_TAKES_GHOST_MODE:
        mesh = dolfinx.mesh.create_mesh(comm, cells, x, domain, ghost_mode=ghost_mode, partitioner=partitioner)
    else:
        mesh = dolfinx.mesh.create_mesh(comm, cells, domain, x, partitioner=partitioner)
    settle_coordinate_element(mesh)
    return mesh


def create_triangle_mesh(comm: MPI.Comm, cells: npt.NDArray[np.int64], x: npt.NDArray[np.float64],
                         destinations: npt.NDArray[np.int32]) -> dolfinx.mesh.Mesh:
    """Create a distributed (straight-sided) triangle mesh with a prescribed cell distribution.

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
    return _create_mesh_distributed(comm, cells, x, destinations, "triangle", _facet_ghost_destinations)


def create_tetrahedron_mesh(comm: MPI.Comm, cells: npt.NDArray[np.int64], x: npt.NDArray[np.float64],
                            destinations: npt.NDArray[np.int32]) -> dolfinx.mesh.Mesh:
    """Create a distributed (straight-sided) tetrahedron mesh with a prescribed cell distribution.

    As :func:`create_triangle_mesh`, with ``cells`` (n_cells, 4) and ``x`` (n_nodes, 3); in
    parallel every cell is also sent, as a ghost, to the owners of all cells that share a vertex
    with it (in 3D ranks may meet at an edge or a vertex only).
    """
    return _create_mesh_distributed(comm, cells, x, destinations, "tetrahedron", _vertex_ghost_destinations)


def _create_mesh_distributed(comm, cells, x, destinations, cell, ghost_destinations) -> dolfinx.mesh.Mesh:
    """The mesh of ``cell`` s owned by ``destinations``, ghosted in parallel by
    ``ghost_destinations(cells, owner)`` (CSR of owner and ghost ranks)."""
    owner = np.ascontiguousarray(destinations, dtype=np.int32)
    if owner.shape != (len(cells),):
        raise ValueError(f"one destination per input cell expected: {owner.shape} for {len(cells)} cells")
    if comm.size == 1:
        csr = owner, np.arange(owner.size + 1, dtype=np.int32)
        ghost_mode = dolfinx.mesh.GhostMode.none
    else:
        csr = ghost_destinations(np.asarray(cells, dtype=np.int64), owner)
        ghost_mode = dolfinx.mesh.GhostMode.shared_facet
    return _create_mesh(comm, cells, x, cell, ghost_mode, csr)


def num_owned_cells(mesh: dolfinx.mesh.Mesh) -> int:
    """Number of cells owned by this rank (they come before the ghost cells)."""
    return mesh.topology.index_map(mesh.topology.dim).size_local


def original_cell_index(mesh: dolfinx.mesh.Mesh) -> npt.NDArray[np.int64]:
    """Input index of every local cell, shape (n_local_cells,)."""
    return np.asarray(mesh.topology.original_cell_index, dtype=np.int64)


def input_node_index(mesh: dolfinx.mesh.Mesh) -> npt.NDArray[np.int64]:
    """Input index of every local geometry node, shape (n_local_nodes,)."""
    return np.asarray(mesh.geometry.input_global_indices, dtype=np.int64)


def _rows(table) -> npt.NDArray[np.int32]:
    """A 2D array of a fixed-width table: an ndarray (DOLFINx 0.11) or an AdjacencyList (0.5)."""
    if isinstance(table, np.ndarray):
        return table
    return table.array.reshape(table.num_nodes, -1)


def cell_geometry_nodes(mesh: dolfinx.mesh.Mesh) -> npt.NDArray[np.int32]:
    """Geometry node indices of each local cell, shape (n_local_cells, n_nodes): the vertices first,
    then (geometry of degree 2) the nodes on edges, faces and the interior, in DOLFINx's order
    (:data:`COUNTER_CLOCKWISE` turns a 2D cell's vertices counter-clockwise)."""
    geometry = mesh.geometry
    return _rows(geometry.dofmaps[0] if hasattr(geometry, "dofmaps") else geometry.dofmap)


def cell_dofs(V: dolfinx.fem.FunctionSpace) -> npt.NDArray[np.int32]:
    """Blocked dof (node) indices of each local cell of a Lagrange space, shape (n_cells, n_dofs)."""
    return _rows(V.dofmap.list)


# --------------------------------------------------------------------------- spaces, vectors, UFL
def vector_function_space(mesh: dolfinx.mesh.Mesh, degree: int, family: str = "Lagrange") -> dolfinx.fem.FunctionSpace:
    """Vector Lagrange space of ``degree`` (block size = geometric dimension); ``family="DG"`` the
    discontinuous one."""
    with compiling():                                  # a new element is compiled on a cold cache
        if hasattr(dolfinx.fem, "functionspace"):     # DOLFINx 0.11
            return dolfinx.fem.functionspace(mesh, (family, degree, (mesh.geometry.dim,)))
        return dolfinx.fem.VectorFunctionSpace(mesh, (family, degree))


def scalar_function_space(mesh: dolfinx.mesh.Mesh, degree: int, family: str = "Lagrange") -> dolfinx.fem.FunctionSpace:
    """Scalar Lagrange space of ``degree``; ``family="DG"`` the discontinuous one."""
    with compiling():
        if hasattr(dolfinx.fem, "functionspace"):     # DOLFINx 0.11
            return dolfinx.fem.functionspace(mesh, (family, degree))
        return dolfinx.fem.FunctionSpace(mesh, (family, degree))


def interpolation_matrix(V_from: dolfinx.fem.FunctionSpace, V_to: dolfinx.fem.FunctionSpace) -> PETSc.Mat:
    """The assembled matrix that interpolates a function of ``V_from`` into ``V_to``
    (rows: the dofs of V_to, columns: those of V_from; block size of the spaces)."""
    if hasattr(dolfinx.fem.petsc, "interpolation_matrix"):     # DOLFINx 0.11
        P = dolfinx.fem.petsc.interpolation_matrix(V_from, V_to)
    else:
        P = dolfinx.cpp.fem.petsc.interpolation_matrix(V_from._cpp_object, V_to._cpp_object)
    P.assemble()
    return P


def cell_tensor_space(mesh: dolfinx.mesh.Mesh) -> dolfinx.fem.FunctionSpace:
    """(d, d) tensors constant in every cell (DG0), d the geometric dimension."""
    d = mesh.geometry.dim
    with compiling():
        if hasattr(dolfinx.fem, "functionspace"):     # DOLFINx 0.11
            return dolfinx.fem.functionspace(mesh, ("DG", 0, (d, d)))
        return dolfinx.fem.TensorFunctionSpace(mesh, ("DG", 0), shape=(d, d))


#: MPI tag of the messages DOLFINx 0.11 exchanges while it builds an index map (any tag works: the
#: construction is collective and completes before it returns); None: the constructor takes none
#: (DOLFINx 0.5, whose five-argument constructor is another one). Decided from the signature, never
#: by trying: a call that one overload takes on one rank and not on another (it depends on the
#: arrays) would leave the ranks in different collectives.
_INDEX_MAP_TAG = 1 if "tag: int" in (dolfinx.cpp.common.IndexMap.__init__.__doc__ or "") else None


def create_index_map(comm: MPI.Comm, n_owned: int, ghosts: npt.NDArray[np.int64],
                     ghost_owners: npt.NDArray[np.int32]) -> dolfinx.cpp.common.IndexMap:
    """Index map of ``n_owned`` owned indices and the given ghosts (global indices, owner ranks)."""
    args = (comm, n_owned, np.ascontiguousarray(ghosts, dtype=np.int64),
            np.ascontiguousarray(ghost_owners, dtype=np.int32))
    return dolfinx.cpp.common.IndexMap(*args, *(() if _INDEX_MAP_TAG is None else (_INDEX_MAP_TAG,)))


def _petsc_vector_function():
    """DOLFINx's function creating a ghosted PETSc vector, called as ``f(index_map, bs)``."""
    if hasattr(dolfinx.la, "create_petsc_vector"):    # DOLFINx 0.5
        return dolfinx.la.create_petsc_vector
    from dolfinx.la.petsc import create_vector as create
    if "maps" in inspect.signature(create).parameters:     # DOLFINx 0.11: a list of (map, bs) pairs
        return lambda index_map, bs: create([(index_map, bs)])
    return create


_create_petsc_vector = _petsc_vector_function()


def create_petsc_vector(index_map: dolfinx.cpp.common.IndexMap, bs: int) -> PETSc.Vec:
    """Ghosted PETSc vector of ``index_map`` with block size ``bs`` (values not initialised)."""
    return _create_petsc_vector(index_map, bs)


def atan2(y: ufl.core.expr.Expr, x: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """``atan2(y, x)`` in UFL (``ufl.atan_2`` in UFL 2022, DOLFINx 0.5's)."""
    return ufl.atan2(y, x) if hasattr(ufl, "atan2") else ufl.atan_2(y, x)


# --------------------------------------------------------------------------- JIT
class _DlInfo(ctypes.Structure):
    """``Dl_info`` of ``dladdr`` (dlfcn.h)."""
    _fields_ = [("dli_fname", ctypes.c_char_p), ("dli_fbase", ctypes.c_void_p),
                ("dli_sname", ctypes.c_char_p), ("dli_saddr", ctypes.c_void_p)]


def form_module_name(form: dolfinx.fem.Form) -> str:
    """The name of the FFCx module that holds a compiled form's code (``libffcx_forms_<hash>``):
    the file name, up to its first dot, of the shared library the dynamic linker finds the form's
    ``ufcx_form`` struct in (``dladdr``). The same on both stacks: DOLFINx 0.5's form does not
    keep its module, only the struct."""
    import cffi
    ffi = cffi.FFI()
    info = _DlInfo()
    address = int(ffi.cast("uintptr_t", ffi.addressof(form.ufcx_form)))
    if not ctypes.CDLL(None).dladdr(ctypes.c_void_p(address), ctypes.byref(info)) or not info.dli_fname:
        raise RuntimeError(f"no shared library holds the form at {address:#x}")
    return pathlib.Path(info.dli_fname.decode()).name.split(".")[0]


def compile_pointwise_expression(comm: MPI.Comm, expression: ufl.core.expr.Expr):
    """Compile a spatially constant UFL expression of ``ufl.Constant`` s with FFCx.

    The generated C function has the ufcx signature
    ``void f(double* A, const double* w, const double* c, const double* x,
    const int* entity_local_index, const uint8_t* perm[, void* custom_data])`` (the last
    argument in the ufcx of DOLFINx 0.11, not of 0.5); it *adds* the expression's flattened
    (row-major) components to ``A``. ``c`` holds the constants that survive derivative
    expansion, in UFL count order; pass a single vector Constant to keep the packing explicit.
    Call it with :func:`call_kernel`.

    Returns
    -------
    (function, module)
        A ctypes function with the generated function's argument count (callable from numba
        nopython code) and the compiled module (keep it alive as long as the function is used).
    """
    point = np.zeros((1, 2))
    with compiling():
        compiled, module, _ = dolfinx.jit.ffcx_jit(comm, (expression, point))
    tabulate = compiled.tabulate_tensor_float64
    prototype = ctypes.CFUNCTYPE(None, *[ctypes.c_void_p] * len(module.ffi.typeof(tabulate).args))
    return prototype(int(module.ffi.cast("uintptr_t", tabulate))), module


@numba.njit(cache=True)
def kernel_scratch():
    """The arrays :func:`call_kernel` passes for the arguments a pointwise kernel does not read:
    coefficients w, coordinates x, entity index, quadrature permutation, custom data."""
    return (np.zeros(1), np.zeros(9), np.zeros(1, dtype=np.int32), np.zeros(1, dtype=np.uint8),
            np.zeros(1, dtype=np.uint8))


def call_kernel(kernel, out: npt.NDArray[np.float64], c: npt.NDArray[np.float64], scratch: tuple) -> None:
    """Call a kernel of :func:`compile_pointwise_expression`: add its output to ``out``.

    Parameters
    ----------
    kernel
        The ctypes function.
    out : (n,) float64
        Output, added to.
    c : (n_constants,) float64
        The constants (contiguous).
    scratch
        :func:`kernel_scratch` ()'s arrays.

    Callable from Python and from numba nopython code; both pass as many arguments as the
    generated function takes.
    """
    w, x, entity, perm, data = scratch
    arguments = (out, w, c, x, entity, perm, data)[:len(kernel.argtypes)]
    kernel(*[a.ctypes.data for a in arguments])


@numba.extending.overload(call_kernel)
def _call_kernel_nopython(kernel, out, c, scratch):
    """:func:`call_kernel` in numba code: the call that matches the kernel's argument count."""
    if len(kernel.sig.args) == 7:
        def call(kernel, out, c, scratch):
            w, x, entity, perm, data = scratch
            kernel(out.ctypes, w.ctypes, c.ctypes, x.ctypes, entity.ctypes, perm.ctypes, data.ctypes)
        return call
    if len(kernel.sig.args) == 6:
        def call(kernel, out, c, scratch):
            w, x, entity, perm, _ = scratch
            kernel(out.ctypes, w.ctypes, c.ctypes, x.ctypes, entity.ctypes, perm.ctypes)
        return call
    return None


# --------------------------------------------------------------------------- PETSc
@functools.lru_cache(maxsize=None)
def _libpetsc() -> ctypes.CDLL:
    """The PETSc library of the loaded petsc4py.

    The handle of petsc4py's extension module resolves PETSc's symbols through the module's
    own dependencies, so another libpetsc on the library path (Debian's beside a wheel's) is
    never loaded into the process.
    """
    lib = ctypes.CDLL(PETSc.__file__)
    lib.MatSetPreallocationCOO.argtypes = [ctypes.c_void_p, ctypes.c_int64, ctypes.c_void_p, ctypes.c_void_p]
    lib.MatSetValuesCOO.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int]
    lib.SNESSetFunctionDomainError.argtypes = [ctypes.c_void_p]
    return lib


#: Option defaults that keep PETSc 3.18's behaviour on later PETSc (solver defaults: options given on
#: the command line or from Python win). Since PETSc 3.24 the ``l2`` line search (renamed ``secant``)
#: also stops when |d||F||^2/dlambda| <= ``snes_linesearch_atol`` (default 1e-15), which changes
#: Newton iteration counts; PETSc 3.18's ``l2`` does not read that tolerance.
PETSC_OPTION_DEFAULTS: dict[str, str] = (
    {"snes_linesearch_atol": "0"}
    if hasattr(getattr(getattr(PETSc, "SNESLineSearch", None), "Type", None), "SECANT") else {})


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


# --------------------------------------------------------------------------- output
#: the ADIOS2 engine of the VTX series: BP4, which every ParaView that reads VTX opens (BP5,
#: ADIOS2's default since 2.9, needs ParaView >= 5.11)
VTX_ENGINE = "BP4"


def has_vtx() -> bool:
    """Whether DOLFINx was built with ADIOS2 and offers ``dolfinx.io.VTXWriter``: the 0.11 wheel
    does, Debian 12's 0.5.2 (``python3-dolfinx``, built without ADIOS2) does not."""
    import dolfinx.io
    return hasattr(dolfinx.io, "VTXWriter")


def vtx_writer(comm: MPI.Comm, path: str | pathlib.Path, functions: typing.Sequence[dolfinx.fem.Function]):
    """A ``dolfinx.io.VTXWriter`` of ``functions`` into the ADIOS2 directory ``path``
    (:data:`VTX_ENGINE`); the functions must share one Lagrange element (any degree, any block
    size), the mesh is written once (its geometry does not change). Only when :func:`has_vtx`."""
    import dolfinx.io
    policy = getattr(dolfinx.io, "VTXMeshPolicy", None)
    return dolfinx.io.VTXWriter(comm, str(path), list(functions), engine=VTX_ENGINE,
                                **({"mesh_policy": policy.reuse} if policy is not None else {}))


# --------------------------------------------------------------------------- P2 FEM reference
#: vertex count -> the 2D cell with that many vertices
_CELL = {3: "triangle", 4: "quadrilateral"}
#: vertex count -> the columns that put DOLFINx's cell vertices counter-clockwise (DOLFINx
#: numbers a quadrilateral's vertices in tensor-product order: (0, 0), (1, 0), (0, 1), (1, 1));
#: the permutation is its own inverse
COUNTER_CLOCKWISE = {3: [0, 1, 2], 4: [0, 1, 3, 2]}


def create_mesh_partitioned(comm: MPI.Comm, cells: npt.NDArray[np.int64], x: npt.NDArray[np.float64], *,
                            ghost_facet_neighbours: bool = False, cell: str | None = None) -> dolfinx.mesh.Mesh:
    """Distributed mesh partitioned by DOLFINx's graph partitioner.

    Parameters
    ----------
    cells : (n_cells, k) int64
        Input cells held by this rank (usually all on rank 0, none elsewhere): without ``cell``,
        triangles or quadrilaterals of degree-1 geometry with their vertices counter-clockwise; with
        ``cell``, in DOLFINx's node order, k the node count of a geometry of degree 1 or 2
        (:func:`geometry_degree`: 10-node tetrahedra, 27-node hexahedra, ... are curved cells). Quadrilaterals and hexahedra may be non-affine (bilinear,
        trilinear maps): UFL differentiates their inverse Jacobian in second derivatives.
    x : (n_nodes, gdim) float64
        Input node coordinates held by this rank.
    ghost_facet_neighbours
        Ghost the cells across the partition's facets (``GhostMode.shared_facet``), as interior
        facet integrals need; otherwise no ghost cells.
    cell
        The cell type (e.g. ``"tetrahedron"``, ``"hexahedron"``); None: 2D cells counter-clockwise.
    """
    ghost_mode = dolfinx.mesh.GhostMode.shared_facet if ghost_facet_neighbours else dolfinx.mesh.GhostMode.none
    if cell is not None:
        return _create_mesh(comm, cells, x, cell, ghost_mode)
    n_vertices = cells.shape[1]
    if n_vertices not in _CELL:
        raise ValueError(f"cells must have 3 or 4 vertices, not {n_vertices}")
    return _create_mesh(comm, cells[:, COUNTER_CLOCKWISE[n_vertices]], x, _CELL[n_vertices], ghost_mode)


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


def reference_quadrature(mesh: dolfinx.mesh.Mesh | str, degree: int, rule: str = "default"
                         ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Basix's rule ``rule`` on the reference cell of ``mesh`` (or on the cell type named) exact for
    ``degree``, the rule FFCx uses for ``metadata={"quadrature_rule": rule, "quadrature_degree": degree}``
    (both stacks spell the metadata so): points (n, tdim) and weights (n,).

    ``rule`` is a name of ``basix.quadrature.string_to_type``: ``"default"`` or ``"GLL"``
    (Gauss-Lobatto-Legendre, on quadrilaterals and hexahedra; degree 2-3: the Q2 nodes).
    """
    name = mesh if isinstance(mesh, str) else mesh.topology.cell_type.name
    cell = getattr(basix.CellType, name)
    rule_type = basix.quadrature.string_to_type(rule)
    if hasattr(basix.quadrature, "make_quadrature"):          # basix 0.11: (cell, degree, rule=)
        points, weights = basix.make_quadrature(cell, degree, rule=rule_type)
    else:                                                     # basix 0.5: (rule, cell, degree)
        points, weights = basix.make_quadrature(rule_type, cell, degree)
    return np.asarray(points), np.asarray(weights)


#: whether ``Expression.eval`` takes the mesh (DOLFINx 0.11)
_EVAL_TAKES_MESH = "mesh" in inspect.signature(dolfinx.fem.Expression.eval).parameters


class CompiledExpression:
    """A UFL expression compiled for evaluation at fixed reference points of the cells."""

    def __init__(self, expression: ufl.core.expr.Expr, mesh: dolfinx.mesh.Mesh, points: npt.NDArray[np.float64]):
        with compiling():
            self._expression = dolfinx.fem.Expression(expression, np.ascontiguousarray(points, dtype=np.float64))
        self._mesh_argument = (mesh,) if _EVAL_TAKES_MESH else ()
        self._n_points = points.shape[0]

    def __call__(self, cells: npt.NDArray[np.int32]) -> npt.NDArray[np.float64]:
        """Values (n_cells, n_points, value_size) on the local ``cells``."""
        values = self._expression.eval(*self._mesh_argument, np.ascontiguousarray(cells, dtype=np.int32))
        return values.reshape(cells.size, self._n_points, -1)


def locate_cells(mesh: dolfinx.mesh.Mesh, points: npt.NDArray[np.float64], n_cells: int) -> npt.NDArray[np.int32]:
    """For every point (n, gdim) the first of the local cells [0, ``n_cells``) that contains it,
    -1 for none (DOLFINx's bounding-box tree and its exact collision test)."""
    import dolfinx.geometry
    tdim = mesh.topology.dim
    xyz = np.zeros((len(points), 3))
    xyz[:, :points.shape[1]] = points
    cells = np.arange(n_cells, dtype=np.int32)
    if hasattr(dolfinx.geometry, "bb_tree"):          # DOLFINx 0.11
        tree = dolfinx.geometry.bb_tree(mesh, tdim, entities=cells)
        candidates = dolfinx.geometry.compute_collisions_points(tree, xyz)
    else:
        tree = dolfinx.geometry.BoundingBoxTree(mesh, tdim, cells)
        candidates = dolfinx.geometry.compute_collisions(tree, xyz)
    colliding = dolfinx.geometry.compute_colliding_cells(mesh, candidates, xyz)
    offsets = np.asarray(colliding.offsets)
    found = np.diff(offsets) > 0
    out = np.full(len(points), -1, dtype=np.int32)
    out[found] = np.asarray(colliding.array)[offsets[:-1][found]]
    return out


def entity_geometry_nodes(mesh: dolfinx.mesh.Mesh, dim: int, entities: npt.NDArray[np.int32]) -> npt.NDArray[np.int32]:
    """Geometry node indices (n, k) of the local entities of dimension ``dim``."""
    entities = np.ascontiguousarray(entities, dtype=np.int32)
    if hasattr(dolfinx.mesh, "entities_to_geometry"):         # DOLFINx 0.11
        return np.asarray(dolfinx.mesh.entities_to_geometry(mesh, dim, entities, False))
    return np.asarray(dolfinx.cpp.mesh.entities_to_geometry(getattr(mesh, "_mesh", mesh), dim, entities, False))


def plaza_refine(cells: npt.NDArray[np.int64], x: npt.NDArray[np.float64], cell: str,
                 marked: npt.NDArray[np.int64]
                 ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """One step of DOLFINx's refinement (Plaza's algorithm) of a simplex mesh held whole by this
    rank, on ``MPI.COMM_SELF``: the edges of the ``marked`` cells are split, and neighbours as the
    algorithm needs to stay conforming.

    Parameters
    ----------
    cells : (n_cells, 3 | 4) int64
        The cells, DOLFINx's vertex order.
    x : (n_points, gdim) float64
    cell
        ``"triangle"`` or ``"tetrahedron"``.
    marked : (m,) int64
        Indices into ``cells`` of the cells to split.

    Returns
    -------
    points : (n_new_points, gdim) float64
    cells : (n_new_cells, 3 | 4) int64
        Into ``points``, DOLFINx's vertex order.
    parent : (n_new_cells,) int64
        The row of the input ``cells`` that contains each new cell: DOLFINx 0.11 returns it
        (``RefinementOption.parent_cell``); on 0.5.2 it is the input cell holding the new cell's
        centroid (the bounding-box tree of :func:`locate_cells`).
    """
    mesh = _create_mesh(MPI.COMM_SELF, np.asarray(cells, dtype=np.int64), np.asarray(x, dtype=np.float64), cell,
                        dolfinx.mesh.GhostMode.none)
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim, 1)
    local_of = np.empty(cells.shape[0], dtype=np.int64)
    local_of[original_cell_index(mesh)] = np.arange(cells.shape[0])
    c2e = np.asarray(mesh.topology.connectivity(tdim, 1).array).reshape(cells.shape[0], -1)
    edges = np.unique(c2e[local_of[np.asarray(marked, dtype=np.int64)]]).astype(np.int32)
    if hasattr(dolfinx.mesh, "RefinementOption"):                          # DOLFINx 0.11
        fine, parent, _ = dolfinx.mesh.refine(mesh, edges, partitioner=None,
                                              option=dolfinx.mesh.RefinementOption.parent_cell)
        # the parents are listed in the order the refined cells were created, which the new
        # mesh's original cell index gives (its cells are reordered)
        parent = np.asarray(parent, dtype=np.int64)[original_cell_index(fine)]
    else:
        fine = dolfinx.mesh.refine(mesh, edges, redistribute=False)
        parent = None
    nodes = cell_geometry_nodes(fine).astype(np.int64)
    points = np.asarray(fine.geometry.x[:, :x.shape[1]], dtype=np.float64)
    if parent is None:
        parent = locate_cells(mesh, points[nodes].mean(axis=1), cells.shape[0]).astype(np.int64)
        if np.any(parent < 0):
            raise RuntimeError("refine: a refined cell's centroid lies in no cell of the mesh refined")
    return points, nodes, original_cell_index(mesh)[parent]
