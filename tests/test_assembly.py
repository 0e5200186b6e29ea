"""Consistency of the assembled SFVEM energy, residual and tangent (paper Eqs. 46, 52, 56; docs/method.md §7).

All checks use independent references: central finite differences of the assembled
quantities themselves, the exact identity K = Kᵀ of a Hessian, and exact invariances
(rigid motions, superposed rotations). Two tiny two-region meshes (solid below, third
medium above): Voronoi-like polygons (gmsh duals) and quadrilaterals with hanging nodes.

The medium has gamma = 1 so that its terms weigh as much as the solid's, and
alpha_r = exp(beta) when scaled, so that exp(-beta J) alpha_r stays O(1) near J = 1.
Everything runs on ``MPI.COMM_SELF``: local and global numbering coincide, so the
PETSc vectors and matrices are the full arrays.
"""
import functools

import numpy as np
import pytest
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem import meshes
from dolfinx_sfvem.discretizations.discretization import AssemblyInfo
from dolfinx_sfvem.discretizations.space import INTERIOR

COMM = MPI.COMM_SELF
SOLID, MEDIUM = meshes.SOLID, meshes.MEDIUM
REGULARIZATIONS = ("huhu", "huhu_lulu", "rotation", "tan_rotation")
BETA = 5.0
#: (energy of the MEDIUM region, beta): "solid" puts a second solid there
CASES = [("solid", None)] + [(r, b) for r in REGULARIZATIONS for b in (None, BETA)]
CASE_IDS = [f"{r}-beta{b}" if b else r for r, b in CASES]
MESHES = ("voronoi", "hanging")
#: central differences: truncation ~ step², round-off ~ 1e-16 / step; the residual is
#: differenced along noisy directions (second derivatives ~ 1/h² per unit DOF), the energy
#: along smooth ones
FD_STEP_RESIDUAL = 1e-7
FD_STEP_ENERGY = 1e-5
FD_RTOL = 1e-6
DIRECTIONS = ("noise", "smooth")
INVARIANCE_RTOL = 1e-10
ANGLE = 0.7

each_mesh = pytest.mark.parametrize("kind", MESHES)
each_energy = pytest.mark.parametrize("medium,beta", CASES, ids=CASE_IDS)


# ----------------------------------------------------------------------------- set-up helpers
def retagged(mesh: sf.PolygonMesh, y_interface: float) -> sf.PolygonMesh:
    """The same polygons, SOLID below ``y_interface`` (by centroid) and MEDIUM above."""
    tags = np.where(mesh.centroids[:, 1] < y_interface, SOLID, MEDIUM)
    return sf.PolygonMesh(mesh.points, [mesh.polygon(i) for i in range(mesh.n_polygons)], tags)


@functools.lru_cache(maxsize=None)
def two_region_mesh(kind: str) -> sf.PolygonMesh:
    """≈ 30-50 polygons on [0, 1]²: solid in y < 0.5, medium in y > 0.5."""
    if kind == "voronoi":
        return meshes.glue(meshes.polygon_rectangle(1.0, 0.5, 0.2, tag=SOLID),
                           meshes.polygon_rectangle(1.0, 0.5, 0.2, origin=(0.0, 0.5), tag=MEDIUM))
    # the refined 2 x 2 block straddles the interface: hanging nodes in both regions
    return retagged(meshes.quads_with_hanging_nodes(1.0, 1.0, 4, refine=(0.25, 0.75, 0.25, 0.75)), 0.5)


def energy(name: str, beta: float | None = None) -> sf.Energy:
    """The solid (Eq. 2) or the third medium with a regularization of Table 1 (Eqs. 3-9, 15-16)."""
    if name == "solid":
        return sf.Hyperelastic(K=5 / 3, mu=5 / 14)
    alpha_r = 1.0 if beta is None else float(np.exp(beta))
    return sf.ThirdMedium(mu=5 / 14, gamma=1.0, alpha_r=alpha_r, regularization=name, beta=beta, K=0.2)


@functools.lru_cache(maxsize=None)
def discretization(kind: str, medium: str, beta: float | None = None,
                   everywhere: bool = False) -> sf.SFVEMDiscretization:
    """Solid below and ``medium`` above, or ``medium`` in both regions (``everywhere``)."""
    top = energy(medium, beta)
    if medium == "solid" and not everywhere:
        top = sf.Hyperelastic(K=2.0, mu=0.8)          # a second, different solid
    bottom = top if everywhere else energy("solid")
    return sf.SFVEMDiscretization(two_region_mesh(kind), {SOLID: bottom, MEDIUM: top}, COMM, verbose=False)


def smooth_field(seed: int, amplitude: float = 0.04):
    """Random smooth displacement u(X) (2, n) of two Fourier modes per component, |∇u| ≲ 0.3."""
    rng = np.random.default_rng(seed)
    k = rng.uniform(1.0, 3.0, size=(2, 2, 2))        # (component, mode, direction)
    phase = rng.uniform(0.0, 2 * np.pi, size=(2, 2))
    a = amplitude * rng.uniform(0.5, 1.0, size=(2, 2))

    def u(X: np.ndarray) -> np.ndarray:
        return np.array([sum(a[i, m] * np.sin(k[i, m] @ X + phase[i, m]) for m in range(2)) for i in range(2)])
    return u


