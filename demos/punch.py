"""Punch problem (paper §5.3): a half-disc punch pressed into a soft block.

Problem
-------
A circular punch is pressed into a rectangular block by prescribing the vertical
displacement u_y of its flat top. The punch and the block are separated by a gap filled
with the third medium; contact is transmitted through the medium, which is severely
compressed under the punch, no contact algorithm is involved. By symmetry only the right
half is modelled.

Geometry and mesh (``dolfinx_sfvem.meshes.punch``, see meshes/README.md)
------------------------------------------------------------------------
Symmetry axis x = 0. Block [0, 2] x [0, 1] (L x H = 2 x 1 in the half model). Punch = the
lower right quarter of a disc of radius R = 1 centred at (0, 3): flat top y = 3 for
0 <= x <= 1, lowest point (0, 2), i.e. an initial gap of 1 above the block (the paper's
figure is missing; the gap 1 is our choice, with it the paper's u_y = -1.3 indents the
block by 0.3). Medium = the box [0, 2] x [1, 3] minus the punch. One gmsh triangle mesh of
size ``--h`` of all three regions, converted to its dual polygons (polygons everywhere,
conforming along the chords that follow the curved punch surface).

Boundary conditions (our reading of the paper's Fig. 9)
-------------------------------------------------------
- symmetry line x = 0 (block, medium and punch): u_x = 0 (``symmetry``);
- block bottom y = 0: clamped, u_x = u_y = 0 (``fixed``);
- punch top y = 3, 0 <= x <= 1: u_y = load * ``--uy`` (default -1.3), u_x free (``load``);
- everything else traction free (block side x = 2, medium outer sides).

Parameters
----------
Block: K = 5/3, mu = 5/14 (paper Eq. 2). Punch (``--punch``): ``soft`` the same as the block,
``rigid`` K = 500/3, mu = 500/14. Medium (Eq. 59): mu = 5/14 (the block's), gamma = 1e-4,
alpha_r = 1, regularization ``rotation``. 130 equal load steps by default. The rigid punch
needs the automatic step adjustment: a failed step is retried with half the increment (down
to ``--min-increment``, default (1/steps)/2^10) and the increment grows back after two
converged steps.

Outputs (in ``--out``)
----------------------
summary.json (parameters, DOFs, per step: load factor, Newton residuals, reactions of
``load`` = the punch force of the half model, ``fixed``, ``symmetry``; observers
``punch_uy`` (top of the punch on the axis, = the prescribed u_y), ``tip_uy`` (lowest point
of the punch), ``block_uy`` (top of the block on the axis) and ``gap`` (vertical distance
between the two on the axis, initially 1)), load_path.csv (one row per converged step),
displacement.xdmf, deformed.png (deformed mesh, paper Figs. 10/11), uy.png (u_y contour) and
reaction.png (punch force -R_y and gap against the punch displacement -u_y).

Paper runs
----------
Soft punch (Fig. 10) and rigid punch (Fig. 11)::

    mpirun -n 2 python3 demos/punch.py --punch soft --out out/punch-soft
    mpirun -n 2 python3 demos/punch.py --punch rigid --out out/punch-rigid

Measured on 2 (shared) cores: soft punch with ``--h 0.07`` (20550 unknowns), full load in
130 steps, 359 Newton iterations, 12 min; the default h = 0.05 has 36970 unknowns and costs
about 3 s per Newton iteration. Rigid punch with ``--h 0.1 --steps 65``: full load without
cut-back, 240 Newton iterations, 2.5 min.

Further options: ``python3 demos/punch.py --help``; PETSc options are passed through, e.g.
``-tmc_snes_monitor -tmc_snes_linesearch_type bt``.
"""
from __future__ import annotations

import argparse
import pathlib
import sys
import typing

from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem import paper
from dolfinx_sfvem.output.figure_output import save_png

import _common as common

#: block moduli (the soft punch and the medium's mu are the same)
K, MU = 5 / 3, 5 / 14
#: punch moduli by ``--punch``
PUNCH = {"soft": (K, MU), "rigid": (500 / 3, 500 / 14)}
#: initial gap between the punch tip and the block
GAP = paper.PUNCH_GAP


