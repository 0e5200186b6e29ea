"""3D C-box self-contact (Wriggers et al. 2025, as dolfiny's ``demo/tmc/3D/Cbox_Wriggers_3D.py``).

Problem
-------
A C-shaped block, clamped on its face x = 0, is closed by moving one corner of its upper beam's
tip: the upper beam bends down and twists until it touches the lower beam. Contact goes through
the third medium that fills the inside of the C; no contact algorithm is involved.

Geometry and mesh (``sf.meshes.cbox3d``)
----------------------------------------
The box [0, 2] x [0, 0.7] x [0, 0.7], wall thickness 0.1: the C lies in the x-z plane and is
extruded along y (wall x <= 0.1, beams z <= 0.1 and z >= 0.6); the medium fills x >= 0.1,
0.1 <= z <= 0.6, open at x = 2, y = 0 and y = 0.7. A tensor-product grid of ``--n nx ny nz``
cells (default 20 4 7; nx must put a grid line on x = 0.1 and nz on z = 0.1 and 0.6), or of
size about ``--h``; ``--tip-refinement K`` splits the cells within 0.4 of x = 2 and 0.35 of
y = 0 (the medium under the moved corner, where the point contact squeezes it) into K in x and
y. Q2 hexahedra (``--cell hexahedron``, default) or P2 tetrahedra, each hexahedron split into 6
(``--cell tetrahedron``: the same nodes, so the same unknowns).

Parameters
----------
Solid: E = 5, nu = 0.3 (K = 25/6, mu = 25/13), Eq. 2. Medium: the same mu, bulk modulus
``--medium-K`` (default the solid's K, as dolfiny, whose medium is the solid's material scaled by
gamma), ``--gamma`` (default 1e-5), ``--alpha-r`` (default 10), ``--regularization`` (default
rotation, Eq. 15 in its 3D form; dolfiny: gamma = 2e-6 and the rotation regularization on
auxiliary fields, with weights of order one not scaled by gamma, i.e. a far stiffer
regularization than alpha_r = 10). Face x = 0 clamped; the corner (2, 0, 0.7) moved by
(u_y, u_z) = (0.25, -1.0) ("point contact", ``--contact point``, default) or (0.5, -2.0) ("line
contact"), times ``--scale`` (default 1) and the load factor; its u_x is free, as in dolfiny.
``--load-patch S`` moves the S x S square of the top face at the corner instead, ``--load-end`` the
upper beam's whole end face x = 2: their reactions stay finite under refinement, where the
corner's vanishes (for comparing discretizations).
``--method vem``: the SFVEM on the cells read as polyhedra. ``--linear-solver iterative``
(GMRES + p-multigrid) for grids beyond about 5e4 unknowns (bench/cbox3d_sizes.md; on dolfiny's
40 x 14 x 14 grid, 204 k unknowns, 2 ranks: 20 s per Newton iteration; the point contact to load 1
in 42 min with ``--alpha-r 30``, while at alpha_r = 10 the medium under the corner inverts at
0.88; docs/notes/2026-11-26-bench-3d-sizes.md).

What it prints and writes
-------------------------
Per step the load factor, Newton iterations, the reaction of ``load`` (the force on the moved
corner, [R_x, R_y, R_z]) and the smallest gap between the beams. In ``--out``: summary.json,
load_path.csv (per converged step: ``load_R*``, ``clamp_R*``, the corner's displacement
``tip_u*``, the smallest gap), displacement.xdmf, the 3D pictures of the last state
(``final-deformed.png``: the solids, medium hidden; ``final-clip.png``: the cut y = 0.35 through
the contact; ``final-pressure.png``: the contact pressure on the solids) and ``curves.png`` (the
corner's reaction R_z and the smallest gap against the load factor).

Commands
--------
Point contact (the defaults: Q2 hexahedra (20, 4, 7), alpha_r = 10), then P2 tetrahedra on
the same nodes, then the line contact::

    mpirun -n 2 python3 demos/cbox3d.py --out out/cbox3d-hex
    mpirun -n 2 python3 demos/cbox3d.py --cell tetrahedron --out out/cbox3d-tet
    mpirun -n 2 python3 demos/cbox3d.py --contact line --out out/cbox3d-line

Measured
--------
2026-11-26, MUMPS LDL^T, point contact, rotation regularization, gamma = 1e-5, on a machine
loaded ~10x (docs/notes/2026-11-26-cbox3d-full-load.md; the earlier runs in
docs/notes/2026-11-26-demos3d.md):

=======================  =========  =======  ==========  ===========  =============================
cells                    unknowns   alpha_r  load        Newton its   smallest gap; what stops it
=======================  =========  =======  ==========  ===========  =============================
Q2 hex (20, 4, 7)        16,605     10       **1**       100 (0)      0.040 at the full load
Q2 hex, --tip-ref. 2     28,665     10       **1**       105 (0)      0.022 at the full load
Q2 hex (20, 4, 7)        16,605     1        0.807       155 (+141)   5.6e-4; medium inverts under
                                                                      the tip corner, then the
                                                                      overlap check (tip in beam)
P2 tet (20, 4, 7)        16,605     10       0.496       88 (+60)     0.156; medium under the tip
                                                                      corner inverts (stopped)
Q2 hex, line contact     16,605     10       0.549       133 (+13     -3.5e-3: the tip corner goes
                                                         attempts)    into the lower beam (overlap
                                                                      check); gap < 0 from 0.548
=======================  =========  =======  ==========  ===========  =============================

Newton iterations of the converged steps (and of the failed ones); 1 rank, 4-5 s per iteration for
both cell types on this machine; 7.7 min and 0.70 GB for the full Q2 path. The smallest gap is
positive at every step of the point-contact runs, not of the line contact's last four. alpha_r = 10
costs stiffness: the corner's reaction is 2 % (load 0.1) to 9 % (load 0.8) above alpha_r = 1's, and
the beams meet later (gap 0.040 at the full load, bridged by medium squeezed to J = 0.013). P2
tetrahedra (6 per grid cell) are stiffer than Q2 hexahedra at small loads: 4.5 % on (20, 4, 7),
4.4 % on (20, 4, 14), 6.9 % on (20, 8, 7) (the solid alone: 6.6 % on (20, 4, 7)); agreement within 2 %
needs finer grids than were run, and may not come: the reaction of the one prescribed node is
singular in the limit (an in-plane point load on the beam; it fell 8 % with --tip-refinement 2). Compiling the tangent takes ~4-5 min of CPU (13 min for Q2, 47 min
for P2 on the loaded machine) the first time.

The line contact with a stronger regularization (docs/notes/2026-11-26-cbox3d-line-contact.md), Q2
(20, 4, 7): alpha_r = 100 reaches load 0.989 (138 Newton iterations in 23 steps), alpha_r = 300
0.979, both with the smallest gap positive at every step (0.043 and 0.052 at the end); the steps
beyond invert the solid cell that holds the moved corner node at that node (a displacement
prescribed at one node crushes its own cell; --tip-refinement 2 only moves that to load 0.87).
On the 0.35 patch (``--load-patch 0.35``, alpha_r = 100) the corner cell survives and the medium
under the tip (x = 1.95, z = 0.25) inverts at load 0.905 (gap 0.0056, positive throughout). The
SFVEM on the same hexahedra (alpha_r = 10) reaches 0.70 with its gap positive (0.026), its steps
shrinking to 0.003 (43 min). With two cells across the width, (20, 2, 7), and alpha_r = 100 the
corner cell is not crushed and both reach the full line-contact load with the gap positive at every
step (Q2: 0.027 at the end, 57 s; SFVEM: 0.022, 6 min)::

    python3 demos/cbox3d.py --contact line --alpha-r 100 --n 20 2 7 --out out/cbox3d-line
    python3 demos/cbox3d.py --contact line --alpha-r 100 --n 20 2 7 --method vem --out out/cbox3d-line-vem

Finer grids stop short of it for the same reason as above, the cell at the moved corner turning over
at its vertex next to the corner: (40, 2, 14) at 0.981, (20, 4, 7) at 0.989; P2 tetrahedra on
(20, 2, 7) stall at 0.30.

The SFVEM (``--method vem``) on the same hexahedra read as polyhedra, which then has exactly Q2's
unknowns: a quarter of the point-contact load in 2 steps, Hu-Hu regularization, gamma = 1e-5,
alpha_r = 10, 1 rank (``bench/cbox3d_vem_fem.py``; docs/notes/2026-11-26-sfvem-3d-cbox.md).
R: the corner's reaction (R_x = 0: u_x is free), difference |R_vem - R_fem| / |R_fem|; closure:
0.5 less the smallest gap; s/it: wall time per Newton iteration:

=========  ========  =================  =================  ==========  ======  ===============  =======  ===============
grid       unknowns  R_y, R_z SFVEM     R_y, R_z Q2        difference  R_z     gap SFVEM / Q2   closure  s/it (ratio)
=========  ========  =================  =================  ==========  ======  ===============  =======  ===============
20, 1, 7   5,535     3.31e-4, -4.82e-5  2.88e-4, -4.28e-5  14.7 %      12.5 %  0.4007 / 0.4031  2.5 %    2.8 / 0.24 (12)
20, 2, 7   9,225     3.00e-4, -4.58e-5  2.72e-4, -4.32e-5  10.0 %      6.2 %   0.4011 / 0.4032  2.1 %    5.8 / 0.56 (10)
20, 4, 7   16,605    2.84e-4, -4.48e-5  2.59e-4, -4.34e-5  9.5 %       3.1 %   0.4013 / 0.4033  2.0 %    11 / 1.7 (6)
40, 2, 14  35,235    2.92e-4, -4.40e-5  2.65e-4, -4.29e-5  10.0 %      2.6 %   0.4028 / 0.4040  1.3 %    27 / 4 (7)
40, 4, 14  63,423    2.73e-4, -4.35e-5  2.44e-4, -4.33e-5  11.7 %      0.4 %   0.4031 / 0.4042  1.2 %    46 / 8.9 (5)
=========  ========  =================  =================  ==========  ======  ===============  =======  ===============

The gap and the bending reaction R_z converge together (closure 2.5 % to 1.2 %, R_z 12.5 % to
0.4 %); the in-plane R_y, which dominates R, stays 10-12 % apart: the force that moves one node
of a 3D solid is singular (it falls with the cell size), so it measures each space's stiffness
next to that node, not the structure's. Newton iterations are the same for both (12-19); an
SFVEM iteration costs 5-12 times a Q2 one on the same unknowns. At the full point-contact load
(scale 1, 10 steps, grid (20, 1, 7)) both reach load 1 with the gap positive at every step and
the same smallest gap at the end (0.1130), 50 Newton iterations (SFVEM) against 64 (Q2). With the
upper beam's end face moved instead (``--load-end``, a finite reaction), the two converge to each
other: |R_vem - R_fem| / |R_fem| = 5.1 %, 3.1 %, 2.3 %, 1.3 % on (20, 2, 7), (20, 4, 7), (40, 2, 14),
(40, 4, 14) without the regularization, 5.5 % and 1.5 % with alpha_r = 10
(docs/notes/2026-11-27-sfvem-fem-end-face.md).
"""
from __future__ import annotations

