"""The 3D C-box demo (demos/cbox3d.py) on its coarsest grid (20 x 1 x 7 cells, P2 tetrahedra: one
compiled form for the whole file) at a small share of the point-contact load: equilibrium of the
reactions, 1 rank against 2, and the SFVEM on the hexahedra against Q2. The medium has the Hu-Hu
regularization here: the demo's default (rotation) compiles for minutes on a cold cache."""
from __future__ import annotations

import json

import numpy as np
import pytest
from mpi4py import MPI

import cbox3d

#: the coarsest grid that resolves the C's wall (grid lines on x = 0.1, z = 0.1 and z = 0.6)
COARSE = ["--n", "20", "1", "7", "--cell", "tetrahedron", "--scale", "0.05", "--steps", "1", "--quiet",
          "--regularization", "huhu"]


def coarse(method: str = "fem") -> list[str]:
    """The coarse command line: P2 tetrahedra for the FEM, the SFVEM on the grid's hexahedra."""
    cell = "tetrahedron" if method == "fem" else "hexahedron"
    at = COARSE.index("--cell")
    return COARSE[:at] + ["--cell", cell] + COARSE[at + 2:] + ["--method", method]


def solved(comm: MPI.Comm = MPI.COMM_WORLD, argv: list[str] | None = None):
    """The converged coarse problem on ``comm`` (no output directory) and its last step's record."""
    args = cbox3d.common.parse_args(cbox3d.make_parser(), argv or coarse())
    problem, _ = cbox3d.build(args, comm)
    result = problem.solve(control=cbox3d.common.load_stepping(args))
    assert result.converged
    return problem, result.steps[-1]


def run(comm: MPI.Comm = MPI.COMM_WORLD, argv: list[str] | None = None):
    """The converged coarse problem on ``comm``."""
    return solved(comm, argv)[0]


def reactions(comm: MPI.Comm = MPI.COMM_WORLD, method: str = "fem") -> dict[str, list[float]]:
    """The reactions after the coarse run on ``comm``."""
    return run(comm, coarse(method)).reactions()


def test_reactions_balance():
    """No other load acts: the clamp holds exactly what the corner is pulled with (to Newton's
    tolerance); the corner is pushed down, so the internal force there points down."""
    r = reactions()
    load, clamp = np.array(r["load"]), np.array(r["clamp"])
    assert load[2] < 0.0                   # the internal force of the structure pushed down
    assert np.allclose(load + clamp, 0.0, atol=1e-6 * np.linalg.norm(load))


def test_sfvem_on_the_hexahedra_follows_q2():
    """The SFVEM on the coarse grid's hexahedra read as polyhedra (the same 5535 unknowns as Q2):
    converged, the clamp carries the corner's load, the gap stays open, and the corner's reaction
    is within the coarse grid's discretization error of Q2's (12 % measured; the refinement study
    is bench/cbox3d_vem_fem.py)."""
    hexahedra = coarse("fem")
    hexahedra[hexahedra.index("tetrahedron")] = "hexahedron"
    vem, fem = run(MPI.COMM_SELF, coarse("vem")), run(MPI.COMM_SELF, hexahedra)
    assert vem.disc.num_dofs_global == fem.disc.num_dofs_global
    r_vem, r_fem = (np.array(p.reactions()["load"]) for p in (vem, fem))
    assert np.allclose(r_vem + np.array(vem.reactions()["clamp"]), 0.0, atol=1e-6 * np.linalg.norm(r_vem))
    assert vem.contact_gap().value > 0.0
    assert np.linalg.norm(r_vem - r_fem) < 0.2 * np.linalg.norm(r_fem)


def test_iterative_solver_same_reactions(tmp_path):
    """--linear-solver iterative (GMRES + p-multigrid), the whole demo with its outputs, reaches the
    direct solver's state: both Newton iterations end at the tolerance, so the reactions agree far
    below the load's size. The iterative run did not factorize the tangent: no negative-pivot count
    (LDL^T's) in its record, an empty field in load_path.csv that the curves read as NaN."""
    direct, direct_step = solved(argv=coarse())
    out = tmp_path / "iterative"
    assert cbox3d.main(coarse() + ["--linear-solver", "iterative", "--out", str(out)]) == 0
    last = json.loads((out / "summary.json").read_text())["steps"][-1]
    assert direct_step["negative_pivots"] is not None and last["negative_pivots"] is None
    assert (out / "curves.png").exists()
    rows = cbox3d.common.read_load_path(out / "load_path.csv")
    assert np.isnan(rows[-1]["negative_pivots"]) and rows[-1]["load"] == last["load"]
    direct = direct.reactions()
    for name in direct:
        assert np.allclose(last["reaction"][name], direct[name], rtol=0.0, atol=1e-6 * np.abs(direct[name]).max())


