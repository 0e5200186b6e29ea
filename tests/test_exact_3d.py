"""Exact answers in 3D (dolfinx_sfvem.exact): the thick sphere's radial BVP checked against Eq. 2
differentiated here by sympy and finite differences of the returned rho, its limits (Lamé written
with E and nu, follower vs dead, medium with gamma = 0), and Hertz's formulas against hand-computed
cases."""
from __future__ import annotations

import math

import numpy as np
import pytest
import sympy

from dolfinx_sfvem import exact

A, B, K, MU = 1.0, 2.0, 5 / 3, 1.0
E, NU = 9 * K * MU / (3 * K + MU), (3 * K - 2 * MU) / (2 * (3 * K + MU))


def _spherical_energy():
    """dPsi/dlambda_r and (1/2) dPsi/dlambda_theta of paper Eq. 2 in 3D under a radial deformation
    with two equal hoop stretches (sympy)."""
    lr, lt, k, mu = sympy.symbols("lambda_r lambda_theta K mu", positive=True)
    J = lr * lt ** 2
    psi = k / 2 * sympy.log(J) ** 2 + mu / 2 * (J ** sympy.Rational(-2, 3) * (lr ** 2 + 2 * lt ** 2) - 3)
    return (sympy.lambdify((lr, lt, k, mu), sympy.diff(psi, lr), "numpy"),
            sympy.lambdify((lr, lt, k, mu), sympy.diff(psi, lt) / 2, "numpy"))


P_R, P_THETA = _spherical_energy()
STEP = 1e-3


def stretch(solution, R):
    """rho'(R) by fourth-order central differences of the returned rho."""
    rho = solution.rho
    return (rho(R - 2 * STEP) - 8 * rho(R - STEP) + 8 * rho(R + STEP) - rho(R + 2 * STEP)) / (12 * STEP)


def end_stretch(solution, R, inward):
    weights = np.array([-25, 48, -36, 16, -3]) / 12
    return inward * sum(w * solution.rho(R + inward * i * STEP) for i, w in enumerate(weights)) / STEP


def lame_u(R, p):
    """The brief's Lamé formula in E and nu."""
    return p * A ** 3 / (E * (B ** 3 - A ** 3)) * ((1 - 2 * NU) * R + (1 + NU) * B ** 3 / (2 * R ** 2))


def test_lame_sphere_is_the_textbook_formula_in_E_and_nu_and_meets_its_boundary_conditions():
    p = 0.3
    s = exact.lame_sphere(A, B, K, MU, p)
    R = np.linspace(A, B, 7)
    assert s.u_r(R) == pytest.approx(lame_u(R, p), rel=1e-13)
    assert s.sigma_r(A) == pytest.approx(-p, rel=1e-13)
    assert s.sigma_r(B) == pytest.approx(0.0, abs=1e-14)
    assert s.cavity_volume_change == pytest.approx(4 * math.pi * A ** 2 * lame_u(A, p), rel=1e-13)
    with pytest.raises(AttributeError, match="volume"):
        s.cavity_area_change


@pytest.mark.parametrize("follower", [True, False])
def test_thick_sphere_satisfies_the_equilibrium_and_boundary_conditions(follower):
    p = 0.4
    s = exact.thick_sphere(A, B, K, MU, p, follower)
    # (R^2 P_r)' = 2 R P_theta, integrated over pieces of the wall with rho' from finite differences
    edges = np.linspace(A + 3 * STEP, B - 3 * STEP, 9)
    x, w = np.polynomial.legendre.leggauss(30)

    def R2_Pr(R):
        return R ** 2 * P_R(stretch(s, R), s.rho(R) / R, K, MU)

    scale = p * A ** 2
    for R0, R1 in zip(edges[:-1], edges[1:]):
        R = (R0 + R1) / 2 + (R1 - R0) / 2 * x
        integral = (R1 - R0) / 2 * np.sum(w * 2 * R * P_THETA(stretch(s, R), s.rho(R) / R, K, MU))
        assert abs(R2_Pr(R1) - R2_Pr(R0) - integral) < 1e-8 * scale
    c = s.rho(A) / A
    assert P_R(end_stretch(s, B, -1), s.rho(B) / B, K, MU) == pytest.approx(0.0, abs=1e-8 * p)
    assert P_R(end_stretch(s, A, 1), c, K, MU) == pytest.approx(-p * c ** 2 if follower else -p, rel=1e-8)
    assert s.cavity_volume_change == pytest.approx(4 / 3 * math.pi * (s.rho(A) ** 3 - A ** 3), rel=1e-13)
    assert s.outer_radius_change == pytest.approx(s.rho(B) - B, rel=1e-13)


def test_thick_sphere_tends_to_lame_as_p_vanishes():
    differences = []
    for p in (1e-2, 1e-3):
        s = exact.thick_sphere(A, B, K, MU, p)
        differences.append(abs(s.inner_radius_change / s.lame.inner_radius_change - 1))
        assert s.lame.inner_radius_change == pytest.approx(lame_u(A, p), rel=1e-13)
        assert s.outer_radius_change / lame_u(B, p) - 1 == pytest.approx(0.0, abs=20 * p)
    assert differences[0] / differences[1] == pytest.approx(10.0, rel=0.05)    # relative difference O(p)


