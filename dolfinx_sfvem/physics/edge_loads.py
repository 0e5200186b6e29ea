"""Loads on boundary edges with quadratic traces: nodal forces, load stiffness, work conjugates.

A boundary edge is a straight reference segment with three nodes [a, m, b] (vertex, midpoint,
vertex), ordered so that the body lies on the LEFT of a → b; its outward unit normal is
N = (ΔY, -ΔX)/L with Δ = X_b - X_a and L = |Δ|. The displacement on the edge is the quadratic
through its three nodes (the SFVEM trace and the P2 trace alike):

    x(ξ) = Σ_k N_k(ξ) (X_k + u_k),   ξ ∈ [-1, 1],
    N_a = ξ(ξ - 1)/2,   N_m = 1 - ξ²,   N_b = ξ(ξ + 1)/2.

With y_ξ × e_z = (y_ξ,y, -y_ξ,x) (for y = X: N L/2, the outward normal times the length
element):

- dead traction t per unit reference length:  f_k = ∫ N_k t |X_ξ| dξ;
- pressure p (p > 0 pushes INTO the body):      f_k = -p ∫ N_k (x_ξ × e_z) dξ  (follower),
                                                f_k = -p ∫ N_k (X_ξ × e_z) dξ  (dead);
- the follower force is linear in x, so its load stiffness ∂f/∂u is one constant 6 × 6 matrix
  -p M ⊗ Q with M_kl = ∫ N_k N_l' dξ and Q = [[0, 1], [-1, 0]] (:func:`pressure_stiffness`).

Every integrand is a polynomial of degree at most 3 in ξ (dead traction 2, pressure force 3,
stiffness 3, swept area 3), so the 2-point Gauss–Legendre rule (exact to degree 3) integrates
all of them exactly; one point (exact to degree 1) would not. Work conjugates
(:func:`traction_work`, :func:`swept_area`, :func:`dead_pressure_conjugate`) are sums over the
given edges, hence additive over disjoint edge sets (sum them over MPI ranks). docs/guide/loads.md
"Loads on boundary edges" has the derivations.

Arrays are node-major: ``X``, ``u`` and ``f`` are (n_nodes, 2), ``f[k, i]`` is component i of
node k; edge matrices are ordered (a,x), (a,y), (m,x), (m,y), (b,x), (b,y).
"""
from __future__ import annotations

import numba
import numpy as np
import numpy.typing as npt

#: 2-point Gauss–Legendre rule on [-1, 1], exact for degree 3: ξ_q = ±1/√3, w_q = 1
XI_Q, W_Q = np.polynomial.legendre.leggauss(2)