import argparse
import sys
import typing

import numpy as np
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem.meshing.benchmarks3d import CBOX3D_T
from dolfinx_sfvem.path_following.linear_solvers import LINEAR_SOLVERS

import _common as common

#: Young's modulus and Poisson ratio of the solid (dolfiny)
E, NU = 5.0, 0.3
K, MU = E / (3 * (1 - 2 * NU)), E / (2 * (1 + NU))
#: displacement of the corner (2, 0, 0.7) at load factor 1 (u_y, u_z)
CONTACTS = {"point": (0.25, -1.0), "line": (0.5, -2.0)}
#: default cells per side (x, y, z)
N_DEFAULT = (20, 4, 7)


def make_parser() -> argparse.ArgumentParser:
    """The shared demo options with the 3D C-box defaults, plus ``--n --tip-refinement --cell --contact
    --medium-K --scale --linear-solver``."""
    p = common.parser("cbox3d", __doc__, steps=20, meshes=(1,), h=0.1, h_max=CBOX3D_T, gamma=1e-5,
                      alpha_r=10.0, regularization="rotation")
    p.set_defaults(method="fem", h=None)
    p.add_argument("--n", type=common.positive_int, nargs=3, default=None, metavar=("NX", "NY", "NZ"),
                   help=f"cells per side (default {' '.join(map(str, N_DEFAULT))} unless --h is given)")
    p.add_argument("--tip-refinement", type=common.positive_int, default=1, metavar="K",
                   help="split the grid cells within 0.4 of x = 2 and 0.35 of y = 0 (under the moved corner) "
                        "into K in x and y (default %(default)s)")
    p.add_argument("--cell", choices=("hexahedron", "tetrahedron"), default="hexahedron",
                   help="Q2 hexahedra or P2 tetrahedra, 6 per hexahedron (default %(default)s)")
    p.add_argument("--contact", choices=tuple(CONTACTS), default="point",
                   help="corner displacement (0, 0.25, -1) 'point' or (0, 0.5, -2) 'line' (default %(default)s)")
    p.add_argument("--medium-K", type=common.non_negative_float, default=K,
                   help="bulk modulus of the medium before the gamma scaling (default the solid's, %(default).4g)")
    p.add_argument("--scale", type=common.positive_float, default=1.0,
                   help="multiplies the corner displacement of --contact (default %(default)s)")
    p.add_argument("--load-patch", type=common.positive_float, default=None, metavar="S",
                   help="move the S x S square of the top face at the corner instead of the corner alone "
                        "(a finite reaction under refinement; default: the corner, as dolfiny)")
    p.add_argument("--load-end", action="store_true",
                   help="move the upper beam's whole end face x = 2, z >= 0.6 instead of the corner (a finite "
                        "reaction whose only singularities are at the face's edges)")
    p.add_argument("--linear-solver", choices=tuple(LINEAR_SOLVERS), default="direct",
                   help="the Newton steps' linear solver: MUMPS LDL^T or GMRES + p-multigrid, for large grids "
                        "(docs/guide/solving.md; default %(default)s)")
    return p


