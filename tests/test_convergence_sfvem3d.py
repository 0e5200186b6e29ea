"""Convergence of the order-2 SFVEM on octree meshes of polyhedra, linear elasticity (docs/method.md §8).

A manufactured smooth displacement on the unit cube, its body force -div sigma from sympy, the
exact displacement on the boundary DOFs; the errors of the projections against the exact
field: ||u - Pi^nabla_2 u_h||_L2 ~ h^3 and ||grad u - Pi^0_l grad u_h||_L2 ~ h^2 when the element
is consistent (patch test) and stable (rank). The meshes are cubes with the corner octant
refined once: coarse cubes next to it are polyhedra with hanging vertices and split faces.
"""
import dataclasses

import numpy as np
import scipy.sparse
import scipy.sparse.linalg
import sympy

from dolfinx_sfvem.discretizations.elasticity import linear_elastic_stiffness_3d
from dolfinx_sfvem.discretizations.monomials3d import exponents3
from dolfinx_sfvem.mesh.polyhedron import polyhedron_quadrature
from dolfinx_sfvem.discretizations.projection3d import interpolation_dofs, polyhedron_projections

YOUNG, POISSON = 3.0, 0.3


def manufactured():
    """u (n, 3) -> (n, 3), its gradient (n, 3, 3) and the body force f = -div sigma(u) (n, 3)."""
    x = sympy.symbols("x0:3")
    u = sympy.Matrix([sympy.sin(1.3 * x[0] + 0.7 * x[1]) * sympy.cos(0.5 * x[2]),
                      sympy.exp(0.4 * x[0]) * sympy.sin(x[1] - x[2]),
                      sympy.cos(x[0] + x[1] + x[2])])
    mu = YOUNG / (2 * (1 + POISSON))
    lam = YOUNG * POISSON / ((1 + POISSON) * (1 - 2 * POISSON))
    grad = u.jacobian(x)
    sigma = lam * grad.trace() * sympy.eye(3) + mu * (grad + grad.T)
    force = -sympy.Matrix([sum(sympy.diff(sigma[i, j], x[j]) for j in range(3)) for i in range(3)])
    to_numpy = [sympy.lambdify([x], expression, "numpy") for expression in (u, grad, force)]

    def vectorised(function, shape):
        return lambda p: np.moveaxis(np.array(function(p.T), dtype=float).reshape(*shape, len(p)), -1, 0)

    return vectorised(to_numpy[0], (3,)), vectorised(to_numpy[1], (3, 3)), vectorised(to_numpy[2], (3,))


def solve_and_measure(cells, global_dofs, u_exact, grad_exact, force):
    """Assemble, solve with the boundary DOFs exact, return (h, L2 error, H1 seminorm error)."""
    cell_dofs, locations = global_dofs(cells)
    n = len(locations)
    rows, cols, values = [], [], []
    load = np.zeros(3 * n)
    exact = np.zeros(3 * n)
    elements = []
    shapes: dict = {}  # octree cells are translates of a few shapes: K, Pi_nabla and Pi_m do not move
    for (points, faces), dofs in zip(cells, cell_dofs):
        corner = points.min(axis=0)
        key = (np.round(points - corner, 12).tobytes(), tuple(tuple(f) for f in faces))
        if key not in shapes:
            shapes[key] = (polyhedron_projections(points, faces), linear_elastic_stiffness_3d(points, faces, YOUNG,
                                                                                             POISSON)[0], corner)
        P, K, shape_corner = shapes[key]
        P = dataclasses.replace(P, centroid=P.centroid + corner - shape_corner)
        index = np.concatenate([dofs + c * n for c in range(3)])
        rows.append(np.repeat(index, index.size))
        cols.append(np.tile(index, index.size))
        values.append(K.ravel())
        x, w = polyhedron_quadrature(points, faces, 8)
        m2 = np.prod(((x[:, None] - P.centroid) / P.diameter) ** exponents3(2), axis=2)
        basis = m2 @ P.Pi_nabla  # (n_q, n_d): Pi^nabla_2 of each basis function (load on the enhanced space)
        f = force(x)
        u_dofs = interpolation_dofs(points, faces, u_exact, 8)  # (3, n_d)
        for c in range(3):
            load[dofs + c * n] += basis.T @ (w * f[:, c])
            exact[dofs + c * n] = u_dofs[c]
        elements.append((P, dofs, x, w, m2))
    K = scipy.sparse.csr_matrix((np.concatenate(values), (np.concatenate(rows), np.concatenate(cols))),
                                shape=(3 * n, 3 * n))
    boundary = np.tile(np.any(np.isclose(locations, 0.0) | np.isclose(locations, 1.0), axis=1), 3)
    inner = ~boundary
    u = exact.copy()
    u[inner] = scipy.sparse.linalg.spsolve(K[inner][:, inner].tocsc(), load[inner] - K[inner][:, boundary] @ u[boundary])
    l2 = h1 = 0.0
    for P, dofs, x, w, m2 in elements:
        local = np.stack([u[dofs + c * n] for c in range(3)])  # (3, n_d)
        value = m2 @ (P.Pi_nabla @ local.T)  # (n_q, 3)
        ml = np.prod(((x[:, None] - P.centroid) / P.diameter) ** exponents3(P.l), axis=2)
        gradient = np.stack([ml @ (P.Pi_m[d] @ local.T) for d in range(3)], axis=2)  # (n_q, 3 comps, 3 dirs)
        l2 += w @ np.sum((value - u_exact(x)) ** 2, axis=1)
        h1 += w @ np.sum((gradient - grad_exact(x)) ** 2, axis=(1, 2))
    return max(P.diameter for P, *_ in elements), np.sqrt(l2), np.sqrt(h1)


def test_octree_rates(octree_polyhedra, global_dofs):
    """L2 rate 3 and H1 rate 2 (coarse: 15 and 120 polyhedra; measured 3.0 and 2.0 between them)."""
    u_exact, grad_exact, force = manufactured()
    results = [solve_and_measure(octree_polyhedra(n, lambda c: bool(np.all(c < 0.5))), global_dofs,
                                 u_exact, grad_exact, force) for n in (2, 4)]
    (h0, l2_0, h1_0), (h1_, l2_1, h1_1) = results
    rate_l2 = np.log(l2_0 / l2_1) / np.log(h0 / h1_)
    rate_h1 = np.log(h1_0 / h1_1) / np.log(h0 / h1_)
    assert rate_l2 > 2.7 and rate_h1 > 1.8, (results, rate_l2, rate_h1)
