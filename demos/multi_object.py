"""Contact of multiple objects (paper §5.4): seven hard half-discs pressed into a soft block.

Problem
-------
Seven very stiff half-discs are pushed down onto a long soft block by prescribing the
vertical displacement u_y of their flat tops. The third medium fills all the cavities
between the discs and the block; every contact is transmitted through it, no contact search
is involved. Two sets of boundary conditions (``--bc``):

- ``--bc 1``: block clamped at both ends (u_x = u_y = 0 on x = 0 and x = 8); the discs are
  moved by u_y with u_x = 0 (pure vertical motion);
- ``--bc 2``: block clamped at the left end, simply supported at the right end (u_y = 0 on
  x = 8, u_x free: a roller that lets the end section rotate); the discs are moved by u_y
  with u_x free, so they slide with the bending block and drag the medium along.

Geometry and mesh (``dolfinx_sfvem.meshes.multi_object``, see meshes/README.md)
-------------------------------------------------------------------------------
Block [0, 8] x [0, 0.2]. Seven half-discs of radius R = 0.2, all above the block, evenly
spaced at x_i = 1, 2, ..., 7, flat side up at y = 0.5, round side down with its lowest point
(x_i, 0.3), i.e. an initial gap of 0.1 to the block (the paper's Fig. 12 is missing: the
placement and the gap are our choice). Medium = the box [0, 8] x [0.2, 0.5] minus the discs
(all the cavities between the parts); the block bottom is free. One gmsh triangle mesh of
size ``--h`` of all regions converted to its dual polygons (polygons everywhere).

Loading (our choice, the paper gives no value)
----------------------------------------------
The whole flat top of every disc (the segment y = 0.5, |x - x_i| <= R, disc nodes only) is
moved by u_y = load * ``--uy``, the same for all seven discs. The default u_y = -0.3 is three
times the gap: after closing the gap of 0.1 the discs push the block down by another 0.2
(its thickness). What to expect with this geometry: the block is very compliant in bending
(EI ~ 0.02 over a span of 8), so it does not resist the discs, it follows them. Discs 1 and 7,
next to the supports, close their gap, press into the block and bend it down; beyond them
the block keeps the slope they impose (lever effect of the clamped end) and sinks slightly
below the middle discs, which stay separated from it by stretched medium. With ``--bc 2``
the outer discs also slide along the inclined block towards the middle (disc 1 by ~ 0.1).

Parameters
----------
Block: K = 50, mu = 10; discs: K = 50000, mu = 10000 (paper Eq. 2). Medium (Eq. 59):
mu = 10 (the block's), gamma = 1e-4, alpha_r = 10, regularization ``rotation``. 30 equal load
steps by default (the paper gives none); failed steps are cut back automatically (down to
``--min-increment``).
Newton stops at |R| <= 1e-8 (give ``-tmc_snes_atol`` to change it): tighter than the library's
default, which follows the round-off level of the residual and, with the stiff discs, lies
at a few 1e-6 (the residual stagnates at 2e-10 .. 5e-10).

Outputs (in ``--out``)
----------------------
summary.json (parameters, DOFs, per step: load factor, Newton residuals, reactions of
``discs`` = the total force on the seven discs, ``left``, ``right``; observers
``disc{i}_ux``, ``disc{i}_uy`` at the centre of the flat top of discs i = 1, 4, 7 and
``tip{i}_uy`` at their lowest points), load_path.csv (one row per converged step),
displacement.xdmf, deformed.png (deformed mesh, paper Figs. 13/14), uy.png (u_y contour) and
reaction.png (total disc force -R_y against -u_y, and the horizontal disc displacements) and
zoom.png (the deformed mesh around discs 1-2 and 3-5 at true scale).

Paper runs
----------
::

    mpirun -n 2 python3 demos/multi_object.py --bc 1 --out out/multi-bc1
    mpirun -n 2 python3 demos/multi_object.py --bc 2 --out out/multi-bc2

Further options: ``python3 demos/multi_object.py --help``; PETSc options are passed through,
e.g. ``-tmc_snes_monitor -tmc_snes_linesearch_type bt``.
"""
from __future__ import annotations