def make_parser() -> argparse.ArgumentParser:
    """The shared demo options with the punch defaults, plus ``--uy --punch --min-increment``."""
    p = common.parser("punch", __doc__, steps=130, meshes=(1,), h=paper.DEFAULT_H["punch"], h_max=0.25, gamma=1e-4,
                      alpha_r=1.0, regularization="rotation",
                      mesh_help="mesh variant (only 1: dual polygons everywhere)")
    common.add_uy(p, -1.3, "the punch top")
    p.add_argument("--punch", choices=tuple(PUNCH), default="soft",
                   help="punch material: soft = block's K = 5/3, mu = 5/14; rigid = K = 500/3, mu = 500/14 "
                        "(default %(default)s)")
    return p


def build(args: argparse.Namespace) -> tuple[sf.ContactProblem, dict]:
    """The punch problem of the command line.

    Returns
    -------
    problem
        Boundary conditions ``fixed`` (block bottom), ``symmetry`` (u_x = 0 on x = 0) and
        ``load`` (u_y on the punch top).
    observers
        ``punch_uy``, ``tip_uy``, ``block_uy``, ``gap`` (see the module docstring).
    """
    bench = sf.meshes.punch(h=args.h, gap=GAP)
    block, medium, punch = (bench.regions[n] for n in ("block", "medium", "punch"))
    K_p, mu_p = PUNCH[args.punch]
    problem = sf.ContactProblem(bench.mesh, {block: sf.Hyperelastic(K=K, mu=MU),
                                             punch: sf.Hyperelastic(K=K_p, mu=mu_p),
                                             medium: common.third_medium(args, mu=MU)},
                                **common.discretization(args))
    problem.fix(common.on_segment(*bench.segments["fixed"]), name="fixed")
    problem.fix(common.on_segment(*bench.segments["symmetry"]), components=(0,), name="symmetry")
    problem.prescribe(common.on_segment(*bench.segments["load"]), tags=[punch], uy=args.uy, name="load")

    top = bench.segments["load"][0]                       # (0, 3): punch top on the axis
    tip = common.displacement_observer(problem, common.at_point(bench.points["punch_tip"]), 1)
    block_top = common.displacement_observer(problem, common.at_point(bench.points["block_top"]), 1)
    gap0 = bench.points["punch_tip"][1] - bench.points["block_top"][1]
    observers = {"punch_uy": common.displacement_observer(problem, common.at_point(top), 1),
                 "tip_uy": tip, "block_uy": block_top,
                 "gap": lambda p: gap0 + tip(p) - block_top(p)}
    problem.parameters["geometry"] = {"L": 2.0, "H": 1.0, "R": 1.0, "gap": gap0, "half_model": True,
                                      "block_bottom": "clamped", "punch_top": "u_y prescribed, u_x free"}
    return problem, observers


def plot_reaction(out: pathlib.Path) -> None:
    """reaction.png: punch force -R_y (half model) and gap against the punch displacement -u_y."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = common.read_load_path(out / "load_path.csv")
    if not rows:
        return
    d = [-r["punch_uy"] for r in rows]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4), dpi=120)
    ax1.plot([0.0] + d, [0.0] + [-r["load_Ry"] for r in rows], ".-")
    ax1.set_xlabel("punch displacement -u_y")
    ax1.set_ylabel("punch force -R_y (half model)")
    ax2.plot([0.0] + d, [GAP] + [r["gap"] for r in rows], ".-")
    ax2.set_xlabel("punch displacement -u_y")
    ax2.set_ylabel("gap on the axis")
    for ax in (ax1, ax2):
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    save_png(fig, out / "reaction.png")


def main(argv: typing.Sequence[str] | None = None) -> int:
    """Parse ``argv`` (default ``sys.argv[1:]``), build and solve; returns the exit code (0 or 1)."""
    args = common.parse_args(make_parser(), argv)
    problem, observers = build(args)
    code = common.run(problem, args, observers)
    if MPI.COMM_WORLD.rank == 0:
        plot_reaction(args.out)
    return code


if __name__ == "__main__":
    sys.exit(common.exit_code(main))
