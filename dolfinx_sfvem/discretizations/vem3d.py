"""SFVEM discretization on polyhedra: residual and tangent of a region-wise energy into PETSc objects.

The polyhedra's hooks of :class:`~dolfinx_sfvem.discretizations.sfvem.OnSFVEMNodes` (docs/method.md
§8), which holds the steps both dimensions share: the space
(:class:`~dolfinx_sfvem.discretizations.polyhedral_space.PolyhedralSpace`, hosted by the P2 space of a
tetrahedral fan mesh, with the projections and the energy quadrature of its polyhedra) and the
compiled 3D kernels of each region's UFL energy meet in the loops of
:mod:`~dolfinx_sfvem.discretizations.polyhedron_loops`.

What the contact checks, the pictures and the loads on faces see is the *host*: the P2 function on
the fan mesh that :meth:`PolyhedralSpace.p2_interpolation` makes of the SFVEM state (T u, T a fixed
sparse matrix): the degrees of freedom at vertices and edge midpoints, each face's projection of
its trace on the face, each polyhedron's Π^∇_2 u inside it. A load written as a UFL form on the host
(:mod:`~dolfinx_sfvem.physics.face_loads`) enters the SFVEM system as Tᵀ f and Tᵀ K T (:meth:`to_host`,
:meth:`add_from_host`, :meth:`add_host_matrix`): the discrete load is the host form evaluated at
T u, so its residual and stiffness stay consistent.
"""
from __future__ import annotations

import typing
from dataclasses import dataclass

import numpy as np
import scipy.sparse
from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.fem
import dolfinx.fem.petsc

from dolfinx_sfvem import _compat
from dolfinx_sfvem.mesh.cell_mesh import CellMesh, CellOutlines
from dolfinx_sfvem.discretizations.discretization import SFVEM_NO_FEM_RULES, EnergyTerm, check_materials
from dolfinx_sfvem.discretizations.sfvem import EnclosedTerm, OnSFVEMNodes, Region
from dolfinx_sfvem.physics.enclosed_volume import EnclosedVolume
from dolfinx_sfvem.physics.energy import Energy
from dolfinx_sfvem.mesh.csr import edge_key
from dolfinx_sfvem.discretizations.polyhedral_space import FACE, TET_EDGES, PolyhedralSpace
from dolfinx_sfvem.discretizations.polyhedron_loops import (
    PolyhedronTables, basis_tables, deformation_at, load_loop, projected_fields, residual_loop, tangent_loop)
from dolfinx_sfvem.mesh.polyhedron_mesh import PolyhedronMesh
from dolfinx_sfvem.discretizations.projection3d import L_MIN

#: degree of the quadrature of the forms on the faces of the load space: the loads on faces and the
#: enclosed volume (P2 traces: dead loads exactly)
FACE_QUADRATURE_DEGREE = 4


@dataclass
class _CavityTerm(EnclosedTerm):
    """The cavity's work on polyhedra: −p ΔV, the volume swept by the region's faces
    (:mod:`~dolfinx_sfvem.physics.enclosed_volume`), exact on the face projections, where the projected
    gradient's ∫ det Π⁰_l∇u would depend on interior DOFs; its tangent is a form on the load space,
    added to the assembled matrix."""
    volume: EnclosedVolume

    def add_force(self, u: np.ndarray, scale: float, R: np.ndarray) -> float:
        return self.volume.add_force(u, scale, R)

    def add_tangent_matrix(self, u: np.ndarray, scale: float, A: PETSc.Mat) -> None:
        self.volume.add_tangent(u, scale, A)


