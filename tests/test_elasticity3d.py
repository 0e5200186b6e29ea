"""Linear-elastic SFVEM element on polyhedra: rank, rigid motions, patch test, exact energy
(dolfinx_sfvem.discretizations.elasticity.linear_elastic_stiffness_3d; docs/method.md §8).

References from outside the code under test: the rigid motions and linear fields evaluated
directly, Hooke's law by hand, the equivalent nodal forces of a constant traction (on a face,
int_f v t = |f| t mean_f(v): only the face-mean DOFs carry it), and the strain energy of a
quadratic field integrated with the sub-tetrahedral rule (test_polyhedron checks that rule).
"""
import numpy as np
import pytest

from dolfinx_sfvem.discretizations.elasticity import isotropic_elasticity, linear_elastic_stiffness_3d
from dolfinx_sfvem.mesh.polyhedron import polyhedron_geometry, polyhedron_quadrature
from dolfinx_sfvem.discretizations.projection3d import interpolation_dofs

YOUNG, POISSON = 7.0, 0.3
_cache: dict[str, tuple[np.ndarray, int]] = {}


def stiffness(name, polyhedra):
    if name not in _cache:
        _cache[name] = linear_elastic_stiffness_3d(*polyhedra[name], YOUNG, POISSON)
    return _cache[name]


def vector_dofs(points, faces, u, degree=1):
    """DOFs [u_x~, u_y~, u_z~] of a vector field u: (n, 3) -> (n, 3)."""
    return interpolation_dofs(points, faces, u, degree).ravel()


def stress(strain):
    """Hooke by hand: sigma = lambda tr(eps) I + 2 mu eps."""
    mu = YOUNG / (2 * (1 + POISSON))
    lam = YOUNG * POISSON / ((1 + POISSON) * (1 - 2 * POISSON))
    return lam * np.trace(strain) * np.eye(3) + 2 * mu * strain


def test_six_zero_eigenvalues(polyhedron_name, polyhedra):
    K, l = stiffness(polyhedron_name, polyhedra)
    np.testing.assert_allclose(K, K.T, rtol=0, atol=1e-13 * np.abs(K).max())
    eigenvalues = np.linalg.eigvalsh(K) / np.linalg.eigvalsh(K)[-1]
    assert np.all(np.abs(eigenvalues[:6]) < 1e-13)
    assert eigenvalues[6] > 1e-8  # measured >= 4.7e-8 (the cube with one refined neighbour)


def test_rigid_motions_are_free(polyhedron_name, polyhedra):
    points, faces = polyhedra[polyhedron_name]
    K, _ = stiffness(polyhedron_name, polyhedra)
    rng = np.random.default_rng(2)
    for _ in range(3):
        W = rng.standard_normal((3, 3))
        W -= W.T
        b = rng.standard_normal(3)
        u = vector_dofs(points, faces, lambda x: x @ W.T + b)
        assert np.linalg.norm(K @ u) <= 1e-12 * np.linalg.norm(K, 2) * np.linalg.norm(u)


def test_patch_test(polyhedron_name, polyhedra):
    """A linear field's DOFs: K u~ is the constant stress's traction on each face, |f| sigma n_f on the
    face-mean DOFs, zero at vertices, edge midpoints and the cell mean (interior DOF)."""
    points, faces = polyhedra[polyhedron_name]
    K, l = stiffness(polyhedron_name, polyhedra)
    rng = np.random.default_rng(5)
    A = rng.standard_normal((3, 3))
    u = vector_dofs(points, faces, lambda x: x @ A.T + 1.0)
    sigma = stress(0.5 * (A + A.T))
    g = polyhedron_geometry(points, faces)
    n_v, n_f = len(points), len(faces)
    nd = K.shape[0] // 3
    expected = np.zeros((3, nd))
    face_dofs = slice(nd - 1 - n_f, nd - 1)
    expected[:, face_dofs] = (g.face_areas[:, None] * g.face_normals @ sigma).T
    force = (K @ u).reshape(3, nd)
    scale = np.abs(expected).max()
    # round-off grows about a digit per degree of the scaled monomials (measured 4e-10 at l = 9)
    np.testing.assert_allclose(force, expected, rtol=0, atol=10.0 ** (max(l, 7) - 18) * scale)
    assert nd == n_v + (nd - 1 - n_f - n_v) + n_f + 1


