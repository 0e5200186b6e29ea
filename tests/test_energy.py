"""Energies (paper §2, Table 1) and their compiled pointwise kernels (Eqs. 30, 32)."""
import numpy as np
import pytest
import ufl

from dolfinx_sfvem.physics.energy import REGULARIZATIONS, Hyperelastic, ThirdMedium, UserEnergy
from dolfinx_sfvem.discretizations.compiled_energy import compile_kernels, evaluate, tabulate

STEP = 1e-5  # central differences: truncation ~ STEP^2, round-off ~ 1e-16 / STEP
RTOL = 1e-6


def user_psi(F, G, a, b):
    """A user energy coupling F and G (non-zero A and B)."""
    J = ufl.det(F)
    return (a / 2 * (ufl.inner(F, F) - 2 - 2 * ufl.ln(J)) + b / 2 * ufl.exp(-J) * ufl.inner(G, G)
            + a * b * F[1, 0] * G[0, 1, 1] ** 2)


def medium(regularization, beta=None, **params):
    """Medium with the regularization of the same order as the bulk part (s(J) ~ exp(-5) when scaled)."""
    values = dict(mu=0.3, gamma=1.5, alpha_r=1.0 if beta is None else 150.0, K=0.2) | params
    return ThirdMedium(regularization=regularization, beta=beta, **values)


ENERGIES = {"solid": Hyperelastic(K=2.0, mu=0.7), "user": UserEnergy(user_psi, a=0.8, b=1.3)}
for _reg in REGULARIZATIONS:
    ENERGIES[_reg] = medium(_reg)
    ENERGIES[f"{_reg}-scaled"] = medium(_reg, beta=5.0)
ENERGIES["skew-penalty"] = medium("rotation", beta1=0.7)


def state(seed):
    """Moderately deformed random F (J > 0.3, F11 + F22 > 0.5) and random G."""
    rng = np.random.default_rng(seed)
    while True:
        F = np.eye(2) + 0.3 * rng.standard_normal((2, 2))
        if np.linalg.det(F) > 0.3 and np.trace(F) > 0.5:
            return F, 0.6 * rng.standard_normal((2, 2, 2))


def rotation_matrix(theta):
    return np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])


def evaluate_energy(energy, F, G):
    return evaluate(compile_kernels(energy), F, G, energy.params)


def assert_close(actual, expected, what):
    error = np.linalg.norm(actual - expected)
    assert error <= RTOL * np.linalg.norm(expected), f"{what}: |error| = {error:.3e}, |exact| = " \
                                                     f"{np.linalg.norm(expected):.3e}"


# ---------------------------------------------------------------------------- derivatives
@pytest.mark.parametrize("seed", [1, 2])
@pytest.mark.parametrize("name", ENERGIES)
def test_derivatives_match_finite_differences(name, seed, by_hand):
    def central_difference(f, x):
        return by_hand.central_difference(f, x, STEP)

    energy = ENERGIES[name]
    F, G = state(seed)
    q = evaluate_energy(energy, F, G)

    def at(what, F, G):
        return evaluate_energy(energy, F, G)[what]

    assert_close(central_difference(lambda X: at("psi", X, G), F), q["P"], "P")
    assert_close(central_difference(lambda X: at("psi", F, X), G), q["T"], "T")
    assert_close(central_difference(lambda X: at("P", X, G), F), q["D"], "D")
    assert_close(central_difference(lambda X: at("T", X, G), F), q["A"], "A")
    assert_close(central_difference(lambda X: at("T", F, X), G), q["B"], "B")


