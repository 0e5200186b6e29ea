"""Serial linear elasticity with the order-2 SFVEM on a PolyhedronMesh (scipy.sparse, no DOLFINx).

A verification tool for the element (issue 31 item 4): global DOF numbering, assembly of the
stabilization-free stiffness and of the load vector, Dirichlet data on the whole boundary, a direct
solve, and the errors of the projections against an exact solution.

Global DOFs
-----------
Per displacement component, the scalar DOFs are numbered

    [mesh points (n_p), mesh edges (n_e, PolyhedronMesh.edges order), mesh faces (n_f), cells (n_c)]

and the vector DOF of component c and scalar DOF i is ``c * n_scalar + i``. A cell's local DOFs
are those of :mod:`dolfinx_sfvem.discretizations.projection3d` for ``mesh.polyhedron(c)``: its vertices in
increasing global index, its edges as :func:`~dolfinx_sfvem.mesh.polyhedron.polyhedron_edges` orders
them (local sorted pairs = global sorted pairs, since the local numbering keeps the global order),
its faces in the cell's face order, its mean.

Discrete problem
----------------
    sum_E int_E C eps(Pi^0_l grad u_h) : eps(Pi^0_l grad v) = sum_E int_E f . Pi^nabla_2 v

(the load with Pi^nabla_2 as the 2D code does, ``dolfinx_sfvem.discretizations.assemble.load_loop``), with the
DOFs on boundary faces (points, edge midpoints, face means) set to those of the exact solution
(:func:`~dolfinx_sfvem.discretizations.projection3d.interpolation_dofs`: values, and face means by the element's
face quadrature).

Errors (per polyhedron with its sub-tetrahedral rule, summed)
    L2: ||u - Pi^nabla_2 u_h||,    H1: ||grad u - Pi^0_l grad u_h||.

Projections are cached per polyhedron shape up to translation (exact: the scaled monomials are
centred at the centroid), so uniform and octree grids compute a handful of polyhedra.
"""
from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from petsc4py import PETSc

from dolfinx_sfvem.discretizations.elasticity import isotropic_elasticity, stiffness_from_gradient_projection_3d
from dolfinx_sfvem.discretizations.monomials3d import exponents3
from dolfinx_sfvem.mesh.polyhedron import polyhedron_edges, polyhedron_quadrature
from dolfinx_sfvem.mesh.polyhedron_mesh import PolyhedronMesh
from dolfinx_sfvem.discretizations.projection3d import PolyhedronProjections, interpolation_dofs, polyhedron_projections

#: degree of the polyhedron rule for the load vector and the errors (integrands are not polynomials)
QUADRATURE_DEGREE = 6

Field = Callable[[npt.NDArray[np.float64]], npt.NDArray[np.float64]]


@dataclass(frozen=True)
class DofMap:
    """Global scalar DOFs of a mesh (module docstring).

    Attributes
    ----------
    n_scalar : int
        Scalar DOFs per component, n_p + n_e + n_f + n_c.
    cell_dofs : list of (n_d,) int64
        Global scalar DOFs of every cell in its local order.
    boundary : (n_scalar,) bool
        DOFs on boundary faces (points, edges, faces).
    """

    n_scalar: int
    cell_dofs: list[npt.NDArray[np.int64]]
    boundary: npt.NDArray[np.bool_]