@pytest.mark.parametrize("name", ["tetrahedron", "L prism (non-convex)", "cube, 2 refined neighbours",
                                  "random convex hull"])
def test_energy_of_a_quadratic_field_is_exact(name, polyhedra):
    """u~^T K u~ = int_E eps : C : eps for a quadratic u (strain linear: the projection is exact)."""
    points, faces = polyhedra[name]
    K, _ = stiffness(name, polyhedra)
    rng = np.random.default_rng(9)
    A, Bq = rng.standard_normal((3, 3)), rng.standard_normal((3, 3, 3))
    Bq = 0.5 * (Bq + Bq.transpose(0, 2, 1))  # u_i = A_ij x_j + B_ijk x_j x_k, grad u_ij = A_ij + 2 B_ijk x_k

    def u(x):
        return x @ A.T + np.einsum("ijk,nj,nk->ni", Bq, x, x)

    dofs = vector_dofs(points, faces, u, degree=2)
    x, w = polyhedron_quadrature(points, faces, 2)
    grad = A[None] + 2 * np.einsum("ijk,nk->nij", Bq, x)
    eps = 0.5 * (grad + grad.transpose(0, 2, 1))
    energy = sum(wq * np.sum(stress(e) * e) for wq, e in zip(w, eps))
    assert dofs @ K @ dofs == pytest.approx(energy, rel=1e-10)


def test_hooke_voigt_matrix():
    C = isotropic_elasticity(YOUNG, POISSON)
    strain = np.array([[0.1, 0.02, -0.03], [0.02, -0.2, 0.05], [-0.03, 0.05, 0.3]])
    voigt = np.array([strain[0, 0], strain[1, 1], strain[2, 2], 2 * strain[1, 2], 2 * strain[0, 2], 2 * strain[0, 1]])
    s = stress(strain)
    np.testing.assert_allclose(C @ voigt, [s[0, 0], s[1, 1], s[2, 2], s[1, 2], s[0, 2], s[0, 1]], rtol=1e-14)
    with pytest.raises(ValueError, match="Poisson"):
        isotropic_elasticity(1.0, 0.5)
    with pytest.raises(ValueError, match="Young"):
        isotropic_elasticity(0.0, 0.3)


def test_patch_test_across_a_hanging_face(refined_cube, global_dofs):
    """An octree patch: the unit cube with its +x face split, glued to the four cubes of half size
    beyond it (the hanging vertices and the split face are shared DOFs). With the DOFs on the
    outer boundary of [0, 1.5] x [0, 1]^2 taken from a linear field, the assembled system gives
    the linear field at every interior DOF (shared face means, the hanging face's centre vertex and
    its edges, the cell means)."""
    cells = [refined_cube((1,))]
    small_points, small_faces = refined_cube(())
    for y in (0.0, 0.5):
        for z in (0.0, 0.5):
            cells.append((0.5 * small_points + [1.0, y, z], small_faces))
    rng = np.random.default_rng(4)
    A, b = rng.standard_normal((3, 3)), rng.standard_normal(3)
    cell_dofs, locations = global_dofs(cells)
    n = len(locations)
    K = np.zeros((3 * n, 3 * n))
    for (points, faces), dofs in zip(cells, cell_dofs):
        Ke, _ = linear_elastic_stiffness_3d(points, faces, YOUNG, POISSON)
        index = np.concatenate([dofs + c * n for c in range(3)])
        K[np.ix_(index, index)] += Ke
    upper = np.array([1.5, 1.0, 1.0])
    on_boundary = np.tile(np.any(np.isclose(locations, 0.0) | np.isclose(locations, upper), axis=1), 3)
    exact = (locations @ A.T + b).T.ravel()  # the DOFs of a linear field are its values at these points
    u = exact.copy()
    inner = ~on_boundary
    # inner: the split face's centre vertex, its 4 cross edges and the edge from it along x, the 4 quarter
    # faces and the 4 faces between the small cubes, 5 cell means
    assert inner.sum() == 3 * (1 + 5 + 8 + 5)
    u[inner] = np.linalg.solve(K[np.ix_(inner, inner)], -K[np.ix_(inner, on_boundary)] @ u[on_boundary])
    np.testing.assert_allclose(u, exact, rtol=0, atol=1e-10 * np.abs(exact).max())
