"""The Lagrange discretization in 3D (P2 tetrahedra, Q2 hexahedra) on a handful of cells:
node keys, a homogeneous deformation's energy and internal forces (exact answers)."""
import numpy as np
import pytest
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem.mesh.cell_mesh import CellMesh
from dolfinx_sfvem.discretizations.fem import LagrangeDiscretization

K, MU = 5 / 3, 5 / 14
H = np.array([[0.02, -0.01, 0.03], [0.015, -0.02, 0.0], [0.01, 0.02, 0.025]])


def hex_mesh(tiny3d):
    points, cells = tiny3d.hex_grid(2, (2.0, 1.0, 1.0))
    return CellMesh(points, cells, np.ones(len(cells)), "hexahedron")


def tet_mesh(tiny3d):
    return CellMesh(tiny3d.CUBE * [2.0, 1.0, 1.0], tiny3d.kuhn_tets(), np.ones(6), "tetrahedron")


def neo_hookean(F):
    """Eq. 2 in 3D, independently of the package."""
    J = np.linalg.det(F)
    return K / 2 * np.log(J) ** 2 + MU / 2 * (J ** (-2 / 3) * np.trace(F.T @ F) - 3)


@pytest.mark.parametrize("make, n_nodes", [(hex_mesh, 5 * 5 * 5), (tet_mesh, 8 + 19)])
def test_nodes_keys_and_homogeneous_state(make, n_nodes, tiny3d):
    mesh = make(tiny3d)
    disc = LagrangeDiscretization.from_cell_mesh(mesh, {1: sf.Hyperelastic(K=K, mu=MU)}, MPI.COMM_WORLD,
                                                 verbose=False)
    assert disc.gdim == 3 and disc.num_dofs_global == 3 * n_nodes
    keys = np.concatenate(MPI.COMM_WORLD.allgather(disc.node_key[:disc.n_owned_nodes]))
    assert np.unique(keys).size == n_nodes
    # a vertex node's key is its point, its position the point's
    vertex = disc.node_point >= 0
    assert np.allclose(disc.x_nodes[vertex], mesh.points[disc.node_point[vertex]])
    x, b = disc.create_vector(), disc.create_vector()
    with x.localForm() as xl:
        xl.array[:] = (disc.x_nodes @ H.T).ravel()
    info = disc.residual(x, b)
    assert info.energy == pytest.approx(neo_hookean(np.eye(3) + H) * 2.0, rel=1e-12)
    assert info.min_J == pytest.approx(np.linalg.det(np.eye(3) + H), rel=1e-12)
    assert info.folded == 0
    # internal force: zero at interior nodes; at the boundary the traction P N of the homogeneous stress
    X = disc.x_nodes[:disc.n_owned_nodes]
    interior = np.all((X > 1e-12) & (X < np.array([2.0, 1.0, 1.0]) - 1e-12), axis=1)
    f = b.getArray(readonly=True).reshape(-1, 3)
    total = MPI.COMM_WORLD.allreduce(f.sum(axis=0), op=MPI.SUM)
    assert np.abs(f[interior]).max(initial=0.0) < 1e-13
    assert np.allclose(total, 0.0, atol=1e-13)               # equilibrium of the whole body
    A = disc.create_matrix()
    disc.assemble_tangent(x, A)
    assert A.isSymmetric(1e-10)
    for v in (x, b, A):
        v.destroy()


@pytest.mark.parametrize("d, folded", [(0.25, 0), (0.36, 1)])
def test_solid_cell_turned_over_at_a_vertex_is_folded(d, folded, tiny3d):
    """A solid hexahedron whose corner is pushed in along its diagonal by d of its edges,
    u = d (h_x, h_y, h_z) (1 - X/h_x)(1 - Y/h_y)(1 - Z/h_z) (trilinear, so exact in Q2), has
    J = 1 - 3d at that corner and a positive J at every quadrature point: beyond d = 1/3 it is
    folded (not admissible), and it is not counted as kinked."""
    mesh = hex_mesh(tiny3d)
    disc = LagrangeDiscretization.from_cell_mesh(mesh, {1: sf.Hyperelastic(K=K, mu=MU)}, MPI.COMM_WORLD,
                                                 verbose=False)
    h = np.array([1.0, 0.5, 0.5])                             # the cells of the 2 x 2 x 2 grid
    bump = np.prod(np.clip(1.0 - disc.x_nodes / h, 0.0, None), axis=1)
    x, b = disc.create_vector(), disc.create_vector()
    with x.localForm() as xl:
        xl.array[:] = (d * bump[:, None] * h).ravel()
    info = disc.residual(x, b)
    assert info.min_J > 0.0
    assert info.folded == folded and info.kinked == 0
    assert info.admissible == (folded == 0)
    if folded:
        corner_cell = np.flatnonzero(np.all(mesh.points[mesh.cells].min(axis=1) == 0.0, axis=1))
        assert info.folded_cell == corner_cell[0]
    for v in (x, b):
        v.destroy()


def test_body_force_and_displacement_at(tiny3d):
    mesh = hex_mesh(tiny3d)
    disc = LagrangeDiscretization.from_cell_mesh(mesh, {1: sf.Hyperelastic(K=K, mu=MU)}, MPI.COMM_WORLD,
                                                 verbose=False)
    b = disc.body_force_vector(lambda x: np.array([0.0 * x[0], 0.0 * x[0], -1.0 + 0.0 * x[0]]))
    totals = MPI.COMM_WORLD.allreduce(b.getArray(readonly=True).reshape(-1, 3).sum(axis=0), op=MPI.SUM)
    assert np.allclose(totals, [0.0, 0.0, -2.0], atol=1e-13)        # -1 per unit volume on a volume of 2
    x = disc.create_vector()
    with x.localForm() as xl:
        xl.array[:] = (disc.x_nodes @ H.T).ravel()
    points = np.array([[0.3, 0.7, 0.1], [1.9, 0.2, 0.95]])
    values, found = disc.displacement_at(x, points)
    count = MPI.COMM_WORLD.allreduce(found.astype(int), op=MPI.SUM)
    total = MPI.COMM_WORLD.allreduce(values, op=MPI.SUM)
    assert np.all(count >= 1)
    assert np.allclose(total / count[:, None], points @ H.T, atol=1e-14)
    x.destroy()
    b.destroy()
