"""The medium's Gauss-Lobatto quadrature (``ThirdMedium(..., quadrature="lobatto")``, issue 42 item 1).

- On Q2 cells the FEM integrates the medium at the 3 x 3 (x 3) Gauss-Lobatto points, the nodes:
  a homogeneous deformation's energy is Gauss's; a field whose J varies has the energy of the
  Lobatto sum worked out by hand and not Gauss's, and the smallest J reported is the corner's,
  which the Gauss points do not see.
- The medium's tangent at F = I on one cell has exactly the rigid-body null space (3 in 2D, 6 in
  3D), with and without the regularization: the rule adds no zero-energy mode.
- Plane strain: a one-layer slab of Q2 hexahedra with a z-independent field, u_z = 0, has the 2D Q2
  energy per unit depth with the same rule.

The option and its refusal by the discretizations without the rule: test_fem_only_medium_rules. The
medium (Hu-Hu), the field whose J varies and its Psi by hand: the ``medium_by_hand`` fixture.
"""
import numpy as np
import pytest
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem.discretizations.fem import LagrangeDiscretization
from dolfinx_sfvem.mesh.cell_mesh import CellMesh

#: the 1D Gauss-Lobatto rule with 3 points on [0, 1]
GLL_POINTS, GLL_WEIGHTS = np.array([0.0, 0.5, 1.0]), np.array([1.0, 4.0, 1.0]) / 6


def square(energy: sf.ThirdMedium, n: tuple[int, int] = (1, 1), lengths: tuple[float, float] = (1.0, 1.0)
           ) -> LagrangeDiscretization:
    """Q2 on an n[0] x n[1] grid of quadrilaterals of the medium alone."""
    mesh = sf.meshes.quad_rectangle(*lengths, *n, tag=1)
    return LagrangeDiscretization.from_polygon_mesh(mesh, {1: energy}, MPI.COMM_WORLD, fem_mesh=mesh, verbose=False)


def box(energy: sf.ThirdMedium, tiny3d, n=(1, 1, 1), lengths=(1.0, 1.0, 1.0)) -> LagrangeDiscretization:
    """Q2 on an n[0] x n[1] x n[2] grid of hexahedra of the medium alone."""
    points, cells = tiny3d.hex_grid(n, lengths)
    return LagrangeDiscretization.from_cell_mesh(CellMesh(points, cells, np.ones(len(cells)), "hexahedron"),
                                                 {1: energy}, MPI.COMM_WORLD, verbose=False)


# --------------------------------------------------------------------------- the rule's points
def test_homogeneous_deformation_has_gauss_energy(medium_by_hand):
    H = np.array([[0.1, -0.05], [0.08, -0.12]])
    lobatto, gauss = (medium_by_hand.energy_and_min_J(square(medium_by_hand.medium(q), (2, 1), (2.0, 1.0)),
                                                      lambda x: x @ H.T)
                      for q in ("lobatto", "gauss"))
    assert lobatto == pytest.approx(gauss, rel=1e-13)
    assert lobatto[1] == pytest.approx(np.linalg.det(np.eye(2) + H), rel=1e-13)


def test_lobatto_sees_the_nodes(medium_by_hand):
    m = medium_by_hand
    energy, min_J = m.energy_and_min_J(square(m.medium("lobatto")), m.varying_J)
    by_hand = sum(wx * wy * m.psi_by_hand(x, y) for x, wx in zip(GLL_POINTS, GLL_WEIGHTS)
                  for y, wy in zip(GLL_POINTS, GLL_WEIGHTS))
    assert energy == pytest.approx(by_hand, rel=1e-12)
    assert min_J == pytest.approx(1 - 0.12, rel=1e-12)                  # the corner (1, 0)
    gauss_energy, gauss_min_J = m.energy_and_min_J(square(m.medium("gauss")), m.varying_J)
    assert abs(gauss_energy - by_hand) > 1e-5 * by_hand                 # another rule
    assert gauss_min_J > 0.92                                           # the Gauss points miss the corner


@pytest.mark.parametrize("alpha_r", [None, 0.0], ids=["regularized", "alpha_r=0"])  # None: medium_by_hand.ALPHA_R
def test_one_square_has_only_rigid_modes(alpha_r, medium_by_hand):
    m = medium_by_hand
    assert m.rigid_modes(m.tangent(square(m.medium("lobatto", alpha_r)))) == 3


@pytest.mark.parametrize("alpha_r", [None, 0.0], ids=["regularized", "alpha_r=0"])  # None: medium_by_hand.ALPHA_R
def test_one_hexahedron_has_only_rigid_modes(alpha_r, medium_by_hand, tiny3d):
    m = medium_by_hand
    assert m.rigid_modes(m.tangent(box(m.medium("lobatto", alpha_r), tiny3d))) == 6


def test_slab_is_plane_strain(medium_by_hand, tiny3d):
    depth = 0.3
    m = medium_by_hand

    def u(x):
        return np.column_stack([0.1 * np.sin(x[:, 0]) * x[:, 1], -0.05 * x[:, 0] ** 2 + 0.1 * x[:, 1] ** 2])

    plane = m.energy_and_min_J(square(m.medium("lobatto"), (2, 1), (2.0, 1.0)), u)
    slab = m.energy_and_min_J(box(m.medium("lobatto"), tiny3d, (2, 1, 1), (2.0, 1.0, depth)),
                              lambda x: np.column_stack([u(x[:, :2]), np.zeros(len(x))]))
    assert slab[0] / depth == pytest.approx(plane[0], rel=1e-12)
    assert slab[1] == pytest.approx(plane[1], rel=1e-12)
