"""The finite-strain SFVEM element on polyhedra (dolfinx_sfvem.discretizations.hyperelastic3d; docs/method.md §8).

References from outside the code under test: central finite differences of the element energy and
residual; the exact nodal forces of a constant first Piola stress P(F0) (on a face,
int_f v P N = |f| P N mean_f(v): only the face-mean DOFs carry it), with P(F0) by finite
differences of Psi written by hand (conftest.py's ``by_hand``); the linear-elastic stiffness of
dolfinx_sfvem.discretizations.elasticity (test_elasticity3d checks it); a rigid rotation of the deformed state.
"""
import numpy as np
import pytest

from dolfinx_sfvem import Hyperelastic, ThirdMedium
from dolfinx_sfvem.discretizations.elasticity import linear_elastic_stiffness_3d
from dolfinx_sfvem.discretizations.hyperelastic3d import hyperelastic_polyhedron
from dolfinx_sfvem.mesh.polyhedron import polyhedron_geometry
from dolfinx_sfvem.discretizations.projection3d import interpolation_dofs

K_BULK, MU = 5.0, 1.5
SOLID = Hyperelastic(K=K_BULK, mu=MU)
MEDIUM = ThirdMedium(mu=1.5, gamma=0.3, alpha_r=0.7, regularization="huhu", beta=0.4, K=2.0)
ENERGIES = {"neo-Hooke": SOLID, "huhu medium": MEDIUM}
_elements = {}


def element(polyhedra, name, energy_name, quadrature="auto"):
    key = (name, energy_name, quadrature)
    if key not in _elements:
        _elements[key] = hyperelastic_polyhedron(*polyhedra[name], ENERGIES[energy_name], quadrature=quadrature)
    return _elements[key]


def deformed_state(points, faces, seed):
    """DOFs (3, n_d) of a smooth non-polynomial displacement (all DOFs non-trivial). Gentle: on the
    unit cube the projected gradient of sin(a x) with |a| ~ 2 errs by 1.5 (l = 5), and J < 0."""
    a = 0.5 * np.random.default_rng(seed).standard_normal((3, 3))
    return 0.1 * interpolation_dofs(points, faces, lambda x: np.sin(x @ a.T + 0.3), 6)


@pytest.mark.parametrize("energy_name", list(ENERGIES))
@pytest.mark.parametrize("name", ["tetrahedron", "triangle prism"])
def test_residual_and_tangent_are_derivatives(polyhedra, name, energy_name, by_hand):
    central = by_hand.central_difference
    el = element(polyhedra, name, energy_name)
    u = deformed_state(*polyhedra[name], seed=1)
    _, R, min_J = el.residual(u)
    assert 0.5 < min_J < 1.5
    R_fd = central(el.energy, u, h=1e-6)
    np.testing.assert_allclose(R, R_fd, rtol=0, atol=1e-6 * np.abs(R).max())
    K = el.tangent(u)
    K_fd = central(lambda v: el.residual(v)[1], u, h=1e-6).reshape(K.shape)
    np.testing.assert_allclose(K, K_fd, rtol=0, atol=1e-6 * np.abs(K).max())
    np.testing.assert_allclose(K, K.T, rtol=0, atol=1e-12 * np.abs(K).max())


@pytest.mark.parametrize("energy_name", list(ENERGIES))
@pytest.mark.parametrize("name", ["cube", "cube, 3 refined neighbours", "triangle prism",
                                  "L prism (non-convex)"])
def test_homogeneous_deformation(polyhedra, name, energy_name, by_hand):
    """u = (F0 - I) X: F = F0 and G = 0 everywhere, and the residual is the exact nodal force of the
    constant stress P(F0): |f| P(F0) N_f on each face-mean DOF, zero on vertices, edge midpoints and
    the cell mean."""
    points, faces = polyhedra[name]
    el = element(polyhedra, name, energy_name)
    F0 = np.eye(3) + 0.15 * np.random.default_rng(3).standard_normal((3, 3))
    energy = ENERGIES[energy_name]
    G0 = np.zeros((3, 3, 3))
    P0 = by_hand.central_difference(lambda F: by_hand.psi(energy, F, G0), F0)
    W, R, min_J = el.residual(interpolation_dofs(points, faces, lambda x: x @ (F0 - np.eye(3)).T, 1))
    g = polyhedron_geometry(points, faces)
    volume, areas, normals = g.volume, g.face_areas, g.face_normals
    assert min_J == pytest.approx(np.linalg.det(F0), rel=1e-12)
    assert W == pytest.approx(volume * by_hand.psi(energy, F0, G0), rel=1e-11)
    n_v, n_e, n_f = len(points), len(el.projections.edges), len(faces)
    expected = np.zeros_like(R)
    expected[:, n_v + n_e:n_v + n_e + n_f] = (areas[:, None] * normals @ P0.T).T
    np.testing.assert_allclose(R, expected, rtol=0, atol=1e-8 * np.abs(expected).max())


@pytest.mark.parametrize("name, quadrature", [("cube", "auto"), ("cube", "tetrahedra"),
                                              ("cube, 1 refined neighbour", "auto"), ("pentagon prism", "auto"),
                                              ("triangle prism", "compressed")])
def test_linearization_at_rest_is_linear_elasticity(polyhedra, name, quadrature):
    """At u = 0 the neo-Hookean D is Hooke's law with lambda = K - 2 mu / 3 (every energy rule is
    exact for the degree-2l integrand)."""
    lam = K_BULK - 2 * MU / 3
    young, poisson = MU * (3 * lam + 2 * MU) / (lam + MU), lam / (2 * (lam + MU))
    el = element(polyhedra, name, "neo-Hooke", quadrature)
    K_lin, l = linear_elastic_stiffness_3d(*polyhedra[name], young, poisson)
    assert l == el.projections.l
    K = el.tangent(np.zeros((3, el.projections.n_dofs)))
    np.testing.assert_allclose(K, K_lin, rtol=0, atol=1e-10 * np.abs(K_lin).max())


def rotation(seed):
    q, _ = np.linalg.qr(np.random.default_rng(seed).standard_normal((3, 3)))
    return q * np.sign(np.linalg.det(q))


@pytest.mark.parametrize("energy_name", list(ENERGIES))
@pytest.mark.parametrize("name", ["cube", "random convex hull"])
def test_frame_invariance(polyhedra, name, energy_name):
    """x -> Q x of a deformed state (DOFs Q (X~ + u~) - X~): same energy, residual rotated by Q."""
    points, faces = polyhedra[name]
    el = element(polyhedra, name, energy_name)
    X = interpolation_dofs(points, faces, lambda x: x, 1)
    u = deformed_state(points, faces, seed=2)
    Q = rotation(4)
    W, R, min_J = el.residual(u)
    assert 0.5 < min_J < 1.5
    W_rotated, R_rotated, _ = el.residual(Q @ (X + u) - X)
    assert abs(W) > 1e-3 * abs(W_rotated)
    assert W_rotated == pytest.approx(W, rel=1e-11)
    np.testing.assert_allclose(R_rotated, Q @ R, rtol=0, atol=1e-10 * np.abs(R).max())
