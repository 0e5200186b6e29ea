"""The medium's reduced quadrature (``ThirdMedium(..., quadrature="reduced")``) on P2 simplices.

- The option is validated and refused by the discretizations without the rule (the SFVEM in 2D
  and 3D, Q2 cells), each naming where it is available.
- On a P2 triangle the FEM integrates the medium at the 3 points of the degree-2 Gauss rule: a
  field whose J varies has the energy of that sum worked out by hand and not the default rule's,
  and the smallest J reported is the smallest of those three.
- The rule is exact for the linear-elastic stiffness: the tangent at F = I equals the default
  rule's on a triangle and a tetrahedron (neo-Hookean and Hu-Hu), and so has the rigid-body null
  space only (3 in 2D, 6 in 3D).
"""
import numpy as np
import pytest
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem.discretizations.fem import LagrangeDiscretization
from dolfinx_sfvem.discretizations.vem import SFVEMDiscretization
from dolfinx_sfvem.discretizations.vem3d import PolyhedralDiscretization
from dolfinx_sfvem.mesh.cell_mesh import CellMesh

K, MU, ALPHA_R = 1.0, 0.5, 0.3
#: u = (C1 x y, C2 x^2): J = 1 + C1 y - 2 C1 C2 x^2 varies over the triangle
C1, C2 = 0.3, 0.2
#: the degree-2 Gauss rule on the reference triangle (0, 0), (1, 0), (0, 1): 3 points, weights 1/6
POINTS, WEIGHT = np.array([[1 / 6, 1 / 6], [2 / 3, 1 / 6], [1 / 6, 2 / 3]]), 1 / 6


def medium(quadrature: str = "reduced") -> sf.ThirdMedium:
    return sf.ThirdMedium(mu=MU, K=K, gamma=1.0, alpha_r=ALPHA_R, regularization="huhu", quadrature=quadrature)


def triangle(energy: sf.ThirdMedium) -> LagrangeDiscretization:
    mesh = sf.PolygonMesh([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]], [1])
    return LagrangeDiscretization.from_polygon_mesh(mesh, {1: energy}, MPI.COMM_WORLD, fem_mesh=mesh, verbose=False)


def tetrahedron(energy: sf.ThirdMedium) -> LagrangeDiscretization:
    points = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.2, 0.3, 0.9]]
    return LagrangeDiscretization.from_cell_mesh(CellMesh(points, [[0, 1, 2, 3]], [1], "tetrahedron"),
                                                 {1: energy}, MPI.COMM_WORLD, verbose=False)


def state(disc: LagrangeDiscretization, u):
    x = disc.create_vector()
    with x.localForm() as xl:
        xl.array[:] = u(disc.x_nodes).ravel()
    return x


def varying_J(x: np.ndarray) -> np.ndarray:
    return np.column_stack([C1 * x[:, 0] * x[:, 1], C2 * x[:, 0] ** 2])


def F_by_hand(x: float, y: float) -> np.ndarray:
    return np.array([[1 + C1 * y, C1 * x], [2 * C2 * x, 1.0]])


def psi_by_hand(x: float, y: float) -> float:
    """The medium's Psi (gamma = 1, Hu-Hu) for :func:`varying_J` at (x, y), in plane strain."""
    F = F_by_hand(x, y)
    J = np.linalg.det(F)
    G_G = 2 * C1 ** 2 + (2 * C2) ** 2
    return K / 2 * np.log(J) ** 2 + MU / 2 * (J ** (-2 / 3) * (np.trace(F.T @ F) + 1) - 3) + ALPHA_R / 2 * G_G


def tangent(disc: LagrangeDiscretization) -> np.ndarray:
    A = disc.create_matrix()
    disc.assemble_tangent(state(disc, np.zeros_like), A)
    return A.convert("dense").getDenseArray()


# --------------------------------------------------------------------------- the option
def test_option_is_validated_and_named():
    with pytest.raises(ValueError, match=r"quadrature 'simpson'.*'reduced'"):
        sf.ThirdMedium(mu=MU, gamma=1e-5, alpha_r=1.0, quadrature="simpson")
    assert "reduced" in repr(medium())


def test_sfvem_refuses_reduced():
    mesh = sf.meshes.quad_rectangle(1.0, 1.0, 2, 2, tag=1)
    with pytest.raises(ValueError, match=r"quadrature='reduced' is not available with the SFVEM.*P2 triangles"):
        SFVEMDiscretization(mesh, {1: medium()}, MPI.COMM_WORLD, verbose=False)
    cubes = sf.meshes.octree_box([0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [1, 1, 1]).polyhedra()
    cubes.tags[:] = 1
    with pytest.raises(ValueError, match=r"quadrature='reduced' is not available with the SFVEM"):
        PolyhedralDiscretization(cubes, {1: medium()}, MPI.COMM_WORLD, verbose=False)


def test_q2_cells_refuse_reduced():
    mesh = sf.meshes.quad_rectangle(1.0, 1.0, 1, 1, tag=1)
    with pytest.raises(ValueError, match=r"quadrature='reduced' is not available on Q2 quadrilaterals"):
        LagrangeDiscretization.from_polygon_mesh(mesh, {1: medium()}, MPI.COMM_WORLD, fem_mesh=mesh, verbose=False)


# --------------------------------------------------------------------------- the rule
def test_reduced_rule_is_the_three_point_sum():
    disc = triangle(medium())
    info = disc.residual(state(disc, varying_J), disc.create_vector())
    by_hand = WEIGHT * sum(psi_by_hand(x, y) for x, y in POINTS)
    assert info.energy == pytest.approx(by_hand, rel=1e-12)
    assert info.min_J == pytest.approx(min(np.linalg.det(F_by_hand(x, y)) for x, y in POINTS), rel=1e-12)
    gauss = triangle(medium("gauss"))
    gauss_energy = gauss.residual(state(gauss, varying_J), gauss.create_vector()).energy
    assert abs(gauss_energy - by_hand) > 1e-6 * by_hand                 # another rule


@pytest.mark.parametrize("cell, rigid", [(triangle, 3), (tetrahedron, 6)])
def test_reduced_rule_keeps_the_stiffness(cell, rigid):
    reduced, gauss = tangent(cell(medium())), tangent(cell(medium("gauss")))
    assert np.abs(reduced - gauss).max() < 1e-12 * np.abs(gauss).max()
    eigenvalues = np.linalg.eigvalsh(reduced)
    assert int(np.sum(np.abs(eigenvalues) < 1e-10 * np.abs(eigenvalues).max())) == rigid
