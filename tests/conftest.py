"""Fixtures shared by several test modules: pytest hands them to any test that names them as an
argument, so test modules never import each other. Most are helpers (a function or class)
returned as they are; ``polygon`` and ``tabulated_name`` run a test once per test polygon.

- Test polygons and reference maths for the projections (test_projection, test_elasticity,
  test_local_refinement): ``polygons``, ``polygon``, ``zero_eigenvalue_table`` (docs/method.md §3),
  ``tabulated_name``, ``as_csr``, ``build_one``, ``polygon_moments`` (Green's formulas),
  ``Quadratic``, ``monomials_at``, ``check_patch``, ``zero_eigenvalues``, ``square_with_hanging_nodes``.
- ``two_blocks``: two blocks across a medium layer (test_local_refinement, test_adaptive).
- ``manufactured``: the manufactured small-strain solution (test_convergence, test_fem).
- ``two_region_materials``, ``nodal_field``, ``state_of``, ``direction_of``: a solid and a medium
  region and states of a discretization (test_fem, test_discretization).
- ``block``: a block on one rank (test_solver, test_run_summary).
- ``summary_content``, ``write_summary``: summary.json files (test_results, test_refinement_page).
- PolygonMesh builders and checks (test_polygon_mesh, test_polygon_mesh_fuzz): ``square_grid``,
  ``hanging_mesh``, ``glue``, ``shoelace``, ``assert_valid_mesh``, ``assert_valid_triangulation``,
  ``assert_deepest_diagonal``, ``nonconvex`` (polygons to triangulate).
- ``box_grid``: structured 3D grids of hexahedra or tetrahedra as the arrays of a ``CellMesh``
  (test_solid_surface, test_pictures3d).
- ``medium_by_hand``: a medium, a field whose J varies and its Psi by hand, states and tangents
  (test_fem_only_medium_rules, test_lobatto_medium, test_reduced_medium).
"""
import json
import pathlib
import typing

import numpy as np
import pytest
import ufl
from matplotlib.path import Path
from mpi4py import MPI
from scipy.spatial import ConvexHull

import dolfinx_sfvem as sf
from dolfinx_sfvem.discretizations.monomials import evaluate_monomials, n_monomials
from dolfinx_sfvem.discretizations.projection import build_projections


def shared(helper, name: str | None = None):
    """A session fixture named ``name`` (default: the helper's own name) that returns ``helper``
    (a function or class): how test modules share a helper without importing each other."""
    return pytest.fixture(scope="session", name=name or helper.__name__)(lambda: helper)


# =========================================================================== test polygons
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


def zero_eigenvalues(K: np.ndarray) -> int:
    """Eigenvalues below 1e-10 lambda_max (round-off sits near 1e-16, the smallest genuine ones
    of the test polygons above 1e-5)."""
    eigenvalues = np.linalg.eigvalsh(K)
    return int(np.sum(eigenvalues < 1e-10 * eigenvalues[-1]))


@pytest.fixture(scope="session")
def polygons() -> dict[str, np.ndarray]:
    """The test polygons by name: counter-clockwise vertices (n, 2)."""
    return POLYGONS


@pytest.fixture(params=list(POLYGONS))
def polygon(request) -> np.ndarray:
    """Each test polygon in turn (the test id is its name): counter-clockwise vertices (n, 2)."""
    return POLYGONS[request.param]


@pytest.fixture(scope="session")
def zero_eigenvalue_table() -> dict[str, list[int]]:
    """docs/method.md §3: polygon name -> zero eigenvalues of the linear-elastic element for l = 2..6."""
    return ZERO_EIGENVALUES


@pytest.fixture(params=list(ZERO_EIGENVALUES))
def tabulated_name(request) -> str:
    """Each polygon of the zero-eigenvalue table in turn (the test id is its name)."""
    return request.param


# =========================================================================== two blocks across a medium
class TwoBlocks:
    """Block [0, 1] x [0, 1] (tag SOLID), a medium layer [0, 1] x [1, 1.2] (MEDIUM) and block
    [0, 1] x [1.2, 2.2] (OTHER), of 4 x 4, 4 x 1 and 4 x 4 quadrilaterals; both blocks of the
    compressible neo-Hookean solid K = 5/3, mu = 5/14, the layer a third medium
    gamma = 1e-5, alpha_r = 1."""

    SOLID, MEDIUM, OTHER = 1, 2, 3
    K, MU = 5 / 3, 5 / 14

    @classmethod
    def mesh(cls) -> sf.PolygonMesh:
        return sf.meshes.glue(sf.meshes.quad_rectangle(1.0, 1.0, 4, 4, tag=cls.SOLID),
                              sf.meshes.quad_rectangle(1.0, 0.2, 4, 1, origin=(0.0, 1.0), tag=cls.MEDIUM),
                              sf.meshes.quad_rectangle(1.0, 1.0, 4, 4, origin=(0.0, 1.2), tag=cls.OTHER))

    @classmethod
    def materials(cls) -> dict:
        return {cls.SOLID: sf.Hyperelastic(K=cls.K, mu=cls.MU),
                cls.MEDIUM: sf.ThirdMedium(mu=cls.MU, gamma=1e-5, alpha_r=1.0),
                cls.OTHER: sf.Hyperelastic(K=cls.K, mu=cls.MU)}


