"""Scaled monomials, Pi^nabla_2 and Pi^0_l nabla (paper Eqs. 36, 41-45; docs/method.md §2-3).

The reference values come from outside the code under test: closed-form integrals, Green's
formulas for polygon moments, quadratic fields evaluated directly, LAPACK SVDs, and the
zero-eigenvalue table of docs/method.md §3.
"""
import numpy as np
import pytest
from matplotlib.path import Path
from scipy.spatial import ConvexHull

from dolfinx_sfvem.monomials import (evaluate_monomials, exponents, gauss_legendre, n_monomials,
                                     polygon_monomial_integrals)
from dolfinx_sfvem.projection import (RANK_TOL, build_projections, cholesky, null_space_dimensions,
                                      orthonormal_moments, pi_nabla_2, polygon_geometry, projection_system)


# --------------------------------------------------------------------------- test polygons
def regular_polygon(N: int) -> np.ndarray:
    angle = 2 * np.pi * np.arange(N) / N
    return np.column_stack([np.cos(angle), np.sin(angle)])


def square_with_hanging_nodes(y_hanging) -> np.ndarray:
    """Unit square with extra vertices on its right side at the heights y_hanging."""
    right = [[1.0, y] for y in y_hanging]
    return np.array([[0.0, 0.0], [1.0, 0.0], *right, [1.0, 1.0], [0.0, 1.0]])


def _random_convex() -> np.ndarray:
    points = np.random.default_rng(3).random((12, 2))
    return points[ConvexHull(points).vertices]  # counter-clockwise in 2D


#: name -> counter-clockwise vertices
POLYGONS = {
    "triangle": np.array([[0.0, 0.0], [1.0, 0.0], [0.2, 0.9]]),
    "square": square_with_hanging_nodes([]),
    "hexagon": regular_polygon(6),
    "heptagon": regular_polygon(7),
    "octagon": regular_polygon(8),
    "random convex": _random_convex(),
    "arrow (star-shaped)": np.array([[0, 0.25], [2, 0.25], [2, 0], [3, 0.5], [2, 1], [2, 0.75], [0, 0.75]]),
    "star (star-shaped)": np.array([[np.cos(t), np.sin(t)] for t in np.linspace(0, 2 * np.pi, 10, endpoint=False)])
    * np.where(np.arange(10) % 2 == 0, 1.0, 0.4)[:, None],
    "U (not star-shaped)": np.array([[0, 0], [3, 0], [3, 2], [2, 2], [2, 1], [1, 1], [1, 2], [0, 2]], dtype=float),
    "comb (not star-shaped)": np.array([[0, 0], [5, 0], [5, 2], [4, 2], [4, 1], [3, 1], [3, 2], [2, 2], [2, 1],
                                        [1, 1], [1, 2], [0, 2]], dtype=float),
    "square, 1 hanging node": square_with_hanging_nodes([0.5]),
    "square, 2 hanging nodes": square_with_hanging_nodes([1 / 3, 2 / 3]),
    "square, 3 hanging nodes": square_with_hanging_nodes([0.25, 0.5, 0.75]),
    "square, 2 uneven hanging nodes": square_with_hanging_nodes([0.2, 0.7]),
    "square, 1 hanging node per side": np.array([[0, 0], [0.5, 0], [1, 0], [1, 0.5], [1, 1], [0.5, 1], [0, 1],
                                                 [0, 0.5]]),
}

#: docs/method.md §3: zero eigenvalues of the linear-elastic element, l = 2..6 (3 is right)
ZERO_EIGENVALUES = {
    "square": [5, 3, 3, 3, 3],
    "hexagon": [9, 3, 3, 3, 3],
    "heptagon": [13, 3, 3, 3, 3],
    "octagon": [17, 7, 3, 3, 3],
    "square, 1 hanging node": [6, 3, 3, 3, 3],
    "square, 2 hanging nodes": [10, 5, 3, 3, 3],
    "square, 3 hanging nodes": [14, 9, 7, 5, 3],
    "square, 1 hanging node per side": [18, 10, 5, 3, 3],
}


def design_l(name: str) -> int:
    """The automatic l that docs/method.md's table implies: the smallest l >= 3 with 3 zero eigenvalues."""
    return next(l for l, zeros in zip(range(2, 7), ZERO_EIGENVALUES[name]) if l >= 3 and zeros == 3)


