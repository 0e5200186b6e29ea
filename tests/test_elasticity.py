"""Linear-elastic SFVEM element: rank, symmetry, rigid motions, exact energy (docs/method.md §3, §7).

The test polygons, the zero-eigenvalue table and the reference maths are conftest.py's fixtures.
"""
import numpy as np
import pytest

from dolfinx_sfvem.discretizations.elasticity import linear_elastic_stiffness

YOUNG, POISSON = 7.0, 0.3


def rigid_motions(xy: np.ndarray, polygon_moments) -> np.ndarray:
    """DOF vectors (3, 2(2N+1)) of u = (1, 0), (0, 1) and the rotation u = (-y, x) (DOF order of K)."""
    midpoints = 0.5 * (xy + np.roll(xy, -1, axis=0))
    moments = polygon_moments(xy)
    centroid = moments[1:3] / moments[0]
    one = np.ones(2 * len(xy) + 1)
    x = np.concatenate([xy[:, 0], midpoints[:, 0], [centroid[0]]])
    y = np.concatenate([xy[:, 1], midpoints[:, 1], [centroid[1]]])
    return np.array([np.concatenate([one, 0 * one]), np.concatenate([0 * one, one]), np.concatenate([-y, x])])


def test_rank_symmetry_definiteness(polygon, build_one, zero_eigenvalues):
    K, l = linear_elastic_stiffness(polygon, YOUNG, POISSON)
    assert l == build_one(polygon).l[0]
    assert K.shape == (2 * (2 * len(polygon) + 1),) * 2
    np.testing.assert_allclose(K, K.T, rtol=0, atol=1e-13 * np.abs(K).max())
    eigenvalues = np.linalg.eigvalsh(K)
    assert eigenvalues[0] > -1e-13 * eigenvalues[-1]
    assert zero_eigenvalues(K) == 3


def test_rigid_motions_in_kernel(polygon, polygon_moments):
    xy = polygon
    K, _ = linear_elastic_stiffness(xy, YOUNG, POISSON)
    for mode in rigid_motions(xy, polygon_moments):
        assert np.linalg.norm(K @ mode) <= 1e-12 * np.linalg.norm(K, 2) * np.linalg.norm(mode)


def test_zero_eigenvalues_match_design_table(tabulated_name, polygons, zero_eigenvalue_table, zero_eigenvalues):
    counts = [zero_eigenvalues(linear_elastic_stiffness(polygons[tabulated_name], YOUNG, POISSON, l)[0])
              for l in range(2, 7)]
    assert counts == zero_eigenvalue_table[tabulated_name]


@pytest.mark.parametrize("name", ["square", "random convex", "U (not star-shaped)", "square, 2 hanging nodes"])
def test_energy_of_quadratic_field_is_exact(name, polygons, Quadratic, polygon_moments):
    """u^T K u = int_E eps(u) : C : eps(u) for quadratic u: the projected strain is exact (patch test),
    and the energy density, a quadratic polynomial, is integrated with Green's moments."""
    xy = polygons[name]
    rng = np.random.default_rng(11)
    ux, uy = Quadratic(rng.standard_normal(6)), Quadratic(rng.standard_normal(6))
    K, _ = linear_elastic_stiffness(xy, YOUNG, POISSON)
    u = np.concatenate([ux.dofs(xy), uy.dofs(xy)])
    # Voigt strain [e_xx, e_yy, 2 e_xy] is linear: a + B x with x = (x, y)
    a = np.array([ux.c[1], uy.c[2], ux.c[2] + uy.c[1]])
    B = np.array([[2 * ux.c[3], ux.c[4]], [uy.c[4], 2 * uy.c[5]], [ux.c[4] + 2 * uy.c[3], 2 * ux.c[5] + uy.c[4]]])
    factor = YOUNG / ((1 + POISSON) * (1 - 2 * POISSON))
    C = factor * np.array([[1 - POISSON, POISSON, 0], [POISSON, 1 - POISSON, 0], [0, 0, 0.5 - POISSON]])
    area, mx, my, mxx, mxy, myy = polygon_moments(xy)
    first = np.array([mx, my])
    second = np.array([[mxx, mxy], [mxy, myy]])
    energy = area * a @ C @ a + 2 * a @ C @ B @ first + np.sum((B.T @ C @ B) * second)
    assert u @ K @ u == pytest.approx(energy, rel=1e-11)


def test_invariant_under_translation_and_scaling(polygons):
    """In 2D K = int B^T C B does not depend on the element size."""
    xy = polygons["arrow (star-shaped)"]
    K, _ = linear_elastic_stiffness(xy, YOUNG, POISSON)
    K_moved, _ = linear_elastic_stiffness(0.01 * xy + np.array([2.0, -1.0]), YOUNG, POISSON)
    np.testing.assert_allclose(K_moved, K, rtol=0, atol=1e-10 * np.abs(K).max())


def test_bad_input(polygons):
    square = polygons["square"]
    with pytest.raises(ValueError, match="not counter-clockwise"):
        linear_elastic_stiffness(square[::-1], YOUNG, POISSON)
    with pytest.raises(ValueError, match="N >= 3"):
        linear_elastic_stiffness(square[:2], YOUNG, POISSON)
    with pytest.raises(ValueError, match="Poisson"):
        linear_elastic_stiffness(square, YOUNG, 0.5)
    with pytest.raises(ValueError, match="Young"):
        linear_elastic_stiffness(square, -1.0, POISSON)
    with pytest.raises(ValueError, match="l must be an integer"):
        linear_elastic_stiffness(square, YOUNG, POISSON, l=0)