two_blocks_fixture = shared(TwoBlocks, "two_blocks")


# =========================================================================== manufactured solution
class ManufacturedSolution:
    """Small-strain plane elasticity ψ = μ ε:ε + λ/2 (tr ε)², ε = sym(F − I) (E = 1, ν = 0.3), on
    the unit square with u = 0 on the boundary and the body force f = −div σ(u) of

        u_1 = u_2 = a sin(πx) sin(πy),   a = 0.01 (small strain: J stays near 1)

    (test_convergence for the SFVEM, test_fem for P2 and Q2)."""

    E, NU = 1.0, 0.3
    LAM, MU = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))
    AMPLITUDE = 0.01

    @staticmethod
    def small_strain(F, G, lam, mu):
        eps = ufl.sym(F - ufl.Identity(2))
        return mu * ufl.inner(eps, eps) + lam / 2 * ufl.tr(eps) ** 2

    @classmethod
    def energy(cls) -> sf.UserEnergy:
        """ψ as a user energy."""
        return sf.UserEnergy(cls.small_strain, uses_gradient=False, lam=cls.LAM, mu=cls.MU)

    @classmethod
    def u_exact(cls, x):
        s = cls.AMPLITUDE * np.sin(np.pi * x[0]) * np.sin(np.pi * x[1])
        return np.array([s, s])

    @classmethod
    def grad_exact(cls, x):
        gx = cls.AMPLITUDE * np.pi * np.cos(np.pi * x[0]) * np.sin(np.pi * x[1])
        gy = cls.AMPLITUDE * np.pi * np.sin(np.pi * x[0]) * np.cos(np.pi * x[1])
        return np.array([[gx, gy], [gx, gy]])

    @classmethod
    def body_force(cls, x):
        """f = −(μ Δu + (λ + μ) ∇ div u) for the field above."""
        s = cls.AMPLITUDE * np.sin(np.pi * x[0]) * np.sin(np.pi * x[1])
        c = cls.AMPLITUDE * np.cos(np.pi * (x[0] + x[1]))
        f = 2 * np.pi ** 2 * cls.MU * s - (cls.LAM + cls.MU) * np.pi ** 2 * c
        return np.array([f, f])

    @staticmethod
    def on_boundary(x):
        return np.isclose(x[0], 0) | np.isclose(x[0], 1) | np.isclose(x[1], 0) | np.isclose(x[1], 1)

    @staticmethod
    def rates(results) -> tuple[float, float]:
        """Convergence rates (L2, H1) fitted to rows (h, L2 error, H1 error)."""
        h, e0, e1 = np.array(results).T
        return np.polyfit(np.log(h), np.log(e0), 1)[0], np.polyfit(np.log(h), np.log(e1), 1)[0]


manufactured_fixture = shared(ManufacturedSolution, "manufactured")


# =========================================================================== states of a discretization
def two_region_materials(regularization: str = "rotation", beta: float | None = None) -> dict:
    """Region 1 a solid, region 2 a medium whose regularization is as large as its bulk part
    (test_energy's values)."""
    return {1: sf.Hyperelastic(K=2.0, mu=0.7),
            2: sf.ThirdMedium(mu=0.3, gamma=1.5, alpha_r=1.0 if beta is None else 150.0, K=0.2,
                              regularization=regularization, beta=beta)}


def nodal_field(disc, values):
    """A ghosted vector with ``values(x (n, 2), key (n,)) -> (n, 2)`` at every local node."""
    x = disc.create_vector()
    with x.localForm() as xl:
        xl.array[:] = values(disc.x_nodes, disc.node_key).ravel()
    return x


def state_of(disc):
    """A smooth finite deformation plus node-key noise (partition independent)."""
    def values(X, key):
        smooth = 0.1 * np.stack([np.sin(2 * X[:, 0] + X[:, 1]), np.cos(X[:, 0] - 2 * X[:, 1])], axis=1)
        return smooth + 0.01 * np.stack([np.sin(12.9898 * key), np.sin(78.233 * key)], axis=1)
    return nodal_field(disc, values)


def direction_of(disc):
    """A direction of node-key noise (partition independent)."""
    return nodal_field(disc, lambda X, key: np.stack([np.cos(3.7 * key), np.sin(5.3 * key + 1.0)], axis=1))