def build(args: argparse.Namespace, comm: MPI.Comm = MPI.COMM_WORLD) -> tuple[sf.ContactProblem, dict]:
    """The 3D C-box of the command line on ``comm``: the problem (boundary conditions ``clamp`` and
    ``load``) and the observers ``tip_ux``, ``tip_uy``, ``tip_uz`` (the moved corner's displacement)."""
    if args.n is not None and args.h is not None:
        raise ValueError("cbox3d: give --n or --h, not both")
    box = (sf.meshes.cbox3d(h=args.h, cell=args.cell, tip_refinement=args.tip_refinement) if args.h is not None
           else sf.meshes.cbox3d(n=tuple(args.n or N_DEFAULT), cell=args.cell, tip_refinement=args.tip_refinement))
    medium = common.third_medium(args, mu=MU, K=args.medium_K)
    problem = sf.ContactProblem(box.mesh, {sf.meshes.SOLID: sf.Hyperelastic(K=K, mu=MU), sf.meshes.MEDIUM: medium},
                                comm=comm, linear_solver=args.linear_solver, **common.discretization(args))
    problem.fix(box.marker("clamp"), name="clamp")
    tip = common.at_point(box.points["load"])
    uy, uz = (args.scale * u for u in CONTACTS[args.contact])
    if args.load_end and args.load_patch is not None:
        raise ValueError("cbox3d: give --load-patch or --load-end, not both")
    moved = (end_face(box.points["load"]) if args.load_end else
             tip if args.load_patch is None else corner_patch(box.points["load"], args.load_patch))
    problem.prescribe(moved, uy=uy, uz=uz, name="load")   # u_x free, as in dolfiny
    observers = {f"tip_u{c}": common.displacement_observer(problem, tip, i) for i, c in enumerate("xyz")}
    return problem, observers


