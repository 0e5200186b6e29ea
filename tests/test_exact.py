"""Exact answers for validating loads (dolfinx_sfvem.exact) and their meshes (thick_cylinder,
shallow_arch): the radial BVP checked against an energy differentiated here by sympy and finite
differences of the returned rho, its limits (Lamé, follower vs dead, medium with gamma = 0), and
the meshes' areas against the exact chord-polygon areas."""
from __future__ import annotations

import numpy as np
import pytest
import sympy

from dolfinx_sfvem import exact, meshes
from dolfinx_sfvem.meshes import MEDIUM, SOLID

A, B, K, MU = 1.0, 2.0, 5 / 3, 1.0   # the reference case of docs/validation-loads.md (Lamé lambda = mu)
P = 2 / 15                             # Lamé's u_r(a) = 0.1


# --------------------------------------------------------------------------- Eq. 2 differentiated here
def _radial_energy():
    """Psi(lambda_r, lambda_theta) of paper Eq. 2 in plane strain and its first derivatives (sympy)."""
    lr, lt, k, mu = sympy.symbols("lambda_r lambda_theta K mu", positive=True)
    J = lr * lt
    psi = k / 2 * sympy.log(J) ** 2 + mu / 2 * (J ** sympy.Rational(-2, 3) * (lr ** 2 + lt ** 2 + 1) - 3)
    return [sympy.lambdify((lr, lt, k, mu), sympy.diff(psi, x), "numpy") for x in (lr, lt)]


P1, P2 = _radial_energy()
STEP = 1e-3


def stretch(solution, R: np.ndarray) -> np.ndarray:
    """rho'(R) by fourth-order central differences of the returned rho."""
    rho = solution.rho
    return (rho(R - 2 * STEP) - 8 * rho(R - STEP) + 8 * rho(R + STEP) - rho(R + 2 * STEP)) / (12 * STEP)


def end_stretch(solution, R: float, inward: int) -> float:
    """rho'(R) at an end of the wall by fourth-order one-sided differences into the wall."""
    weights = np.array([-25, 48, -36, 16, -3]) / 12
    return inward * sum(w * solution.rho(R + inward * i * STEP) for i, w in enumerate(weights)) / STEP


def equilibrium_residuals(solution, pieces: int = 8) -> np.ndarray:
    """``[R P1]_{R0}^{R1} - int_{R0}^{R1} P2 dR`` (the integrated (R P1)' = P2) on ``pieces``
    intervals of the wall, P1 and P2 from the sympy derivatives, rho' from finite differences."""
    edges = np.linspace(solution.a + 3 * STEP, solution.b - 3 * STEP, pieces + 1)
    x, w = np.polynomial.legendre.leggauss(30)

    def R_P1(R):
        return R * P1(stretch(solution, R), solution.rho(R) / R, solution.K, solution.mu)

    residuals = []
    for R0, R1 in zip(edges[:-1], edges[1:]):
        R = (R0 + R1) / 2 + (R1 - R0) / 2 * x
        integral = (R1 - R0) / 2 * np.sum(w * P2(stretch(solution, R), solution.rho(R) / R, solution.K, solution.mu))
        residuals.append(R_P1(R1) - R_P1(R0) - integral)
    return np.array(residuals)


def end_P1(solution, at_outer: bool) -> float:
    R, inward = (solution.b, -1) if at_outer else (solution.a, 1)
    return float(P1(end_stretch(solution, R, inward), solution.rho(R) / R, solution.K, solution.mu))


def medium_dPsi(c: float, mu_m: float, K_m: float) -> float:
    """dPsi_m/dlambda_r at lambda_r = lambda_theta = c (Psi_m of Eq. 4 is Eq. 2 with the medium's moduli)."""
    return float(P1(c, c, K_m, mu_m))