# =========================================================================== a block on one rank
class Block:
    """A 1 x 0.2 block of 5 x 2 quadrilaterals (region ``meshes.SOLID``), on one rank."""

    HEIGHT = 0.2

    @classmethod
    def mesh(cls) -> sf.PolygonMesh:
        return sf.meshes.quad_rectangle(1.0, cls.HEIGHT, 5, 2, tag=sf.meshes.SOLID)

    @classmethod
    def compressed(cls, uy: float) -> sf.ContactProblem:
        """The block of the neo-Hookean solid K = 5/3, mu = 5/14, clamped below ("bottom"), its top
        face ("top") moved by (0, uy)."""
        problem = sf.ContactProblem(cls.mesh(), {sf.meshes.SOLID: sf.Hyperelastic(K=5 / 3, mu=5 / 14)},
                                    comm=MPI.COMM_SELF, verbose=False)
        problem.fix(lambda x: np.isclose(x[1], 0.0), name="bottom")
        problem.prescribe(lambda x: np.isclose(x[1], cls.HEIGHT), ux=0.0, uy=uy, name="top")
        return problem


block_fixture = shared(Block, "block")


# =========================================================================== summary.json files
def summary_content(*, converged: bool = True, loads=(0.5, 1.0), force: float = 2.0, extra: dict | None = None,
            method: str = "vem", ranks: int = 2, uy: float = -1.0, condition: str = "load") -> dict:
    """A summary.json content with one converged step per load factor (the force grows linearly)."""
    steps = [{"step": k + 1, "load": load, "newton_iterations": 3, "converged": True,
              "reaction": {condition: [0.0, -force * load]}, "extra": dict(extra or {})}
             for k, load in enumerate(loads)]
    return {"method": method, "dofs": 1234, "ranks": ranks, "wall_time_s": 12.5, "converged": converged,
            "message": "" if converged else f"step {len(loads) + 1}: load step failed",
            "polygons": 100, "projection_order_histogram": {"3": 90, "4": 10},
            "parameters": {"method": method, "uy": uy}, "steps": steps}


def write_summary(directory: pathlib.Path, content: dict) -> None:
    directory.mkdir(parents=True, exist_ok=True)
    (directory / "summary.json").write_text(json.dumps(content))


# =========================================================================== PolygonMesh builders and checks
def shoelace(xy):
    x, y = np.asarray(xy, dtype=float).T
    return 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)


def square_grid(nx, ny, h=1.0, x0=0.0, y0=0.0):
    """Points and CCW vertex lists of an nx x ny grid of squares of side h."""
    x, y = np.meshgrid(x0 + h * np.arange(nx + 1), y0 + h * np.arange(ny + 1))
    points = np.column_stack([x.ravel(), y.ravel()])
    idx = np.arange((nx + 1) * (ny + 1)).reshape(ny + 1, nx + 1)
    polygons = [[idx[j, i], idx[j, i + 1], idx[j + 1, i + 1], idx[j + 1, i]] for j in range(ny) for i in range(nx)]
    return points, polygons


def assert_valid_triangulation(xy, triangles, interior, extra):
    """``triangles`` (into vstack(xy, extra)) form a CCW triangulation of the CCW polygon ``xy``
    in which every polygon edge is an edge of exactly one triangle, and the interior DOF point
    (midpoint of nodes interior[0], interior[1]) lies strictly inside the polygon."""
    n = len(xy)
    nodes = np.vstack([xy, extra])
    areas = np.array([shoelace(nodes[t]) for t in triangles])
    scale = np.ptp(xy, axis=0).max()
    assert np.all(areas > 1e-12 * scale**2)
    assert np.isclose(areas.sum(), shoelace(xy), rtol=1e-12)
    directed = [(t[k], t[(k + 1) % 3]) for t in triangles for k in range(3)]
    assert len(set(directed)) == len(directed)
    boundary = {(i, (i + 1) % n) for i in range(n)}
    assert boundary <= set(directed)  # each polygon edge once (directed edges are unique) ...
    assert not any((b, a) in directed for a, b in boundary)  # ... and never reversed
    for a, b in set(directed) - boundary:  # every other edge is interior: shared by two triangles
        assert (b, a) in directed
    assert len(extra) == (1 if interior[0] == interior[1] else 0)
    dof_point = 0.5 * (nodes[interior[0]] + nodes[interior[1]])
    assert Path(xy).contains_point(dof_point)
    assert min(distance_to_segment(dof_point, xy[a], xy[b]) for a, b in boundary) > 1e-9 * scale


def assert_deepest_diagonal(xy, triangles, interior):
    """The interior DOF of an ear-clipped polygon sits on the diagonal whose midpoint is deepest inside."""
    n = len(xy)
    diagonals = {tuple(sorted((t[k], t[(k + 1) % 3]))) for t in triangles for k in range(3)}
    diagonals -= {tuple(sorted((i, (i + 1) % n))) for i in range(n)}
    depth = {d: min(distance_to_segment(0.5 * (xy[d[0]] + xy[d[1]]), xy[i], xy[(i + 1) % n]) for i in range(n))
             for d in diagonals}
    assert len(diagonals) == n - 3
    assert np.isclose(depth[tuple(sorted(interior))], max(depth.values()))