class PolyhedralDiscretization(OnSFVEMNodes):
    """Order-2 SFVEM discretization of Σ_regions ∫ Ψ_r(F, ∇F) dΩ on a polyhedral mesh (module docstring).

    Parameters
    ----------
    mesh
        Polyhedral mesh with region tags (identical on every rank).
    materials
        Region tag -> energy.
    comm
        Communicator.
    l, l_min, quadrature
        Passed to :class:`PolyhedralSpace`.
    verbose
        Print the space's summary on rank 0.
    """

    def __init__(self, mesh: PolyhedronMesh, materials: typing.Mapping[int, Energy], comm: MPI.Comm = MPI.COMM_WORLD,
                 *, l: int | None = None, l_min: int = L_MIN, quadrature: str = "auto", verbose: bool = True):
        check_materials(mesh.tags, materials, ("gauss",), SFVEM_NO_FEM_RULES)
        super().__init__(PolyhedralSpace(mesh, comm, l=l, l_min=l_min, quadrature=quadrature, verbose=verbose),
                         materials, comm)
        space = self.space
        self.element_loops = None
        self._host_by_key()
        self._output_mesh = CellMesh(space.fan.nodes, space.fan.tetrahedra,
                                     mesh.tags[space.fan.tetrahedron_cell], "tetrahedron", mesh.region_names)
        self._host_products: dict[int, tuple[PETSc.Mat, PETSc.Mat | None]] = {}
        self._T_petsc: PETSc.Mat | None = None

    # ------------------------------------------------------------------ the polyhedra's hooks
    def _basis_tables(self, nphi: np.ndarray, phi_off: np.ndarray) -> PolyhedronTables:
        space, proj = self.space, self.space.projections
        Phi = basis_tables(space.dof_offsets, space.q_offsets, space.x_q, proj.l, proj.centroid, proj.diameter,
                           proj.Pi_m_offsets, proj.Pi_m, nphi, phi_off)
        return PolyhedronTables(space.dof_offsets, space.dofs.astype(np.int64), space.q_offsets, space.w_q, nphi,
                                phi_off, Phi)

    def _residual_loop(self, reg: Region, c: np.ndarray, u: np.ndarray, R: np.ndarray, stats: np.ndarray) -> None:
        k = reg.kernels
        residual_loop(k.residual, c, k.F_offset, k.G_offset, *reg.residual_at, reg.cells, self._tables, u, R, stats)

    def _tangent_loop(self, reg: Region, c: np.ndarray, u: np.ndarray, values: np.ndarray) -> None:
        k = reg.kernels
        tangent_loop(k.tangent, c, k.F_offset, k.G_offset, *reg.tangent_at, reg.cells, self._tables, u, values,
                     self._coo_off, reg.term is not None)

    def _load_loop(self, f_q: np.ndarray, F: np.ndarray) -> None:
        proj = self.space.projections
        load_loop(self._tables, self.space.x_q, proj.centroid, proj.diameter, proj.Pi_nabla_offsets, proj.Pi_nabla,
                  f_q, F)

    def _projected_fields(self, u: np.ndarray, u_q: np.ndarray, grad_q: np.ndarray) -> None:
        proj = self.space.projections
        projected_fields(self._tables, self.space.x_q, proj.centroid, proj.diameter, proj.Pi_nabla_offsets,
                         proj.Pi_nabla, u, u_q, grad_q)

    def _folds(self, u: np.ndarray) -> None:
        """None: the polyhedra's boundaries are not checked for folds (the guard is J > 0)."""
        return None

    def _enclosed_term(self, region: Region, energy: Energy, term: EnergyTerm) -> _CavityTerm:
        return _CavityTerm(region.tag, energy, region.cells, term, EnclosedVolume(self, region.tag))

    # ------------------------------------------------------------------ fields
    def dof_values(self, value: typing.Callable[[np.ndarray], np.ndarray], dofs: np.ndarray) -> np.ndarray:
        """Values of ``value(x) -> (n,)`` at the unknowns ``dofs`` of one component: point values at
        vertices and edge midpoints, means on the faces and polyhedra."""
        vector = self.space.interpolate(lambda X: np.broadcast_to(np.asarray(value(X), dtype=np.float64),
                                                                  (3, X.shape[1])))
        with vector.localForm() as vl:
            out = vl.array_r[np.asarray(dofs, dtype=np.int64)].copy()
        vector.destroy()
        return out

    def displacement_at(self, x: PETSc.Vec, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The host displacement (module docstring) at reference ``points`` (n, 3) inside this rank's
        polyhedra: (values (n, 3), found (n,) bool)."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, self.gdim)
        local = _compat.locate_cells(self.space.mesh, points, _compat.num_owned_cells(self.space.mesh))
        found = local >= 0
        values = np.zeros((len(points), 3))
        u = self.output_function(x)                      # collective
        if found.any():
            values[found] = u.eval(points[found], local[found])
        return values, found

    # ------------------------------------------------------------------ the hosts on the fan mesh (:class:`LoadHost`)
    @property
    def V(self) -> dolfinx.fem.FunctionSpace:
        """The output host: the vector P2 space on the fan mesh (:meth:`output_function`), whose nodes at
        the polyhedra's vertices, edge midpoints and face centres carry SFVEM nodes (:meth:`nodes_of_host`)."""
        return self.space.V

    @property
    def load_space(self) -> dolfinx.fem.FunctionSpace:
        """The host of the loads on faces: discontinuous P2 on the fan mesh, the face projections
        on the faces (:meth:`PolyhedralSpace.face_trace_interpolation`)."""
        return self.space.face_trace_interpolation()[0]

    @property
    def cell_tag(self) -> np.ndarray:
        """Region tag of every local fan tetrahedron (its polyhedron's)."""
        return self.space.polyhedron_mesh.tags[self.space.cell_polyhedron]

    face_quadrature_degree = FACE_QUADRATURE_DEGREE
    #: each face's own projected trace on the load space: not continuous across the faces' edges
    continuous_face_traces = False

    @property
    def _trace(self) -> scipy.sparse.csr_matrix:
        return self.space.face_trace_interpolation()[1]

    def to_host(self, u: np.ndarray) -> np.ndarray:
        """Values (n_local_W · 3,) on :attr:`load_space` from the nodal values u (n_local_nodes, 3):
        those of the owned tetrahedra (the caller scatters them to the ghosts)."""
        return (self._trace @ np.asarray(u).reshape(-1, self.gdim)).ravel()

    def add_from_host(self, host: PETSc.Vec, f: np.ndarray) -> None:
        """f (n_local_nodes, 3) += Tᵀ host: an assembled (not yet accumulated) vector of
        :attr:`load_space` as the force on the SFVEM unknowns (their ghosts accumulated by the
        caller). ``host``'s ghost contributions are accumulated here."""
        host.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        n = self.load_space.dofmap.index_map.size_local
        f.reshape(-1, self.gdim)[:] += self._trace[:n].T @ host.getArray(readonly=True).reshape(-1, self.gdim)

    def nodes_of_host(self, nodes: np.ndarray) -> np.ndarray:
        """The SFVEM nodes hosted by the local P2 nodes ``nodes`` of :attr:`V` (those that host one)."""
        node_of_p2 = np.full(self.V.dofmap.index_map.size_local + self.V.dofmap.index_map.num_ghosts, -1,
                             dtype=np.int64)
        node_of_p2[self.space.p2_node] = np.arange(self.n_local_nodes)
        found = node_of_p2[np.asarray(nodes, dtype=np.int64)]
        return found[found >= 0]

    def add_host_matrix(self, A: PETSc.Mat, form: dolfinx.fem.Form, scale: float = 1.0) -> None:
        """A += scale Tᵀ K T for the bilinear ``form`` on :attr:`load_space` (compiled), assembled
        (collective). Tᵀ K T couples the DOFs of faces only, inside the polyhedron blocks of A."""
        if self._T_petsc is None:
            self._T_petsc = self._petsc_trace()
        if id(form) not in self._host_products:
            self._host_products[id(form)] = (dolfinx.fem.petsc.create_matrix(form), None)
        K, product = self._host_products[id(form)]
        K.zeroEntries()
        dolfinx.fem.petsc.assemble_matrix(K, form)
        K.assemble()
        product = K.PtAP(self._T_petsc) if product is None else K.PtAP(self._T_petsc, product)
        self._host_products[id(form)] = (K, product)
        A.assemble()
        A.axpy(scale, product, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)

    def _petsc_trace(self) -> PETSc.Mat:
        """The map of :attr:`load_space` as a PETSc matrix: its owned unknowns (rows) by the SFVEM ones."""
        im = self.load_space.dofmap.index_map
        T = self._trace.tocoo()
        owned = T.row < im.size_local
        first = 3 * im.local_range[0]
        rows = (first + 3 * T.row[owned][:, None] + np.arange(3)).ravel()
        cols = (3 * self.global_nodes[T.col[owned]][:, None] + np.arange(3)).ravel()
        M = PETSc.Mat().create(self.comm)
        M.setSizes(((3 * im.size_local, 3 * im.size_global), (3 * self.n_owned_nodes, self.num_dofs_global)))
        M.setType(PETSc.Mat.Type.AIJ)
        _compat.mat_set_preallocation_coo(M, rows.astype(PETSc.IntType), cols.astype(PETSc.IntType))
        _compat.mat_set_values_coo(M, np.repeat(T.data[owned], 3), _compat.INSERT_VALUES)
        M.assemble()
        return M

    def _host_by_key(self) -> None:
        """The partition-independent key of every local host node: its fan point for the P2 nodes at
        the fan mesh's points, ``n + edge_key(a, b)`` for the edge nodes (n fan points)."""
        mesh, V = self.space.mesh, self.space.V
        im = V.dofmap.index_map
        dofs = _compat.cell_dofs(V)
        inp = _compat.input_node_index(mesh)[_compat.cell_geometry_nodes(mesh)]
        self.host_key = np.full(im.size_local + im.num_ghosts, -1, dtype=np.int64)
        self.host_key[dofs[:, :4]] = inp
        self.host_key[dofs[:, 4:]] = self.midpoint_keys(inp[:, TET_EDGES[:, 0]], inp[:, TET_EDGES[:, 1]])
        self._n_owned_host = im.size_local

    def midpoint_keys(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Host node keys (:meth:`output_state`) of the midpoints of the edges between the
        :attr:`output_mesh` points a and b (n,)."""
        n = self.space.fan.nodes.shape[0]
        return n + edge_key(a, b, n)

    def output_state(self, v: PETSc.Vec) -> tuple[np.ndarray, np.ndarray]:
        """The host values (T v) at the owned host nodes with their keys: what the contact checks read."""
        with v.localForm() as vl:
            values = self.space.p2_interpolation()[:self._n_owned_host] @ vl.array_r.reshape(-1, self.gdim)
        return self.host_key[:self._n_owned_host].copy(), values

    def output_forces(self, f: PETSc.Vec) -> tuple[np.ndarray, np.ndarray]:
        """Nodal forces ``f`` of the SFVEM unknowns on the owned host nodes, for the contact pressure's
        recovery: at vertices and edge midpoints their own, at a face's fan centre the force of the
        face's mean DOF, zero at the other host nodes (the resultant on each face is kept)."""
        space = self.space
        with f.localForm() as fl:
            nodal = fl.array_r.reshape(-1, self.gdim)
            values = np.zeros((self._n_owned_host, 3))
            hosted = np.flatnonzero(space.node_kind <= FACE)
            p2 = space.p2_node[hosted]
            mine = p2 < self._n_owned_host
            values[p2[mine]] = nodal[hosted[mine]]
        return self.host_key[:self._n_owned_host].copy(), values

    # ------------------------------------------------------------------ output
    @property
    def output_mesh(self) -> CellMesh:
        """The fan tetrahedra (identical on all ranks): pictures and the contact checks."""
        return self._output_mesh

    @property
    def cell_outlines(self) -> CellOutlines:
        """The polyhedra over the fan tetrahedra of :attr:`output_mesh`: the edges of
        :meth:`PolyhedronMesh.edges` (the polyhedron mesh's points are the fan mesh's first) and the
        polyhedron of every fan tetrahedron."""
        space = self.space
        return CellOutlines(space.polyhedron_mesh.edges(), space.fan.tetrahedron_cell)

    @property
    def pressure_keys(self) -> np.ndarray:
        """The polyhedra's vertices (the fan mesh's first points): a face's force, mostly on its mean
        DOF, follows a smooth traction poorly face by face, its sum over a vertex's faces well
        (docs/contact.md)."""
        return np.arange(self.space.polyhedron_mesh.points.shape[0], dtype=np.int64)

    def output_point_displacements(self, x: PETSc.Vec) -> tuple[np.ndarray, np.ndarray]:
        """(fan points (k,), host displacements (k, 3)) of the owned host nodes at fan points."""
        keys, values = self.output_state(x)
        at_point = keys < self.space.fan.nodes.shape[0]
        return keys[at_point], values[at_point]

    def cell_tags(self):
        """Region tag of every local fan tetrahedron (its polyhedron's)."""
        return _compat.create_cell_tags(self.space.mesh, self.cell_tag)

    def cell_stress(self, x: PETSc.Vec) -> tuple[np.ndarray, np.ndarray]:
        """F and P at the centre of every owned fan tetrahedron, from Π⁰_l∇u (and its gradient) of
        its polyhedron and the region's compiled kernel."""
        from dolfinx_sfvem.discretizations.compiled_energy import tabulate
        space, proj = self.space, self.space.projections
        n = _compat.num_owned_cells(space.mesh)
        centre = space.mesh.geometry.x[_compat.cell_geometry_nodes(space.mesh)[:n], :3].mean(axis=1)
        cell = np.searchsorted(space.cells, space.cell_polyhedron[:n])
        F, G = np.empty((n, 3, 3)), np.empty((n, 3, 3, 3))
        with x.localForm() as xl:
            deformation_at(np.ascontiguousarray(centre), cell, self._tables, proj.l, proj.centroid, proj.diameter,
                           proj.Pi_m_offsets, proj.Pi_m, xl.array_r.reshape(-1, self.gdim), F, G)
        P = np.zeros((n, 3, 3))
        tag = space.tags[cell]
        for reg in self.regions:
            k = reg.kernels
            c = k.pack_constants(reg.params)
            for t in np.flatnonzero(tag == reg.tag):
                c[k.F_offset:k.F_offset + 9] = F[t].ravel()
                if k.uses_gradient:
                    c[k.G_offset:k.G_offset + 27] = G[t].ravel()
                P[t] = tabulate(k.residual, k.n_residual, c)[reg.residual_at[0]:][:9].reshape(3, 3)
        return F, P

    def describe(self) -> dict:
        """Mesh facts for summary.json."""
        l, counts = np.unique(np.concatenate(self.comm.allgather(self.space.projections.l)), return_counts=True)
        return {"polyhedra": int(self.space.polyhedron_mesh.n_cells), "quadrature": self.space.quadrature,
                "projection_order_histogram": {str(k): int(n) for k, n in zip(l, counts)}}