# --------------------------------------------------------------------------- exact answers
def test_linearisation_of_eq2_is_lame_with_lambda_K_minus_two_thirds_mu():
    F = sympy.Matrix(2, 2, sympy.symbols("F11 F12 F21 F22"))
    k, mu = sympy.symbols("K mu", positive=True)
    J = F.det()
    psi = k / 2 * sympy.log(J) ** 2 + mu / 2 * (J ** sympy.Rational(-2, 3) * ((F.T * F).trace() + 1) - 3)
    identity = {F[0, 0]: 1, F[0, 1]: 0, F[1, 0]: 0, F[1, 1]: 1}
    lame = k - 2 * mu / 3
    for i, j, m, n in np.ndindex(2, 2, 2, 2):
        modulus = sympy.diff(psi, F[i, j], F[m, n]).subs(identity)
        expected = lame * int(i == j and m == n) + mu * (int(i == m and j == n) + int(i == n and j == m))
        assert sympy.simplify(modulus - expected) == 0, (i, j, m, n)


def test_lame_solution_solves_the_linear_problem():
    s = exact.lame_cylinder(A, B, K, MU, P)
    lame = K - 2 * MU / 3
    R = np.linspace(A + 0.01, B - 0.01, 7)
    du = (s.u_r(R + 1e-5) - s.u_r(R - 1e-5)) / 2e-5
    assert s.sigma_r(R) == pytest.approx((lame + 2 * MU) * du + lame * s.u_r(R) / R, abs=1e-9)
    assert s.sigma_theta(R) == pytest.approx(lame * du + (lame + 2 * MU) * s.u_r(R) / R, abs=1e-9)
    dsigma = (s.sigma_r(R + 1e-5) - s.sigma_r(R - 1e-5)) / 2e-5
    assert np.abs(dsigma + (s.sigma_r(R) - s.sigma_theta(R)) / R).max() < 1e-8
    assert s.sigma_r(A) == pytest.approx(-P) and abs(s.sigma_r(B)) < 1e-15
    assert s.inner_radius_change == pytest.approx(0.1, rel=1e-14)


@pytest.mark.parametrize("load", ["follower", "dead"])
def test_bvp_solution_satisfies_equilibrium_and_boundary_conditions(load):
    s = exact.pressurized_cylinder(A, B, K, MU, P, load)
    assert np.abs(equilibrium_residuals(s)).max() < 1e-8
    assert abs(end_P1(s, at_outer=True)) < 1e-8
    inner = -P * s.rho(A) / A if load == "follower" else -P
    assert end_P1(s, at_outer=False) == pytest.approx(inner, abs=1e-8)
    # the state's stretch is the derivative of its rho
    R = np.linspace(A + 0.05, B - 0.05, 9)
    assert s.stretches(R)[0] == pytest.approx(stretch(s, R), abs=1e-9)


def test_cauchy_stresses_at_the_surfaces():
    follower, dead = (exact.pressurized_cylinder(A, B, K, MU, P, load) for load in ("follower", "dead"))
    assert follower.sigma_r(A) == pytest.approx(-P, rel=1e-10)               # p per deformed length
    assert dead.sigma_r(A) == pytest.approx(-P * A / dead.rho(A), rel=1e-10)  # p per reference length
    for s in (follower, dead):
        assert abs(s.sigma_r(B)) < 1e-10
        assert s.cavity_area_change == pytest.approx(np.pi * (s.rho(A) ** 2 - A ** 2), rel=1e-14)
        assert s.inner_radius_change == pytest.approx(s.u_r(A), rel=1e-14)


def test_small_pressure_approaches_lame_linearly():
    def relative_difference(p: float) -> float:
        finite, lame = exact.pressurized_cylinder(A, B, K, MU, p), exact.lame_cylinder(A, B, K, MU, p)
        R = np.linspace(A, B, 11)
        return float(np.abs(finite.u_r(R) - lame.u_r(R)).max() / np.abs(lame.u_r(R)).max())

    differences = [relative_difference(p) for p in (1e-2, 5e-3, 2.5e-3)]
    assert differences[-1] < 0.02
    assert differences[0] / differences[1] == pytest.approx(2, rel=0.02)
    assert differences[1] / differences[2] == pytest.approx(2, rel=0.01)