def assert_valid_mesh(mesh):
    """Every polygon CCW with positive area and a valid sub-triangulation in mesh numbering."""
    assert mesh.offsets[0] == 0 and mesh.offsets[-1] == mesh.vertices.size
    assert mesh.triangle_offsets[-1] == mesh.triangles.shape[0]
    nodes = mesh.nodes
    for i in range(mesh.n_polygons):
        verts = mesh.polygon(i)
        assert len(set(verts.tolist())) == verts.size >= 3
        xy = mesh.points[verts]
        assert shoelace(xy) > 0
        local = {v: k for k, v in enumerate(verts.tolist())}
        tri = mesh.triangles[mesh.triangle_offsets[i]:mesh.triangle_offsets[i + 1]]
        fan = sorted(set(tri.ravel().tolist()) - set(local))
        assert len(fan) <= 1 and all(f >= mesh.n_points for f in fan)
        local.update({f: verts.size for f in fan})
        extra = nodes[fan]
        assert_valid_triangulation(xy, np.vectorize(local.get)(tri),
                                   [local[v] for v in mesh.interior_node[i]], extra)


def hanging_mesh(k, listed):
    """k + 1 squares of side s = 1/(k+1) on [0, 1] x [0, s] below the unit square [0, 1] x [s, 1+s],
    whose bottom side holds the k inner points of the fine row's top side; they are listed in its
    vertex list if ``listed``. Returns points, polygons (the big square last), the k points."""
    s = 1.0 / (k + 1)
    fine_points, fine = square_grid(k + 1, 1, h=s)
    n = len(fine_points)
    points = np.vstack([fine_points, [[1.0, 1.0 + s], [0.0, 1.0 + s]]])
    top = list(range(k + 2, n))  # (0, s), ..., (1, s) left to right
    big = [top[0]] + (top[1:-1] if listed else []) + [top[-1], n, n + 1]
    return points, fine + [big], top[1:-1]


def glue(*blocks):
    """Concatenate (points, polygons) blocks and merge coincident points."""
    points = np.vstack([b[0] for b in blocks])
    offsets = np.cumsum([0] + [len(b[0]) for b in blocks])
    merged, inverse = np.unique(points.round(12), axis=0, return_inverse=True)
    return merged, [[int(inverse[v + o]) for v in p] for (_, polygons), o in zip(blocks, offsets) for p in polygons]


def distance_to_segment(p, a, b):
    t = np.clip(np.dot(p - a, b - a) / np.dot(b - a, b - a), 0.0, 1.0)
    return np.hypot(*(p - a - t * (b - a)))


class NonconvexPolygons:
    """Counter-clockwise polygons (n, 2): an L (star-shaped), a comb and a spiral (not star-shaped)."""

    STAR_L = np.array([(0, 0), (2, 0), (2, .2), (.2, .2), (.2, 2), (0, 2)], dtype=float)  # kernel [0,.2]^2
    COMB = np.array([(0, 0), (5, 0), (5, 3), (4, 3), (4, 1), (3, 1), (3, 3), (2, 3), (2, 1), (1, 1), (1, 3), (0, 3)],
                    dtype=float)  # empty kernel
    SPIRAL = np.array([(0, 0), (4, 0), (4, 4), (1, 4), (1, 2), (2, 2), (2, 3), (3, 3), (3, 1), (0, 1)], dtype=float)


class CellArrays(typing.NamedTuple):
    """The fields of a 3D mesh the contact geometry and the pictures read (a stand-in of ``CellMesh``)."""
    points: np.ndarray
    cells: np.ndarray
    tags: np.ndarray
    cell_type: str


def box_grid(xs, ys, zs, tag=lambda centre: 1, cell_type="hexahedron") -> CellArrays:
    """A structured grid of the box with grid lines ``xs``, ``ys``, ``zs``: hexahedra in DOLFINx's
    vertex order, or each split into six tetrahedra about its diagonal (conforming); ``tag(centre)``
    gives the tag of a cell from its centre (3,)."""
    xs, ys, zs = (np.asarray(v, dtype=float) for v in (xs, ys, zs))
    nx, ny = xs.size, ys.size
    points = np.stack(np.meshgrid(xs, ys, zs, indexing="ij"), axis=-1).transpose(2, 1, 0, 3).reshape(-1, 3)
    i, j, k = (a.ravel() for a in np.meshgrid(np.arange(xs.size - 1), np.arange(ys.size - 1), np.arange(zs.size - 1),
                                               indexing="ij"))
    corner = i + nx * j + nx * ny * k
    hexes = np.stack([corner + di + nx * dj + nx * ny * dk for dk in (0, 1) for dj in (0, 1) for di in (0, 1)], axis=1)
    tags = np.array([tag(c) for c in points[hexes].mean(axis=1)], dtype=np.int64)
    if cell_type == "hexahedron":
        return CellArrays(points, hexes, tags, cell_type)
    kuhn = np.array([[0, 1, 3, 7], [0, 1, 5, 7], [0, 4, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 6, 7]])
    return CellArrays(points, hexes[:, kuhn].reshape(-1, 4), np.repeat(tags, 6), "tetrahedron")