@pytest.mark.parametrize("name", ENERGIES)
def test_layouts(name):
    """Residual [Ψ, P, T], tangent [D, A, B] (no P, T: they would only cost time)."""
    energy = ENERGIES[name]
    kernels = compile_kernels(energy)
    F, G = state(3)
    c = kernels.pack_constants(energy.params)
    c[kernels.F_offset:kernels.F_offset + 4] = F.ravel()
    c[kernels.G_offset:kernels.G_offset + 8] = G.ravel()
    tangent = tabulate(kernels.tangent, kernels.n_tangent, c)
    q = evaluate(kernels, F, G, energy.params)
    np.testing.assert_array_equal(tangent[kernels.tangent_offsets["D"]:][:16], q["D"].ravel())
    if energy.uses_gradient:
        assert (kernels.n_residual, kernels.n_tangent) == (13, 112)
        assert kernels.residual_offsets == {"psi": 0, "P": 1, "T": 5}
        assert kernels.tangent_offsets == {"D": 0, "A": 16, "B": 48}
    else:
        assert (kernels.n_residual, kernels.n_tangent) == (5, 16)
        assert kernels.tangent_offsets == {"D": 0}
        assert not (q["T"].any() or q["A"].any() or q["B"].any())


# ---------------------------------------------------------------------------- energies vs. the paper
def numpy_psi_r(regularization, F, G):
    """Table 1 in numpy; grad f_k = d/de f(F + e G[:, :, k]) by central differences (the chain rule of Eq. 17)."""
    def grad(f):
        h = 1e-6
        return np.array([(f(F + h * G[:, :, k]) - f(F - h * G[:, :, k])) / (2 * h) for k in range(2)])

    L = np.einsum("ijj->i", G)
    J = np.linalg.det
    phi = lambda F: np.arctan((F[0, 1] - F[1, 0]) / (F[0, 0] + F[1, 1]))  # Eq. 12 as printed
    t = lambda F: (F[0, 1] - F[1, 0]) / (F[0, 0] + F[1, 1])
    return {"huhu": 0.5 * np.sum(G * G),
            "huhu_lulu": 0.5 * (np.sum(G * G) - L @ L / 2),
            "rotation": 0.5 * (grad(phi) @ grad(phi) + grad(J) @ grad(J)),
            "tan_rotation": 0.5 * (grad(t) @ grad(t) + grad(J) @ grad(J))}[regularization]


def numpy_neo_hookean(F, K, mu):
    """Eq. 2 with the 3D C of plane strain (C_33 = 1)."""
    J = np.linalg.det(F)
    return K / 2 * np.log(J) ** 2 + mu / 2 * (J ** (-2 / 3) * (np.sum(F * F) + 1) - 3)


@pytest.mark.parametrize("name", [n for n in ENERGIES if n not in ("solid", "user")])
def test_medium_energy_matches_paper(name):
    energy = ENERGIES[name]
    p = energy.params
    F, G = state(4)
    s = np.exp(-p["beta"] * np.linalg.det(F)) if "beta" in p else 1.0
    expected = p["gamma"] * (numpy_neo_hookean(F, p["K"], p["mu"])
                             + p["alpha_r"] * s * numpy_psi_r(energy.regularization, F, G))
    expected += p.get("beta1", 0.0) / 2 * (F[0, 1] - F[1, 0]) ** 2
    assert evaluate_energy(energy, F, G)["psi"] == pytest.approx(expected, rel=1e-8)


def test_user_energy_value():
    F, G = state(5)
    J = np.linalg.det(F)
    a, b = 0.8, 1.3
    expected = a / 2 * (np.sum(F * F) - 2 - 2 * np.log(J)) + b / 2 * np.exp(-J) * np.sum(G * G) \
        + a * b * F[1, 0] * G[0, 1, 1] ** 2
    assert evaluate_energy(ENERGIES["user"], F, G)["psi"] == pytest.approx(expected, rel=1e-13)


@pytest.mark.parametrize("seed", [6, 7])
def test_solid_stress_is_F_times_S_of_eq24(seed):
    """P = F S, S = K ln J C^-1 - mu/3 J^(-2/3) tr C C^-1 + mu J^(-2/3) I (Eq. 24), 3D with C_33 = 1."""
    energy = ENERGIES["solid"]
    K, mu = energy.params["K"], energy.params["mu"]
    F2, _ = state(seed)
    F = np.eye(3)
    F[:2, :2] = F2
    C = F.T @ F
    J = np.linalg.det(F)
    C_inv = np.linalg.inv(C)
    S = K * np.log(J) * C_inv - mu / 3 * J ** (-2 / 3) * np.trace(C) * C_inv + mu * J ** (-2 / 3) * np.eye(3)
    np.testing.assert_allclose(evaluate_energy(energy, F2, None)["P"], (F @ S)[:2, :2], rtol=1e-12, atol=1e-14)