def test_follower_and_dead_pressure_differ_at_second_order():
    def gap(p: float) -> float:
        return exact.pressurized_cylinder(A, B, K, MU, p).c - exact.pressurized_cylinder(A, B, K, MU, p, "dead").c

    gaps = [gap(p) for p in (2e-2, 1e-2, 5e-3)]
    assert all(g > 0 for g in gaps)   # the follower pressure acts on the grown surface
    assert gaps[0] / gaps[1] == pytest.approx(4, rel=0.03)
    assert gaps[1] / gaps[2] == pytest.approx(4, rel=0.015)


def test_medium_with_gamma_zero_is_the_follower_pressure():
    follower = exact.pressurized_cylinder(A, B, K, MU, P)
    medium = exact.pressurized_cylinder(A, B, K, MU, P, exact.CavityMedium(gamma=0.0, mu=MU))
    assert medium.c == pytest.approx(follower.c, rel=1e-13)
    R = np.linspace(A, B, 5)
    assert medium.rho(R) == pytest.approx(follower.rho(R), rel=1e-12)


@pytest.mark.parametrize("K_m", [0.0, 0.5])
def test_medium_filled_cylinder(K_m):
    gamma, mu_m = 0.05, 2.0
    s = exact.pressurized_cylinder(A, B, K, MU, P, exact.CavityMedium(gamma, mu_m, K_m))
    c = s.c
    assert s.p == pytest.approx(P, rel=1e-13)
    assert np.abs(equilibrium_residuals(s)).max() < 1e-8
    assert abs(end_P1(s, at_outer=True)) < 1e-8
    assert end_P1(s, at_outer=False) == pytest.approx(gamma * medium_dPsi(c, mu_m, K_m) - P * c, abs=1e-8)
    # the disc deforms homogeneously and its hydrostatic Cauchy stress meets the wall's sigma_r
    R = np.array([0.0, 0.3, 0.7, A])
    assert s.rho(R) == pytest.approx(c * R, rel=1e-14)
    assert s.stretches(R[1:3])[0] == pytest.approx([c, c])
    assert s.sigma_r(R[1:3]) == pytest.approx(s.sigma_theta(R[1:3]))
    assert s.sigma_r(0.5) == pytest.approx(s.sigma_r(A), rel=1e-10)
    # a stiffer medium holds the wall back
    follower = exact.pressurized_cylinder(A, B, K, MU, P)
    assert 1 < c < follower.c


@pytest.mark.parametrize("load", ["follower", "dead"])
def test_limit_pressure_and_the_path_beyond_it(load):
    peak = exact.limit_pressure(A, B, K, MU, load)
    beta = peak.rho(B) / B
    near = [exact.cylinder_at_outer_stretch(A, B, K, MU, beta * f, load).p for f in (0.99, 1.01)]
    assert max(near) < peak.p and peak.p - max(near) < 1e-3 * peak.p   # a smooth maximum
    beyond = exact.cylinder_at_outer_stretch(A, B, K, MU, 1.2 * beta, load)
    assert beyond.p < peak.p and beyond.c > peak.c
    assert np.abs(equilibrium_residuals(beyond)).max() < 1e-8 * peak.c
    inner = -beyond.p * beyond.c if load == "follower" else -beyond.p
    assert end_P1(beyond, at_outer=False) == pytest.approx(inner, abs=1e-8)
    # the pressure below the limit is found again on the rising branch
    again = exact.pressurized_cylinder(A, B, K, MU, 0.9 * peak.p, load)
    assert again.p == pytest.approx(0.9 * peak.p, rel=1e-13) and again.c < peak.c
    with pytest.raises(ValueError, match="exceeds the limit pressure"):
        exact.pressurized_cylinder(A, B, K, MU, 1.01 * peak.p, load)