nonconvex_fixture = shared(NonconvexPolygons, "nonconvex")


# =========================================================================== the helpers as fixtures
# one session fixture per shared helper, named like it (pytest collects the fixtures it finds among
# the module's names)
for _helper in (square_with_hanging_nodes, Quadratic, as_csr, build_one, polygon_moments, monomials_at, check_patch,
                zero_eigenvalues,
                two_region_materials, nodal_field, state_of, direction_of,
                summary_content, write_summary,
                shoelace, square_grid, assert_valid_triangulation, assert_deepest_diagonal, assert_valid_mesh,
                hanging_mesh, glue, box_grid):
    globals()[f"{_helper.__name__}_fixture"] = shared(_helper)


# =========================================================================== tiny 3D meshes
class Tiny3D:
    """Tiny 3D meshes with exact answers (test_cell_mesh, test_fem3d, test_problem3d, test_loads3d)."""

    #: the unit cube's corners in DOLFINx's hexahedron order (x fastest)
    CUBE = np.array([(x, y, z) for z in (0.0, 1.0) for y in (0.0, 1.0) for x in (0.0, 1.0)])

    @staticmethod
    def kuhn_tets() -> np.ndarray:
        """The unit cube as 6 tetrahedra around its diagonal (0,0,0)-(1,1,1) (3 of them
        left-handed), indices into :attr:`CUBE`."""
        import itertools
        tets = []
        for perm in itertools.permutations(range(3)):
            path = [np.zeros(3)]
            for axis in perm:
                path.append(path[-1] + np.eye(3)[axis])
            tets.append([int(np.flatnonzero((Tiny3D.CUBE == p).all(axis=1))[0]) for p in path])
        return np.array(tets)

    @staticmethod
    def hex_grid(n, lengths=(1.0, 1.0, 1.0)) -> tuple[np.ndarray, np.ndarray]:
        """(points, cells) of n[0] x n[1] x n[2] hexahedra (n an int: n x n x n) of the box
        [0, lengths], DOLFINx's vertex order."""
        n = (n, n, n) if np.isscalar(n) else tuple(n)
        axes = [np.linspace(0.0, length, k + 1) for length, k in zip(lengths, n)]
        points = np.array([(x, y, z) for z in axes[2] for y in axes[1] for x in axes[0]])

        def index(i, j, k):
            return (k * (n[1] + 1) + j) * (n[0] + 1) + i
        cells = [[index(i + a, j + b, k + c) for c in (0, 1) for b in (0, 1) for a in (0, 1)]
                 for k in range(n[2]) for j in range(n[1]) for i in range(n[0])]
        return points, np.array(cells)


tiny3d_fixture = shared(Tiny3D, "tiny3d")


# =========================================================================== test polyhedra
def refined_cube(refined: tuple[int, ...]) -> tuple[np.ndarray, list[np.ndarray]]:
    """The unit cube as an octree cell next to refined neighbours: each face listed in ``refined``
    (0..5 = -x, +x, -y, +y, -z, +z) is split into 4 quadrilaterals, and every cube edge of a split
    face carries its midpoint as a hanging vertex in the other face too. Faces outward."""
    index: dict[tuple, int] = {}

    def vertex(x) -> int:
        return index.setdefault(tuple(np.round(x, 12)), len(index))

    faces = []
    for k in range(3):
        for side in (0, 1):
            a, b = ((k + 1) % 3, (k + 2) % 3) if side == 1 else ((k + 2) % 3, (k + 1) % 3)  # (e_a x e_b) . n > 0

            def point(u, v):
                x = np.zeros(3)
                x[k], x[a], x[b] = side, u, v
                return vertex(x)

            if 2 * k + side in refined:
                for u0, v0 in ((0, 0), (0.5, 0), (0.5, 0.5), (0, 0.5)):
                    faces.append(np.array([point(u0, v0), point(u0 + 0.5, v0), point(u0 + 0.5, v0 + 0.5),
                                           point(u0, v0 + 0.5)]))
                continue
            # a cube edge is split when the face across it is refined
            split = {(0.5, 0): 2 * b + 0 in refined, (1, 0.5): 2 * a + 1 in refined,
                     (0.5, 1): 2 * b + 1 in refined, (0, 0.5): 2 * a + 0 in refined}
            loop = []
            for corner, middle in (((0, 0), (0.5, 0)), ((1, 0), (1, 0.5)), ((1, 1), (0.5, 1)), ((0, 1), (0, 0.5))):
                loop.append(point(*corner))
                if split[middle]:
                    loop.append(point(*middle))
            faces.append(np.array(loop))
    points = np.array(sorted(index, key=index.get), dtype=float)
    return points, faces