def reference_points(disc: sf.SFVEMDiscretization) -> np.ndarray:
    """Reference position X of every node (n_local_nodes, 2): vertices and midpoints at the node,
    interior (mean) DOFs at the polygon centroid, i.e. the mean of X over the polygon."""
    space = disc.space
    X = space.x_nodes.copy()
    mesh = space.polygon_mesh
    for k, polygon in enumerate(space.cells):
        X[space.cell_dofs(k)[-1]] = polygon_centroid(mesh.polygon_coordinates(polygon))
    assert np.all(space.node_kind[[space.cell_dofs(k)[-1] for k in range(space.cells.size)]] == INTERIOR)
    return X


def polygon_centroid(xy: np.ndarray) -> np.ndarray:
    """Area centroid of a simple polygon (shoelace formula)."""
    x, y = xy.T
    x1, y1 = np.roll(x, -1), np.roll(y, -1)
    cross = x * y1 - x1 * y
    return np.array([np.sum((x + x1) * cross), np.sum((y + y1) * cross)]) / (3 * np.sum(cross))


def nodal_values(disc: sf.SFVEMDiscretization, u) -> np.ndarray:
    """A smooth state: u at every node (interior DOFs at their host point, O(h²) from the mean)."""
    return np.ascontiguousarray(u(disc.space.x_nodes.T).T)


def rotation_matrix(theta: float) -> np.ndarray:
    return np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])


# ----------------------------------------------------------------------------- assembly wrappers
def as_vector(disc: sf.SFVEMDiscretization, values: np.ndarray):
    x = disc.create_vector()
    x.array[:] = np.asarray(values).ravel()
    return x


def residual(disc: sf.SFVEMDiscretization, values: np.ndarray) -> tuple[np.ndarray, AssemblyInfo]:
    """Nodal residual (n_nodes, 2) (Eq. 52) and the assembly info (energy, Eq. 46)."""
    b = disc.create_vector()
    info = disc.residual(as_vector(disc, values), b)
    return b.array.reshape(-1, 2).copy(), info


def total_energy(disc: sf.SFVEMDiscretization, values: np.ndarray) -> float:
    return residual(disc, values)[1].energy


def tangent(disc: sf.SFVEMDiscretization, values: np.ndarray) -> np.ndarray:
    """Dense tangent (Eq. 56), no constrained rows."""
    A = disc.create_matrix()
    disc.jacobian(as_vector(disc, values), A)
    return A.convert("dense").getDenseArray().copy()


def deformed_state(disc: sf.SFVEMDiscretization, seed: int = 3) -> np.ndarray:
    """Moderate smooth deformation; asserts it is admissible (J > 0 at every quadrature point)."""
    values = nodal_values(disc, smooth_field(seed))
    min_J = residual(disc, values)[1].min_J
    assert 0.3 < min_J < 0.99, f"test state should be moderately deformed, min J = {min_J}"
    return values


def direction(disc: sf.SFVEMDiscretization, kind: str, seed: int) -> np.ndarray:
    """A perturbation of unit size: independent random DOFs ("noise", dominated by ∇F, i.e. by
    the B-terms of the medium) or a smooth field ("smooth", F- and ∇F-terms of similar size)."""
    if kind == "noise":
        return np.random.default_rng(seed).standard_normal((disc.space.n_local_nodes, 2))
    return nodal_values(disc, smooth_field(seed, amplitude=1.0))


def relative_error(actual: np.ndarray, expected: np.ndarray) -> float:
    return float(np.linalg.norm(np.asarray(actual) - expected) / np.linalg.norm(expected))


# ----------------------------------------------------------------------------- tests
@each_mesh
@each_energy
@pytest.mark.parametrize("v_kind", DIRECTIONS)
def test_tangent_is_derivative_of_residual(kind, medium, beta, v_kind):
    """K v = (R(u + εv) − R(u − εv)) / 2ε: the tangent of Eq. 56 (D, A, B of Eq. 32 contracted
    with B1, B2 of Eqs. 49-51) is the derivative of the residual of Eq. 52, for the solid
    energy and every regularization with and without exp(-beta J) scaling."""
    disc = discretization(kind, medium, beta)
    u = deformed_state(disc)
    v = direction(disc, v_kind, seed=7)
    Kv = tangent(disc, u) @ v.ravel()
    step = FD_STEP_RESIDUAL
    difference = (residual(disc, u + step * v)[0] - residual(disc, u - step * v)[0]) / (2 * step)
    assert relative_error(difference.ravel(), Kv) < FD_RTOL


