"""Continuation in the medium's gamma along the path (dolfinx_sfvem/path_following/gamma_continuation.py).

Two blocks across a medium layer (conftest.py ``two_blocks``), the top pressed down by 0.1 (the
layer squeezed to half its height) at gamma = 1e-6. With ``gamma_start=1e-4`` every step is
solved at gamma(λ) = 1e-4^(1 - λ) 1e-6^λ, recorded per step; the final state must be the
equilibrium of the problem as given (the same as the path at gamma = 1e-6 throughout: the
equilibrium is unique here), summary.json must keep the asked gamma (a resume compares it) and
the material is back at its own gamma afterwards.
"""
import math

import numpy as np
import pytest

import dolfinx_sfvem as sf
from dolfinx_sfvem.path_following.gamma_continuation import GammaContinuation
from dolfinx_sfvem.output.run_summary import read_summary

GAMMA, START = 1e-6, 1e-4


def pressed(two_blocks) -> sf.ContactProblem:
    materials = two_blocks.materials()
    materials[two_blocks.MEDIUM] = sf.ThirdMedium(mu=two_blocks.MU, gamma=GAMMA, alpha_r=1.0)
    problem = sf.ContactProblem(two_blocks.mesh(), materials, verbose=False)
    problem.fix(lambda x: np.isclose(x[1], 0.0), name="fixed")
    problem.prescribe(lambda x: np.isclose(x[1], 2.2), ux=0.0, uy=-0.1, name="top")
    return problem


def test_the_schedule_runs_log_linearly_from_the_start_to_the_asked_gamma():
    medium = sf.ThirdMedium(mu=1.0, gamma=GAMMA, alpha_r=1.0)
    stiff = sf.ThirdMedium(mu=1.0, gamma=1e-3, alpha_r=1.0)
    c = GammaContinuation({1: medium, 2: stiff, 3: sf.Hyperelastic(K=1.0, mu=1.0)}, START)
    assert c.gamma(GAMMA, 0.0) == pytest.approx(START, rel=1e-14)
    assert c.gamma(GAMMA, 1.0) == pytest.approx(GAMMA, rel=1e-14)
    assert c.gamma(GAMMA, 0.5) == pytest.approx(math.sqrt(START * GAMMA), rel=1e-14)
    c.set_load(0.25)
    assert medium.params["gamma"] == pytest.approx(START ** 0.75 * GAMMA ** 0.25, rel=1e-14)
    assert stiff.params["gamma"] == 1e-3, "a medium at or above the start keeps its gamma"
    with c.as_asked():
        assert medium.params["gamma"] == GAMMA
    c.restore()
    assert medium.params["gamma"] == GAMMA
    with pytest.raises(ValueError, match="no ThirdMedium"):
        GammaContinuation({1: sf.Hyperelastic(K=1.0, mu=1.0)}, START)
    with pytest.raises(ValueError, match="> 0"):
        GammaContinuation({1: medium}, -1.0)


def test_the_continued_path_ends_at_the_equilibrium_of_the_asked_gamma(two_blocks, tmp_path):
    direct = pressed(two_blocks)
    assert direct.solve(control=sf.LoadStepping(4, adaptive=False, predictor=False)).converged
    problem = pressed(two_blocks)
    result = problem.solve(control=sf.LoadStepping(4, adaptive=False, predictor=False), out=tmp_path,
                           gamma_start=START)
    assert result.converged and result.stable, result.message
    for step in result.steps:
        assert step["extra"]["gamma"] == pytest.approx(START ** (1 - step["load"]) * GAMMA ** step["load"], rel=1e-12)
    u, u_direct = problem.point_displacements(), direct.point_displacements()
    assert np.abs(u - u_direct).max() < 1e-7 * np.abs(u_direct).max()
    assert problem.materials[two_blocks.MEDIUM].params["gamma"] == GAMMA
    summary = read_summary(tmp_path)
    assert summary.parameters["materials"][str(two_blocks.MEDIUM)]["gamma"] == GAMMA
    assert summary.parameters["gamma_continuation"]["gamma_start"] == START


def test_arc_length_refuses_the_continuation(two_blocks):
    problem = pressed(two_blocks)
    with pytest.raises(ValueError, match="prescribed load factor"):
        problem.solve(control=sf.ArcLength(), gamma_start=START)
