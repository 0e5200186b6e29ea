"""The medium's reduced quadrature (``ThirdMedium(..., quadrature="reduced")``) on P2 simplices.

- On a P2 triangle the FEM integrates the medium at the 3 points of the degree-2 Gauss rule: a
  field whose J varies has the energy of that sum worked out by hand and not the default rule's,
  and the smallest J reported is the smallest of those three.
- The rule is exact for the linear-elastic stiffness: the tangent at F = I equals the default
  rule's on a triangle and a tetrahedron (neo-Hookean and Hu-Hu), and so has the rigid-body null
  space only (3 in 2D, 6 in 3D).

The option and its refusal by the discretizations without the rule: test_fem_only_medium_rules. The
medium (Hu-Hu), the field whose J varies and its Psi by hand: the ``medium_by_hand`` fixture.
"""
import numpy as np
import pytest
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem.discretizations.fem import LagrangeDiscretization
from dolfinx_sfvem.mesh.cell_mesh import CellMesh

#: the degree-2 Gauss rule on the reference triangle (0, 0), (1, 0), (0, 1): 3 points, weights 1/6
POINTS, WEIGHT = np.array([[1 / 6, 1 / 6], [2 / 3, 1 / 6], [1 / 6, 2 / 3]]), 1 / 6


def triangle(energy: sf.ThirdMedium) -> LagrangeDiscretization:
    mesh = sf.PolygonMesh([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]], [1])
    return LagrangeDiscretization.from_polygon_mesh(mesh, {1: energy}, MPI.COMM_WORLD, fem_mesh=mesh, verbose=False)


def tetrahedron(energy: sf.ThirdMedium) -> LagrangeDiscretization:
    points = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.2, 0.3, 0.9]]
    return LagrangeDiscretization.from_cell_mesh(CellMesh(points, [[0, 1, 2, 3]], [1], "tetrahedron"),
                                                 {1: energy}, MPI.COMM_WORLD, verbose=False)


# --------------------------------------------------------------------------- the rule
def test_reduced_rule_is_the_three_point_sum(medium_by_hand):
    m = medium_by_hand
    energy, min_J = m.energy_and_min_J(triangle(m.medium("reduced")), m.varying_J)
    by_hand = WEIGHT * sum(m.psi_by_hand(x, y) for x, y in POINTS)
    assert energy == pytest.approx(by_hand, rel=1e-12)
    assert min_J == pytest.approx(min(np.linalg.det(m.F_by_hand(x, y)) for x, y in POINTS), rel=1e-12)
    gauss_energy, _ = m.energy_and_min_J(triangle(m.medium("gauss")), m.varying_J)
    assert abs(gauss_energy - by_hand) > 1e-6 * by_hand                 # another rule


@pytest.mark.parametrize("cell, rigid", [(triangle, 3), (tetrahedron, 6)])
def test_reduced_rule_keeps_the_stiffness(cell, rigid, medium_by_hand):
    m = medium_by_hand
    reduced, gauss = m.tangent(cell(m.medium("reduced"))), m.tangent(cell(m.medium("gauss")))
    assert np.abs(reduced - gauss).max() < 1e-12 * np.abs(gauss).max()
    assert m.rigid_modes(reduced) == rigid
