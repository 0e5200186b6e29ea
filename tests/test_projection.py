"""Scaled monomials, Pi^nabla_2 and Pi^0_l nabla (paper Eqs. 36, 41-45; docs/method.md §2-3).

The reference values come from outside the code under test: closed-form integrals, Green's
formulas for polygon moments, quadratic fields evaluated directly, LAPACK SVDs, and the
zero-eigenvalue table of docs/method.md §3. The test polygons, the table and the reference maths
(Green's moments, quadratic fields, the patch test) are fixtures of conftest.py: test_elasticity
and test_local_refinement use them too.
"""
import numpy as np
import pytest

from dolfinx_sfvem.discretizations.cell_projection import (
    RANK_TOL, cholesky, n_monomials_in, null_space_dimensions, orthonormal_moments)
from dolfinx_sfvem.discretizations.monomials import exponents, gauss_legendre, n_monomials, polygon_monomial_integrals
from dolfinx_sfvem.discretizations.monomials3d import n_monomials3
from dolfinx_sfvem.discretizations.projection import build_projections, pi_nabla_2, polygon_geometry, projection_system


# --------------------------------------------------------------------------- helpers
def design_l(zero_eigenvalues: list[int]) -> int:
    """The automatic l that a row of docs/method.md's table (zero eigenvalues for l = 2..6) implies:
    the smallest l >= 3 with 3 zero eigenvalues."""
    return next(l for l, zeros in zip(range(2, 7), zero_eigenvalues) if l >= 3 and zeros == 3)


# --------------------------------------------------------------------------- monomials
def test_exponents_graded_order():
    assert n_monomials(0) == 1 and n_monomials(2) == 6 and n_monomials(10) == 66
    assert exponents(3).tolist() == [[0, 0], [1, 0], [0, 1], [2, 0], [1, 1], [0, 2], [3, 0], [2, 1], [1, 2], [0, 3]]


def test_monomial_values_and_physical_derivatives(monomials_at):
    x_E, h_E, k = np.array([0.3, -0.2]), 0.7, 5
    p = np.array([0.9, 0.4])
    m, dm_dx, dm_dy = monomials_at(p[None], x_E, h_E, k)[:, 0]
    xi, eta = (p - x_E) / h_E
    for a, (i, j) in enumerate(exponents(k)):
        assert m[a] == pytest.approx(xi ** i * eta ** j, rel=1e-14)
        # central differences in physical coordinates
        step = 1e-6
        fx = [((p[0] + s - x_E[0]) / h_E) ** i * eta ** j for s in (step, -step)]
        fy = [xi ** i * ((p[1] + s - x_E[1]) / h_E) ** j for s in (step, -step)]
        assert dm_dx[a] == pytest.approx((fx[0] - fx[1]) / (2 * step), rel=1e-7, abs=1e-9)
        assert dm_dy[a] == pytest.approx((fy[0] - fy[1]) / (2 * step), rel=1e-7, abs=1e-9)


@pytest.mark.parametrize("n", [1, 2, 3, 5, 8])
def test_gauss_legendre_exact_to_degree_2n_minus_1(n):
    t, w = gauss_legendre(n)
    for degree in range(2 * n):
        assert w @ t ** degree == pytest.approx(1 / (degree + 1), rel=1e-14)