def test_solid_reference_state_is_stress_free():
    q = evaluate_energy(ENERGIES["solid"], np.eye(2), np.zeros((2, 2, 2)))
    assert abs(q["psi"]) < 1e-15
    assert np.abs(q["P"]).max() < 1e-14


# ---------------------------------------------------------------------------- objectivity
@pytest.mark.parametrize("theta", [0.7, 2.5, -1.9])
@pytest.mark.parametrize("name", ["solid", "huhu", "huhu_lulu", "rotation", "huhu_lulu-scaled", "rotation-scaled"])
def test_objective(name, theta):
    """Psi(QF, QG) = Psi(F, G), hence P(QF, QG) = Q P and T(QF, QG) = Q T, with (QG)_ijk = Q_im G_mjk."""
    energy = ENERGIES[name]
    F, G = state(8)
    Q = rotation_matrix(theta)
    q = evaluate_energy(energy, F, G)
    rotated = evaluate_energy(energy, Q @ F, np.einsum("im,mjk->ijk", Q, G))
    assert rotated["psi"] == pytest.approx(q["psi"], rel=1e-12)
    np.testing.assert_allclose(rotated["P"], Q @ q["P"], rtol=1e-10, atol=1e-12 * np.abs(q["P"]).max())
    np.testing.assert_allclose(rotated["T"], np.einsum("im,mjk->ijk", Q, q["T"]), rtol=1e-10,
                               atol=1e-12 * np.abs(q["T"]).max())


@pytest.mark.parametrize("theta", [0.7, 2.5, -1.9, np.pi])
def test_tan_rotation_is_not_objective(theta):
    """Eq. 16 uses grad t = (1 + t^2) grad phi, t = tan(phi), and phi shifts under rotation.

    With g = gamma alpha_r / 2 |grad phi|^2 (objective), Psi_tan - Psi_rot = ((1 + t^2)^2 - 1) g, so
    Psi_tan(QF, QG) = Psi_rot(F, G) + ((1 + t_Q^2)^2 - 1) / ((1 + t^2)^2 - 1) (Psi_tan - Psi_rot)(F, G).
    Only a rotation by pi (t periodic) leaves it unchanged.
    """
    F, G = state(9)
    Q = rotation_matrix(theta)
    QF, QG = Q @ F, np.einsum("im,mjk->ijk", Q, G)
    t = lambda F: (F[0, 1] - F[1, 0]) / (F[0, 0] + F[1, 1])
    psi_rot = evaluate_energy(ENERGIES["rotation"], F, G)["psi"]
    psi_tan = evaluate_energy(ENERGIES["tan_rotation"], F, G)["psi"]
    psi_tan_rotated = evaluate_energy(ENERGIES["tan_rotation"], QF, QG)["psi"]
    factor = ((1 + t(QF) ** 2) ** 2 - 1) / ((1 + t(F) ** 2) ** 2 - 1)
    assert psi_tan_rotated == pytest.approx(psi_rot + factor * (psi_tan - psi_rot), rel=1e-10)
    if theta == np.pi:
        assert psi_tan_rotated == pytest.approx(psi_tan, rel=1e-12)
    else:
        assert abs(psi_tan_rotated - psi_tan) > 1e-2 * psi_tan


