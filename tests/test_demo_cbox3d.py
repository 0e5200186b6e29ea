"""The 3D C-box demo (demos/cbox3d.py) on its coarsest grid (20 x 1 x 7 cells, P2 tetrahedra: one
compiled form for the whole file) at a small share of the point-contact load: equilibrium of the
reactions, 1 rank against 2, and the refusal of the SFVEM in 3D. The medium has the Hu-Hu
regularization here: the demo's default (rotation) compiles for minutes on a cold cache."""
from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

import cbox3d

#: the coarsest grid that resolves the C's wall (grid lines on x = 0.1, z = 0.1 and z = 0.6)
COARSE = ["--n", "20", "1", "7", "--cell", "tetrahedron", "--scale", "0.05", "--steps", "1", "--quiet",
          "--regularization", "huhu"]


def coarse_run(comm: MPI.Comm = MPI.COMM_WORLD, extra: tuple[str, ...] = ()) -> tuple[dict[str, list[float]], dict]:
    """The reactions and the last step's record after the coarse run on ``comm`` with the options
    ``extra`` (no output directory)."""
    args = cbox3d.common.parse_args(cbox3d.make_parser(), COARSE + list(extra))
    problem, _ = cbox3d.build(args, comm)
    result = problem.solve(control=cbox3d.common.load_stepping(args))
    assert result.converged
    return problem.reactions(), result.steps[-1]


def reactions(comm: MPI.Comm = MPI.COMM_WORLD) -> dict[str, list[float]]:
    """The reactions after the coarse run on ``comm``."""
    return coarse_run(comm)[0]


def test_reactions_balance():
    """No other load acts: the clamp holds exactly what the corner is pulled with (to Newton's
    tolerance); the corner is pushed down, so the internal force there points down."""
    r = reactions()
    load, clamp = np.array(r["load"]), np.array(r["clamp"])
    assert load[2] < 0.0                   # the internal force of the structure pushed down
    assert np.allclose(load + clamp, 0.0, atol=1e-6 * np.linalg.norm(load))


def test_iterative_solver_same_reactions():
    """--linear-solver iterative (GMRES + p-multigrid) reaches the direct solver's state: both
    Newton iterations end at the tolerance, so the reactions agree far below the load's size. The
    iterative run did not factorize the tangent: no negative-pivot count (LDL^T's) in its record."""
    (direct, direct_step), (iterative, iterative_step) = coarse_run(), coarse_run(extra=("--linear-solver", "iterative"))
    assert direct_step["negative_pivots"] is not None and iterative_step["negative_pivots"] is None
    for name in direct:
        assert np.allclose(iterative[name], direct[name], rtol=0.0, atol=1e-6 * np.abs(direct[name]).max())


def test_sfvem_refused():
    """The SFVEM on polyhedra is not there yet: --method vem is invalid input (exit code 2)."""
    assert cbox3d.common.exit_code(cbox3d.main, ["--method", "vem", "--quiet"]) == 2


@pytest.mark.mpi
def test_same_reactions_on_one_and_two_ranks():
    """The coarse run on all ranks and on each rank alone: the reactions agree to 1e-9."""
    world = reactions(MPI.COMM_WORLD)
    alone = reactions(MPI.COMM_SELF)
    for name in alone:
        assert np.allclose(world[name], alone[name], rtol=1e-9, atol=1e-12 * np.abs(alone[name]).max())