def dof_map(mesh: PolyhedronMesh) -> DofMap:
    """The global DOF numbering of ``mesh`` (module docstring)."""
    edges = mesh.edges()
    n_p, n_e, n_f = mesh.n_points, edges.shape[0], mesh.n_faces
    keys = edges[:, 0] * n_p + edges[:, 1]
    cell_dofs = []
    for c in range(mesh.n_cells):
        faces = [mesh.face(f) for f in mesh.cell_face_indices(c)]
        vertices = np.unique(np.concatenate(faces))
        local = polyhedron_edges([np.searchsorted(vertices, f) for f in faces])
        edge_keys = vertices[local[:, 0]] * n_p + vertices[local[:, 1]]
        cell_dofs.append(np.concatenate([vertices, n_p + np.searchsorted(keys, edge_keys),
                                         n_p + n_e + mesh.cell_face_indices(c), [n_p + n_e + n_f + c]]))
    boundary = np.zeros(n_p + n_e + n_f + mesh.n_cells, dtype=bool)
    faces = mesh.boundary_faces()
    points = np.unique(np.concatenate([mesh.face(f) for f in faces]))
    nxt = [np.roll(mesh.face(f), -1) for f in faces]
    pairs = np.sort(np.column_stack([np.concatenate([mesh.face(f) for f in faces]), np.concatenate(nxt)]), axis=1)
    boundary[points] = True
    boundary[n_p + np.searchsorted(keys, pairs[:, 0] * n_p + pairs[:, 1])] = True
    boundary[n_p + n_e + faces] = True
    return DofMap(n_p + n_e + n_f + mesh.n_cells, cell_dofs, boundary)


@dataclass
class CellCache:
    """Projections and the polyhedron rule per cell shape up to translation (module docstring)."""

    entries: dict = field(default_factory=dict)

    def get(self, points: npt.NDArray[np.float64], faces: list[npt.NDArray[np.int64]]
            ) -> tuple[PolyhedronProjections, npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """(projections with x_E at the cell's centroid, rule points (n_q, 3), weights (n_q,))."""
        origin = points[0]
        scale = np.ptp(points, axis=0).max()
        key = (tuple(tuple(f) for f in faces), np.round((points - origin) / scale, 12).tobytes(), round(scale, 14))
        hit = self.entries.get(key)
        if hit is None:
            P = polyhedron_projections(points, faces)
            x_q, w_q = polyhedron_quadrature(points, faces, QUADRATURE_DEGREE)
            hit = self.entries[key] = (P, P.centroid - origin, x_q - origin, w_q)
        P, centroid, x_q, w_q = hit
        shifted = PolyhedronProjections(P.l, P.volume, centroid + origin, P.diameter, P.edges, P.face_degrees,
                                        P.Pi_nabla, P.Pi_m, P.Q)
        return shifted, x_q + origin, w_q


def monomial_values(x: npt.NDArray[np.float64], centre: npt.NDArray[np.float64], scale: float, k: int
                    ) -> npt.NDArray[np.float64]:
    """Scaled monomials of degree <= k (order of :mod:`dolfinx_sfvem.discretizations.monomials3d`) at x (n, 3): (n, n_k)."""
    xi = (x - centre) / scale
    return np.prod(xi[:, None, :] ** exponents3(k)[None], axis=2)


@dataclass(frozen=True)
class Solution:
    """The solved problem: DOFs, per-cell data for the errors, and counts.

    ``u`` (3 n_scalar,) the vector DOFs; ``cells`` per cell (dofs, projections, rule points,
    weights); ``ls`` the l of every cell; ``n_free`` the unknowns; ``seconds`` assembly and solve.
    """

    dofs: DofMap
    u: npt.NDArray[np.float64]
    cells: list
    ls: npt.NDArray[np.int64]
    n_free: int
    seconds: dict


def solve(mesh: PolyhedronMesh, u_exact: Field, body_force: Field, young: float = 1.0,
          poisson: float = 0.3) -> Solution:
    """Solve linear elasticity on ``mesh`` with the boundary DOFs of ``u_exact``.

    Parameters
    ----------
    mesh : PolyhedronMesh
    u_exact, body_force : callables (n, 3) -> (n, 3)
        Exact displacement (boundary data) and body force per unit volume.
    young, poisson : float
        Isotropic material.
    """
    t0 = time.perf_counter()
    dofs = dof_map(mesh)
    n = dofs.n_scalar
    C = isotropic_elasticity(young, poisson)
    cache = CellCache()
    rows, cols, vals = [], [], []
    F = np.zeros(3 * n)
    u = np.zeros(3 * n)
    cells = []
    boundary_cells = np.zeros(mesh.n_cells, dtype=bool)
    boundary_cells[mesh.face_cells[mesh.boundary_faces()].max(axis=1)] = True
    for c in range(mesh.n_cells):
        points, faces = mesh.polyhedron(c)
        P, x_q, w_q = cache.get(points, faces)
        d = dofs.cell_dofs[c]
        g = np.concatenate([d, d + n, d + 2 * n])
        K = stiffness_from_gradient_projection_3d(P.Q, C)
        rows.append(np.repeat(g, g.size))
        cols.append(np.tile(g, g.size))
        vals.append(K.ravel())
        phi = monomial_values(x_q, P.centroid, P.diameter, 2) @ P.Pi_nabla      # (n_q, n_d)
        F[g] += ((w_q[:, None] * body_force(x_q)).T @ phi).ravel()
        if boundary_cells[c]:
            for comp in range(3):
                u[d + comp * n] = interpolation_dofs(points, faces, lambda x: u_exact(x)[:, comp], QUADRATURE_DEGREE)
        cells.append((d, P, x_q, w_q))
    t1 = time.perf_counter()
    A = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(3 * n, 3 * n))
    fixed = np.tile(dofs.boundary, 3)
    free = np.flatnonzero(~fixed)
    rhs = F[free] - A[free][:, fixed] @ u[fixed]
    u[free] = direct_solve(A[free][:, free], rhs)
    t2 = time.perf_counter()
    ls = np.array([P.l for _, P, _, _ in cells])
    return Solution(dofs, u, cells, ls, free.size, {"assembly": t1 - t0, "solve": t2 - t1})


