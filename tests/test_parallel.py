"""Same results on 1 and 2 ranks (docs/method.md §1, §7).

Each test solves the same problem twice in one pytest process, on ``MPI.COMM_WORLD`` and
on ``MPI.COMM_SELF`` (every rank alone), and compares the load paths step by step:
point displacements (gathered on rank 0 by ``point_displacements``) and the reaction force
of every boundary condition. Run under ``mpirun -n 2`` this is "1 rank vs 2 ranks"; run
serially both are one rank and the tests still pass.

Meshes are generated on rank 0 and broadcast, so that every rank holds the same polygons
whatever gmsh does.
"""
import dataclasses
import functools

import numpy as np
import pytest
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem import meshes
from dolfinx_sfvem.path_following import snes as solver

pytestmark = pytest.mark.mpi

WORLD = MPI.COMM_WORLD
SOLID, MEDIUM = meshes.SOLID, meshes.MEDIUM


def on_rank_0(build):
    """``build()`` run on rank 0 of COMM_WORLD, its result broadcast to every rank."""
    return WORLD.bcast(build() if WORLD.rank == 0 else None, root=0)


@functools.lru_cache(maxsize=None)
def cbox_benchmark() -> meshes.Benchmark:
    """The C-box of paper §5.2 with a coarse solid (h = 0.1, about 100 polygons)."""
    return on_rank_0(lambda: meshes.cbox(0.1))


@functools.lru_cache(maxsize=None)
def beam_mesh() -> sf.PolygonMesh:
    """A 1 x 0.2 beam of Voronoi-like polygons."""
    return on_rank_0(lambda: meshes.polygon_rectangle(1.0, 0.2, 0.05, tag=SOLID))


def at_point(point):
    return lambda x: np.isclose(x[0], point[0]) & np.isclose(x[1], point[1])


def cbox_problem(comm: MPI.Comm) -> tuple[sf.ContactProblem, int]:
    """C-box closing its gap of 0.3 (u_y = -0.5 at the top-right corner, contact from ~ -0.3)."""
    bench = cbox_benchmark()
    problem = sf.ContactProblem(bench.mesh, {SOLID: sf.Hyperelastic(K=5 / 3, mu=5 / 14),
                                             MEDIUM: sf.ThirdMedium(mu=5 / 14, gamma=1e-5, alpha_r=1.0)},
                                comm=comm, verbose=False)
    problem.fix(lambda x: np.isclose(x[0], 0.0), name="fixed")
    problem.prescribe(at_point(bench.points["load"]), uy=-0.5, name="load")
    return problem, 10


def beam_problem(comm: MPI.Comm) -> tuple[sf.ContactProblem, int]:
    """Solid cantilever, tip moved by 1e-3 (almost linear elasticity), one step."""
    problem = sf.ContactProblem(beam_mesh(), {SOLID: sf.Hyperelastic(K=5 / 3, mu=5 / 14)}, comm=comm, verbose=False)
    problem.fix(lambda x: np.isclose(x[0], 0.0), name="fixed")
    problem.prescribe(lambda x: np.isclose(x[0], 1.0), uy=-1e-3, name="tip")
    return problem, 1


class DisplacementRecorder:
    """Observer: keeps the point displacements (rank 0) after every converged step and
    records their largest magnitude."""

    def __init__(self):
        self.history: list[np.ndarray | None] = []

    def __call__(self, problem: sf.ContactProblem) -> float:
        u = problem.point_displacements()
        self.history.append(u)
        return problem.comm.bcast(float(np.abs(u).max()) if problem.comm.rank == 0 else None, root=0)


def load_path(make_problem, comm: MPI.Comm) -> tuple[list[dict], list[np.ndarray | None]]:
    """Converged steps and point displacements per step of the problem solved on ``comm``."""
    problem, steps = make_problem(comm)
    recorder = DisplacementRecorder()
    result = problem.solve(steps, observers={"max_u": recorder})
    assert result.converged, result.message
    return [s for s in result.steps if s["converged"]], recorder.history


def relative_difference(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(np.asarray(a) - b) / np.linalg.norm(b))


@pytest.mark.parametrize("make_problem,rtol", [(cbox_problem, 1e-8), (beam_problem, 1e-10)], ids=["cbox", "beam"])
def test_same_load_path_on_world_and_self(make_problem, rtol):
    """The load path on all ranks equals the one on a single rank: the same converged steps
    (load factors, hence the same cut-backs), point displacements and reactions per step to
    ``rtol`` (1e-8 for the C-box through contact, 1e-10 for the almost linear beam)."""
    steps_world, u_world = load_path(make_problem, WORLD)
    steps_self, u_self = load_path(make_problem, MPI.COMM_SELF)
    assert [s["load"] for s in steps_world] == pytest.approx([s["load"] for s in steps_self], rel=1e-14)
    for world, alone in zip(steps_world, steps_self):
        assert world["reaction"].keys() == alone["reaction"].keys()
        for name, reaction in alone["reaction"].items():
            assert relative_difference(world["reaction"][name], reaction) < rtol, (world["load"], name)
    errors = [relative_difference(a, b) for a, b in zip(u_world, u_self)] if WORLD.rank == 0 else None
    errors = WORLD.bcast(errors, root=0)
    assert len(errors) == len(steps_self) and max(errors) < rtol, errors


def test_fallback_line_search_restarts_from_the_whole_start_state(monkeypatch):
    """A Newton solve that fails with the default line search is repeated with the fallback from
    its start state, ghost values included: here the first try leaves NaN in every local entry
    (owned and ghost, as a diverged iterate can) and counts no iterations (the adaptive increments
    follow the count), and the load path must equal the plain one."""
    plain_steps, plain_u = load_path(cbox_problem, WORLD)
    original = solver.SNESNewton._solve_once
    tries = []

    def first_try_diverges(self, x, g, load):
        result = original(self, x, g, load)
        if tries:
            return result
        tries.append(load)
        with x.localForm() as xl:
            xl.array[:] = np.nan
        return dataclasses.replace(result, converged=False, failure="diverged (test)", iterations=0)

    monkeypatch.setattr(solver.SNESNewton, "_solve_once", first_try_diverges)
    steps, u = load_path(cbox_problem, WORLD)
    assert tries and [s["load"] for s in steps] == [s["load"] for s in plain_steps]
    if WORLD.rank == 0:
        assert max(relative_difference(a, b) for a, b in zip(u, plain_u)) < 1e-10