@pytest.mark.mpi
@pytest.mark.parametrize("method", ["fem", "vem"])
def test_same_reactions_on_one_and_two_ranks(method):
    """The coarse run on all ranks and on each rank alone: the reactions agree to 1e-9 of their size
    (a component that is zero by symmetry carries round-off of about 1e-12 of it)."""
    world = reactions(MPI.COMM_WORLD, method)
    alone = reactions(MPI.COMM_SELF, method)
    for name in alone:
        assert np.allclose(world[name], alone[name], rtol=0.0, atol=1e-9 * np.abs(alone[name]).max())


def test_tetrahedra_and_hexahedra_agree_under_a_patch_load():
    """The corner's displacement on the 0.35 x 0.35 square of the top face at the corner
    (--load-patch) on the 20 x 2 x 7 grid: P2 on its tetrahedra and Q2 on its hexahedra (the same
    unknowns) agree on the reaction's main component R_y within 2 % (1.1 % measured) and on the
    whole reaction better than on the corner point alone (2.3 % against 4.1 %). R_z differs by 8 %
    because of the medium's element-wise Hu-Hu term, which a P2 tetrahedron hardly feels (its
    Hessian is constant) and a Q2 hexahedron does: without it (alpha_r = 0) R_z differs by 2 %
    (docs/notes/2026-11-26-cbox3d-reactions-regularization.md)."""
    def load_reaction(cell, patch, *extra):
        argv = coarse("fem") + ["--scale", "0.1", "--n", "20", "2", "7", *extra]
        argv[argv.index("tetrahedron")] = cell
        argv += ["--load-patch", "0.35"] if patch else []
        return np.array(run(MPI.COMM_SELF, argv).reactions()["load"])
    hexa, tet = (load_reaction(cell, True) for cell in ("hexahedron", "tetrahedron"))
    assert abs(tet[1] - hexa[1]) < 0.02 * abs(hexa[1])
    point = [load_reaction(cell, False) for cell in ("hexahedron", "tetrahedron")]
    assert np.linalg.norm(point[1] - point[0]) / np.linalg.norm(point[0]) > \
        np.linalg.norm(tet - hexa) / np.linalg.norm(hexa)
    plain = [load_reaction(cell, True, "--alpha-r", "0") for cell in ("hexahedron", "tetrahedron")]
    assert abs(plain[1][2] - plain[0][2]) < 0.03 * abs(plain[0][2]) < abs(tet[2] - hexa[2]) / 2


def test_end_face_load_moves_the_whole_end_face_and_balances():
    """--load-end prescribes every node of the upper beam's end face x = 2, z >= 0.6 (and none of
    the lower beam's or the medium's): their displacement is the corner's, and the clamp holds the
    face's reaction. Giving --load-patch as well is refused."""
    args = cbox3d.common.parse_args(cbox3d.make_parser(), coarse() + ["--load-end"])
    problem, _ = cbox3d.build(args)
    problem.solve(control=cbox3d.common.load_stepping(args))
    u = problem.displacement()
    x = u.function_space.tabulate_dof_coordinates()
    on_end = np.isclose(x[:, 0], 2.0) & (x[:, 2] >= 0.6 - 1e-10)
    below = np.isclose(x[:, 0], 2.0) & (x[:, 2] < 0.6 - 1e-10)
    values = u.x.array.reshape(-1, 3)[: len(x)]
    assert on_end.sum() > 4 and np.allclose(values[on_end, 1:], [0.05 * 0.25, -0.05 * 1.0])
    assert not np.allclose(values[below, 2], -0.05)
    r = problem.reactions()
    assert np.allclose(np.add(r["load"], r["clamp"]), 0.0, atol=1e-6 * np.linalg.norm(r["load"]))
    with pytest.raises(ValueError, match="not both"):
        cbox3d.build(cbox3d.common.parse_args(cbox3d.make_parser(), coarse() + ["--load-end", "--load-patch", "0.2"]))