def corner_patch(corner, size: float, tol: float = 1e-10):
    """Marker of the S x S square of the top face z = corner_z at the corner (x = L, y = 0).

    A displacement prescribed at one point of a 3D solid has a reaction that vanishes as the mesh
    is refined (a point has no capacity in 3D elasticity), so the corner's reaction depends on the
    cells around it; over a patch of fixed size it converges."""
    x0, y0, z0 = corner
    return lambda x: (x[0] >= x0 - size - tol) & (x[1] <= y0 + size + tol) & (np.abs(x[2] - z0) <= tol)


def end_face(corner, tol: float = 1e-10):
    """Marker of the upper beam's end face x = corner_x, z >= corner_z - wall thickness."""
    x0, _, z0 = corner
    return lambda x: (np.abs(x[0] - x0) <= tol) & (x[2] >= z0 - CBOX3D_T - tol)


def plot_curves(out, title: str) -> None:
    """curves.png: the corner's reaction R_z and the smallest gap against the load factor."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from dolfinx_sfvem.output.figure_output import save_png

    rows = common.read_load_path(out / "load_path.csv")
    if not rows:
        return
    load = [r["load"] for r in rows]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9, 3.4))
    for c in "xyz":
        ax1.plot(load, [r[f"load_R{c}"] for r in rows], "o-", ms=3, label=f"R_{c}")
    ax1.set(xlabel="load factor", ylabel="reaction at the moved corner")
    ax1.legend(fontsize=8)
    gaps = [r.get("gap", np.nan) for r in rows]
    ax2.plot(load, gaps, "o-", ms=3)
    ax2.set(xlabel="load factor", ylabel="smallest gap between the solids")
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    save_png(fig, out / "curves.png", dpi=90)


def main(argv: typing.Sequence[str] | None = None) -> int:
    """Parse ``argv`` (default ``sys.argv[1:]``), build and solve; returns the exit code (0 or 1)."""
    args = common.parse_args(make_parser(), argv)
    problem, observers = build(args)
    code = common.run(problem, args, observers)
    if problem.comm.rank == 0:
        plot_curves(args.out, f"cbox3d: {args.cell}, {args.contact} contact, {args.regularization}, "
                              f"gamma = {args.gamma:g}, alpha_r = {args.alpha_r:g}")
    return code


if __name__ == "__main__":
    sys.exit(common.exit_code(main))