def shape_functions(xi: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """N_k(ξ) and N_k'(ξ) of the nodes [a, m, b] at the points ``xi`` (n,): two (n, 3) arrays."""
    xi = np.asarray(xi, dtype=np.float64)[:, None]
    N = np.hstack([xi * (xi - 1) / 2, 1 - xi ** 2, xi * (xi + 1) / 2])
    dN = np.hstack([xi - 0.5, -2 * xi, xi + 0.5])
    return N, dN


#: shape functions and their ξ-derivatives at the Gauss points, (2, 3)
N_Q, DN_Q = shape_functions(XI_Q)

#: relative distance of a midpoint node from the middle of its edge above which the edge is
#: rejected (the formulas assume straight reference edges with X_m at the middle)
MIDPOINT_TOLERANCE = 1e-10


# ----------------------------------------------------------------------------- compiled loops
@numba.njit(cache=True)
def _add_edge_forces(f, edge, g):
    """f[edge[k]] += Σ_q w_q N_k(ξ_q) g[q] for the three nodes k of one edge; g (n_q, 2)."""
    for q in range(W_Q.size):
        for k in range(3):
            c = W_Q[q] * N_Q[q, k]
            f[edge[k], 0] += c * g[q, 0]
            f[edge[k], 1] += c * g[q, 1]


@numba.njit(cache=True)
def _dead_traction_loop(edges, X, t, f):
    """f_k += ∫ N_k t_e |X_ξ| dξ with |X_ξ| = L_e/2 (straight edge); t (n_e, 2)."""
    g = np.empty((W_Q.size, 2))
    for e in range(edges.shape[0]):
        a, b = edges[e, 0], edges[e, 2]
        jacobian = 0.5 * np.hypot(X[b, 0] - X[a, 0], X[b, 1] - X[a, 1])
        for q in range(W_Q.size):
            g[q, 0] = t[e, 0] * jacobian
            g[q, 1] = t[e, 1] * jacobian
        _add_edge_forces(f, edges[e], g)


@numba.njit(cache=True)
def _pressure_loop(edges, X, u, p, follower, f):
    """f_k += -p ∫ N_k (y_ξ × e_z) dξ with y = X + u (follower) or y = X (dead)."""
    s = 1.0 if follower else 0.0
    g = np.empty((W_Q.size, 2))
    for e in range(edges.shape[0]):
        for q in range(W_Q.size):
            y_xi_0 = 0.0
            y_xi_1 = 0.0
            for k in range(3):
                n = edges[e, k]
                y_xi_0 += DN_Q[q, k] * (X[n, 0] + s * u[n, 0])
                y_xi_1 += DN_Q[q, k] * (X[n, 1] + s * u[n, 1])
            g[q, 0] = -p * y_xi_1
            g[q, 1] = p * y_xi_0
        _add_edge_forces(f, edges[e], g)


@numba.njit(cache=True)
def _swept_area_loop(edges, X, u):
    """Σ_e ½ [X_b × x_b - ∫ x × x_ξ dξ] in coordinates relative to X_a of each edge."""
    area = 0.0
    x = np.empty((3, 2))
    for e in range(edges.shape[0]):
        a, b = edges[e, 0], edges[e, 2]
        for k in range(3):
            n = edges[e, k]
            x[k, 0] = X[n, 0] + u[n, 0] - X[a, 0]
            x[k, 1] = X[n, 1] + u[n, 1] - X[a, 1]
        s = (X[b, 0] - X[a, 0]) * x[2, 1] - (X[b, 1] - X[a, 1]) * x[2, 0]
        for q in range(W_Q.size):
            x0 = N_Q[q, 0] * x[0, 0] + N_Q[q, 1] * x[1, 0] + N_Q[q, 2] * x[2, 0]
            x1 = N_Q[q, 0] * x[0, 1] + N_Q[q, 1] * x[1, 1] + N_Q[q, 2] * x[2, 1]
            x_xi_0 = DN_Q[q, 0] * x[0, 0] + DN_Q[q, 1] * x[1, 0] + DN_Q[q, 2] * x[2, 0]
            x_xi_1 = DN_Q[q, 0] * x[0, 1] + DN_Q[q, 1] * x[1, 1] + DN_Q[q, 2] * x[2, 1]
            s -= W_Q[q] * (x0 * x_xi_1 - x1 * x_xi_0)
        area += 0.5 * s
    return area


# ----------------------------------------------------------------------------- input checks
def _nodal_array(name: str, a: npt.ArrayLike, n_nodes: int) -> np.ndarray:
    a = np.asarray(a)
    if a.shape != (n_nodes, 2):
        raise ValueError(f"{name} must have shape ({n_nodes}, 2) like X, got {a.shape}")
    return a


def check_edges(edges: npt.ArrayLike, X: npt.ArrayLike) -> np.ndarray:
    """``edges`` as a contiguous (n_e, 3) int64 array after checking it against ``X``.

    Raises
    ------
    ValueError
        Naming the first offending edge: wrong shape, node index outside ``X`` (n_nodes, 2),
        zero length, or a midpoint node off the middle of its (straight) reference edge by more
        than :data:`MIDPOINT_TOLERANCE` times the edge length.
    """
    X = np.asarray(X, dtype=np.float64)
    if X.ndim != 2 or X.shape[1] != 2:
        raise ValueError(f"X must have shape (n_nodes, 2), got {X.shape}")
    edges = np.asarray(edges)
    if edges.ndim != 2 or edges.shape[1] != 3 or not np.issubdtype(edges.dtype, np.integer):
        raise ValueError(f"edges must be an integer array of shape (n_edges, 3) [a, m, b], got "
                         f"{edges.dtype} {edges.shape}")
    edges = np.ascontiguousarray(edges, dtype=np.int64)
    outside = np.flatnonzero(((edges < 0) | (edges >= X.shape[0])).any(axis=1))
    if outside.size:
        e = outside[0]
        raise ValueError(f"edge {e} {edges[e].tolist()} has a node outside X ({X.shape[0]} nodes)")
    Xa, Xm, Xb = X[edges[:, 0]], X[edges[:, 1]], X[edges[:, 2]]
    L = np.linalg.norm(Xb - Xa, axis=1)
    off_middle = np.linalg.norm(Xm - (Xa + Xb) / 2, axis=1)
    bad = np.flatnonzero(~(L > 0) | (off_middle > MIDPOINT_TOLERANCE * L))
    if bad.size:
        e = bad[0]
        why = "has zero length" if not L[e] > 0 else \
            f"has its midpoint node {off_middle[e] / L[e]:.3g} edge lengths off the middle"
        raise ValueError(f"edge {e} {edges[e].tolist()} {why}")
    return edges


def edge_lengths(edges: npt.ArrayLike, X: npt.ArrayLike) -> np.ndarray:
    """Reference lengths L_e = |X_b - X_a| of the edges, (n_e,)."""
    edges = check_edges(edges, X)
    X = np.asarray(X, dtype=np.float64)
    return np.linalg.norm(X[edges[:, 2]] - X[edges[:, 0]], axis=1)


def _edge_tractions(t: npt.ArrayLike, n_edges: int) -> np.ndarray:
    t = np.asarray(t, dtype=np.float64)
    if t.shape not in ((2,), (n_edges, 2)):
        raise ValueError(f"traction t must have shape (2,) or ({n_edges}, 2) (one per edge), got {t.shape}")
    return np.ascontiguousarray(np.broadcast_to(t, (n_edges, 2)))


def _force_array(f: np.ndarray, n_nodes: int) -> np.ndarray:
    if not (isinstance(f, np.ndarray) and f.dtype == np.float64 and f.flags.c_contiguous):
        raise ValueError("f must be a C-contiguous float64 numpy array (added to in place)")
    return _nodal_array("f", f, n_nodes)


# ----------------------------------------------------------------------------- nodal forces
def dead_traction_forces(edges: npt.ArrayLike, X: npt.ArrayLike, t: npt.ArrayLike, f: np.ndarray) -> None:
    """Add the nodal forces of a dead traction per unit reference length: f_k += ∫ N_k t |X_ξ| dξ.

    On a straight edge of length L: t L (1/6, 2/3, 1/6) at (a, m, b).

    Parameters
    ----------
    edges : (n_e, 3) int
        Nodes [a, m, b] of every edge (module docstring).
    X : (n_nodes, 2)
        Reference coordinates.
    t : (2,) or (n_e, 2)
        Traction [force / length], constant or one per edge.
    f : (n_nodes, 2) float64
        Nodal forces, added to in place.
    """
    edges = check_edges(edges, X)
    X = np.asarray(X, dtype=np.float64)
    _dead_traction_loop(edges, X, _edge_tractions(t, edges.shape[0]), _force_array(f, X.shape[0]))


def pressure_forces(edges: npt.ArrayLike, X: npt.ArrayLike, u: npt.ArrayLike, p: float, follower: bool,
                    f: np.ndarray) -> None:
    """Add the nodal forces of a uniform pressure p: f_k += -p ∫ N_k (y_ξ × e_z) dξ.

    y = X + u for a follower pressure (direction and length of the deformed edge), y = X for
    a dead pressure on the reference normal (``u`` is then not read). p > 0 pushes into the
    body (against the outward normal). On a straight edge of deformed length ℓ and outward
    normal n: -p n ℓ (1/6, 2/3, 1/6) at (a, m, b).

    Parameters
    ----------
    edges : (n_e, 3) int
        Nodes [a, m, b] of every edge, body on the left of a → b.
    X, u : (n_nodes, 2)
        Reference coordinates and displacements.
    p : float
        Pressure [force / length].
    follower : bool
        Follower (True) or dead (False) pressure.
    f : (n_nodes, 2) float64
        Nodal forces, added to in place.
    """
    edges = check_edges(edges, X)
    X = np.asarray(X, dtype=np.float64)
    u = np.asarray(_nodal_array("u", u, X.shape[0]), dtype=np.float64)
    _pressure_loop(edges, X, u, float(p), bool(follower), _force_array(f, X.shape[0]))


def pressure_stiffness(p: float) -> np.ndarray:
    """∂f/∂u of the follower pressure forces of one edge, (6, 6): the same for every edge and state.

    ``K[2k + i, 2l + j] = ∂f_ki/∂u_lj = -p M_kl Q_ij`` with M_kl = ∫ N_k N_l' dξ (2-point Gauss,
    exact) and Q = [[0, 1], [-1, 0]]; rows and columns ordered (a,x), (a,y), (m,x), (m,y),
    (b,x), (b,y). This is the derivative of the EXTERNAL force: a residual R = f_int - λ f_ext
    has the tangent K_int - λ K. It does not depend on X or u because the force is linear in
    x = X + u. M + Mᵀ = diag(-1, 0, 1), so the edge matrix is symmetric except for the
    antisymmetric blocks (p/2) Q at a and -(p/2) Q at b, which cancel where one edge ends and
    the next starts: the sum over edges is symmetric iff :func:`chain_ends` is empty.
    The dead pressure has no load stiffness.
    """
    M = np.einsum("q,qk,ql->kl", W_Q, N_Q, DN_Q)
    return -float(p) * np.kron(M, np.array([[0.0, 1.0], [-1.0, 0.0]]))


# ----------------------------------------------------------------------------- work conjugates
def traction_work(edges: npt.ArrayLike, X: npt.ArrayLike, u: npt.ArrayLike, t: npt.ArrayLike) -> float:
    """∫ t · u dS over the reference edges = Σ_k f_k · u_k with f of :func:`dead_traction_forces`.

    The work of the traction; divided by :func:`traction_magnitude` it is the mean
    displacement along t over the loaded length, the traction's work-conjugate displacement
    (sum numerator and denominator over MPI ranks before dividing).
    """
    X = np.asarray(X, dtype=np.float64)
    f = np.zeros_like(X)
    dead_traction_forces(edges, X, t, f)
    return float(np.vdot(f, _nodal_array("u", u, X.shape[0])))


def traction_magnitude(edges: npt.ArrayLike, X: npt.ArrayLike, t: npt.ArrayLike) -> float:
    """∫ |t| dS over the reference edges: |t| L_total for a constant traction t (2,) or (n_e, 2)."""
    L = edge_lengths(edges, X)
    return float(np.linalg.norm(_edge_tractions(t, L.size), axis=1) @ L)


def swept_area(edges: npt.ArrayLike, X: npt.ArrayLike, u: npt.ArrayLike) -> float:
    """Area swept by the edges against their outward normal: the follower pressure's work conjugate.

    Per edge, the signed area (Green: ½∮ x × dx) of the loop X_a → X_b (reference edge),
    X_b → x_b (straight), x_b → x_a (deformed quadratic), x_a → X_a (straight):

        A_e = ½ [X_a × X_b + X_b × x_b - ∫ x × x_ξ dξ + x_a × X_a],

    positive when the edge moves into the body. The straight pieces at a vertex shared by two
    consecutive edges cancel, so over a closed loop the sum is minus the change of the loop's
    signed area (body on the left): the area change of a cavity, the loss of area of a body
    bounded by the loop. Its derivative is the follower force for p = 1, plus ½ (u_a × δu_a -
    u_b × δu_b) at the start a and end b of an open chain, which vanishes where the end is
    fixed or slides along its own displacement (a roller through its reference position).

    Parameters
    ----------
    edges : (n_e, 3) int
    X, u : (n_nodes, 2)

    Returns
    -------
    float
        Σ_e A_e [length²], additive over edge sets.
    """
    edges = check_edges(edges, X)
    X = np.asarray(X, dtype=np.float64)
    u = np.asarray(_nodal_array("u", u, X.shape[0]), dtype=np.float64)
    return float(_swept_area_loop(edges, X, u))


def dead_pressure_conjugate(edges: npt.ArrayLike, X: npt.ArrayLike, u: npt.ArrayLike) -> float:
    """∫ u · (-N) dS over the reference edges: the dead pressure's work conjugate (work = p × it).

    Equal to Σ_k f_k · u_k with f the dead pressure forces for p = 1 (:func:`pressure_forces`).
    """
    X = np.asarray(X, dtype=np.float64)
    f = np.zeros_like(X)
    pressure_forces(edges, X, np.zeros_like(X), 1.0, False, f)
    return float(np.vdot(f, _nodal_array("u", u, X.shape[0])))


# ----------------------------------------------------------------------------- topology
def _vertex_counts(edges: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """How many edges start and end at every node: two (max node + 1,) arrays."""
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 3)
    n = int(edges.max(initial=-1)) + 1
    return np.bincount(edges[:, 0], minlength=n), np.bincount(edges[:, 2], minlength=n)


def chain_ends(edges: npt.ArrayLike) -> np.ndarray:
    """Vertex nodes that start a different number of edges than they end, sorted (n,) int64.

    These are the ends of open chains (and the vertices where the orientation flips); the
    follower pressure stiffness summed over the edges is symmetric iff there are none, or
    after elimination iff each of them has a constrained displacement component.
    """
    starts, ends = _vertex_counts(edges)
    return np.flatnonzero(starts != ends).astype(np.int64)


def forms_closed_loops(edges: npt.ArrayLike) -> bool:
    """Whether every vertex node starts exactly one edge and ends exactly one (closed loops,
    consistently oriented). Then the summed follower pressure stiffness is symmetric.

    Decide on the whole edge set: edges split over MPI ranks have open ends on each rank.
    """
    starts, ends = _vertex_counts(edges)
    vertices = (starts > 0) | (ends > 0)
    return bool(np.all(starts[vertices] == 1) and np.all(ends[vertices] == 1))
