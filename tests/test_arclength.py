"""Arc-length control (dolfinx_sfvem/path_following/arclength.py): a shallow clamped arch snapping through under a
force at its apex.

- The path passes the upper limit point (the load factor falls after it), records the unstable
  branch (negative pivots > 0 between the two limit points, 0 outside) and lands on load factor 1.
- Displacement control at the apex traces the same curve: the force it needs at the apex
  displacements of the arc-length path agrees.
- A resumed arc-length run continues exactly; a stop criterion on the apex displacement ends the
  path there; arc-length without any load to scale is refused.
"""
import logging
import shutil

import numpy as np
import pytest
import scipy.interpolate
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem import meshes

COMM = MPI.COMM_WORLD
SOLID = meshes.SOLID
SPAN, RISE, THICK = 1.0, 0.08, 0.02
APEX = (0.5, RISE + THICK)
MODULUS = 1e3


def arch_mesh(nx: int = 24) -> sf.PolygonMesh:
    """A parabolic shallow arch: a strip of nx x 2 quads bent to y + RISE (1 - (2x - 1)²)."""
    strip = meshes.quad_rectangle(SPAN, THICK, nx, 2, tag=SOLID)
    points = strip.points.copy()
    points[:, 1] += RISE * (1 - (2 * points[:, 0] / SPAN - 1) ** 2)
    return sf.PolygonMesh(points, [strip.polygon(i) for i in range(strip.n_polygons)], strip.tags)


def arch(method: str = "vem") -> sf.ContactProblem:
    problem = sf.ContactProblem(arch_mesh(), {SOLID: sf.Hyperelastic(K=5 / 3 * MODULUS, mu=5 / 14 * MODULUS)},
                                method=method, comm=COMM, verbose=False)
    problem.fix(lambda x: np.isclose(x[0], 0.0) | np.isclose(x[0], SPAN), name="clamped")
    return problem


def snap(method: str = "vem", **control) -> tuple[sf.ContactProblem, list[dict]]:
    problem = arch(method)
    problem.point_force(APEX, fy=-1.0, name="apex")
    result = problem.solve(control=sf.ArcLength(**{"load_step": 0.002, **control}))
    assert result.converged, result.message
    return problem, result.steps


@pytest.fixture(scope="module")
def path():
    return snap()[1]


