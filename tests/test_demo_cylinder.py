"""The thick-cylinder demo (demos/thick_cylinder.py) on a coarse mesh (h = 0.2) against the exact
answers of dolfinx_sfvem/exact.py: small p against Lamé, the finite p with follower, dead and
cavity pressure against the radial BVP of paper Eq. 2, SFVEM and FEM.

The tolerances are what the coarse mesh meets (measured: relative L2 errors 1.8e-4 to 2.1e-4,
u_r at the arc vertices 3.2e-4 at most, the recorded work conjugates 2.6e-4 to 2.7e-4 short,
all from the chords' O(h^2) geometric error; docs/thick-cylinder.md), and each test checks that
the answer of the wrong load misses them by far: the follower and dead answers differ by 11 % at
this pressure (the solution of one is 110 to 250 times the tolerances away from the other's
answer), Lamé's with Poisson's ratio 0.3 by 2-5 %, and the medium's stiffness moves u_r(a) by
0.5 %.
"""
from __future__ import annotations

import pathlib
import subprocess
import sys

import numpy as np
import pytest
import thick_cylinder as tc
from dolfinx_sfvem.mpi_launcher import job_environment
from process_report import report

DEMOS = pathlib.Path(__file__).resolve().parents[1] / "demos"

H = 0.2
#: relative L2 and H1 error, u_r error at the arc vertices (of u_r(a)), error of the work conjugate
TOLERANCE = {"L2": 5e-4, "H1": 5e-3, "u_r_inner": 1e-3, "u_r_outer": 1e-3, "conjugate_error": 1e-3}


def args(*options: str):
    return tc.common.parse_args(tc.make_parser(), ["--quiet", *options])


def solved(load: str, p: float, method: str, lame: bool = False, *options: str):
    """The coarse problem solved (one step at the small p, four otherwise) and its run records."""
    a = args(*options)
    benchmark = tc.benchmark_for(load, H, method, a)
    problem = tc.build(load, p, method, benchmark, a)
    result = problem.solve(1 if lame else 4)
    assert result.converged, result.message
    return problem, tc.RunSummary.from_dict(result.summary), benchmark


def assert_within(r: dict) -> None:
    for key, tolerance in TOLERANCE.items():
        assert abs(r[key]) < tolerance, (key, r[key])


def assert_missed(r: dict, factor: float) -> None:
    """The wrong answer's L2 error and u_r(a) error exceed ``factor`` times the tolerance."""
    assert r["L2"] > factor * TOLERANCE["L2"] and r["u_r_inner"] > factor * TOLERANCE["u_r_inner"], r


def test_exact_field_is_the_radial_solution():
    """u_exact and grad_exact of the demo in Cartesian components: u = u_r(R) e_r in the wall
    (u_r of exact.py), (c - 1) X in the medium, the gradient against central differences of u;
    the chord test puts a point 1.5 sagittas inside R = a on the medium's side, one at half a
    sagitta on the wall's."""
    gamma = 1e-2
    solution = tc.exact.pressurized_cylinder(tc.A_IN, tc.B_OUT, tc.K, tc.MU, tc.P_REF, tc.medium_of(gamma))
    answer = tc.radial_answer("cavity", tc.P_REF, gamma)
    vertices = np.array([[np.cos(t), np.sin(t)] for t in np.linspace(0.0, np.pi / 2, 9)])
    inside = tc.inside_chords(vertices)
    mid, sagitta = np.pi / 32, 1 - np.cos(np.pi / 32)       # the middle of the first chord and its sagitta
    X = np.array([[(1 - 1.5 * sagitta) * np.cos(mid), (1 - 0.5 * sagitta) * np.cos(mid), 1.3, 0.2],
                  [(1 - 1.5 * sagitta) * np.sin(mid), (1 - 0.5 * sagitta) * np.sin(mid), 0.9, 0.1]])
    assert inside(X).tolist() == [True, False, False, True]
    u_exact, grad_exact = tc.exact_field(answer, inside)
    wall, medium = X[:, 2:3], X[:, 3:4]
    R = np.hypot(*wall)
    np.testing.assert_allclose(u_exact(wall), solution.u_r(R) * wall / R, rtol=1e-12)
    np.testing.assert_allclose(u_exact(medium), (solution.c - 1) * medium, rtol=1e-12)
    step = 1e-6
    for point in (wall, medium):
        for j in range(2):
            dX = step * np.eye(2)[:, j:j + 1]
            derivative = (u_exact(point + dX) - u_exact(point - dX)) / (2 * step)
            np.testing.assert_allclose(grad_exact(point)[:, j, 0], derivative[:, 0], atol=1e-8)


