"""The medium's Gauss-Lobatto quadrature (``ThirdMedium(..., quadrature="lobatto")``, issue 42 item 1).

- The option is validated, named in messages, and refused by the discretizations without a rule at
  the nodes (the SFVEM in 2D and 3D, P2 triangles).
- On Q2 cells the FEM integrates the medium at the 3 x 3 (x 3) Gauss-Lobatto points, the nodes:
  a homogeneous deformation's energy is Gauss's; a field whose J varies has the energy of the
  Lobatto sum worked out by hand and not Gauss's, and the smallest J reported is the corner's,
  which the Gauss points do not see.
- The medium's tangent at F = I on one cell has exactly the rigid-body null space (3 in 2D, 6 in
  3D), with and without the regularization: the rule adds no zero-energy mode.
- Plane strain: a one-layer slab of Q2 hexahedra with a z-independent field, u_z = 0, has the 2D Q2
  energy per unit depth with the same rule.

Hu-Hu regularization throughout (its tangent compiles in seconds).
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
#: a field whose J varies over the unit square: J = 1 + 0.3 y - 0.12 x, smallest (0.88) at the corner (1, 0)
C1, C2 = 0.3, 0.2
#: the 1D Gauss-Lobatto rule with 3 points on [0, 1]
GLL_POINTS, GLL_WEIGHTS = np.array([0.0, 0.5, 1.0]), np.array([1.0, 4.0, 1.0]) / 6


def medium(quadrature: str = "lobatto", alpha_r: float = ALPHA_R) -> sf.ThirdMedium:
    return sf.ThirdMedium(mu=MU, K=K, gamma=1.0, alpha_r=alpha_r, regularization="huhu", quadrature=quadrature)


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


def state(disc: LagrangeDiscretization, u):
    """The vector of the nodal values of ``u(x) -> (n, d)``."""
    x = disc.create_vector()
    with x.localForm() as xl:
        xl.array[:] = u(disc.x_nodes).ravel()
    return x


def energy_and_min_J(disc: LagrangeDiscretization, u) -> tuple[float, float]:
    info = disc.residual(state(disc, u), disc.create_vector())
    return info.energy, info.min_J


def varying_J(x: np.ndarray) -> np.ndarray:
    """u = (C1 x y, C2 x^2) (in Q2)."""
    return np.column_stack([C1 * x[:, 0] * x[:, 1], C2 * x[:, 0] ** 2])


def psi_by_hand(x: float, y: float) -> float:
    """The medium's Psi (gamma = 1, Hu-Hu) for :func:`varying_J` at (x, y), in plane strain."""
    F = np.array([[1 + C1 * y, C1 * x], [2 * C2 * x, 1.0]])
    J = np.linalg.det(F)
    G_G = 2 * C1 ** 2 + (2 * C2) ** 2                   # u_x,xy = u_x,yx = C1, u_y,xx = 2 C2
    return K / 2 * np.log(J) ** 2 + MU / 2 * (J ** (-2 / 3) * (np.trace(F.T @ F) + 1) - 3) + ALPHA_R / 2 * G_G


# --------------------------------------------------------------------------- the option
def test_option_is_validated_and_named():
    with pytest.raises(ValueError, match=r"quadrature 'simpson'.*'gauss', 'lobatto'"):
        sf.ThirdMedium(mu=MU, gamma=1e-5, alpha_r=1.0, quadrature="simpson")
    assert sf.ThirdMedium(mu=MU, gamma=1e-5, alpha_r=1.0).quadrature == "gauss"
    assert "lobatto" in repr(medium())
    assert sf.Hyperelastic(K=K, mu=MU).quadrature == "gauss"