def test_follower_and_dead_pressure_on_the_sphere_differ_by_the_area_change():
    p = 0.4
    follower, dead = exact.thick_sphere(A, B, K, MU, p), exact.thick_sphere(A, B, K, MU, p, follower=False)
    assert follower.inner_radius_change > dead.inner_radius_change > 0
    # the dead pressure p c^2 gives the same P_r(a) as the follower pressure p: the same solution
    same = exact.thick_sphere(A, B, K, MU, p * follower.c ** 2, follower=False)
    assert same.c == pytest.approx(follower.c, rel=1e-10)


def test_sphere_cavity_medium_without_stiffness_is_the_follower_pressure():
    p = 0.4
    medium = exact.thick_sphere(A, B, K, MU, p, medium=exact.CavityMedium(gamma=0.0, mu=MU))
    assert medium.c == pytest.approx(exact.thick_sphere(A, B, K, MU, p).c, rel=1e-10)
    assert medium.medium_stress == pytest.approx(-p, rel=1e-12)
    stiff = exact.thick_sphere(A, B, K, MU, p, medium=exact.CavityMedium(gamma=1e-2, mu=MU, K=K))
    assert stiff.c < medium.c     # (with K = 0 the medium's Psi is isochoric: a uniform dilation costs nothing)


def test_sphere_path_beyond_the_limit_pressure_is_refused_by_thick_sphere():
    ps = [exact.sphere_at_outer_stretch(A, B, K, MU, beta).p for beta in (1.05, 1.17, 1.6)]
    assert ps[1] > ps[0] and ps[2] < ps[1]              # a limit pressure between
    with pytest.raises(ValueError, match="limit pressure"):
        exact.thick_sphere(A, B, K, MU, 1.2 * ps[1])


def test_hertz_sphere_against_hand_computed_cases():
    rigid = exact.hertz_sphere(F=1.0, R=1.0, E1=1.0, nu1=0.0)          # E* = 1: a^3 = 3/4
    assert rigid.E_star == 1.0
    assert rigid.a == pytest.approx(0.9085602964160698, rel=1e-14)
    assert rigid.p0 == pytest.approx(3 / (2 * math.pi * 0.75 ** (2 / 3)), rel=1e-14)
    assert rigid.delta == pytest.approx(0.75 ** (2 / 3), rel=1e-14)
    both = exact.hertz_sphere(F=2.0, R=0.5, E1=2.0, nu1=0.5, E2=2.0, nu2=0.5)   # 1/E* = 2 x 0.75/2: E* = 4/3
    assert both.E_star == pytest.approx(4 / 3, rel=1e-15)
    assert both.a == pytest.approx((3 * 2.0 * 0.5 / (4 * 4 / 3)) ** (1 / 3), rel=1e-14)
    # Hertz's force-indentation law F = 4/3 E* sqrt(R) delta^(3/2)
    assert 4 / 3 * both.E_star * math.sqrt(0.5) * both.delta ** 1.5 == pytest.approx(2.0, rel=1e-13)
    # the mean pressure over the contact disc is 2/3 p0
    assert 2.0 / (math.pi * both.a ** 2) == pytest.approx(2 / 3 * both.p0, rel=1e-14)
    with pytest.raises(ValueError, match="nu1"):
        exact.hertz_sphere(1.0, 1.0, 1.0, 0.7)


@pytest.mark.parametrize("which", ["lame sphere", "finite sphere", "lame cylinder"])
def test_radial_field_is_the_radial_solution_in_cartesian_components(which):
    """u of exact.radial_field is u_r(R) e_r, its gradient that of u (central differences)."""
    solution = {"lame sphere": lambda: exact.lame_sphere(A, B, K, MU, 1e-3),
                "finite sphere": lambda: exact.thick_sphere(A, B, K, MU, 0.2, follower=False),
                "lame cylinder": lambda: exact.lame_cylinder(A, B, K, MU, 1e-3)}[which]()
    u_exact, grad_exact = exact.radial_field(solution)
    d = solution.hoop + 1
    X = np.random.default_rng(4).uniform(0.3, 1.2, (d, 6)) * np.array([1.0, 1.3, 0.9][:d])[:, None]
    R = np.linalg.norm(X, axis=0)
    X = X * np.clip(R, A + 0.05, B - 0.05) / R                          # inside the wall
    R = np.linalg.norm(X, axis=0)
    assert np.allclose(u_exact(X), solution.u_r(R) * X / R, rtol=1e-12, atol=1e-15)
    step = 1e-6
    numeric = np.stack([(u_exact(X + step * e[:, None]) - u_exact(X - step * e[:, None])) / (2 * step)
                        for e in np.eye(d)], axis=1)
    assert np.allclose(grad_exact(X), numeric, rtol=1e-7, atol=1e-9)