@pytest.mark.mpi
def test_arc_length_passes_the_limit_point_and_records_the_unstable_branch(path):
    loads = np.array([s["load"] for s in path])
    w = np.array([s["loads"]["apex"]["displacement"] for s in path])
    pivots = np.array([s["negative_pivots"] for s in path])
    top = int(np.argmax(loads[:len(loads) // 2]))
    assert 0 < top and loads[top + 1] < loads[top], "the load factor falls after the upper limit point"
    assert np.all(np.diff(w) > 0), "the apex moves down monotonically along this path"
    assert loads[-1] == pytest.approx(1.0, abs=1e-12)
    rise = np.diff(loads) > 0
    falling_both_sides = ~rise[:-1] & ~rise[1:]        # points inside the falling branch
    rising_both_sides = rise[:-1] & rise[1:]
    assert falling_both_sides.sum() >= 3 and np.all(pivots[1:-1][falling_both_sides] >= 1), "the falling branch is unstable"
    assert np.all(pivots[1:-1][rising_both_sides] == 0), "the rising branches are stable"
    assert w[-1] > 2 * RISE, "snapped through: the apex ends below the chord of the arch's ends"


def test_displacement_control_traces_the_same_curve(path):
    """The apex moved by prescribed u_y through the arc-length path's apex displacements needs the
    force λ |f| of the arc-length points (interpolated), on the unstable branch as well."""
    problem = arch()
    w_end = 0.12
    problem.prescribe(lambda x: np.hypot(x[0] - APEX[0], x[1] - APEX[1]) < 1e-10, uy=-w_end, name="apex")
    result = problem.solve(control=sf.LoadStepping(24, adaptive=False, predictor=False))   # evenly sampled
    assert result.converged, result.message
    w = np.array([s["load"] * w_end for s in result.steps])
    force = np.array([-s["reaction"]["apex"][1] for s in result.steps])
    w_al = np.array([s["loads"]["apex"]["displacement"] for s in path])
    force_al = np.array([s["loads"]["apex"]["magnitude"] for s in path])
    along_path = scipy.interpolate.CubicSpline(w_al, force_al)(w)
    np.testing.assert_allclose(force, along_path, atol=5e-3 * force_al.max(initial=0.0, where=w_al < w_end))
    assert force.max() == pytest.approx(force_al[w_al < w_end].max(), rel=2e-3)


def upper_limit(path: list[dict]) -> float:
    """The upper limit load factor: the maximum of a cubic spline of the load factor against the
    apex displacement between the neighbours of the path's highest point."""
    w = np.array([s["loads"]["apex"]["displacement"] for s in path])
    load = np.array([s["load"] for s in path])
    top = int(np.argmax(load[:len(load) // 2]))
    return float(scipy.interpolate.CubicSpline(w, load)(np.linspace(w[top - 1], w[top + 1], 2001)).max())


def test_fem_limit_load_is_close(path):
    """The P2 FEM on a matched triangulation finds the upper limit load within 1 % of the SFVEM's
    on this coarse arch (measured: 0.55 %; on the snap-through demo's finer arch they agree to 6e-6,
    tests/test_demo_snap_through.py)."""
    _, fem = snap("fem")
    assert upper_limit(fem) == pytest.approx(upper_limit(path), rel=1e-2)


def test_stop_criterion(path):
    """stop=("apex", 0.06) ends the path at the first step past 0.06 (on the unstable branch, load
    factor below 1), as converged, at the points of the whole path."""
    problem = arch()
    problem.point_force(APEX, fy=-1.0, name="apex")
    result = problem.solve(control=sf.ArcLength(load_step=0.002, stop=("apex", 0.06)))
    assert result.converged and result.load < 0.5
    w = [s["loads"]["apex"]["displacement"] for s in result.steps]
    assert w[-1] >= 0.06 > w[-2]
    np.testing.assert_allclose([s["load"] for s in result.steps], [s["load"] for s in path[:len(w)]], rtol=1e-9)


def test_resume_continues_exactly(tmp_path, path):
    """A copy of the run directory taken in the middle of the path (the checkpoint of step 8,
    before the limit point) resumes to the same points as the uninterrupted run."""
    run, copy = tmp_path / "run", tmp_path / "copy"

    def keep_step_8(problem):          # called at step 9, before its checkpoint is written
        if len(list(run.glob("summary.json"))) and not copy.exists() and problem.load > path[7]["load"]:
            shutil.copytree(run, copy)
        return 0.0
    first = arch()
    first.point_force(APEX, fy=-1.0, name="apex")
    first.solve(out=run, control=sf.ArcLength(load_step=0.002, stop=("apex", 0.06)), observers={"copy": keep_step_8})
    resumed = arch()
    resumed.point_force(APEX, fy=-1.0, name="apex")
    result = resumed.solve(out=copy, resume=True, control=sf.ArcLength(load_step=0.002, stop=("apex", 0.06)),
                           observers={"copy": lambda problem: 0.0})
    assert result.converged
    n = len(result.steps)
    np.testing.assert_allclose([s["load"] for s in result.steps], [s["load"] for s in path[:n]], rtol=1e-10)
    with pytest.raises(ValueError, match="cannot resume"):       # the stop criterion is part of the run
        other = arch()
        other.point_force(APEX, fy=-1.0, name="apex")
        other.solve(out=copy, resume=True, control=sf.ArcLength(load_step=0.002, stop=("apex", 0.07)))


def test_bordered_newton_prints_with_the_snes_monitor(capfd):
    """``-tmc_snes_monitor`` prints every residual norm of the bordered Newton iterations (which
    run outside SNES): one line per recorded norm of every attempt."""
    problem = arch()
    problem.point_force(APEX, fy=-1.0, name="apex")
    result = problem.solve(control=sf.ArcLength(load_step=0.002, stop=("apex", 0.01)),
                           petsc_options={"snes_monitor": ""})
    assert result.converged and result.load < 1.0           # no landing on λ = 1: every step was bordered
    printed = [line for line in capfd.readouterr().out.splitlines() if "SNES Function norm" in line]
    norms = [norm for s in result.steps for norm in s["residual_norms"]]
    assert len(printed) == len(norms) > len(result.steps)
    np.testing.assert_allclose([float(line.split()[-1]) for line in printed], norms, rtol=1e-10)


def test_failed_bordered_attempts_record_their_snes_reason():
    """``-tmc_snes_max_it 1`` bounds the bordered iterations, and the attempts that need more are
    recorded with SNES's DIVERGED_MAX_IT (not the domain error of J <= 0); an option that does not
    reach the bordered iterations (``snes_stol``) is named at the start."""
    problem = arch()
    problem.point_force(APEX, fy=-1.0, name="apex")
    warnings = []
    handler = logging.Handler(logging.WARNING)
    handler.emit = warnings.append
    logger = logging.getLogger("dolfinx_sfvem.path_following.arclength")
    logger.addHandler(handler)
    try:
        result = problem.solve(control=sf.ArcLength(load_step=0.05, min_shrink=2.0 ** -3, max_steps=2),
                               petsc_options={"snes_max_it": 1, "snes_stol": 0})
    finally:
        logger.removeHandler(handler)
    failed = [s for s in result.attempts if not s["converged"]]
    assert failed and all(len(s["residual_norms"]) == 2 for s in failed)
    assert all("SNES reason -5 (DIVERGED_MAX_IT)" in s["failure"] for s in failed)
    assert any("-tmc_snes_stol do not apply to its bordered Newton iterations" in w.getMessage() for w in warnings)


def test_arc_length_without_a_load_is_refused():
    problem = arch()
    with pytest.raises(ValueError, match="without any load to scale"):
        problem.solve(control=sf.ArcLength())
    with pytest.raises(ValueError, match="load_step must be a positive"):
        sf.ArcLength(load_step=0.0)
    with pytest.raises(ValueError, match="steps and min_increment belong to the default load stepping"):
        arch().solve(10, control=sf.ArcLength())
