"""The energies in 3D: the same classes, reducing exactly to plane strain (issue 29, item 2).

The UFL expressions are evaluated at constant F and G (UFL's own evaluation), so these tests
check the formulas, independent of any discretization: with F3 = [[F, 0], [0, 1]] and G3 the
2D G padded with zeros (no z-dependence), every energy and its stress P = dPsi/dF must equal
the 2D (plane-strain) ones, and the out-of-plane stress P_33 is the plane-strain reaction.
"""
import numpy as np
import pytest
import ufl

from dolfinx_sfvem.physics.energy import (
    REGULARIZATIONS, Hyperelastic, ThirdMedium, huhu_lulu, rotation_angle, tan_rotation_angle)


def random_state(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A moderately deformed plane F (J > 0.3, tr F > 0.5) and a random G, in 2D."""
    rng = np.random.default_rng(seed)
    while True:
        F = np.eye(2) + 0.3 * rng.standard_normal((2, 2))
        if np.linalg.det(F) > 0.3 and np.trace(F) > 0.5:
            return F, 0.6 * rng.standard_normal((2, 2, 2))


def embedded(F: np.ndarray, G: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The plane-strain embedding: F3 = [[F, 0], [0, 1]], G3 = G padded with zeros."""
    F3, G3 = np.eye(3), np.zeros((3, 3, 3))
    F3[:2, :2], G3[:2, :2, :2] = F, G
    return F3, G3


def psi_and_P(energy, F: np.ndarray, G: np.ndarray) -> tuple[float, np.ndarray]:
    """Psi and P = dPsi/dF of ``energy`` at constant F, G (UFL evaluation)."""
    Fv = ufl.variable(ufl.as_tensor(F.tolist()))
    p = {name: ufl.as_ufl(value) for name, value in energy.params.items()}
    psi = energy.psi(Fv, ufl.as_tensor(G.tolist()), p)
    P = ufl.diff(psi, Fv)
    d = F.shape[0]
    return float(psi((), {})), np.array([[P[i, j]((), {}) for j in range(d)] for i in range(d)])


def medium(regularization: str, **options) -> ThirdMedium:
    return ThirdMedium(mu=0.3, gamma=1.5, alpha_r=1.0 if options.get("beta") is None else 150.0, K=0.2,
                       regularization=regularization, **options)


PLANE_STRAIN = {"solid": Hyperelastic(K=2.0, mu=0.7)}
for _name in REGULARIZATIONS:
    PLANE_STRAIN[_name] = medium(_name, n_dim=2) if _name == "huhu_lulu" else medium(_name)
    PLANE_STRAIN[f"{_name}-scaled"] = medium(_name, beta=5.0, **({"n_dim": 2} if _name == "huhu_lulu" else {}))


@pytest.mark.parametrize("seed", [1, 2])
@pytest.mark.parametrize("name", sorted(PLANE_STRAIN))
def test_3d_energy_reduces_to_plane_strain(name, seed):
    """Psi(F3, G3) = Psi(F, G) and P(F3, G3)[:2, :2] = P(F, G), to round-off (Eqs. 2, 5, 6, 8, 9 with
    n_dim = 2, 15, 16)."""
    energy = PLANE_STRAIN[name]
    F, G = random_state(seed)
    psi2, P2 = psi_and_P(energy, F, G)
    psi3, P3 = psi_and_P(energy, *embedded(F, G))
    assert psi3 == pytest.approx(psi2, rel=1e-13, abs=1e-15)
    np.testing.assert_allclose(P3[:2, :2], P2, rtol=1e-12, atol=1e-14 * np.abs(P2).max())
    np.testing.assert_allclose(P3[:2, 2], 0.0, atol=1e-14 * np.abs(P2).max())   # no shear out of the plane
    np.testing.assert_allclose(P3[2, :2], 0.0, atol=1e-14 * np.abs(P2).max())


def test_huhu_lulu_n_dim_defaults_to_the_dimension():
    """Eq. 9 in 3D: 1/2 (G:G - L.L / 3) by default, 1/2 (G:G - L.L / 2) with n_dim = 2."""
    G = np.random.default_rng(3).standard_normal((3, 3, 3))
    L = np.einsum("ijj->i", G)
    F = ufl.Identity(3)
    for n_dim, expected in ((None, 3), (2, 2), (3, 3)):
        value = huhu_lulu(F, ufl.as_tensor(G.tolist()), n_dim)((), {})
        assert value == pytest.approx(0.5 * (np.sum(G * G) - L @ L / expected), rel=1e-14)


@pytest.mark.parametrize("axis", [0, 1, 2])
@pytest.mark.parametrize("phi", [0.3, -1.1, 1.4])
def test_3d_rotation_measures_of_a_rotation_about_an_axis(axis, phi):
    """For F = R(phi) about coordinate axis i, |phi| < pi/2: Eq. 12's angle vector is -phi e_i
    (Eq. 12's sign) and Eq. 16's t = -tan(phi) e_i. (Beyond pi/2 the other angles are atan2(0, c < 0)
    = +-pi: only their gradients enter Eq. 15.)"""
    c, s = np.cos(phi), np.sin(phi)
    j, k = (axis + 1) % 3, (axis + 2) % 3                 # right-handed: rotation about +e_axis
    R = np.eye(3)
    R[j, j], R[j, k], R[k, j], R[k, k] = c, -s, s, c
    F = ufl.as_tensor(R.tolist())
    angle = np.array([rotation_angle(F)[m]((), {}) for m in range(3)])
    t = np.array([tan_rotation_angle(F)[m]((), {}) for m in range(3)])
    expected = np.zeros(3)
    expected[axis] = -phi
    np.testing.assert_allclose(angle, expected, atol=1e-14)
    expected[axis] = -np.tan(phi)
    np.testing.assert_allclose(t, expected, atol=1e-13)


def test_3d_tan_rotation_of_an_oblique_rotation_is_tan_phi_times_the_axis():
    """t = w / (tr F - 1) is tan(phi) a (up to Eq. 12's sign) for a rotation by phi about any unit axis a."""
    a = np.array([1.0, -2.0, 0.5])
    a /= np.linalg.norm(a)
    phi = 0.8
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    R = np.eye(3) + np.sin(phi) * K + (1 - np.cos(phi)) * K @ K
    t = tan_rotation_angle(ufl.as_tensor(R.tolist()))
    np.testing.assert_allclose([t[m]((), {}) for m in range(3)], -np.tan(phi) * a, rtol=1e-13)


@pytest.mark.parametrize("name", ["solid", "huhu", "huhu_lulu", "huhu-scaled"])
def test_3d_energy_is_objective(name):
    """Psi(QF, QG) = Psi(F, G) for a 3D rotation Q, (QG)_ijk = Q_im G_mjk (Eqs. 2, 6, 8, 9)."""
    energy = PLANE_STRAIN[name] if name != "huhu_lulu" else medium("huhu_lulu")
    rng = np.random.default_rng(4)
    F, G = np.eye(3) + 0.2 * rng.standard_normal((3, 3)), 0.5 * rng.standard_normal((3, 3, 3))
    Q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    Q *= np.sign(np.linalg.det(Q))
    psi, _ = psi_and_P(energy, F, G)
    rotated, _ = psi_and_P(energy, Q @ F, np.einsum("im,mjk->ijk", Q, G))
    assert rotated == pytest.approx(psi, rel=1e-12)


def test_n_dim_is_only_for_huhu_lulu():
    with pytest.raises(ValueError, match="n_dim"):
        ThirdMedium(mu=1.0, gamma=1.0, alpha_r=1.0, regularization="rotation", n_dim=2)
    with pytest.raises(ValueError, match="n_dim"):
        ThirdMedium(mu=1.0, gamma=1.0, alpha_r=1.0, regularization="huhu_lulu", n_dim=4)