def test_sfvem_refuses_lobatto():
    mesh = sf.meshes.quad_rectangle(1.0, 1.0, 2, 2, tag=1)
    with pytest.raises(ValueError, match=r"quadrature='lobatto' is not available with the SFVEM.*method='fem'"):
        SFVEMDiscretization(mesh, {1: medium()}, MPI.COMM_WORLD, verbose=False)
    cubes = sf.meshes.octree_box([0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [1, 1, 1]).polyhedra()
    cubes.tags[:] = 1
    with pytest.raises(ValueError, match=r"quadrature='lobatto' is not available with the SFVEM.*method='fem'"):
        PolyhedralDiscretization(cubes, {1: medium()}, MPI.COMM_WORLD, verbose=False)


def test_p2_triangles_refuse_lobatto():
    mesh = sf.PolygonMesh([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]], [1])
    with pytest.raises(ValueError, match=r"quadrature='lobatto' is not available on P2 triangles"):
        LagrangeDiscretization.from_polygon_mesh(mesh, {1: medium()}, MPI.COMM_WORLD, fem_mesh=mesh, verbose=False)


# --------------------------------------------------------------------------- the rule's points
def test_homogeneous_deformation_has_gauss_energy():
    H = np.array([[0.1, -0.05], [0.08, -0.12]])
    lobatto, gauss = (energy_and_min_J(square(medium(q), (2, 1), (2.0, 1.0)), lambda x: x @ H.T)
                      for q in ("lobatto", "gauss"))
    assert lobatto == pytest.approx(gauss, rel=1e-13)
    assert lobatto[1] == pytest.approx(np.linalg.det(np.eye(2) + H), rel=1e-13)


def test_lobatto_sees_the_nodes():
    energy, min_J = energy_and_min_J(square(medium()), varying_J)
    by_hand = sum(wx * wy * psi_by_hand(x, y) for x, wx in zip(GLL_POINTS, GLL_WEIGHTS)
                  for y, wy in zip(GLL_POINTS, GLL_WEIGHTS))
    assert energy == pytest.approx(by_hand, rel=1e-12)
    assert min_J == pytest.approx(1 - 0.12, rel=1e-12)                  # the corner (1, 0)
    gauss_energy, gauss_min_J = energy_and_min_J(square(medium("gauss")), varying_J)
    assert abs(gauss_energy - by_hand) > 1e-5 * by_hand                 # another rule
    assert gauss_min_J > 0.92                                           # the Gauss points miss the corner


def rigid_modes(disc: LagrangeDiscretization) -> int:
    """Dimension of the null space of the medium's tangent at u = 0 (eigenvalues below 1e-10 of the largest)."""
    A = disc.create_matrix()
    disc.assemble_tangent(state(disc, np.zeros_like), A)
    eigenvalues = np.linalg.eigvalsh(A.convert("dense").getDenseArray())
    return int(np.sum(np.abs(eigenvalues) < 1e-10 * np.abs(eigenvalues).max()))


@pytest.mark.parametrize("alpha_r", [ALPHA_R, 0.0])
def test_one_square_has_only_rigid_modes(alpha_r):
    assert rigid_modes(square(medium(alpha_r=alpha_r))) == 3


@pytest.mark.parametrize("alpha_r", [ALPHA_R, 0.0])
def test_one_hexahedron_has_only_rigid_modes(alpha_r, tiny3d):
    assert rigid_modes(box(medium(alpha_r=alpha_r), tiny3d)) == 6


def test_slab_is_plane_strain(tiny3d):
    depth = 0.3

    def u(x):
        return np.column_stack([0.1 * np.sin(x[:, 0]) * x[:, 1], -0.05 * x[:, 0] ** 2 + 0.1 * x[:, 1] ** 2])

    plane = energy_and_min_J(square(medium(), (2, 1), (2.0, 1.0)), u)
    slab = energy_and_min_J(box(medium(), tiny3d, (2, 1, 1), (2.0, 1.0, depth)),
                            lambda x: np.column_stack([u(x[:, :2]), np.zeros(len(x))]))
    assert slab[0] / depth == pytest.approx(plane[0], rel=1e-12)
    assert slab[1] == pytest.approx(plane[1], rel=1e-12)