refined_cube_fixture = shared(refined_cube)


def prism(polygon: np.ndarray, height: float = 1.0) -> tuple[np.ndarray, list[np.ndarray]]:
    """The prism over a counter-clockwise polygon (N, 2), from z = 0 to z = height."""
    N = len(polygon)
    points = np.vstack([np.column_stack([polygon, np.zeros(N)]), np.column_stack([polygon, np.full(N, height)])])
    faces = [np.arange(N)[::-1], np.arange(N, 2 * N)]
    faces += [np.array([i, (i + 1) % N, N + (i + 1) % N, N + i]) for i in range(N)]
    return points, faces


def convex_polyhedron(cloud: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
    """The convex hull of a point cloud as a polyhedron: coplanar hull triangles merged into one
    face, its vertices ordered counter-clockwise about the outward normal."""
    hull = ConvexHull(cloud)
    keep = np.unique(hull.simplices)
    renumber = np.full(len(cloud), -1)
    renumber[keep] = np.arange(keep.size)
    points = cloud[keep]
    planes: dict[tuple, set] = {}
    for simplex, equation in zip(renumber[hull.simplices], hull.equations):
        planes.setdefault(tuple(np.round(equation, 9)), set()).update(simplex.tolist())
    faces = []
    for equation, members in planes.items():
        normal, members = np.array(equation[:3]), np.array(sorted(members))
        centre = points[members].mean(axis=0)
        t1 = points[members[0]] - centre
        t2 = np.cross(normal, t1)
        angle = np.arctan2((points[members] - centre) @ t2, (points[members] - centre) @ t1)
        faces.append(members[np.argsort(angle)])
    return points, faces


def _truncated_octahedron() -> tuple[np.ndarray, list[np.ndarray]]:
    """The Voronoi cell of the body-centred cubic lattice: 6 squares and 8 regular hexagons."""
    import itertools
    cloud = {p for signs in itertools.product((-1, 1), repeat=2) for p in
             itertools.permutations((0.0, signs[0] * 1.0, signs[1] * 2.0))}
    return convex_polyhedron(np.array(sorted(cloud)))


def _dented_cube() -> tuple[np.ndarray, list[np.ndarray]]:
    """The unit cube whose top is four triangles meeting at (0.5, 0.5, 0.6): non-convex, star-shaped."""
    points, faces = refined_cube(())
    points = np.vstack([points, [0.5, 0.5, 0.6]])
    top = next(f for f in faces if np.all(points[f, 2] == 1.0))
    faces = [f for f in faces if f is not top]
    faces += [np.array([top[i], top[(i + 1) % 4], len(points) - 1]) for i in range(4)]
    return points, faces


def _tetrahedron() -> tuple[np.ndarray, list[np.ndarray]]:
    points = np.array([[0.0, 0.0, 0.0], [1.0, 0.1, 0.0], [0.2, 0.9, 0.1], [0.3, 0.2, 1.1]])
    return points, [np.array(f) for f in ([0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2])]


def octree_polyhedra(n: int, refine) -> list[tuple[np.ndarray, list[np.ndarray]]]:
    """The unit cube as n^3 cubes, those whose centre satisfies ``refine`` split once into 8, as
    polyhedra: a cube next to finer ones carries the hanging vertices on its edges and its faces
    split into the finer cubes' faces (one level: 2:1 balanced by construction)."""
    cubes = []
    for i, j, k in np.ndindex(n, n, n):
        lower, size = np.array([i, j, k]) / n, 1.0 / n
        if refine(lower + size / 2):
            cubes += [(lower + size / 2 * np.array(o), size / 2) for o in np.ndindex(2, 2, 2)]
        else:
            cubes.append((lower, size))
    corners = np.unique(np.round([lo + s * np.array(o) for lo, s in cubes for o in np.ndindex(2, 2, 2)], 12), axis=0)
    tol = 1e-9 / n

    def loop(k, side, a, b, u0, v0, size):
        """Mesh vertices on the boundary of the square {x_k = side, u in [u0, u0+size], v ...}, counter-clockwise
        about e_a x e_b; and whether a vertex lies inside it."""
        on = (np.abs(corners[:, k] - side) < tol) & (corners[:, a] > u0 - tol) & (corners[:, a] < u0 + size + tol) \
            & (corners[:, b] > v0 - tol) & (corners[:, b] < v0 + size + tol)
        rim = on & ((np.abs(corners[:, a] - u0) < tol) | (np.abs(corners[:, a] - u0 - size) < tol)
                    | (np.abs(corners[:, b] - v0) < tol) | (np.abs(corners[:, b] - v0 - size) < tol))
        angle = np.arctan2(corners[rim, b] - v0 - size / 2, corners[rim, a] - u0 - size / 2)
        return np.flatnonzero(rim)[np.argsort(angle)], bool(np.any(on & ~rim))

    cells = []
    for lower, size in cubes:
        faces = []
        for k in range(3):
            for side in (0, 1):
                a, b = ((k + 1) % 3, (k + 2) % 3) if side == 1 else ((k + 2) % 3, (k + 1) % 3)
                plane = lower[k] + side * size
                face, split = loop(k, plane, a, b, lower[a], lower[b], size)
                if not split:
                    faces.append(face)
                    continue
                for du, dv in np.ndindex(2, 2):
                    faces.append(loop(k, plane, a, b, lower[a] + du * size / 2, lower[b] + dv * size / 2, size / 2)[0])
        used, local = np.unique(np.concatenate(faces), return_inverse=True)
        offsets = np.cumsum([0] + [len(f) for f in faces])
        cells.append((corners[used], [local[offsets[i]:offsets[i + 1]] for i in range(len(faces))]))
    return cells


def global_dofs(cells) -> tuple[list[np.ndarray], np.ndarray]:
    """A global numbering of the scalar DOFs of polyhedra that share vertices, edges and faces by
    position: per cell its global DOF indices in the element's local order (vertices, edges,
    faces, cell), and the DOF locations (n, 3) (vertex, edge midpoint, face centroid, cell
    centroid: a linear field's DOFs are its values there)."""
    from dolfinx_sfvem.mesh.polyhedron import polyhedron_edges, polyhedron_geometry

    keys: dict = {}
    locations = []
    cell_dofs = []
    for c, (points, faces) in enumerate(cells):
        g = polyhedron_geometry(points, faces)
        vertex = [tuple(np.round(p, 11)) for p in points]
        local = [(key, np.array(key)) for key in vertex]
        local += [(frozenset((vertex[i], vertex[j])), points[[i, j]].mean(axis=0)) for i, j in polyhedron_edges(faces)]
        local += [(frozenset(vertex[i] for i in face), g.face_centroids[f]) for f, face in enumerate(faces)]
        local.append((("cell", c), g.centroid))
        for key, x in local:
            if key not in keys:
                keys[key] = len(keys)
                locations.append(x)
        cell_dofs.append(np.array([keys[key] for key, _ in local]))
    return cell_dofs, np.array(locations)


octree_polyhedra_fixture = shared(octree_polyhedra)
prism_fixture = shared(prism)
global_dofs_fixture = shared(global_dofs)


#: name -> (points, outward faces); octree cubes with 1..6 refined neighbours
POLYHEDRA = {
    "cube": refined_cube(()),
    "tetrahedron": _tetrahedron(),
    "triangle prism": prism(np.array([[0.0, 0.0], [1.0, 0.0], [0.3, 0.8]]), 0.7),
    "pentagon prism": prism(regular_polygon(5), 1.2),
    "L prism (non-convex)": prism(np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], dtype=float)),
    "dented cube (non-convex)": _dented_cube(),
    "random convex hull": convex_polyhedron(np.random.default_rng(5).random((12, 3))),
    "truncated octahedron (BCC Voronoi cell)": _truncated_octahedron(),
    **{f"cube, {k} refined neighbour{'s' if k > 1 else ''}": refined_cube(tuple(range(k))) for k in range(1, 7)},
}


