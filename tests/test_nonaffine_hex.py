"""Hexahedra that are not parallelepipeds (trilinear cells, non-planar inner faces): the Q2 FEM's
second gradient and a homogeneous stretch exact on them, the SFVEM reading them as polyhedra, and
inverted cells refused."""
import numpy as np
import pytest
import ufl
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem.discretizations.fem import LagrangeDiscretization
from dolfinx_sfvem.mesh.cell_mesh import CellMesh, jacobian_determinants
from dolfinx_sfvem.mesh.polyhedron_mesh import PolyhedronMesh

K, MU, STRETCH = 5 / 3, 5 / 14, 0.1
LENGTHS = np.array([2.0, 1.0, 1.0])


def jiggled(points: np.ndarray, lengths, amount: float, seed: int = 1) -> np.ndarray:
    """``points`` of a box grid moved by up to ``amount`` in every coordinate that is not on the
    box's bounds: inner nodes in 3D, face nodes within their face, edge nodes along their edge."""
    delta = np.random.default_rng(seed).uniform(-amount, amount, points.shape)
    on_bound = np.isclose(points, 0.0) | np.isclose(points, np.asarray(lengths))
    return points + np.where(on_bound, 0.0, delta)


def sheared(points: np.ndarray) -> np.ndarray:
    """The issue's warp z += 0.2 x y (bilinear in every cell: trilinear cells, volume kept)."""
    return points + np.c_[np.zeros((len(points), 2)), 0.2 * points[:, 0] * points[:, 1]]


def nonaffinity(x: np.ndarray) -> tuple[float, float]:
    """(largest bilinear coefficient of the cells' maps, largest spread of their Jacobian
    determinants over the vertices) of hexahedra (n, 8, 3): both zero on parallelepipeds."""
    mixed = [x[:, 0] - x[:, 1] - x[:, 2] + x[:, 3], x[:, 0] - x[:, 1] - x[:, 4] + x[:, 5],
             x[:, 0] - x[:, 2] - x[:, 4] + x[:, 6]]
    return (max(np.linalg.norm(m, axis=1).max() for m in mixed),
            float(np.ptp(jacobian_determinants(x, "hexahedron"), axis=1).max()))


def quadratic(x: np.ndarray) -> np.ndarray:
    """u = (x², y z, x y / 2) at points (n, 3): G:G = 4 + 2 + 1/2 = 6.5 everywhere."""
    return np.c_[x[:, 0] ** 2, x[:, 1] * x[:, 2], 0.5 * x[:, 0] * x[:, 1]]


@pytest.mark.parametrize("warp", ["sheared", "jiggled"])
def test_second_gradient_is_exact_on_trilinear_hexahedra(warp, tiny3d):
    """½ ∫ G:G of a quadratic field (in the Q2 space of trilinear cells) is ½ · 6.5 · volume, the
    volume of the unit cube (both warps keep it)."""
    points, cells = tiny3d.hex_grid(3)
    points = sheared(points) if warp == "sheared" else jiggled(points, (1.0, 1.0, 1.0), 0.08)
    mesh = CellMesh(points, cells, np.ones(len(cells)), "hexahedron")
    assert nonaffinity(points[mesh.cells])[0] > 1e-3
    assert mesh.volumes.sum() == pytest.approx(1.0, rel=1e-13)
    energy = sf.UserEnergy(lambda F, G: ufl.inner(G, G) / 2, name="half_GG")
    disc = LagrangeDiscretization.from_cell_mesh(mesh, {1: energy}, MPI.COMM_WORLD, verbose=False)
    u, b = disc.create_vector(), disc.create_vector()
    with u.localForm() as ul:
        ul.array[:] = quadratic(disc.x_nodes).ravel()
    assert disc.residual(u, b).energy == pytest.approx(6.5 / 2, rel=1e-12)
    with u.localForm() as ul:                              # a linear field has no second gradient
        ul.array[:] = (disc.x_nodes @ np.arange(9.0).reshape(3, 3)).ravel()
    assert abs(disc.residual(u, b).energy) < 1e-20
    u.destroy()
    b.destroy()




def warped_bar(tiny3d) -> CellMesh:
    """The bar [0, 2] x [0, 1] x [0, 1] in 4 x 2 x 2 hexahedra, its nodes moved (planar outer faces,
    non-planar inner ones)."""
    points, cells = tiny3d.hex_grid((4, 2, 2), LENGTHS)
    mesh = CellMesh(jiggled(points, LENGTHS, 0.12), cells, np.ones(len(cells)), "hexahedron")
    assert min(nonaffinity(mesh.points[mesh.cells])) > 1e-3
    return mesh


