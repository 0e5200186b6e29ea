"""Loads on boundary edges with quadratic traces (dolfinx_sfvem/physics/edge_loads.py, docs/guide/loads.md).

References are independent of the module: a 12-point Gauss rule written here, hand-integrated
shape-function moments, exact resultants (Σ f = -p (x_end - x_start) × e_z, zero moment on a
closed loop), central finite differences, and the shoelace area of a finely sampled deformed
curve (whose error is exactly C/n² for a quadratic curve, so one Richardson step is exact).
"""
import numpy as np
import pytest

from dolfinx_sfvem.physics import edge_loads as el

P = 1.7
#: central differences of functions at most quadratic in u: only round-off remains
FD_STEP = 1e-6
FD_RTOL = 1e-7
Q = np.array([[0.0, 1.0], [-1.0, 0.0]])
#: M_kl = ∫ N_k N_l' dξ over [-1, 1], integrated by hand
M_EXACT = np.array([[-1 / 2, 2 / 3, -1 / 6], [-2 / 3, 0, 2 / 3], [1 / 6, -2 / 3, 1 / 2]])


# ----------------------------------------------------------------------------- geometry
def shapes(xi):
    """Quadratic shape functions of [a, m, b] and their derivatives at xi (n,): (n, 3) each."""
    xi = np.asarray(xi)[:, None]
    return (np.hstack([xi * (xi - 1) / 2, 1 - xi ** 2, xi * (xi + 1) / 2]),
            np.hstack([xi - 0.5, -2 * xi, xi + 0.5]))


def numbered(vertices, closed, rng, cavity=True):
    """Straight reference edges through ``vertices`` (n, 2) (counter-clockwise), midpoints added,
    nodes numbered in a random order: (X (n_nodes, 2), edges (n_e, 3)).

    ``cavity``: the body lies outside the loop, so the edges run clockwise (body on the left).
    """
    n = len(vertices)
    n_e = n if closed else n - 1
    X = np.vstack([vertices, (vertices[:n_e] + np.roll(vertices, -1, axis=0)[:n_e]) / 2])
    edges = np.array([[i, n + i, (i + 1) % n] for i in range(n_e)])
    if cavity:
        edges = edges[::-1, ::-1]
    perm = rng.permutation(len(X))
    Xp = np.empty_like(X)
    Xp[perm] = X
    return Xp, perm[edges]


def star(rng, n=9, radius=1.0):
    """Vertices of a random star-shaped polygon around the origin, counter-clockwise."""
    theta = np.sort(rng.uniform(0, 2 * np.pi, n))
    r = radius * rng.uniform(0.7, 1.3, n)
    return np.column_stack([r * np.cos(theta), r * np.sin(theta)])


def closed_loop(seed, cavity=True):
    """A random star-shaped loop and a random displacement curving its edges."""
    rng = np.random.default_rng(seed)
    X, edges = numbered(star(rng), True, rng, cavity)
    return edges, X, 0.05 * rng.standard_normal(X.shape)


def open_chain(seed):
    """A random open chain of 5 edges and a random displacement."""
    rng = np.random.default_rng(seed)
    X, edges = numbered(np.cumsum(rng.uniform(-1, 1, (6, 2)), axis=0), False, rng, cavity=False)
    return edges, X, 0.1 * rng.standard_normal(X.shape)


def pressure(edges, X, u, p=P, follower=True):
    f = np.zeros_like(X)
    el.pressure_forces(edges, X, u, p, follower, f)
    return f


def assembled_stiffness(edges, n_nodes, p=P):
    K = np.zeros((2 * n_nodes, 2 * n_nodes))
    dofs = np.stack([2 * edges, 2 * edges + 1], axis=2).reshape(-1, 6)
    for d in dofs:
        K[np.ix_(d, d)] += el.pressure_stiffness(p)
    return K