@pytest.fixture(scope="session")
def polyhedra() -> dict[str, tuple[np.ndarray, list[np.ndarray]]]:
    return POLYHEDRA


@pytest.fixture(params=list(POLYHEDRA))
def polyhedron_name(request) -> str:
    """Runs a test once per test polyhedron (its name in ``polyhedra``)."""
    return request.param


@pytest.fixture
def polyhedron(polyhedron_name) -> tuple[np.ndarray, list[np.ndarray]]:
    return POLYHEDRA[polyhedron_name]


# --------------------------------------------------------------------------- 3D energies by hand
class ByHand:
    """Central differences, and Psi in 3D written with numpy: references of the kernel and element
    tests (fixture ``by_hand``)."""

    @staticmethod
    def central_difference(f, x, h=1e-6):
        """d f / d x by central differences: shape f(x).shape + x.shape."""
        columns = []
        for index in np.ndindex(x.shape):
            e = np.zeros_like(x)
            e[index] = h
            columns.append((np.asarray(f(x + e)) - np.asarray(f(x - e))) / (2 * h))
        return np.moveaxis(np.array(columns), 0, -1).reshape(np.shape(f(x)) + x.shape)

    @staticmethod
    def neo_hooke(F, K, mu):
        """Eq. 2 in 3D."""
        J = np.linalg.det(F)
        return K / 2 * np.log(J) ** 2 + mu / 2 * (J ** (-2 / 3) * np.sum(F * F) - 3)

    @staticmethod
    def neo_hooke_P(F, K, mu):
        """First Piola stress of Eq. 2 in 3D (3, 3)."""
        J = np.linalg.det(F)
        Finv_T = np.linalg.inv(F).T
        return K * np.log(J) * Finv_T + mu * J ** (-2 / 3) * (F - np.trace(F.T @ F) / 3 * Finv_T)

    @classmethod
    def uniaxial(cls, K, mu, stretch):
        """(lateral stretch s, P_11) of the uniaxial stress state F = diag(1 + stretch, s, s) of Eq. 2."""
        import scipy.optimize
        s = scipy.optimize.brentq(lambda s: cls.neo_hooke_P(np.diag([1 + stretch, s, s]), K, mu)[1, 1], 0.8, 1.0,
                                  xtol=1e-15)
        return s, cls.neo_hooke_P(np.diag([1 + stretch, s, s]), K, mu)[0, 0]

    @classmethod
    def psi(cls, energy, F, G):
        """Psi of a Hyperelastic, or of a ThirdMedium with the "huhu" regularization and the beta
        scaling (Eqs. 2, 3, 6, 8)."""
        p = energy.params
        if isinstance(energy, sf.Hyperelastic):
            return cls.neo_hooke(F, p["K"], p["mu"])
        s = np.exp(-p["beta"] * np.linalg.det(F))
        return p["gamma"] * (cls.neo_hooke(F, p["K"], p["mu"]) + p["alpha_r"] * s * np.sum(G * G) / 2)


