"""The thick-sphere demo (demos/thick_sphere.py) on its coarsest mesh (h = 0.3, 5.5 k unknowns):
follower pressure p = 0.2 on the 1/8 shell against the finite-strain radial BVP of paper Eq. 2.

The tolerance is the mesh's geometric error: the flat faces of the inner sphere put the P2 edge
midpoints a sagitta l^2 / (8 a) inside it, so the discrete cavity is smaller and the wall stiffer
than the exact ones by O(h^2). Measured (docs: the demo's gallery page): u_r(a) 2.7 % short at
h = 0.3, 1.5 % at h = 0.2, the same for Lamé at a small p, falling as h^2. The answer of the wrong
load (dead: 14 % below) and a linear (Lamé) answer (15 % below) miss the 4 % tolerance by far.
"""
from __future__ import annotations

import pytest

import thick_sphere as ts

H = 0.3
#: relative error of u_r(a) (mean over the inner vertices, and the largest) and of the cavity's volume change
TOLERANCE = 0.04


@pytest.fixture(scope="module")
def follower_run():
    args = ts.common.parse_args(ts.make_parser(), ["--quiet"])
    problem = ts.build("follower", ts.P_REF, H, args)
    result = problem.solve(2)
    assert result.converged, result.message
    return problem, ts.RunSummary.from_dict(result.summary)


@pytest.mark.mpi
def test_follower_pressure_against_the_bvp(follower_run):
    """Also on 2 ranks (1 and 2 ranks agree to 1e-15 on the cavity run at h = 0.5, measured)."""
    problem, run = follower_run
    r = ts.compare(problem, run, ts.answer_for("follower", ts.P_REF, 0.0))
    assert -TOLERANCE < r["u_r_mean"] < 0, r                 # the discrete cavity is the smaller: u_r short
    assert r["u_r_max"] < TOLERANCE and abs(r["conjugate_error"]) < TOLERANCE, r


@pytest.mark.parametrize("wrong", ["dead", "lame"])
def test_the_wrong_answers_are_missed(follower_run, wrong):
    """The dead-pressure BVP and Lamé's linear answer at the same p lie 2.5 times the tolerance away."""
    problem, run = follower_run
    answer = ts.answer_for("follower", ts.P_REF, 0.0, lame=True) if wrong == "lame" else \
        ts.answer_for("dead", ts.P_REF, 0.0)
    assert ts.compare(problem, run, answer)["u_r_mean"] > 2.5 * TOLERANCE


def test_sfvem_on_the_tetrahedra_has_the_p2_geometric_error():
    """The SFVEM on the tetrahedra of h = 0.5 read as polyhedra, at the small p against Lamé: the flat
    faces make the cavity too small for both methods alike (measured: u_r(a) -3.79 % SFVEM, -3.66 % P2,
    the P2 interpolation error being of higher order). With the face means of the symmetry planes'
    triangles left free (a marker of the P2 nodes only) the SFVEM came out at -0.05 %, too soft."""
    def error(method):
        args = ts.common.parse_args(ts.make_parser(), ["--quiet", "--method", method])
        return ts.solve("follower", ts.SMALL * ts.P_REF, 0.5, args, lame=True)["u_r_mean"]
    vem, fem = error("vem"), error("fem")
    assert -2.5 * TOLERANCE < vem < 0 and -2.5 * TOLERANCE < fem < 0
    assert abs(vem - fem) < 0.005