def test_bad_input_is_named():
    with pytest.raises(ValueError, match="outer radius b"):
        exact.pressurized_cylinder(1.0, 1.0, K, MU, P)
    with pytest.raises(ValueError, match="modulus mu"):
        exact.lame_cylinder(A, B, K, -1.0, P)
    with pytest.raises(ValueError, match="load must be"):
        exact.pressurized_cylinder(A, B, K, MU, P, "medium")
    with pytest.raises(ValueError, match="gamma"):
        exact.CavityMedium(-1.0, MU)
    with pytest.raises(ValueError, match="reference radius R"):
        exact.pressurized_cylinder(A, B, K, MU, P).rho(0.5)


# --------------------------------------------------------------------------- meshes
def shoelace(xy: np.ndarray) -> float:
    return 0.5 * float(np.sum(xy[:, 0] * np.roll(xy[:, 1], -1) - np.roll(xy[:, 0], -1) * xy[:, 1]))


def region_area(mesh, tag: int) -> float:
    return sum(shoelace(mesh.polygon_coordinates(i)) for i in np.flatnonzero(mesh.tags == tag))


def segment_areas(bench, name: str) -> float:
    """Total area between the named arc and its chords (the mesh edges on it)."""
    arc = bench.arcs[name]
    pairs = bench.edges_on(name)
    chord = np.linalg.norm(np.diff(bench.mesh.points[pairs], axis=1)[:, 0], axis=1)
    phi = 2 * np.arcsin(chord / (2 * arc.radius))
    return float(np.sum(arc.radius ** 2 / 2 * (phi - np.sin(phi))))


@pytest.fixture(scope="module")
def cylinders():
    return {(polygons, h): meshes.thick_cylinder(A, B, h, filled=True, polygons=polygons)
            for polygons in ("dual", "triangles", "quads") for h in (0.2, 0.1)}


@pytest.mark.parametrize("polygons", ["dual", "triangles", "quads"])
def test_cylinder_areas_are_the_chord_polygons(cylinders, polygons):
    deficits = []
    for h in (0.2, 0.1):
        bench = cylinders[polygons, h]
        mesh = bench.mesh
        assert bench.regions == {"solid": SOLID, "cavity": MEDIUM} and mesh.region_names == bench.regions
        inner, outer = segment_areas(bench, "inner"), segment_areas(bench, "outer")
        wall, disc = region_area(mesh, SOLID), region_area(mesh, MEDIUM)
        assert wall == pytest.approx(np.pi * (B ** 2 - A ** 2) / 4 - outer + inner, rel=1e-12)
        assert disc == pytest.approx(np.pi * A ** 2 / 4 - inner, rel=1e-12)
        deficits.append((np.pi * A ** 2 / 4 - disc, np.pi * (B ** 2 - A ** 2) / 4 - wall))
    assert len(cylinders[polygons, 0.1].edges_on("outer")) == 2 * len(cylinders[polygons, 0.2].edges_on("outer"))
    (disc_coarse, wall_coarse), (disc_fine, wall_fine) = deficits
    assert 0 < disc_fine and disc_coarse / disc_fine == pytest.approx(4, rel=0.01)   # O(h^2), counts doubled
    assert 0 < wall_fine and wall_coarse / wall_fine == pytest.approx(4, rel=0.01)