import argparse
import functools
import pathlib
import sys
import typing

import numpy as np
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem import paper
from dolfinx_sfvem.output.figure_output import save_png
from dolfinx_sfvem.output.run_summary import read_summary

import _common as common

#: block moduli (the medium has the same mu)
K_BLOCK, MU_BLOCK = 50.0, 10.0
#: disc moduli
K_DISC, MU_DISC = 50000.0, 10000.0
#: initial gap between a disc and the block
GAP = paper.MULTI_OBJECT_GAP
#: number of discs
N_DISCS = 7
#: discs whose displacement is recorded
OBSERVED = (1, 4, 7)
#: absolute Newton tolerance of this demo, 20 to 50 times the round-off floor of the residual with
#: the stiff discs (|R| stagnates at 2e-10 .. 5e-10); the library default would be a few 1e-6
SNES_ATOL = "1e-8"


def make_parser() -> argparse.ArgumentParser:
    """The shared demo options with the multi-object defaults, plus ``--bc --uy --min-increment``."""
    p = common.parser("multi_object", __doc__, steps=30, meshes=(1,), h=paper.DEFAULT_H["multi_object"], h_max=GAP,
                      gamma=1e-4, alpha_r=10.0, regularization="rotation",
                      mesh_help="mesh variant (only 1: dual polygons everywhere)")
    p.add_argument("--bc", type=int, choices=(1, 2), default=1,
                   help="1: block clamped at both ends, discs u_x = 0; 2: block clamped left, "
                        "simply supported right, discs u_x free (default %(default)s)")
    common.add_uy(p, -0.3, "the discs' flat tops", " = -3 x gap")
    return p


def build(args: argparse.Namespace) -> tuple[sf.ContactProblem, dict]:
    """The multiple-object problem of the command line.

    Returns
    -------
    problem
        Boundary conditions ``left``, ``right`` (block ends) and ``discs`` (the flat tops).
    observers
        ``disc{i}_ux``, ``disc{i}_uy``, ``tip{i}_uy`` for i in :data:`OBSERVED`.
    """
    bench = sf.meshes.multi_object(h=args.h, gap=GAP)
    block, medium, discs = (bench.regions[n] for n in ("block", "medium", "discs"))
    problem = sf.ContactProblem(bench.mesh, {block: sf.Hyperelastic(K=K_BLOCK, mu=MU_BLOCK),
                                             discs: sf.Hyperelastic(K=K_DISC, mu=MU_DISC),
                                             medium: common.third_medium(args, mu=MU_BLOCK)},
                                **common.discretization(args))
    problem.fix(common.on_segment(*bench.segments["left_end"]), name="left")
    problem.fix(common.on_segment(*bench.segments["right_end"]), components=(0, 1) if args.bc == 1 else (1,),
                name="right")
    tops = [common.on_segment(*bench.segments[f"disc_top_{i}"]) for i in range(1, N_DISCS + 1)]

    def on_tops(x):
        return functools.reduce(lambda a, b: a | b, (top(x) for top in tops))

    problem.prescribe(on_tops, tags=[discs], uy=args.uy, ux=0.0 if args.bc == 1 else None, name="discs")

    centres = [((a[0] + b[0]) / 2, a[1]) for a, b in (bench.segments[f"disc_top_{i}"]
                                                       for i in range(1, N_DISCS + 1))]
    observers = {}
    for i in OBSERVED:
        centre = common.at_point(centres[i - 1])
        tip = common.at_point(bench.points[f"disc_tip_{i}"])
        observers[f"disc{i}_ux"] = common.displacement_observer(problem, centre, 0)
        observers[f"disc{i}_uy"] = common.displacement_observer(problem, centre, 1)
        observers[f"tip{i}_uy"] = common.displacement_observer(problem, tip, 1)
    problem.parameters["geometry"] = {
        "block": [8.0, 0.2], "R": 0.2, "disc_centres_x": [x for x, _ in centres], "gap": GAP,
        "discs_driven_by": "flat tops",
        "boundary_conditions": ("block clamped at both ends, discs u_x = 0" if args.bc == 1 else
                                "block clamped left, u_y = 0 on the right end, discs u_x free")}
    return problem, observers