def cross(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


# ----------------------------------------------------------------------------- reference rules
def gauss_forces(edges, X, u, n_points, p=P, follower=True):
    """-p ∫ N_k (y_ξ × e_z) dξ with an n-point Gauss rule (numpy)."""
    xi, w = np.polynomial.legendre.leggauss(n_points)
    N, dN = shapes(xi)
    y = X + u if follower else X
    y_xi = np.einsum("qk,ekj->eqj", dN, y[edges])
    g = -p * np.stack([y_xi[..., 1], -y_xi[..., 0]], axis=-1)
    f = np.zeros_like(X)
    np.add.at(f, edges, np.einsum("q,qk,eqj->ekj", w, N, g))
    return f


def gauss_swept_area(edges, X, u, n_points):
    """½ Σ_e [X_a × X_b + X_b × x_b - ∫ x × x_ξ dξ + x_a × X_a] with an n-point Gauss rule."""
    xi, w = np.polynomial.legendre.leggauss(n_points)
    N, dN = shapes(xi)
    x = (X + u)[edges]
    Xa, Xb = X[edges[:, 0]], X[edges[:, 2]]
    integral = np.einsum("q,eq->e", w, cross(np.einsum("qk,ekj->eqj", N, x), np.einsum("qk,ekj->eqj", dN, x)))
    return 0.5 * np.sum(cross(Xa, Xb) + cross(Xb, x[:, 2]) - integral + cross(x[:, 0], Xa))


# ----------------------------------------------------------------------------- quadrature
def test_two_point_rule_is_exact_and_one_point_is_not():
    assert el.W_Q.size == 2
    edges, X, u = closed_loop(1)
    for follower in (True, False):
        f12 = gauss_forces(edges, X, u, 12, follower=follower)
        scale = np.abs(f12).max()
        assert np.abs(pressure(edges, X, u, follower=follower) - f12).max() < 1e-14 * scale
        assert np.abs(gauss_forces(edges, X, u, 1, follower=follower) - f12).max() > 1e-2 * scale
    a12 = gauss_swept_area(edges, X, u, 12)
    assert abs(el.swept_area(edges, X, u) - a12) < 1e-14 * np.abs(X).max() ** 2
    assert abs(gauss_swept_area(edges, X, u, 1) - a12) > 1e-4 * abs(a12)
    xi, w = np.polynomial.legendre.leggauss(12)
    N, dN = shapes(xi)
    M12 = np.einsum("q,qk,ql->kl", w, N, dN)
    np.testing.assert_allclose(M12, M_EXACT, atol=1e-14)
    np.testing.assert_allclose(el.pressure_stiffness(P), -P * np.kron(M_EXACT, Q), atol=1e-14)
    # the traction integrand N_k t |X_ξ| (degree 2): Σ w N_k = ∫ N_k = (1/3, 4/3, 1/3)
    np.testing.assert_allclose(el.W_Q @ el.N_Q, [1 / 3, 4 / 3, 1 / 3], rtol=1e-15)


# ----------------------------------------------------------------------------- resultants
def test_dead_traction_resultant_and_nodal_split():
    edges, X, u = open_chain(2)
    L = np.linalg.norm(X[edges[:, 2]] - X[edges[:, 0]], axis=1)
    t = np.array([0.3, -1.2])
    f = np.zeros_like(X)
    el.dead_traction_forces(edges, X, t, f)
    np.testing.assert_allclose(f.sum(axis=0), t * L.sum(), rtol=1e-14)
    # one edge: t L (1/6, 2/3, 1/6)
    f = np.zeros_like(X)
    el.dead_traction_forces(edges[:1], X, t, f)
    np.testing.assert_allclose(f[edges[0]], np.outer([1 / 6, 2 / 3, 1 / 6], t * L[0]), rtol=1e-14)
    # one traction per edge
    t_e = np.random.default_rng(3).standard_normal((len(edges), 2))
    f = np.zeros_like(X)
    el.dead_traction_forces(edges, X, t_e, f)
    np.testing.assert_allclose(f.sum(axis=0), L @ t_e, rtol=1e-13)


@pytest.mark.parametrize("seed", [4, 5, 6])
def test_follower_pressure_on_closed_loop_has_no_net_force_or_moment(seed):
    edges, X, u = closed_loop(seed)
    f = pressure(edges, X, u)
    scale = P * np.abs(X).max()
    np.testing.assert_allclose(f.sum(axis=0), 0.0, atol=1e-14 * scale)
    assert abs(cross(X + u, f).sum()) < 1e-14 * scale * np.abs(X).max()


def test_pressure_resultant_on_open_chain():
    """Σ f = -p (x_end - x_start) × e_z: the pressure on any curve sums to p times its rotated chord."""
    edges, X, u = open_chain(7)
    for follower, y in ((True, X + u), (False, X)):
        d = y[edges[-1, 2]] - y[edges[0, 0]]
        np.testing.assert_allclose(pressure(edges, X, u, follower=follower).sum(axis=0),
                                   -P * np.array([d[1], -d[0]]), rtol=1e-13)


def test_pressure_on_straight_edge():
    """p ℓ (1/6, 2/3, 1/6) against the outward normal; the dead pressure ignores u."""
    X = np.array([[0.3, 0.1], [1.3, 0.6], [2.3, 1.1]])
    edges = np.array([[0, 1, 2]])
    L = np.hypot(2.0, 1.0)
    N = np.array([1.0, -2.0]) / L
    u = np.random.default_rng(8).standard_normal(X.shape)
    expected = np.outer([1 / 6, 2 / 3, 1 / 6], -P * N * L)
    np.testing.assert_allclose(pressure(edges, X, u, follower=False), expected, rtol=1e-14)
    # follower on the stretched and rotated straight edge x = R (2 X)
    R = np.array([[0.0, -1.0], [1.0, 0.0]])
    x = 2 * X @ R.T
    np.testing.assert_allclose(pressure(edges, X, x - X), 2 * expected @ R.T, rtol=1e-14, atol=1e-14)


def test_circle_expanding_radially_gets_radial_forces():
    """A circular cavity (12 straight chords) mapped onto a circle of radius 1.3, midpoints
    included (curved quadratic edges): every force is radial and pushes outwards."""
    n = 12
    theta = 2 * np.pi * np.arange(n) / n + 0.1
    rng = np.random.default_rng(9)
    X, edges = numbered(np.column_stack([np.cos(theta), np.sin(theta)]), True, rng, cavity=True)
    x = 1.3 * X / np.linalg.norm(X, axis=1)[:, None]
    f = pressure(edges, X, x - X)
    assert np.all(np.abs(cross(x, f)) < 1e-14 * np.linalg.norm(x, axis=1) * np.linalg.norm(f, axis=1))
    assert np.all(np.einsum("ij,ij->i", x, f) > 0)
    vertex = np.isin(np.arange(len(X)), edges[:, [0, 2]])
    for group in (vertex, ~vertex):
        magnitude = np.linalg.norm(f[group], axis=1)
        np.testing.assert_allclose(magnitude, magnitude[0], rtol=1e-13)


# ----------------------------------------------------------------------------- load stiffness
@pytest.mark.parametrize("seed", [10, 11])
def test_stiffness_is_the_derivative_of_the_follower_forces(seed):
    rng = np.random.default_rng(seed)
    X, edges = numbered(rng.standard_normal((2, 2)), False, rng, cavity=False)
    u = 0.3 * rng.standard_normal(X.shape)
    dofs = np.stack([2 * edges[0], 2 * edges[0] + 1], axis=1).ravel()
    K = np.empty((6, 6))
    for c, dof in enumerate(dofs):
        du = np.zeros(X.size)
        du[dof] = FD_STEP
        df = pressure(edges, X, u + du.reshape(X.shape)) - pressure(edges, X, u - du.reshape(X.shape))
        K[:, c] = df.ravel()[dofs] / (2 * FD_STEP)
    np.testing.assert_allclose(el.pressure_stiffness(P), K, rtol=FD_RTOL, atol=FD_RTOL * np.abs(K).max())


def test_summed_stiffness_is_symmetric_on_closed_loops_only():
    edges, X, _ = closed_loop(12)
    assert el.forms_closed_loops(edges) and el.chain_ends(edges).size == 0
    K = assembled_stiffness(edges, len(X))
    np.testing.assert_allclose(K, K.T, atol=1e-14)
    # two disjoint loops
    edges2, _, _ = closed_loop(13)
    assert el.forms_closed_loops(np.vstack([edges, edges2 + len(X)]))

    chain, Xc, _ = open_chain(14)
    assert not el.forms_closed_loops(chain)
    start, end = chain[0, 0], chain[-1, 2]
    np.testing.assert_array_equal(el.chain_ends(chain), np.sort([start, end]))
    K = assembled_stiffness(chain, len(Xc))
    skew = (K - K.T) / 2
    expected = np.zeros_like(K)
    expected[2 * start:2 * start + 2, 2 * start:2 * start + 2] = P / 2 * Q
    expected[2 * end:2 * end + 2, 2 * end:2 * end + 2] = -P / 2 * Q
    np.testing.assert_allclose(skew, expected, atol=1e-14)
    # a roller (one component constrained) at each end makes the rest symmetric
    free = np.setdiff1d(np.arange(K.shape[0]), [2 * start, 2 * end + 1])
    np.testing.assert_allclose(K[np.ix_(free, free)], K[np.ix_(free, free)].T, atol=1e-14)

    # one edge turned round: the loop is no longer consistently oriented
    flipped = edges.copy()
    flipped[0] = flipped[0, ::-1]
    assert not el.forms_closed_loops(flipped) and el.chain_ends(flipped).size == 2
    # a figure eight through a shared vertex: not loops in the sense above, but balanced
    eight = np.array([[0, 1, 2], [2, 3, 4], [4, 5, 0], [0, 6, 7], [7, 8, 9], [9, 10, 0]])
    assert not el.forms_closed_loops(eight) and el.chain_ends(eight).size == 0
    K = assembled_stiffness(eight, 11)
    np.testing.assert_allclose(K, K.T, atol=1e-14)


# ----------------------------------------------------------------------------- work conjugates
def shoelace(points):
    return 0.5 * np.sum(cross(points, np.roll(points, -1, axis=0)))


def sampled_curve(edges, x, n):
    """n points per edge of the deformed quadratic chain, in loop order (start vertices included)."""
    N, _ = shapes(-1 + 2 * np.arange(n) / n)
    return np.einsum("qk,ekj->eqj", N, x[edges]).reshape(-1, 2)


@pytest.mark.parametrize("cavity", [True, False])
def test_swept_area_is_the_area_change_of_a_closed_loop(cavity):
    """Cavity: the growth of the hole; outer boundary: the loss of area of the body."""
    edges, X, u = closed_loop(15, cavity)
    grows = 1.0 if cavity else -1.0
    A0 = abs(shoelace(X[edges[:, 0]]))
    A = {n: abs(shoelace(sampled_curve(edges, X + u, n))) for n in (100, 200)}
    swept = el.swept_area(edges, X, u)
    error = {n: grows * (A[n] - A0) - swept for n in A}
    assert abs(error[100] / error[200] - 4.0) < 1e-4            # O(1/n²), nothing else
    assert abs(error[200]) < 1e-4 * abs(swept)
    assert abs(grows * ((4 * A[200] - A[100]) / 3 - A0) - swept) < 1e-13


def swept_area_gradient(edges, X, u):
    g = np.empty(X.size)
    for dof in range(X.size):
        du = np.zeros(X.size)
        du[dof] = FD_STEP
        du = du.reshape(X.shape)
        g[dof] = (el.swept_area(edges, X, u + du) - el.swept_area(edges, X, u - du)) / (2 * FD_STEP)
    return g.reshape(X.shape)


def test_virtual_work_of_the_swept_area_closed_loop():
    """∂A/∂u = follower pressure forces for p = 1."""
    edges, X, u = closed_loop(16)
    f = pressure(edges, X, u, p=1.0)
    np.testing.assert_allclose(swept_area_gradient(edges, X, u), f, rtol=FD_RTOL, atol=FD_RTOL * np.abs(f).max())


def test_virtual_work_of_the_swept_area_open_chain():
    """∂A/∂u = forces for p = 1 plus ½ (-u_y, u_x) at the start and ½ (u_y, -u_x) at the end,
    which vanish where the chain ends are fixed."""
    edges, X, u = open_chain(17)
    start, end = edges[0, 0], edges[-1, 2]
    expected = pressure(edges, X, u, p=1.0)
    expected[start] += 0.5 * np.array([-u[start, 1], u[start, 0]])
    expected[end] += 0.5 * np.array([u[end, 1], -u[end, 0]])
    atol = FD_RTOL * np.abs(expected).max()
    np.testing.assert_allclose(swept_area_gradient(edges, X, u), expected, rtol=FD_RTOL, atol=atol)
    u[[start, end]] = 0.0
    np.testing.assert_allclose(swept_area_gradient(edges, X, u), pressure(edges, X, u, p=1.0),
                               rtol=FD_RTOL, atol=atol)


def test_dead_load_conjugates_by_simpson():
    """∫ t·u dS and ∫ u·(-N) dS of a quadratic u along straight edges: Simpson's rule is exact."""
    edges, X, u = open_chain(18)
    d = X[edges[:, 2]] - X[edges[:, 0]]
    L = np.linalg.norm(d, axis=1)
    normal = np.column_stack([d[:, 1], -d[:, 0]]) / L[:, None]
    mean_u = np.einsum("k,ekj->ej", [1 / 6, 2 / 3, 1 / 6], u[edges]) * L[:, None]     # ∫ u dS per edge
    t = np.array([-0.4, 0.9])
    np.testing.assert_allclose(el.traction_work(edges, X, u, t), (mean_u @ t).sum(), rtol=1e-13)
    np.testing.assert_allclose(el.traction_magnitude(edges, X, t), np.linalg.norm(t) * L.sum(), rtol=1e-14)
    np.testing.assert_allclose(el.dead_pressure_conjugate(edges, X, u), -np.sum(mean_u * normal), rtol=1e-13)
    # a uniform displacement: the mean displacement along t is its component along t
    w = np.array([0.2, 0.5])
    mean = el.traction_work(edges, X, np.tile(w, (len(X), 1)), t) / el.traction_magnitude(edges, X, t)
    np.testing.assert_allclose(mean, w @ t / np.linalg.norm(t), rtol=1e-13)


# ----------------------------------------------------------------------------- bad input
def test_bad_input_is_named():
    X = np.array([[0.0, 0.0], [0.5, 0.0], [1.0, 0.0], [0.5, 0.3]])
    u = np.zeros_like(X)
    f = np.zeros_like(X)
    with pytest.raises(ValueError, match=r"edge 1 \[2, 1, 7\] has a node outside X"):
        el.pressure_forces([[0, 1, 2], [2, 1, 7]], X, u, 1.0, True, f)
    with pytest.raises(ValueError, match=r"edge 0 \[0, 3, 2\] has its midpoint node"):
        el.swept_area([[0, 3, 2]], X, u)
    with pytest.raises(ValueError, match=r"edge 0 \[0, 1, 0\] has zero length"):
        el.dead_traction_forces([[0, 1, 0]], X, [1.0, 0.0], f)
    with pytest.raises(ValueError, match="edges must be an integer array"):
        el.swept_area([[0.0, 1.0, 2.0]], X, u)
    with pytest.raises(ValueError, match=r"traction t must have shape \(2,\) or \(1, 2\)"):
        el.dead_traction_forces([[0, 1, 2]], X, [1.0, 0.0, 0.0], f)
    with pytest.raises(ValueError, match=r"u must have shape \(4, 2\)"):
        el.pressure_forces([[0, 1, 2]], X, u[:3], 1.0, True, f)
    with pytest.raises(ValueError, match="f must be a C-contiguous float64"):
        el.pressure_forces([[0, 1, 2]], X, u, 1.0, True, np.zeros((4, 2), dtype=np.float32))