@pytest.mark.parametrize("method", ["vem", "fem"])
def test_small_pressure_against_lame(method):
    """p = 1e-6 x 2/15: the coarse mesh within the tolerances of Lamé's solution; a Lamé solution
    with Poisson's ratio 0.3 instead of 0.25 (a wrong linearisation of Eq. 2) would not be."""
    problem, run, benchmark = solved("follower", tc.P_SMALL, method, True)
    assert_within(tc.compare(problem, run, tc.lame_answer(tc.P_SMALL), benchmark))
    poisson_03 = 2 * 1.3 / (3 * 0.4)                       # K of nu = 0.3 (mu = 1)
    assert_missed(tc.compare(problem, run, tc.lame_answer(tc.P_SMALL, bulk=poisson_03), benchmark), 10)


#: the pressures of the load-scale test: 1e-6 and 1e-4 in the small-strain regime, 0.1 finite
LOAD_SCALES = (1e-6, 1e-4, 0.1)


@pytest.mark.parametrize("method", ["vem", "fem"])
def test_default_tolerance_converges_at_every_load_scale(method):
    """Follower pressure p = 1e-6, 1e-4 and 0.1 in one step on the default Newton options (the
    absolute tolerance follows the residual's round-off floor ||K|| h, docs/method.md §6): each
    converges within the coarse mesh's tolerances of the BVP of its own p, and at the two small
    p the relative L2 errors agree within 1 %: the error is the discretization's (the same
    linear problem), not the solver's. Before the floor, p = 1e-6 stalled with FEM (52
    iterations at the round-off level 3.5e-16 against atol 8e-20)."""
    errors = {}
    for p in LOAD_SCALES:
        problem, run, benchmark = solved("follower", p, method, True)
        errors[p] = tc.compare(problem, run, tc.radial_answer("follower", p, 0.0), benchmark)
        assert_within(errors[p])
    assert errors[1e-6]["L2"] == pytest.approx(errors[1e-4]["L2"], rel=1e-2)
    assert errors[1e-6]["u_r_inner"] == pytest.approx(errors[1e-4]["u_r_inner"], rel=1e-2)


@pytest.mark.parametrize("method", ["vem", "fem"])
@pytest.mark.parametrize("load", ["follower", "dead"])
def test_finite_pressure_against_the_bvp(method, load):
    """p = 2/15 (u_r(a) about 0.1 a): within the tolerances of the BVP of its own load, and at least
    50 times outside them against the other load's answer (follower - dead = O(p^2) = 11 % here)."""
    problem, run, benchmark = solved(load, tc.P_REF, method)
    assert_within(tc.compare(problem, run, tc.radial_answer(load, tc.P_REF, 0.0), benchmark))
    other = "dead" if load == "follower" else "follower"
    assert_missed(tc.compare(problem, run, tc.radial_answer(other, tc.P_REF, 0.0), benchmark), 50)


@pytest.mark.mpi
@pytest.mark.parametrize("method", ["vem", "fem"])
def test_cavity_pressure_against_the_bvp_with_medium(method):
    """The hole filled with medium (gamma = 1e-2, mu_m = 1) under cavity_pressure on the quarter
    (closed by the symmetry lines): within the tolerances of the BVP with the medium, and five
    times outside them against the answer without the medium's stiffness (gamma = 0, the follower
    pressure's): the medium holds u_r(a) back by 0.5 %."""
    problem, run, benchmark = solved("cavity", tc.P_REF, method, False, "--gamma", "1e-2")
    assert_within(tc.compare(problem, run, tc.radial_answer("cavity", tc.P_REF, 1e-2), benchmark))
    assert_missed(tc.compare(problem, run, tc.radial_answer("cavity", tc.P_REF, 0.0), benchmark), 5)


def test_demo_writes_its_comparison(tmp_path):
    """The command line: a dead-pressure run writes cylinder.md and cylinder.png, and its numbers
    are those of the coarse test above."""
    proc = subprocess.run([sys.executable, str(DEMOS / "thick_cylinder.py"), "--load", "dead", "--h", str(H),
                           "--quiet", "--out", str(tmp_path)], capture_output=True, text=True, timeout=300,
                          env=job_environment())
    assert proc.returncode == 0, report(proc)
    assert (tmp_path / "cylinder.png").is_file()
    table = (tmp_path / "cylinder.md").read_text().splitlines()[-1].split("|")
    L2, conjugate = float(table[5]), float(table[9])
    assert L2 < TOLERANCE["L2"]
    assert conjugate == pytest.approx(tc.radial_answer("dead", tc.P_REF, 0.0).conjugate, rel=TOLERANCE["conjugate_error"])


@pytest.mark.parametrize("method", ["vem", "fem"])
@pytest.mark.parametrize("load", ["follower", "cavity"])
def test_first_step_takes_a_handful_of_iterations(method, load):
    """p = 2/15 in four steps: the first step from the stress-free state takes no more than 4
    Newton iterations (3 measured, the later steps 2)."""
    _, run, _ = solved(load, tc.P_REF, method)
    iterations = [s.newton_iterations for s in run.steps]
    assert len(iterations) == 4 and iterations[0] <= 4, iterations
