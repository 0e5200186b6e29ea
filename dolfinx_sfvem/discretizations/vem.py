"""SFVEM discretization on polygons: residual and tangent of a region-wise energy into PETSc objects.

The polygons' hooks of :class:`~dolfinx_sfvem.discretizations.sfvem.OnSFVEMNodes`, which holds the
steps both dimensions share: the space (``space.py``: nodes, projections, energy quadrature), the
compiled pointwise energy kernels (``compiled_energy.py``) and the compiled polygon loops
(``assemble.py``) meet here. The PETSc matrix is preallocated once in COO format (one dense block
per polygon plus the diagonal) and refilled in place at every Newton iteration; the residual is
assembled into the ghosted local form of a PETSc vector and accumulated over ranks. What is the
polygons' own: the boundary loops of the injectivity guard, the cavity's work as the enclosed area,
the coarse space, and the evaluation and output on the polygon mesh.
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
    PolygonTables, basis_derivative_tables, first_piola_at, load_loop, projected_fields, residual_loop, tangent_loop)
from dolfinx_sfvem.discretizations.discretization import SFVEM_NO_FEM_RULES, EnergyTerm, check_materials
from dolfinx_sfvem.discretizations.sfvem import EnclosedTerm, OnSFVEMNodes, Region
from dolfinx_sfvem.physics.enclosed_area import area_force_loop, area_tangent_loop
from dolfinx_sfvem.physics.energy import Energy
from dolfinx_sfvem.discretizations.injectivity import folded_elements
from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh
from dolfinx_sfvem.discretizations.monomials import evaluate_monomials
from dolfinx_sfvem.discretizations.space import VERTEX, VEMSpace


@dataclass
class _AreaTerm(EnclosedTerm):
    """The cavity's work on polygons: the area enclosed by the deformed boundary traces of the
    region's polygons (:mod:`~dolfinx_sfvem.physics.enclosed_area`), local to the polygons."""
    space: VEMSpace
    coo_off: np.ndarray     # (n_local + 1,) int64: the polygon blocks in the COO values

    def add_force(self, u: np.ndarray, scale: float, R: np.ndarray) -> float:
        space = self.space
        return scale * area_force_loop(self.cells, space.dof_offsets, space.dofs, space.x_nodes, u, scale, R)

    def add_tangent_values(self, scale: float, values: np.ndarray) -> None:
        area_tangent_loop(self.cells, self.space.dof_offsets, scale, values, self.coo_off)


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
    verbose
        Print the space's summary on rank 0.
    """

    def __init__(self, mesh: PolygonMesh, materials: typing.Mapping[int, Energy], comm: MPI.Comm = MPI.COMM_WORLD,
                 *, l=None, l_min: int = 3, quadrature_degree: int | None = None, quadrature: str = "compressed",
                 verbose: bool = True):
        check_materials(mesh.tags, materials, ("gauss",), SFVEM_NO_FEM_RULES)
        super().__init__(VEMSpace(mesh, comm, l=l, l_min=l_min, quadrature_degree=quadrature_degree,
                                  quadrature=quadrature, verbose=verbose), materials, comm)
        space = self.space
        # boundary loop v_0, m_0, v_1, m_1, ... of every polygon (injectivity guard)
        N = (np.diff(space.dof_offsets) - 1) // 2
        self._loop_offsets = np.concatenate([[0], np.cumsum(2 * N)]).astype(np.int64)
        first = np.repeat(space.dof_offsets[:-1], 2 * N)
        k = np.arange(self._loop_offsets[-1]) - np.repeat(self._loop_offsets[:-1], 2 * N)
        self._loop = space.dofs[first + k // 2 + (k % 2) * np.repeat(N, 2 * N)].astype(np.int64)
        self._solid = np.zeros(space.cells.size, dtype=bool)
        for reg in self.regions:
            self._solid[reg.cells] = not reg.energy.is_medium
        self.element_loops = (self._loop_offsets, self._loop, space.cells)

    # ------------------------------------------------------------------ the polygons' hooks
    def _basis_tables(self, nphi: np.ndarray, phi_off: np.ndarray) -> PolygonTables:
        space, proj = self.space, self.space.projections
        Phi = basis_derivative_tables(space.dof_offsets, proj.l, proj.centroid, proj.diameter,
                                      proj.Pi_m_offsets, proj.Pi_m, space.q_offsets, space.x_q, nphi, phi_off)
        return PolygonTables(space.dof_offsets, space.dofs, phi_off, Phi, space.q_offsets, space.w_q)

    def _residual_loop(self, reg: Region, c: np.ndarray, u: np.ndarray, R: np.ndarray, stats: np.ndarray) -> None:
        k = reg.kernels
        residual_loop(k.residual, c, k.F_offset, k.G_offset, *reg.residual_at, k.uses_gradient, reg.cells, self._tables,
                      u, R, stats)

    def _tangent_loop(self, reg: Region, c: np.ndarray, u: np.ndarray, values: np.ndarray) -> None:
        k = reg.kernels
        tangent_loop(k.tangent, c, k.F_offset, k.G_offset, *reg.tangent_at, k.uses_gradient, reg.cells, self._tables,
                     u, values, self._coo_off, reg.term is not None)

    def _load_loop(self, f_q: np.ndarray, F: np.ndarray) -> None:
        space, proj = self.space, self.space.projections
        load_loop(np.arange(space.cells.size), space.dof_offsets, space.dofs, proj.centroid, proj.diameter,
                  proj.Pi_nabla_offsets, proj.Pi_nabla, space.q_offsets, space.x_q, space.w_q, f_q, F)

    def _projected_fields(self, u: np.ndarray, u_q: np.ndarray, grad_q: np.ndarray) -> None:
        space, proj = self.space, self.space.projections
        projected_fields(np.arange(space.cells.size), space.dof_offsets, space.dofs, proj.l, proj.centroid,
                         proj.diameter, proj.Pi_m_offsets, proj.Pi_m, proj.Pi_nabla_offsets, proj.Pi_nabla,
                         space.q_offsets, space.x_q, u, u_q, grad_q)

    def _folds(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Folded and kinked polygons (:func:`~dolfinx_sfvem.discretizations.injectivity.folded_elements`)."""
        return folded_elements(self._loop_offsets, self._loop, self.space.x_nodes, u,
                               np.arange(self.space.cells.size, dtype=np.int64), self._solid)

    def _enclosed_term(self, region: Region, energy: Energy, term: EnergyTerm) -> _AreaTerm:
        return _AreaTerm(region.tag, energy, region.cells, term, self.space, self._coo_off)

    # ------------------------------------------------------------------ PETSc objects
    def coarse_interpolation(self) -> PETSc.Mat:
        """The vertex values into the unknowns (:meth:`VEMSpace.coarse_interpolation`)."""
        return self.space.coarse_interpolation()

    # ------------------------------------------------------------------ fields
    def quadrature_cells(self) -> np.ndarray:
        """The polygon of every point of :meth:`quadrature_fields` (the space's energy quadrature)."""
        return np.repeat(self.space.cells, np.diff(self.space.q_offsets))

    def displacement_at(self, x: PETSc.Vec, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Π^∇_2 u (Eq. 36) at ``points`` (n, 2) inside this rank's polygons: (values (n, 2), found (n,)
        bool); points elsewhere get zeros and False."""
        space, proj = self.space, self.space.projections
        local_of = np.full(space.polygon_mesh.n_polygons, -1, dtype=np.int64)
        local_of[space.cells] = np.arange(space.cells.size)
        where = space.polygon_mesh.locate(points)
        k_of = np.where(where >= 0, local_of[np.maximum(where, 0)], -1)
        values = np.zeros((len(points), 2))
        m, dm_dx, dm_dy = np.empty(6), np.empty(6), np.empty(6)
        with x.localForm() as xl:
            u = xl.array_r.reshape(-1, self.gdim)
            for i in np.flatnonzero(k_of >= 0):
                k = k_of[i]
                evaluate_monomials(np.asarray(points[i], dtype=np.float64), proj.centroid[k], proj.diameter[k], 2,
                                   m, dm_dx, dm_dy)
                values[i] = (m @ proj.Pi_nabla_of(k)) @ u[space.cell_dofs(k)]
        return values, k_of >= 0

    def dof_values(self, value: typing.Callable[[np.ndarray], np.ndarray], dofs: np.ndarray) -> np.ndarray:
        """DOF values of the function ``value(x) -> (n,)`` for one component at the unknowns ``dofs``:
        point values at vertices/midpoints, polygon means (by quadrature) at interior DOFs."""
        space = self.space
        nodes = dofs // self.gdim
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
            return space.node_point[is_vertex], xl.array_r.reshape(-1, self.gdim)[is_vertex].copy()

    def describe(self) -> dict:
        """Mesh facts for summary.json."""
        return {"polygons": int(self.space.polygon_mesh.n_polygons),
                "projection_order_histogram": {str(k): v for k, v in self.space.l_histogram().items()}}

    def cell_tags(self):
        """Region tag of every local sub-triangle (its polygon's)."""
        return _compat.create_cell_tags(self.space.mesh, self.space.polygon_mesh.tags[self.space.cell_polygon])

    def cell_stress(self, x: PETSc.Vec) -> tuple[np.ndarray, np.ndarray]:
        """F and P at the centroid of every owned sub-triangle, from Π⁰_l∇u of its polygon."""
        space, proj = self.space, self.space.projections
        n = _compat.num_owned_cells(space.mesh)
        centre = space.mesh.geometry.x[_compat.cell_geometry_nodes(space.mesh)[:n], :2].mean(axis=1)
        polygon = np.searchsorted(space.cells, space.cell_polygon[:n])
        F, P = np.zeros((n, 2, 2)), np.zeros((n, 2, 2))
        with x.localForm() as xl:
            u = xl.array_r.reshape(-1, self.gdim)
            for reg in self.regions:
                on = np.flatnonzero(np.isin(polygon, reg.cells))
                k = reg.kernels
                F_on, P_on = np.empty((on.size, 2, 2)), np.empty((on.size, 2, 2))
                first_piola_at(k.residual, k.pack_constants(reg.params), k.F_offset, k.G_offset, reg.residual_at[0],
                               k.uses_gradient, polygon[on], np.ascontiguousarray(centre[on]), space.dof_offsets,
                               space.dofs, proj.l, proj.centroid, proj.diameter, proj.Pi_m_offsets, proj.Pi_m, u,
                               F_on, P_on)
                F[on], P[on] = F_on, P_on
        return F, P