by_hand_fixture = shared(ByHand, "by_hand")


# --------------------------------------------------------------------------- the medium's FEM-only rules
class MediumByHand:
    """A Hu-Hu medium (its tangent compiles in seconds) and a field whose J varies with its Psi
    worked out by hand: what test_fem_only_medium_rules, test_lobatto_medium and
    test_reduced_medium integrate with each rule (fixture ``medium_by_hand``)."""

    K, MU, ALPHA_R = 1.0, 0.5, 0.3
    #: u = (C1 x y, C2 x^2): J = 1 + C1 y - 2 C1 C2 x^2, smallest (0.88) at the corner (1, 0) of the unit square
    C1, C2 = 0.3, 0.2

    @classmethod
    def medium(cls, quadrature: str, alpha_r: float | None = None) -> sf.ThirdMedium:
        return sf.ThirdMedium(mu=cls.MU, K=cls.K, gamma=1.0, alpha_r=cls.ALPHA_R if alpha_r is None else alpha_r,
                              regularization="huhu", quadrature=quadrature)

    @staticmethod
    def state(disc, u):
        """The vector of the nodal values of ``u(x) -> (n, d)``."""
        return nodal_field(disc, lambda x, key: u(x))

    @classmethod
    def energy_and_min_J(cls, disc, u) -> tuple[float, float]:
        info = disc.residual(cls.state(disc, u), disc.create_vector())
        return info.energy, info.min_J

    @classmethod
    def varying_J(cls, x: np.ndarray) -> np.ndarray:
        """u = (C1 x y, C2 x^2) (in P2 and Q2)."""
        return np.column_stack([cls.C1 * x[:, 0] * x[:, 1], cls.C2 * x[:, 0] ** 2])

    @classmethod
    def F_by_hand(cls, x: float, y: float) -> np.ndarray:
        """F of :meth:`varying_J` at (x, y)."""
        return np.array([[1 + cls.C1 * y, cls.C1 * x], [2 * cls.C2 * x, 1.0]])

    @classmethod
    def psi_by_hand(cls, x: float, y: float) -> float:
        """The medium's Psi (gamma = 1, Hu-Hu) for :meth:`varying_J` at (x, y), in plane strain."""
        F = cls.F_by_hand(x, y)
        J = np.linalg.det(F)
        G_G = 2 * cls.C1 ** 2 + (2 * cls.C2) ** 2               # u_x,xy = u_x,yx = C1, u_y,xx = 2 C2
        return (cls.K / 2 * np.log(J) ** 2 + cls.MU / 2 * (J ** (-2 / 3) * (np.trace(F.T @ F) + 1) - 3)
                + cls.ALPHA_R / 2 * G_G)

    @classmethod
    def tangent(cls, disc) -> np.ndarray:
        """The tangent at u = 0, dense."""
        A = disc.create_matrix()
        disc.assemble_tangent(cls.state(disc, np.zeros_like), A)
        return A.convert("dense").getDenseArray()

    @staticmethod
    def rigid_modes(tangent: np.ndarray) -> int:
        """Dimension of the null space of a tangent (eigenvalues below 1e-10 of the largest in magnitude)."""
        eigenvalues = np.linalg.eigvalsh(tangent)
        return int(np.sum(np.abs(eigenvalues) < 1e-10 * np.abs(eigenvalues).max()))


medium_by_hand_fixture = shared(MediumByHand, "medium_by_hand")
