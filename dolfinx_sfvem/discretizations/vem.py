"""SFVEM discretization of a region-wise energy: residual and tangent into PETSc objects.

This is the glue between the space (``space.py``), the compiled pointwise energy
kernels (``compiled_energy.py``) and the compiled polygon loops (``assemble.py``). The PETSc
matrix is preallocated once in COO format (one dense block per polygon plus the
diagonal) and refilled in place at every Newton iteration; the residual is assembled
into the ghosted local form of a PETSc vector and accumulated over ranks.
"""
from __future__ import annotations

import typing
from dataclasses import dataclass

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from dolfinx_sfvem import _compat
from dolfinx_sfvem.discretizations import node_keys
from dolfinx_sfvem.discretizations.assemble import (
    PolygonTables, basis_derivative_tables, coo_pattern, first_piola_at, load_loop, projected_fields, residual_loop,
    tangent_loop)
from dolfinx_sfvem.discretizations.discretization import (
    SFVEM_NO_FEM_RULES, AssemblyInfo, EnergyTerm, OnSFVEMNodes, check_materials)
from dolfinx_sfvem.physics.enclosed_area import area_force_loop, area_tangent_loop
from dolfinx_sfvem.physics.energy import Energy, VolumeWork
from dolfinx_sfvem.discretizations.injectivity import folded_elements, gather_count
from dolfinx_sfvem.discretizations.compiled_energy import EnergyKernels, compile_kernels
from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh
from dolfinx_sfvem.discretizations.monomials import evaluate_monomials
from dolfinx_sfvem.discretizations.space import VERTEX, VEMSpace


def _residual_at(k: EnergyKernels) -> tuple[int, int]:
    """Offsets of P and T in the residual kernel output (T: -1 when absent)."""
    assert k.residual_offsets["psi"] == 0
    return k.residual_offsets["P"], k.residual_offsets.get("T", -1)


def _tangent_at(k: EnergyKernels) -> tuple[int, int, int]:
    """Offsets of D, A and B in the tangent kernel output (-1 when absent)."""
    return k.tangent_offsets["D"], k.tangent_offsets.get("A", -1), k.tangent_offsets.get("B", -1)


@dataclass
class _Region:
    """A region's energy, or an energy term on a region (``term``), with its compiled kernels."""
    tag: int
    energy: Energy
    kernels: EnergyKernels
    cells: np.ndarray        # local cell (polygon or polyhedron) indices (int64)
    term: EnergyTerm | None = None

    @property
    def params(self) -> dict[str, float]:
        return self.energy.params if self.term is None else self.term.params


@dataclass
class _AreaTerm:
    """The energy term −p ∫ (J − 1) dΩ (:class:`VolumeWork`) over a region, as −p (A(x) − A(X)):
    the area enclosed by the deformed boundary traces of its polygons (:mod:`~dolfinx_sfvem.physics.enclosed_area`),
    exact for any nodal displacement, where the projected gradient's ∫ det Π⁰_l∇u is not."""
    tag: int
    energy: Energy
    cells: np.ndarray        # local cell (polygon or polyhedron) indices (int64)
    term: EnergyTerm

    @property
    def params(self) -> dict[str, float]:
        return self.term.params