@pytest.mark.parametrize("method", ["fem", "vem"])
def test_uniaxial_stretch_is_exact_on_warped_hexahedra(method, tiny3d, by_hand):
    """Q2 on trilinear hexahedra and the SFVEM on them as polyhedra (non-planar faces split) are
    exact for the homogeneous stretch: reaction, displacements inside the cells."""
    mesh = warped_bar(tiny3d)
    problem = sf.ContactProblem(mesh, {1: sf.Hyperelastic(K=K, mu=MU)}, method=method, verbose=False)
    problem.fix(lambda x: np.isclose(x[0], 0.0), components="x", name="x0")
    problem.fix(lambda x: np.isclose(x[1], 0.0), components="y", name="y0")
    problem.fix(lambda x: np.isclose(x[2], 0.0), components="z", name="z0")
    problem.prescribe(lambda x: np.isclose(x[0], 2.0), ux=2.0 * STRETCH, name="pull")
    result = problem.solve(steps=2)
    assert result.converged
    s, P11 = by_hand.uniaxial(K, MU, STRETCH)
    assert problem.reactions()["pull"] == pytest.approx([P11 * 1.0, 0.0, 0.0], abs=1e-10)
    X = np.array([[2.0, 1.0, 1.0], [1.1, 0.45, 0.3], [0.3, 0.8, 0.6]])
    assert problem.displacement_at(X) == pytest.approx(X * [STRETCH, s - 1, s - 1], abs=1e-10)


def test_warped_hexahedra_as_polyhedra(tiny3d):
    """Non-planar faces become two triangles, split alike in both cells; the polyhedra fill the bar."""
    mesh = warped_bar(tiny3d)
    polyhedra = PolyhedronMesh.from_cell_mesh(mesh)
    sizes = np.diff(polyhedra.face_offsets)
    assert set(sizes.tolist()) == {3, 4} and polyhedra.n_cells == mesh.n_cells
    assert polyhedra.volumes.sum() == pytest.approx(2.0, rel=1e-12)
    straight = tiny3d.hex_grid((4, 2, 2), LENGTHS)
    assert set(np.diff(PolyhedronMesh.from_cell_mesh(CellMesh(*straight, np.ones(16), "hexahedron"))
                       .face_offsets).tolist()) == {4}


def test_inverted_warped_cell_is_named_and_mirrored_cells_are_turned(tiny3d):
    points, cells = tiny3d.hex_grid(2)
    mirrored = CellMesh(sheared(points), cells[:, [0, 2, 1, 3, 4, 6, 5, 7]], np.ones(8), "hexahedron")
    assert np.array_equal(mirrored.cells, cells) and mirrored.volumes.sum() == pytest.approx(1.0, rel=1e-13)
    tangled = sheared(points)
    tangled[-1] = [0.6, 0.6, 0.6]             # cell 7's outer corner pulled past its centre
    with pytest.raises(ValueError, match=r"hexahedron 7 \(vertices .*\) is inverted or degenerate: .* at its vertex 7"):
        CellMesh(tangled, cells, np.ones(8), "hexahedron")


def test_second_gradient_is_exact_on_quadrilaterals_that_are_not_parallelograms():
    """2D: a fem_mesh of trapezoids (the shared side slanted) is taken; ½ ∫ G:G of u = (x², x y)
    (G:G = 4 + 1 + 1) over [0, 2] x [0, 1] is 6."""
    trapezoids = sf.PolygonMesh([(0, 0), (1, 0), (2, 0), (0, 1), (1.2, 1), (2, 1)], [[0, 1, 4, 3], [1, 2, 5, 4]],
                                [1, 1])
    energy = sf.UserEnergy(lambda F, G: ufl.inner(G, G) / 2, name="half_GG")
    disc = LagrangeDiscretization.from_polygon_mesh(sf.meshes.quad_rectangle(2.0, 1.0, 2, 1, tag=1), {1: energy},
                                                    fem_mesh=trapezoids, verbose=False)
    u, b = disc.create_vector(), disc.create_vector()
    X = disc.x_nodes
    with u.localForm() as ul:
        ul.array[:] = np.c_[X[:, 0] ** 2, X[:, 0] * X[:, 1]].ravel()
    assert disc.residual(u, b).energy == pytest.approx(6.0, rel=1e-12)
    u.destroy()
    b.destroy()