@pytest.mark.parametrize("polygons", ["dual", "triangles", "quads"])
def test_cylinder_names(cylinders, polygons):
    bench = cylinders[polygons, 0.2]
    points = bench.mesh.points
    for name, xy in bench.points.items():
        assert np.array_equal(points[bench.vertex(name)], xy)
    for name, radius in (("inner", A), ("outer", B)):
        on = points[bench.vertices_on(name)]
        assert np.abs(np.hypot(*on.T) - radius).max() < 1e-12 and (on >= 0).all()
        pairs = bench.edges_on(name)
        chord = np.linalg.norm(np.diff(points[pairs], axis=1)[:, 0], axis=1)
        assert chord.sum() == pytest.approx(np.pi / 2 * radius, rel=0.01)   # they follow the whole quarter arc
        midpoints = np.hypot(*points[pairs].mean(axis=1).T)
        assert midpoints == pytest.approx(radius * np.cos(np.arcsin(chord / (2 * radius))), rel=1e-12)
        assert len(bench.nodes_on(name)) == 2 * len(pairs) + 1
    for name, component in (("axis_x", 0), ("axis_y", 1)):
        on = points[bench.vertices_on(name)]
        assert np.abs(on[:, component]).max() == pytest.approx(B) and np.abs(on[:, 1 - component]).max() == 0.0
        assert len(bench.edges_on(name)) == len(on) - 1


def test_cylinder_geometry_does_not_follow_h_and_whole_annulus():
    coarse, fine = meshes.thick_cylinder(h=0.2), meshes.thick_cylinder(h=0.1)
    assert (coarse.points, coarse.segments, coarse.arcs) == (fine.points, fine.segments, fine.arcs)
    assert coarse.regions == {"solid": SOLID}
    whole = meshes.thick_cylinder(h=0.2, quarter=False)
    assert region_area(whole.mesh, SOLID) == pytest.approx(4 * region_area(coarse.mesh, SOLID), rel=1e-12)
    assert len(whole.edges_on("inner")) == 4 * len(coarse.edges_on("inner")) and not whole.segments


def test_bad_mesh_input_is_named():
    with pytest.raises(ValueError, match="outer radius b"):
        meshes.thick_cylinder(2.0, 1.0)
    with pytest.raises(ValueError, match="polygons must be"):
        meshes.thick_cylinder(polygons="hexagons")
    with pytest.raises(ValueError, match="thickness"):
        meshes.shallow_arch(thickness=0.0)


@pytest.mark.parametrize("polygons", ["dual", "triangles", "quads"])
def test_shallow_arch(polygons):
    span, rise, t = 1.0, 0.1, 0.03
    bench = meshes.shallow_arch(0.01, polygons=polygons)
    mesh, points = bench.mesh, bench.mesh.points
    apex = points[bench.vertex("apex")]
    assert np.array_equal(apex, bench.points["apex"]) and apex == pytest.approx([0.0, rise + t / 2], abs=1e-15)
    assert np.array_equal(points[bench.vertex("apex_bottom")], bench.points["apex_bottom"])
    top = bench.arcs["top"]
    assert top.contains(apex[None], 1e-12)[0] and bench.vertex("apex") in bench.edges_on("top")
    assert top.radius - bench.arcs["bottom"].radius == pytest.approx(t)
    R = (span ** 2 / 4 + rise ** 2) / (2 * rise)
    assert top.centre == pytest.approx((0.0, rise - R)) and top.radius == pytest.approx(R + t / 2)
    # symmetric about x = 0: every point has its mirror image
    mirrored = points * [-1.0, 1.0]
    order, mirror_order = np.lexsort(points.T[::-1]), np.lexsort(mirrored.T[::-1])
    assert np.abs(points[order] - mirrored[mirror_order]).max() < 1e-12
    # the clamped faces: radial lines through the centre, mirror images of each other
    for name, sign in (("left_end", -1), ("right_end", 1)):
        on = points[bench.vertices_on(name)] - top.centre
        assert len(on) >= 4 and np.abs(on[:, 0] * on[0, 1] - on[:, 1] * on[0, 0]).max() < 1e-12
        assert np.sign(on[:, 0]).tolist() == [sign] * len(on)
    band = top.end - top.start
    exact_area = band / 2 * (top.radius ** 2 - bench.arcs["bottom"].radius ** 2)
    chords = segment_areas(bench, "top") - segment_areas(bench, "bottom")
    assert region_area(mesh, SOLID) == pytest.approx(exact_area - chords, rel=1e-12)