# ---------------------------------------------------------------------------- parameters and cache
@pytest.mark.parametrize("make, name", [
    (lambda: Hyperelastic(K=0.0, mu=1.0), "'K'"),
    (lambda: Hyperelastic(K=1.0, mu=-1.0), "'mu'"),
    (lambda: Hyperelastic(K=float("nan"), mu=1.0), "'K'"),
    (lambda: ThirdMedium(mu=0.0, gamma=1.0, alpha_r=1.0), "'mu'"),
    (lambda: ThirdMedium(mu=1.0, gamma=0.0, alpha_r=1.0), "'gamma'"),
    (lambda: ThirdMedium(mu=1.0, gamma=1.0, alpha_r=-1.0), "'alpha_r'"),
    (lambda: ThirdMedium(mu=1.0, gamma=1.0, alpha_r=1.0, beta=-5.0), "'beta'"),
    (lambda: ThirdMedium(mu=1.0, gamma=1.0, alpha_r=1.0, K=-1.0), "'K'"),
    (lambda: UserEnergy(user_psi, a="soft", b=1.0), "'a'"),
    (lambda: compile_kernels(ENERGIES["huhu"]).pack_constants({"mu": 1.0, "gamma": 1.0, "alpha_r": 1.0}), "'K'"),
    (lambda: compile_kernels(ENERGIES["solid"]).pack_constants({"K": 1.0, "mu": 1.0, "nu": 0.3}), "'nu'"),
    (lambda: compile_kernels(ENERGIES["solid"]).pack_constants({"K": 1.0, "mu": -1.0}), "'mu'"),
])
def test_invalid_parameters_are_named(make, name):
    with pytest.raises(ValueError, match=name):
        make()


def test_boundary_parameter_values_are_accepted():
    energy = ThirdMedium(mu=1.0, gamma=1.0, alpha_r=0.0, regularization="huhu", beta=0.0, K=0.0)
    assert energy.params == {"mu": 1.0, "gamma": 1.0, "alpha_r": 0.0, "K": 0.0, "beta": 0.0}


def test_unknown_regularization_lists_the_valid_ones():
    with pytest.raises(ValueError) as error:
        ThirdMedium(mu=1.0, gamma=1.0, alpha_r=1.0, regularization="hu-hu")
    assert all(name in str(error.value) for name in REGULARIZATIONS)


def test_gradient_free_declaration_is_checked():
    energy = UserEnergy(lambda F, G: ufl.inner(G, G) + ufl.det(F), uses_gradient=False, name="liar")
    with pytest.raises(ValueError, match="liar"):
        compile_kernels(energy)


def test_one_kernel_serves_every_parameter_value():
    assert compile_kernels(Hyperelastic(K=1.0, mu=2.0)) is compile_kernels(Hyperelastic(K=30.0, mu=4.0))
    kernels = compile_kernels(medium("rotation"))
    assert compile_kernels(medium("rotation", gamma=1e-6, mu=5.0)) is kernels
    assert compile_kernels(medium("rotation", beta=5.0)) is not kernels
    assert compile_kernels(medium("huhu")) is not kernels
    F, G = state(10)
    psi = [evaluate(kernels, F, G, medium("rotation", gamma=gamma).params)["psi"] for gamma in (1.0, 1e-5)]
    assert psi[1] == pytest.approx(1e-5 * psi[0], rel=1e-13)  # Psi is linear in gamma (Eq. 3)


# ---------------------------------------------------------------------------- skew penalty
@pytest.mark.parametrize("theta", [0.3, 1.2])
def test_skew_penalty_adds_beta1_half_w_squared(theta):
    """beta1/2 |w|^2 outside gamma: a rotation by theta adds beta1/2 (2 sin theta)^2 to the same
    medium without it, a stretch adds nothing, and the unregularized parameters drop it."""
    plain, penalised = medium("rotation"), medium("rotation", beta1=0.7)
    G = np.zeros((2, 2, 2))
    for F, w in ((rotation_matrix(theta), 2 * np.sin(theta)), (np.diag([1.3, 0.8]), 0.0)):
        added = evaluate_energy(penalised, F, G)["psi"] - evaluate_energy(plain, F, G)["psi"]
        assert abs(added - 0.7 / 2 * w ** 2) <= 1e-12 * max(1.0, w ** 2), (F, added)
    unregularized = penalised.unregularized_params()
    assert unregularized["beta1"] == 0.0 and unregularized["alpha_r"] == 0.0
    assert penalised.key != plain.key
    assert "skew penalty" in penalised.name and "skew" not in plain.name