class SFVEMDiscretization(OnSFVEMNodes):
    """Order-2 SFVEM discretization of Σ_regions ∫ Ψ_r(F, ∇F) dΩ on a polygon mesh.

    Parameters
    ----------
    mesh
        Polygon mesh with region tags.
    materials
        Region tag -> energy.
    comm
        Communicator.
    l, l_min, quadrature_degree, quadrature
        Passed to :class:`VEMSpace`.
    """

    method = "vem"
    gdim = 2

    def __init__(self, mesh: PolygonMesh, materials: typing.Mapping[int, Energy], comm: MPI.Comm = MPI.COMM_WORLD,
                 *, l=None, l_min: int = 3, quadrature_degree: int | None = None, quadrature: str = "compressed",
                 verbose: bool = True):
        check_materials(mesh.tags, materials, ("gauss",), SFVEM_NO_FEM_RULES)
        self.comm = comm
        self.materials = dict(sorted(materials.items()))
        self.space = space = VEMSpace(mesh, comm, l=l, l_min=l_min, quadrature_degree=quadrature_degree,
                                      quadrature=quadrature, verbose=verbose)
        self.regions = [_Region(tag, energy, compile_kernels(energy, comm),
                                np.flatnonzero(space.tags == tag).astype(np.int64))
                        for tag, energy in self.materials.items()]
        proj = space.projections
        nd = np.diff(space.dof_offsets)
        nphi = np.full(nd.size, 2, dtype=np.int64)       # rows of Φ: ∇φ, and ∇∇φ where Ψ uses G
        for reg in self.regions:
            nphi[reg.cells] = 6 if reg.kernels.uses_gradient else 2
        phi_off = np.concatenate([[0], np.cumsum(nphi * nd * np.diff(space.q_offsets))]).astype(np.int64)
        Phi = basis_derivative_tables(space.dof_offsets, proj.l, proj.centroid, proj.diameter,
                                      proj.Pi_m_offsets, proj.Pi_m, space.q_offsets, space.x_q, nphi, phi_off)
        self._tables = PolygonTables(space.dof_offsets, space.dofs, phi_off, Phi, space.q_offsets, space.w_q)
        self._coo_off = np.concatenate([[0], np.cumsum(4 * nd * nd)]).astype(np.int64)
        self.terms: list[_Region] = []         # energy terms (:meth:`add_energy_term`)
        self.global_nodes = np.asarray(space.index_map.local_to_global(np.arange(space.n_local_nodes, dtype=np.int32)),
                                       dtype=np.int64)
        self._values = np.zeros(self._coo_off[-1] + 2 * space.n_owned_nodes)     # the diagonal's entries stay 0
        # boundary loop v_0, m_0, v_1, m_1, ... of every polygon (injectivity guard)
        N = (nd - 1) // 2
        self._loop_offsets = np.concatenate([[0], np.cumsum(2 * N)]).astype(np.int64)
        first = np.repeat(space.dof_offsets[:-1], 2 * N)
        k = np.arange(self._loop_offsets[-1]) - np.repeat(self._loop_offsets[:-1], 2 * N)
        self._loop = space.dofs[first + k // 2 + (k % 2) * np.repeat(N, 2 * N)].astype(np.int64)
        self._solid = np.zeros(space.polygons.size, dtype=bool)
        for reg in self.regions:
            self._solid[reg.cells] = not reg.energy.is_medium
        self.element_loops = (self._loop_offsets, self._loop, space.polygons)

    # ------------------------------------------------------------------ PETSc objects
    def coarse_interpolation(self) -> PETSc.Mat:
        """The vertex values into the unknowns (:meth:`VEMSpace.coarse_interpolation`)."""
        return self.space.coarse_interpolation()

    def create_matrix(self) -> PETSc.Mat:
        """AIJ matrix with the COO pattern: polygon blocks, then the owned diagonal (zero entries)."""
        space = self.space
        n_owned, n_global = 2 * space.n_owned_nodes, space.num_dofs_global
        A = PETSc.Mat().create(self.comm)
        A.setSizes(((n_owned, n_global), (n_owned, n_global)))
        A.setType(PETSc.Mat.Type.AIJ)
        A.setBlockSize(2)
        rows, cols = coo_pattern(space.dof_offsets, space.dofs, self.global_nodes, self._coo_off)
        start = 2 * space.index_map.local_range[0]
        diagonal = np.arange(start, start + n_owned, dtype=np.int32)
        _compat.mat_set_preallocation_coo(A, np.concatenate([rows, diagonal]), np.concatenate([cols, diagonal]))
        A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, True)
        A.setOption(PETSc.Mat.Option.KEEP_NONZERO_PATTERN, True)
        return A

    # ------------------------------------------------------------------ assembly
    def residual(self, x: PETSc.Vec, b: PETSc.Vec) -> AssemblyInfo:
        """Internal force vector b = ∂W/∂ũ (Eq. 52) at x (ghosts of x must be current), energy
        terms included."""
        stats = self._internal_force(x, b, self.regions + self.terms)
        with x.localForm() as xl:
            folded, kinked = folded_elements(self._loop_offsets, self._loop, self.space.x_nodes,
                                             xl.array_r.reshape(-1, 2),
                                             np.arange(self.space.polygons.size, dtype=np.int64), self._solid)
        return self._gather_info(stats, folded, kinked)

    def _add_force(self, reg: _Region | _AreaTerm, u: np.ndarray, R: np.ndarray, stats: np.ndarray,
                   regularization: bool) -> None:
        """R += ∂/∂ũ of one region's or term's energy (Eq. 52) at the nodal u
        (:meth:`OnSFVEMNodes._internal_force`)."""
        if isinstance(reg, _AreaTerm):
            stats[0] -= reg.params["p"] * area_force_loop(reg.cells, self.space.dof_offsets, self.space.dofs,
                                                          self.space.x_nodes, u, -reg.params["p"], R)
            return
        k = reg.kernels
        P_at, T_at = _residual_at(k)
        c = k.pack_constants(reg.params if regularization else reg.energy.unregularized_params())
        residual_loop(k.residual, c, k.F_offset, k.G_offset, P_at, T_at, k.uses_gradient, reg.cells, self._tables,
                      u, R, stats)

    def _gather_info(self, stats: np.ndarray, folded: np.ndarray, kinked: np.ndarray) -> AssemblyInfo:
        """AssemblyInfo over all ranks from this rank's [energy, min J, its local polygon] and
        folded and kinked masks over the local polygons."""
        min_J, rank = self.comm.allreduce((stats[1], self.comm.rank), op=MPI.MINLOC)
        k = int(stats[2])
        where = (int(self.space.polygons[k]), int(self.space.tags[k])) if k >= 0 else (-1, -1)
        polygon, tag = self.comm.bcast(where, root=rank)
        return AssemblyInfo(self.comm.allreduce(stats[0], op=MPI.SUM), float(min_J), polygon, tag,
                            *gather_count(self.comm, folded, self.space.polygons),
                            gather_count(self.comm, kinked, self.space.polygons)[0])

    def assemble_tangent(self, x: PETSc.Vec, A: PETSc.Mat) -> None:
        """Tangent (Eq. 56) at x into A, energy terms included, constraints not applied."""
        values = self._values
        with x.localForm() as xl:
            u = xl.array_r.reshape(-1, 2)
            for reg in self.regions + self.terms:
                if isinstance(reg, _AreaTerm):
                    area_tangent_loop(reg.cells, self.space.dof_offsets, -reg.params["p"], values, self._coo_off)
                    continue
                k = reg.kernels
                D_at, A_at, B_at = _tangent_at(k)
                c = k.pack_constants(reg.params)
                tangent_loop(k.tangent, c, k.F_offset, k.G_offset, D_at, A_at, B_at, k.uses_gradient,
                             reg.cells, self._tables, u, values, self._coo_off, reg.term is not None)
        _compat.mat_set_values_coo(A, values, _compat.INSERT_VALUES)
        A.assemble()

    # ------------------------------------------------------------------ energy terms
    def _term(self, region: _Region, energy: Energy, term: EnergyTerm) -> _Region | _AreaTerm:
        """The assembled form of an energy term (:meth:`OnSFVEMNodes.add_energy_term`): with the
        region's basis tables, or a :class:`VolumeWork` term −p ∫ (J − 1) dΩ exactly, from the area
        enclosed by the region's deformed boundary traces (:class:`_AreaTerm`)."""
        if isinstance(energy, VolumeWork):
            return _AreaTerm(region.tag, energy, region.cells, term)
        return _Region(region.tag, energy, compile_kernels(energy, self.comm), region.cells, term)

    # ------------------------------------------------------------------ loads and fields
    def body_force_vector(self, f: typing.Callable[[np.ndarray], np.ndarray]) -> PETSc.Vec:
        """External force vector of a body force, ∫ f · Π^∇_2 v dΩ (the b-term of Eq. 1).

        Parameters
        ----------
        f
            Body force per unit reference area: ``f(x)`` with ``x`` of shape (2, n) returns (2, n).
        """
        space = self.space
        f_q = np.ascontiguousarray(np.broadcast_to(np.asarray(f(space.x_q.T), dtype=np.float64),
                                                   (2, space.x_q.shape[0])).T)
        F = self.create_vector()
        proj = space.projections
        with F.localForm() as fl:
            fl.set(0.0)
            load_loop(np.arange(space.polygons.size), space.dof_offsets, space.dofs, proj.centroid, proj.diameter,
                      proj.Pi_nabla_offsets, proj.Pi_nabla, space.q_offsets, space.x_q, space.w_q, f_q,
                      fl.array.reshape(-1, 2))
        F.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        return F

    def quadrature_fields(self, x: PETSc.Vec) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Points x_q (n_q, 2) and weights (n_q,) of the energy quadrature with Π^∇_2 u (n_q, 2) and
        Π⁰_l∇u (n_q, 2, 2) there (Eqs. 36, 45): the fields of :meth:`error_norms`."""
        space = self.space
        proj = space.projections
        u_q = np.empty((space.x_q.shape[0], 2))
        grad_q = np.empty((space.x_q.shape[0], 2, 2))
        with x.localForm() as xl:
            projected_fields(np.arange(space.polygons.size), space.dof_offsets, space.dofs, proj.l, proj.centroid,
                             proj.diameter, proj.Pi_m_offsets, proj.Pi_m, proj.Pi_nabla_offsets, proj.Pi_nabla,
                             space.q_offsets, space.x_q, xl.array_r.reshape(-1, 2), u_q, grad_q)
        return space.x_q, space.w_q, u_q, grad_q

    def quadrature_cells(self) -> np.ndarray:
        """The polygon of every point of :meth:`quadrature_fields` (the space's energy quadrature)."""
        return np.repeat(self.space.polygons, np.diff(self.space.q_offsets))

    # ------------------------------------------------------------------ locating unknowns
    @property
    def node_point(self) -> np.ndarray:
        return self.space.node_point

    def displacement_at(self, x: PETSc.Vec, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Π^∇_2 u (Eq. 36) at ``points`` (n, 2) inside this rank's polygons: (values (n, 2), found (n,)
        bool); points elsewhere get zeros and False."""
        space, proj = self.space, self.space.projections
        local_of = np.full(space.polygon_mesh.n_polygons, -1, dtype=np.int64)
        local_of[space.polygons] = np.arange(space.polygons.size)
        where = space.polygon_mesh.locate(points)
        k_of = np.where(where >= 0, local_of[np.maximum(where, 0)], -1)
        values = np.zeros((len(points), 2))
        m, dm_dx, dm_dy = np.empty(6), np.empty(6), np.empty(6)
        with x.localForm() as xl:
            u = xl.array_r.reshape(-1, 2)
            for i in np.flatnonzero(k_of >= 0):
                k = k_of[i]
                evaluate_monomials(np.asarray(points[i], dtype=np.float64), proj.centroid[k], proj.diameter[k], 2,
                                   m, dm_dx, dm_dy)
                values[i] = (m @ proj.Pi_nabla_of(k)) @ u[space.polygon_dofs(k)]
        return values, k_of >= 0

    def dof_values(self, value: typing.Callable[[np.ndarray], np.ndarray], dofs: np.ndarray) -> np.ndarray:
        """DOF values of the function ``value(x) -> (n,)`` for one component at the unknowns ``dofs``:
        point values at vertices/midpoints, polygon means (by quadrature) at interior DOFs."""
        space = self.space
        nodes = dofs // 2
        out = np.asarray(value(space.x_nodes[nodes].T), dtype=np.float64).reshape(-1)
        interior_node = space.dofs[space.dof_offsets[1:] - 1]          # last DOF of each polygon
        for k in np.flatnonzero(np.isin(interior_node, nodes)):
            q = slice(space.q_offsets[k], space.q_offsets[k + 1])
            out[nodes == interior_node[k]] = np.dot(space.w_q[q], value(space.x_q[q].T)) / space.w_q[q].sum()
        return out

    def midpoint_keys(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Node keys (:meth:`get_state`) of the midpoints of the edges between the points a and b (n,)."""
        return node_keys.midpoint_keys(self.space.polygon_mesh, a, b)

    @property
    def output_mesh(self) -> PolygonMesh:
        """The polygon mesh pictures are drawn on."""
        return self.space.polygon_mesh

    def output_point_displacements(self, x: PETSc.Vec) -> tuple[np.ndarray, np.ndarray]:
        """(point indices of ``output_mesh``, displacements (k, 2)) known on this rank."""
        space = self.space
        is_vertex = np.flatnonzero(space.node_kind == VERTEX)
        with x.localForm() as xl:
            return space.node_point[is_vertex], xl.array_r.reshape(-1, 2)[is_vertex].copy()

    def describe(self) -> dict:
        """Mesh facts for summary.json."""
        return {"polygons": int(self.space.polygon_mesh.n_polygons),
                "projection_order_histogram": {str(k): v for k, v in self.space.l_histogram().items()}}

    def output_function(self, x: PETSc.Vec, u=None):
        """The solution as a P2 DOLFINx Function on the sub-triangulation."""
        return self.space.to_function(x, u)

    @property
    def dolfinx_mesh(self):
        return self.space.mesh

    def cell_tags(self):
        """Region tag of every local sub-triangle (its polygon's)."""
        return _compat.create_cell_tags(self.space.mesh, self.space.polygon_mesh.tags[self.space.cell_polygon])

    def cell_stress(self, x: PETSc.Vec) -> tuple[np.ndarray, np.ndarray]:
        """F and P at the centroid of every owned sub-triangle, from Π⁰_l∇u of its polygon."""
        space, proj = self.space, self.space.projections
        n = _compat.num_owned_cells(space.mesh)
        centre = space.mesh.geometry.x[_compat.cell_geometry_nodes(space.mesh)[:n], :2].mean(axis=1)
        polygon = np.searchsorted(space.polygons, space.cell_polygon[:n])
        F, P = np.zeros((n, 2, 2)), np.zeros((n, 2, 2))
        with x.localForm() as xl:
            u = xl.array_r.reshape(-1, 2)
            for reg in self.regions:
                on = np.flatnonzero(np.isin(polygon, reg.cells))
                k = reg.kernels
                F_on, P_on = np.empty((on.size, 2, 2)), np.empty((on.size, 2, 2))
                first_piola_at(k.residual, k.pack_constants(reg.params), k.F_offset, k.G_offset, _residual_at(k)[0],
                               k.uses_gradient, polygon[on], np.ascontiguousarray(centre[on]), space.dof_offsets,
                               space.dofs, proj.l, proj.centroid, proj.diameter, proj.Pi_m_offsets, proj.Pi_m, u,
                               F_on, P_on)
                F[on], P[on] = F_on, P_on
        return F, P