def as_csr(polygons: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    points = np.vstack(polygons)
    offsets = np.concatenate([[0], np.cumsum([len(p) for p in polygons])])
    return points, offsets, np.arange(len(points))


def build_one(xy: np.ndarray, **kwargs):
    return build_projections(*as_csr([xy]), **kwargs)


# --------------------------------------------------------------------------- reference maths
def polygon_moments(xy: np.ndarray) -> np.ndarray:
    """[int 1, int x, int y, int x^2, int xy, int y^2] over the polygon (Green's formulas)."""
    x0, y0 = xy[:, 0], xy[:, 1]
    x1, y1 = np.roll(x0, -1), np.roll(y0, -1)
    c = x0 * y1 - x1 * y0
    return np.array([c.sum() / 2, ((x0 + x1) * c).sum() / 6, ((y0 + y1) * c).sum() / 6,
                     ((x0 ** 2 + x0 * x1 + x1 ** 2) * c).sum() / 12,
                     ((x0 * y1 + 2 * x0 * y0 + 2 * x1 * y1 + x1 * y0) * c).sum() / 24,
                     ((y0 ** 2 + y0 * y1 + y1 ** 2) * c).sum() / 12])


class Quadratic:
    """v(x) = c . [1, X, Y, X^2, XY, Y^2], (X, Y) = (x - origin) / scale, with its exact derivatives.

    A local origin and scale keep the reference values accurate for small polygons far away.
    """

    def __init__(self, c, origin=(0.0, 0.0), scale=1.0):
        self.c, self.origin, self.scale = np.asarray(c), np.asarray(origin), scale

    def __call__(self, p):
        X, Y = np.moveaxis((p - self.origin) / self.scale, -1, 0)
        return self.c @ np.array([np.ones_like(X), X, Y, X * X, X * Y, Y * Y])

    def gradient(self, p):
        X, Y = np.moveaxis((p - self.origin) / self.scale, -1, 0)
        c = self.c
        return np.stack([c[1] + 2 * c[3] * X + c[4] * Y, c[2] + c[4] * X + 2 * c[5] * Y], axis=-1) / self.scale

    def hessian(self):
        c = self.c
        return np.array([[2 * c[3], c[4]], [c[4], 2 * c[5]]]) / self.scale ** 2

    def dofs(self, xy):
        """[v(x_i), v(m_i), mean of v] (the SFVEM DOFs)."""
        midpoints = 0.5 * (xy + np.roll(xy, -1, axis=0))
        moments = polygon_moments((xy - self.origin) / self.scale)
        return np.concatenate([self(xy), self(midpoints), [self.c @ moments / moments[0]]])


def interior_points(xy: np.ndarray, n: int, rng) -> np.ndarray:
    """n random points strictly inside the polygon (rejection sampling)."""
    path = Path(xy)
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    points = np.empty((0, 2))
    while len(points) < n:
        candidates = lo + (hi - lo) * rng.random((4 * n, 2))
        points = np.vstack([points, candidates[path.contains_points(candidates)]])
    return points[:n]


def monomials_at(points, x_E, h_E, k):
    """(values, d/dx, d/dy) of the monomials of degree <= k at each point, each (n_points, n_monomials)."""
    out = np.zeros((3, len(points), n_monomials(k)))
    for i, p in enumerate(points):
        evaluate_monomials(p, x_E, h_E, k, out[0, i], out[1, i], out[2, i])
    return out


# --------------------------------------------------------------------------- monomials
def test_exponents_graded_order():
    assert n_monomials(0) == 1 and n_monomials(2) == 6 and n_monomials(10) == 66
    assert exponents(3).tolist() == [[0, 0], [1, 0], [0, 1], [2, 0], [1, 1], [0, 2], [3, 0], [2, 1], [1, 2], [0, 3]]


def test_monomial_values_and_physical_derivatives():
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
def test_monomial_integrals_match_green_moments(name):
    xy = POLYGONS[name]
    x_E, h_E = np.zeros(2), 1.0  # then m = [1, x, y, x^2, xy, y^2]
    np.testing.assert_allclose(polygon_monomial_integrals(xy, x_E, h_E, 2), polygon_moments(xy), rtol=1e-13,
                               atol=1e-14)


def test_polygon_geometry():
    xy = POLYGONS["U (not star-shaped)"]
    area, x_E, h_E = polygon_geometry(xy)
    moments = polygon_moments(xy)
    assert area == pytest.approx(3 * 2 - 1 * 1) and area == pytest.approx(moments[0])
    np.testing.assert_allclose(x_E, moments[1:3] / moments[0], rtol=1e-14)
    assert h_E == pytest.approx(np.hypot(3, 2))
    assert polygon_geometry(xy[::-1])[0] == pytest.approx(-5.0)


# --------------------------------------------------------------------------- patch tests
def check_patch(xy: np.ndarray, P, rtol: float, seed: int) -> None:
    """Pi^nabla_2 reproduces quadratics; Pi^0_l grad (Eq. 43) and its derivatives (Eq. 45) their gradients
    and Hessians, at interior points, for random quadratic fields."""
    rng = np.random.default_rng(seed)
    x_E, h_E, l = P.centroid[0], P.diameter[0], int(P.l[0])
    points = interior_points(xy, 20, rng)
    m2 = monomials_at(points, x_E, h_E, 2)[0]
    m, dm_dx, dm_dy = monomials_at(points, x_E, h_E, l)
    for _ in range(4):
        v = Quadratic(rng.standard_normal(6), origin=xy[0], scale=h_E)
        v_dofs = v.dofs(xy)
        value = m2 @ (P.Pi_nabla_of(0) @ v_dofs)
        np.testing.assert_allclose(value, v(points), rtol=0, atol=rtol * np.abs(v(points)).max())
        coefficients = P.Pi_m_of(0) @ v_dofs  # (2, nl): d/dx and d/dy of v
        gradient = np.stack([m @ coefficients[0], m @ coefficients[1]], axis=-1)
        exact = v.gradient(points)
        np.testing.assert_allclose(gradient, exact, rtol=0, atol=rtol * np.abs(exact).max())
        # Eq. 45: H_cd = d/dx_d of component c, not symmetrised
        hessian = np.array([[dm_dx @ coefficients[0], dm_dy @ coefficients[0]],
                            [dm_dx @ coefficients[1], dm_dy @ coefficients[1]]])  # (2, 2, n_points)
        exact = v.hessian()[:, :, None] * np.ones(len(points))
        np.testing.assert_allclose(hessian, exact, rtol=0, atol=rtol * np.abs(exact).max())


@pytest.mark.parametrize("name", POLYGONS)
def test_patch_automatic_l(name):
    xy = POLYGONS[name]
    check_patch(xy, build_one(xy), rtol=1e-10, seed=1)


@pytest.mark.parametrize("name", POLYGONS)
def test_patch_larger_user_l(name):
    """Two degrees above the automatic choice. Scaled monomials of degree 7-8 cost about a digit
    (measured up to 3e-10 at l = 8), hence 1e-9 here."""
    xy = POLYGONS[name]
    l = int(build_one(xy).l[0]) + 2
    P = build_one(xy, l=l)
    assert P.l[0] == l
    check_patch(xy, P, rtol=1e-9, seed=2)


@pytest.mark.parametrize("scale, offset", [(1e-3, (0.1, 0.05)), (0.1, (5.0, -3.0)), (1e4, (0.0, 0.0))])
def test_patch_translated_scaled_polygon(scale, offset):
    """Only relative positions matter. (An offset of d element sizes costs about log10(d) digits
    of the input geometry, amplified by the projection, hence moderate offsets here.)"""
    xy = scale * POLYGONS["star (star-shaped)"] + np.array(offset)
    check_patch(xy, build_one(xy), rtol=1e-9, seed=3)


# --------------------------------------------------------------------------- choice of l
@pytest.mark.parametrize("name", ZERO_EIGENVALUES)
def test_automatic_l_matches_design_table(name):
    assert build_one(POLYGONS[name]).l[0] == design_l(name)


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


@pytest.mark.parametrize("name", POLYGONS)
def test_null_space_dimensions_agree_with_svd(name):
    xy = POLYGONS[name]
    area, x_E, h_E = polygon_geometry(xy)
    Pi_nabla = pi_nabla_2(xy, x_E, h_E, area)
    for l in range(2, 8):
        M, R = projection_system(xy, x_E, h_E, Pi_nabla, l)
        L, mass_ok = cholesky(M)
        assert mass_ok
        assert null_space_dimensions(orthonormal_moments(L, R), RANK_TOL) == svd_null_space_dimensions(xy, l)


def test_strain_criterion_is_stricter_than_gradient_criterion():
    """The U-shaped octagon at l = 3: only constants in the scalar null space, yet spurious strain-free modes."""
    U = POLYGONS["U (not star-shaped)"]
    gradient_nullity, strain_nullity = svd_null_space_dimensions(U, 3)
    assert gradient_nullity == 1 and strain_nullity > 3
    assert build_one(U).l[0] > 3
    with pytest.raises(ValueError, match=rf"polygon 0: l=3 is rank-deficient \({strain_nullity} zero-strain modes"):
        build_one(U, l=3)


def test_rank_deficient_user_l_names_polygon():
    points, offsets, vertices = as_csr([POLYGONS["square"], POLYGONS["square, 3 hanging nodes"]])
    with pytest.raises(ValueError, match=r"polygon 1: l=3 is rank-deficient .*smallest sufficient l is 6"):
        build_projections(points, offsets, vertices, l=3)
    with pytest.raises(ValueError, match=r"polygon 1: l=5 is rank-deficient"):
        build_projections(points, offsets, vertices, l=[3, 5])
    assert build_projections(points, offsets, vertices, l=[3, 6]).l.tolist() == [3, 6]
    with pytest.raises(ValueError, match=r"polygon 0: l=2 is rank-deficient .*smallest sufficient l is 3"):
        build_projections(points, offsets, vertices, l=2)


def test_l_max_guard():
    points, offsets, vertices = as_csr([POLYGONS["square"], POLYGONS["square, 3 hanging nodes"]])
    with pytest.raises(ValueError, match=r"polygon 1: no l <= l_max=5 is sufficient"):
        build_projections(points, offsets, vertices, l_max=5)
    with pytest.raises(ValueError, match=r"l=11 .*outside \[1, l_max=10\]"):
        build_projections(points, offsets, vertices, l=11)
    with pytest.raises(ValueError, match=r"l_min"):
        build_projections(points, offsets, vertices, l_min=4, l_max=3)


def test_bad_polygons_are_named():
    square = POLYGONS["square"]
    with pytest.raises(ValueError, match=r"polygon 1: vertices are not counter-clockwise"):
        build_projections(*as_csr([square, square[::-1]]))
    with pytest.raises(ValueError, match=r"polygon 1: 2 vertices"):
        build_projections(*as_csr([square, square[:2]]))
    with pytest.raises(ValueError, match=r"polygon 0: two consecutive vertices coincide"):
        build_projections(*as_csr([np.vstack([square[:1], square])]))
    thin = np.array([[0.0, 0.0], [1.0, 1.0], [0.5, 0.5 + 1e-9]])
    with pytest.raises(ValueError, match=r"polygon 0: the P_\d+ monomial mass matrix is numerically singular"):
        build_one(thin)


# --------------------------------------------------------------------------- bulk build
def random_polygons(n: int, rng) -> list[np.ndarray]:
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


def test_bulk_build_equals_per_polygon_build():
    rng = np.random.default_rng(7)
    shapes = random_polygons(300, rng)
    points, offsets, vertices = as_csr(shapes)
    # shuffle the point array so that polygons reach their points through `vertices`
    order = rng.permutation(len(points))
    shuffled = np.empty_like(points)
    shuffled[order] = points
    bulk = build_projections(shuffled, offsets, order[vertices])
    assert bulk.n_polygons == len(shapes)
    assert sum(bulk.histogram().values()) == len(shapes)
    for j, xy in enumerate(shapes):
        single = build_one(xy)
        assert bulk.l[j] == single.l[0]
        np.testing.assert_allclose(bulk.centroid[j], single.centroid[0], rtol=1e-14)
        assert bulk.diameter[j] == single.diameter[0] and bulk.area[j] == single.area[0]
        np.testing.assert_allclose(bulk.Pi_nabla_of(j), single.Pi_nabla_of(0), rtol=1e-14, atol=0)
        np.testing.assert_allclose(bulk.Pi_m_of(j), single.Pi_m_of(0), rtol=1e-14, atol=0)
        assert bulk.Pi_m_of(j).shape == (2, n_monomials(int(bulk.l[j])), 2 * len(xy) + 1)
        np.testing.assert_allclose(bulk.area[j], polygon_moments(xy - xy[0])[0], rtol=1e-12)
    # a subset in another order, indexed 0..n-1 in that order
    subset = rng.choice(len(shapes), 40, replace=False)
    part = build_projections(shuffled, offsets, order[vertices], polygons=subset)
    for j, e in enumerate(subset):
        assert part.l[j] == bulk.l[e]
        np.testing.assert_array_equal(part.Pi_m_of(j), bulk.Pi_m_of(e))
        np.testing.assert_array_equal(part.Pi_nabla_of(j), bulk.Pi_nabla_of(e))


def test_histogram_and_summary():
    names = list(ZERO_EIGENVALUES)
    P = build_projections(*as_csr([POLYGONS[name] for name in names]))
    expected = {}
    for name in names:
        expected[design_l(name)] = expected.get(design_l(name), 0) + 1
    assert P.histogram() == dict(sorted(expected.items()))
    assert f"{len(names)} polygons" in P.summary() and "l=6: 1 " in P.summary()