def plot_reaction(out: pathlib.Path) -> None:
    """reaction.png: total disc force -R_y against -u_y; disc displacements u_x against -u_y."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = common.read_load_path(out / "load_path.csv")
    if not rows:
        return
    d = [0.0] + [-r[f"disc{OBSERVED[0]}_uy"] for r in rows]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4), dpi=120)
    ax1.plot(d, [0.0] + [-r["discs_Ry"] for r in rows], ".-")
    ax1.axvline(GAP, color="0.6", ls="--", lw=0.8)
    ax1.set_ylabel("total disc force -R_y")
    for i in OBSERVED:
        ax2.plot(d, [0.0] + [r[f"disc{i}_ux"] for r in rows], ".-", label=f"disc {i}")
    ax2.set_ylabel("disc displacement u_x (top centre)")
    ax2.legend()
    for ax in (ax1, ax2):
        ax.set_xlabel("disc displacement -u_y")
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    save_png(fig, out / "reaction.png")


def plot_zoom(path: pathlib.Path, mesh, u, windows: typing.Sequence[tuple[float, float]], title: str) -> None:
    """PNG of the deformed polygons (coloured by region) in the x-windows of the reference
    configuration, one panel each, at true scale: the whole 8 x 0.5 strip is too thin to
    show the contact zones in deformed.png."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection

    x = mesh.points + u
    off, verts = mesh.offsets, mesh.vertices
    centre_x = np.array([mesh.points[verts[off[e]:off[e + 1]], 0].mean() for e in range(mesh.n_polygons)])
    colours = {tag: plt.get_cmap("Pastel1")(k) for k, tag in enumerate(np.unique(mesh.tags))}
    fig, axes = plt.subplots(len(windows), 1, figsize=(9, 2.6 * len(windows)), dpi=120, squeeze=False)
    for ax, (x0, x1) in zip(axes[:, 0], windows):
        chosen = np.flatnonzero((centre_x >= x0) & (centre_x <= x1))
        ax.add_collection(PolyCollection([x[verts[off[e]:off[e + 1]]] for e in chosen],
                                         facecolors=[colours[mesh.tags[e]] for e in chosen],
                                         edgecolors="k", linewidths=0.3))
        ax.autoscale()
        ax.set_aspect("equal")
        ax.set_title(f"{title}, reference x in [{x0:g}, {x1:g}]", fontsize=9)
    fig.tight_layout()
    save_png(fig, path)


def main(argv: typing.Sequence[str] | None = None) -> int:
    """Parse ``argv`` (default ``sys.argv[1:]``), build and solve; returns the exit code (0 or 1)."""
    args = common.parse_args(make_parser(), argv)
    problem, observers = build(args)
    atol = common.petsc_options(args).get("snes_atol", SNES_ATOL)    # a command-line -tmc_snes_atol wins
    problem.parameters["snes_atol"] = atol
    problem.petsc_options["snes_atol"] = atol
    code = common.run(problem, args, observers)
    u = problem.point_displacements()                     # collective; the last converged state
    if MPI.COMM_WORLD.rank == 0:
        plot_reaction(args.out)
        summary = read_summary(args.out)
        load = summary.load_reached if summary else 0.0
        plot_zoom(args.out / "zoom.png", problem.disc.output_mesh, u, ((0.0, 2.6), (2.7, 5.3)),
                  f"bc {args.bc}, load factor {load:.3g}")
    return code


if __name__ == "__main__":
    sys.exit(common.exit_code(main))