def test_monomial_integrals_rectangle_closed_form():
    """int over [a, b] x [c, d] of ((x - x0)/h)^p ((y - y0)/h)^q, degree <= 14, in closed form."""
    a, b, c, d = 0.2, 1.7, -0.4, 0.3
    xy = np.array([[a, c], [b, c], [b, d], [a, d]])
    x_E, h_E = np.array([0.1, 0.05]), 1.3

    def one_d(lo, hi, centre, power):
        return h_E / (power + 1) * (((hi - centre) / h_E) ** (power + 1) - ((lo - centre) / h_E) ** (power + 1))

    integrals = polygon_monomial_integrals(xy, x_E, h_E, 14)
    expected = [one_d(a, b, x_E[0], p) * one_d(c, d, x_E[1], q) for p, q in exponents(14)]
    np.testing.assert_allclose(integrals, expected, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("name", ["random convex", "U (not star-shaped)", "star (star-shaped)"])
def test_monomial_integrals_match_green_moments(name, polygons, polygon_moments):
    xy = polygons[name]
    x_E, h_E = np.zeros(2), 1.0  # then m = [1, x, y, x^2, xy, y^2]
    np.testing.assert_allclose(polygon_monomial_integrals(xy, x_E, h_E, 2), polygon_moments(xy), rtol=1e-13,
                               atol=1e-14)


def test_polygon_geometry(polygons, polygon_moments):
    xy = polygons["U (not star-shaped)"]
    area, x_E, h_E = polygon_geometry(xy)
    moments = polygon_moments(xy)
    assert area == pytest.approx(3 * 2 - 1 * 1) and area == pytest.approx(moments[0])
    np.testing.assert_allclose(x_E, moments[1:3] / moments[0], rtol=1e-14)
    assert h_E == pytest.approx(np.hypot(3, 2))
    assert polygon_geometry(xy[::-1])[0] == pytest.approx(-5.0)


# --------------------------------------------------------------------------- patch tests
def test_patch_automatic_l(polygon, build_one, check_patch):
    check_patch(polygon, build_one(polygon), rtol=1e-10, seed=1)


def test_patch_larger_user_l(polygon, build_one, check_patch):
    """Two degrees above the automatic choice. Scaled monomials of degree 7-8 cost about a digit
    (measured up to 3e-10 at l = 8), hence 1e-9 here."""
    xy = polygon
    l = int(build_one(xy).l[0]) + 2
    P = build_one(xy, l=l)
    assert P.l[0] == l
    check_patch(xy, P, rtol=1e-9, seed=2)


@pytest.mark.parametrize("scale, offset", [(1e-3, (0.1, 0.05)), (0.1, (5.0, -3.0)), (1e4, (0.0, 0.0))])
def test_patch_translated_scaled_polygon(scale, offset, polygons, build_one, check_patch):
    """Only relative positions matter. (An offset of d element sizes costs about log10(d) digits
    of the input geometry, amplified by the projection, hence moderate offsets here.)"""
    xy = scale * polygons["star (star-shaped)"] + np.array(offset)
    check_patch(xy, build_one(xy), rtol=1e-9, seed=3)


# --------------------------------------------------------------------------- choice of l
def test_automatic_l_matches_design_table(tabulated_name, polygons, zero_eigenvalue_table, build_one):
    assert build_one(polygons[tabulated_name]).l[0] == design_l(zero_eigenvalue_table[tabulated_name])


def svd_null_space_dimensions(xy: np.ndarray, l: int) -> tuple[int, int]:
    """Null-space dimensions of Pi^0_l grad and of sym Pi^0_l grad by LAPACK SVD in the L2-orthonormal basis."""
    area, x_E, h_E = polygon_geometry(xy)
    M, R = projection_system(xy, x_E, h_E, pi_nabla_2(xy, x_E, h_E, area), l)
    L = np.linalg.cholesky(M)
    Q = np.stack([np.linalg.solve(L, R[0]), np.linalg.solve(L, R[1])])
    zero = np.zeros_like(Q[0])
    strain = np.block([[Q[0], zero], [zero, Q[1]], [Q[1] / np.sqrt(2), Q[0] / np.sqrt(2)]])

    def nullity(A):
        sigma = np.linalg.svd(A, compute_uv=False)
        return A.shape[1] - np.sum(sigma > RANK_TOL * sigma[0])

    return nullity(np.vstack([Q[0], Q[1]])), nullity(strain)


def test_null_space_dimensions_agree_with_svd(polygon):
    xy = polygon
    area, x_E, h_E = polygon_geometry(xy)
    Pi_nabla = pi_nabla_2(xy, x_E, h_E, area)
    for l in range(2, 8):
        M, R = projection_system(xy, x_E, h_E, Pi_nabla, l)
        L, mass_ok = cholesky(M)
        assert mass_ok
        assert null_space_dimensions(orthonormal_moments(L, R), RANK_TOL) == svd_null_space_dimensions(xy, l)


def test_strain_criterion_is_stricter_than_gradient_criterion(polygons, build_one):
    """The U-shaped octagon at l = 3: only constants in the scalar null space, yet spurious strain-free modes."""
    U = polygons["U (not star-shaped)"]
    gradient_nullity, strain_nullity = svd_null_space_dimensions(U, 3)
    assert gradient_nullity == 1 and strain_nullity > 3
    assert build_one(U).l[0] > 3
    with pytest.raises(ValueError, match=rf"cell 0: l=3 is rank-deficient \({strain_nullity} zero-strain modes"):
        build_one(U, l=3)


def test_rank_deficient_user_l_names_polygon(polygons, as_csr):
    points, offsets, vertices = as_csr([polygons["square"], polygons["square, 3 hanging nodes"]])
    with pytest.raises(ValueError, match=r"cell 1: l=3 is rank-deficient .*smallest sufficient l is 6"):
        build_projections(points, offsets, vertices, l=3)
    with pytest.raises(ValueError, match=r"cell 1: l=5 is rank-deficient"):
        build_projections(points, offsets, vertices, l=[3, 5])
    assert build_projections(points, offsets, vertices, l=[3, 6]).l.tolist() == [3, 6]
    with pytest.raises(ValueError, match=r"cell 0: l=2 is rank-deficient .*smallest sufficient l is 3"):
        build_projections(points, offsets, vertices, l=2)


def test_l_max_guard(polygons, as_csr):
    points, offsets, vertices = as_csr([polygons["square"], polygons["square, 3 hanging nodes"]])
    with pytest.raises(ValueError, match=r"cell 1: no l <= l_max=5 is sufficient"):
        build_projections(points, offsets, vertices, l_max=5)
    with pytest.raises(ValueError, match=r"l=11 .*outside \[1, l_max=10\]"):
        build_projections(points, offsets, vertices, l=11)
    with pytest.raises(ValueError, match=r"l_min"):
        build_projections(points, offsets, vertices, l_min=4, l_max=3)


def test_bad_polygons_are_named(polygons, as_csr, build_one):
    square = polygons["square"]
    with pytest.raises(ValueError, match=r"polygon 1: vertices are not counter-clockwise"):
        build_projections(*as_csr([square, square[::-1]]))
    with pytest.raises(ValueError, match=r"polygon 1: 2 vertices"):
        build_projections(*as_csr([square, square[:2]]))
    with pytest.raises(ValueError, match=r"polygon 0: two consecutive vertices coincide"):
        build_projections(*as_csr([np.vstack([square[:1], square])]))
    thin = np.array([[0.0, 0.0], [1.0, 1.0], [0.5, 0.5 + 1e-9]])
    with pytest.raises(ValueError, match=r"cell 0: the P_\d+ monomial mass matrix is numerically singular"):
        build_one(thin)


# --------------------------------------------------------------------------- bulk build
def random_polygons(n: int, rng, square_with_hanging_nodes) -> list[np.ndarray]:
    """Perturbed regular polygons (3-9 vertices), star-shaped ones and hanging-node squares,
    randomly rotated, scaled and moved."""
    shapes = []
    for _ in range(n):
        kind = rng.integers(3)
        if kind == 0:
            N = int(rng.integers(3, 10))
            angle = 2 * np.pi * (np.arange(N) + 0.3 * rng.uniform(-1, 1, N)) / N
            xy = rng.uniform(0.6, 1.0, (N, 1)) * np.column_stack([np.cos(angle), np.sin(angle)])
        elif kind == 1:
            N = 2 * int(rng.integers(3, 6))
            angle = 2 * np.pi * np.arange(N) / N
            xy = np.where(np.arange(N) % 2 == 0, 1.0, rng.uniform(0.3, 0.7))[:, None] * np.column_stack(
                [np.cos(angle), np.sin(angle)])
        else:  # hanging nodes near the k-section points (clustered ones make near-singular elements)
            k = int(rng.integers(0, 4))
            xy = square_with_hanging_nodes((np.arange(1, k + 1) + rng.uniform(-0.2, 0.2, k)) / (k + 1))
        turn = rng.uniform(0, 2 * np.pi)
        rotation = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
        shapes.append(rng.uniform(0.01, 2.0) * xy @ rotation.T + rng.uniform(-10, 10, 2))
    return shapes


def test_bulk_build_equals_per_polygon_build(as_csr, build_one, polygon_moments, square_with_hanging_nodes):
    rng = np.random.default_rng(7)
    shapes = random_polygons(300, rng, square_with_hanging_nodes)
    points, offsets, vertices = as_csr(shapes)
    # shuffle the point array so that polygons reach their points through `vertices`
    order = rng.permutation(len(points))
    shuffled = np.empty_like(points)
    shuffled[order] = points
    bulk = build_projections(shuffled, offsets, order[vertices])
    assert bulk.n_cells == len(shapes)
    assert sum(bulk.histogram().values()) == len(shapes)
    for j, xy in enumerate(shapes):
        single = build_one(xy)
        assert bulk.l[j] == single.l[0]
        np.testing.assert_allclose(bulk.centroid[j], single.centroid[0], rtol=1e-14)
        assert bulk.diameter[j] == single.diameter[0] and bulk.measure[j] == single.measure[0]
        np.testing.assert_allclose(bulk.Pi_nabla_of(j), single.Pi_nabla_of(0), rtol=1e-14, atol=0)
        np.testing.assert_allclose(bulk.Pi_m_of(j), single.Pi_m_of(0), rtol=1e-14, atol=0)
        assert bulk.Pi_m_of(j).shape == (2, n_monomials(int(bulk.l[j])), 2 * len(xy) + 1)
        np.testing.assert_allclose(bulk.measure[j], polygon_moments(xy - xy[0])[0], rtol=1e-12)
    # a subset in another order, indexed 0..n-1 in that order
    subset = rng.choice(len(shapes), 40, replace=False)
    part = build_projections(shuffled, offsets, order[vertices], polygons=subset)
    for j, e in enumerate(subset):
        assert part.l[j] == bulk.l[e]
        np.testing.assert_array_equal(part.Pi_m_of(j), bulk.Pi_m_of(e))
        np.testing.assert_array_equal(part.Pi_nabla_of(j), bulk.Pi_nabla_of(e))
        np.testing.assert_array_equal(part.vertices_of(j), order[vertices[offsets[e]:offsets[e + 1]]])


def test_monomial_count_in_any_dimension():
    assert [n_monomials_in(l, 2) for l in range(11)] == [n_monomials(l) for l in range(11)]
    assert [n_monomials_in(l, 3) for l in range(11)] == [n_monomials3(l) for l in range(11)]


def test_histogram_and_summary(polygons, zero_eigenvalue_table, as_csr):
    names = list(zero_eigenvalue_table)
    P = build_projections(*as_csr([polygons[name] for name in names]))
    expected = {}
    for l in (design_l(zero_eigenvalue_table[name]) for name in names):
        expected[l] = expected.get(l, 0) + 1
    assert P.histogram() == dict(sorted(expected.items()))
    assert f"{len(names)} polygons" in P.summary() and "l=6: 1 " in P.summary()