@each_mesh
@each_energy
def test_residual_is_derivative_of_energy(kind, medium, beta):
    """R · v = (W(u + εv) − W(u − εv)) / 2ε: the residual (Eq. 52) is the gradient of the
    assembled total energy W = ∫ Ψ dΩ (Eq. 46) along a random smooth direction v."""
    disc = discretization(kind, medium, beta)
    u = deformed_state(disc)
    v = direction(disc, "smooth", seed=8)
    step = FD_STEP_ENERGY
    slope = (total_energy(disc, u + step * v) - total_energy(disc, u - step * v)) / (2 * step)
    Rv = float(np.sum(residual(disc, u)[0] * v))
    assert slope == pytest.approx(Rv, rel=FD_RTOL)


@each_mesh
@each_energy
def test_tangent_is_symmetric(kind, medium, beta):
    """K = Kᵀ at a deformed state: Eq. 56 is the Hessian of W (the A-terms appear with their
    transpose, and D, B carry the major symmetry of second derivatives)."""
    disc = discretization(kind, medium, beta)
    K = tangent(disc, deformed_state(disc))
    assert np.abs(K - K.T).max() <= 1e-12 * np.abs(K).max()


def rotated_configuration(disc: sf.SFVEMDiscretization, values: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """DOFs of x' = Q x, x = X + u: u'_node = Q (X_node + u_node) − X_node (X at the centroid for
    the mean DOFs: the mean of Q x is Q times the mean of x)."""
    X = reference_points(disc)
    return (X + values) @ Q.T - X


@each_mesh
@pytest.mark.parametrize("medium", ["solid", "huhu", "huhu_lulu", "rotation"])
def test_objectivity(kind, medium):
    """Superposing a rigid rotation Q (0.7 rad) on a deformed state: the energy (Eq. 46) is
    unchanged and the nodal residual (Eq. 52) rotates, R'_a = Q R_a; the tangent (Eq. 56)
    rotates blockwise, K'_ab = Q K_ab Qᵀ. The energy is the only one in the mesh."""
    disc = discretization(kind, medium, everywhere=True)
    u = deformed_state(disc)
    Q = rotation_matrix(ANGLE)
    u_rotated = rotated_configuration(disc, u, Q)
    R, info = residual(disc, u)
    R_rotated, info_rotated = residual(disc, u_rotated)
    assert info_rotated.energy == pytest.approx(info.energy, rel=INVARIANCE_RTOL)
    assert relative_error(R_rotated, R @ Q.T) < INVARIANCE_RTOL
    n = R.shape[0]
    K = tangent(disc, u).reshape(n, 2, n, 2)
    K_rotated = tangent(disc, u_rotated).reshape(n, 2, n, 2)
    assert relative_error(K_rotated, np.einsum("ij,ajbk,lk->aibl", Q, K, Q)) < INVARIANCE_RTOL


@each_mesh
def test_tan_rotation_is_not_objective(kind):
    """Control for :func:`test_objectivity`: the tan_rotation regularization (Eq. 16) uses
    t = tan(phi), grad t = (1 + t²) grad phi, which a superposed rotation changes; the same
    check must see the energy change (so the objectivity test can fail)."""
    disc = discretization(kind, "tan_rotation", everywhere=True)
    u = deformed_state(disc)
    energy_rotated = total_energy(disc, rotated_configuration(disc, u, rotation_matrix(ANGLE)))
    assert abs(energy_rotated - total_energy(disc, u)) > 1e-2 * abs(total_energy(disc, u))


def rigid_motion(disc: sf.SFVEMDiscretization, motion: str) -> np.ndarray:
    """DOFs of a rigid translation, or of a rigid rotation of the undeformed body (F = Q, G = 0)."""
    X = reference_points(disc)
    if motion == "translation":
        return np.tile([0.3, -0.2], (X.shape[0], 1))
    return rotated_configuration(disc, np.zeros_like(X), rotation_matrix(ANGLE))


@each_mesh
@pytest.mark.parametrize("motion", ["translation", "rotation"])
@each_energy
def test_rigid_motion_is_stress_free(kind, motion, medium, beta):
    """A rigid motion of the reference configuration stores no energy and has zero residual:
    Ψ(I, 0) = Ψ(Q, 0) = 0 and P, T vanish there (Eq. 2; Ψ_r is quadratic in G), and the
    projections reproduce linear fields exactly (F = Q, G = 0 at every quadrature point).
    "Zero" is relative to the energy / residual of a smooth deformation: round-off of the
    projected second derivatives (~ 1/h² times the DOF size) enters T = ∂Ψ/∂G linearly, so the
    residual gets a looser bound than the energy, which is quadratic in it near F = I."""
    disc = discretization(kind, medium, beta)
    R, info = residual(disc, rigid_motion(disc, motion))
    R_scale, info_scale = residual(disc, deformed_state(disc))
    assert abs(info.energy) <= 1e-12 * abs(info_scale.energy)
    assert np.linalg.norm(R) <= 1e-10 * np.linalg.norm(R_scale)
    assert info.min_J == pytest.approx(1.0, abs=1e-11)