def direct_solve(A: sp.csr_matrix, b: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """x with A x = b, A symmetric positive definite: PETSc's MUMPS Cholesky, serial (scipy's SuperLU
    takes minutes on these dense-rowed 3D systems: a Voronoi polyhedron couples ~75 DOFs per component)."""
    A = A.tocsr()
    M = PETSc.Mat().createAIJ(A.shape, csr=(A.indptr.astype(PETSc.IntType), A.indices.astype(PETSc.IntType), A.data),
                              comm=PETSc.COMM_SELF)
    M.setOption(PETSc.Mat.Option.SPD, True)
    ksp = PETSc.KSP().create(PETSc.COMM_SELF)
    ksp.setOperators(M)
    ksp.setType("preonly")
    ksp.getPC().setType("cholesky")
    ksp.getPC().setFactorSolverType("mumps")
    x, rhs = M.createVecs()
    rhs.array[:] = b
    ksp.solve(rhs, x)
    out = x.array.copy()
    for obj in (ksp, M, x, rhs):
        obj.destroy()
    return out


def error_norms(solution: Solution, u_exact: Field, grad_exact: Callable[[npt.NDArray[np.float64]],
                                                                            npt.NDArray[np.float64]]
                ) -> tuple[float, float]:
    """(||u - Pi^nabla_2 u_h||_L2, ||grad u - Pi^0_l grad u_h||_L2) over the mesh.

    ``grad_exact`` maps (n, 3) to (n, 3, 3) with [q, c, d] = du_c/dx_d.
    """
    n = solution.dofs.n_scalar
    e0 = e1 = 0.0
    for d, P, x_q, w_q in solution.cells:
        U = solution.u[np.concatenate([d, d + n, d + 2 * n])].reshape(3, -1)        # (3, n_d)
        u_h = monomial_values(x_q, P.centroid, P.diameter, 2) @ P.Pi_nabla @ U.T     # (n_q, 3)
        m_l = monomial_values(x_q, P.centroid, P.diameter, P.l)
        grad_h = np.tensordot(m_l, P.Pi_m @ U.T, axes=(1, 1))                       # (n_q, 3 d, 3 c)
        grad_h = grad_h.transpose(0, 2, 1)
        e0 += w_q @ np.sum((u_exact(x_q) - u_h) ** 2, axis=1)
        e1 += w_q @ np.sum((grad_exact(x_q) - grad_h) ** 2, axis=(1, 2))
    return float(np.sqrt(e0)), float(np.sqrt(e1))
