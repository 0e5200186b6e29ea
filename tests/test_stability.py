"""Unstable converged states are reported, never taken silently as the answer (dolfinx_sfvem/path_following/stability.py).

A clamped-clamped strut (plane strain, L = 1, thickness t = 0.04, a symmetric quad mesh)
compressed by a prescribed end shortening: Newton follows the straight (trivial) branch, which is
an equilibrium at every shortening but loses stability at Euler's load. For a clamped-clamped
strut the critical strain of the first mode is eps_1 = 4 pi^2 EI / (L^2 EA) = pi^2 t^2 / (3 L^2)
and the second (antisymmetric) mode's is 2.046 eps_1 (8.183 pi^2 EI / L^2), independent of E
(plane strain: E / (1 - nu^2) in both). So the tangent has 0 negative pivots below eps_1, 1
between eps_1 and 2.046 eps_1 and 2 above; every state past eps_1 must be reported unstable:
per step (``stable`` False, UNSTABLE in the progress line), in summary.json and the Result, and by
a warning.
"""
import json
import logging
import logging.handlers

import numpy as np
import pytest
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem import meshes
from dolfinx_sfvem.output.run_summary import read_summary
from dolfinx_sfvem.path_following.stability import is_stable

import results_report

L, T = 1.0, 0.04
EULER = np.pi ** 2 * T ** 2 / (3 * L ** 2)      # first critical strain, clamped-clamped
SECOND = 2.046 * EULER                           # second mode (antisymmetric)
STEPS, END = 24, 2.4                             # shortening up to END x EULER in STEPS equal steps


@pytest.fixture(scope="module")
def compressed(tmp_path_factory):
    out = tmp_path_factory.mktemp("strut")
    strip = meshes.quad_rectangle(L, T, 20, 2, tag=meshes.SOLID)
    problem = sf.ContactProblem(strip, {meshes.SOLID: sf.Hyperelastic(K=5 / 3, mu=5 / 14)}, comm=MPI.COMM_WORLD)
    problem.fix(lambda x: np.isclose(x[0], 0.0), name="clamped")
    problem.prescribe(lambda x: np.isclose(x[0], L), ux=-END * EULER * L, uy=0.0, name="end")
    handler = logging.handlers.BufferingHandler(capacity=100_000)      # keeps every record
    logger = logging.getLogger("dolfinx_sfvem")
    logger.addHandler(handler)
    try:
        result = problem.solve(control=sf.LoadStepping(STEPS, adaptive=False, predictor=False), out=out)
    finally:
        logger.removeHandler(handler)
    return result, out, handler.buffer


def test_the_straight_strut_loses_stability_at_eulers_strains(compressed):
    result, _, _ = compressed
    assert result.converged, result.message
    strain = np.array([s["load"] for s in result.steps]) * END * EULER
    pivots = np.array([s["negative_pivots"] for s in result.steps])
    assert np.all(pivots[strain < 0.95 * EULER] == 0)
    assert np.all(pivots[(strain > 1.1 * EULER) & (strain < 0.95 * SECOND)] == 1)
    assert np.all(pivots[strain > 1.05 * SECOND] == 2)
    stable = np.array([s["stable"] for s in result.steps])
    assert list(stable) == list(pivots == 0)


def test_an_unstable_final_state_is_reported_everywhere(compressed):
    result, out, records = compressed
    assert result.stable is False
    data = json.loads((out / "summary.json").read_text())
    assert data["converged"] is True and data["stable"] is False
    summary = read_summary(out)
    assert summary.stable is False and summary.final_step.stable is False
    assert results_report.status(summary) == "full load, unstable"
    progress = [r.getMessage() for r in records if r.levelno == logging.INFO and r.getMessage().startswith("step")]
    assert sum("UNSTABLE (1 negative pivot)" in line for line in progress) > 0
    assert sum("UNSTABLE (2 negative pivots)" in line for line in progress) > 0
    assert not any("UNSTABLE" in line for line in progress[:int(0.95 * STEPS / END)])
    warnings = [r.getMessage() for r in records if r.levelno == logging.WARNING]
    if MPI.COMM_WORLD.rank == 0:
        assert len(warnings) == 2, warnings           # entering the unstable branch, and the final state
        assert "UNSTABLE" in warnings[0] and "not an answer" in warnings[1]


def test_stability_is_not_judged_under_arc_length_nor_without_the_inertia():
    assert is_stable(0, False) is True and is_stable(1, False) is False
    assert is_stable(1, True) is None, "arc-length traces unstable branches on purpose"
    assert is_stable(None, False) is None, "LU gives no inertia"
    assert sf.ArcLength().traces_unstable_branches and not sf.LoadStepping(4).traces_unstable_branches
