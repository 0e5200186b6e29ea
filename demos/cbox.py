"""C-box self-contact (paper §5.2, after Bluhm, Sigmund & Poulios 2021).

Problem
-------
A C-shaped plane-strain structure, clamped on its left side, is closed by prescribing the
vertical displacement u_y of the top right point. The upper beam bends down until it
touches the lower beam at a point; contact is transmitted through the third medium that
fills the cavity, no contact algorithm is involved.

Geometry and mesh (``dolfinx_sfvem.meshes.cbox``, see meshes/README.md)
-----------------------------------------------------------------------
L = 1, wall thickness t = 0.1, height 0.5, so the initial gap is 0.3: left wall
[0, 0.1] x [0, 0.5], beams [0, 1] x [0, 0.1] and [0, 1] x [0.4, 0.5]. The medium fills the
cavity [0.1, 1] x [0.1, 0.4] and a column [1, 1 + w] x [0, 0.5] right of the structure
(the paper's "column of third medium elements"), w = ``--column`` = 0.1 by default, the wall
thickness, whatever the mesh size: ``--h`` refines one problem. The paper's figures are
missing, so the column width and the mesh sizes are our choice; a column as thin as one small
element (e.g. ``--column 0.025 --h 0.025``) lets the medium between the beams be dragged out
sideways until the beams pass through each other, which the run reports as a stop
("solids overlap", docs/contact.md). Solid: polygons (dual of a
gmsh triangle mesh of size ``--h``); medium: quadrilaterals of size h (``--mesh 1``) or
h/2 (``--mesh 2``) joined to the unchanged solid mesh through hanging nodes.

FEM reference (``--method fem``): by default Q2, degree-2 Lagrange on quadrilaterals, on
``dolfinx_sfvem.meshes.cbox_grid``: the medium's grid continued through the solid, the same
geometry in rectangles of size h (``--mesh 1``) or h/2 (``--mesh 2``). ``--fem-cells triangles``
gives P2 on a triangulation with about the SFVEM's unknowns instead, whose cell-wise second
gradient lets the compressed medium fold along element edges more easily
(docs/fem-reference.md).

Parameters
----------
Solid: K = 5/3, mu = 5/14 (paper Eq. 2). Medium (Eq. 59): mu = 5/14, K = 0, gamma = 1e-5,
alpha_r = 1, regularization ``rotation``, Psi_r = 1/2 (grad phi . grad phi + grad J . grad J).
Left side x = 0 clamped; u_y = ``--uy`` (default -0.5) at the top right point (1, 0.5),
reached in ``--steps`` equal load steps.

Outputs (in ``--out``)
----------------------
summary.json (parameters, DOFs, per step: load factor, Newton residuals, reaction of
``load`` = the tip force, observers ``tip_ux``/``tip_uy``), load_path.csv (one row per
converged step; the force curve is ``load_Ry`` against ``tip_uy``), displacement.xdmf,
deformed.png (deformed mesh, paper Fig. 7) and uy.png (u_y contour, paper Fig. 8).

Paper runs
----------
u_y = -0.5, gamma = 1e-5, alpha_r = 1 on both medium densities (Fig. 7, point contact)::

    mpirun -n 2 python3 demos/cbox.py --uy -0.5 --steps 50 --mesh 1 --out out/cbox-mesh1
    mpirun -n 2 python3 demos/cbox.py --uy -0.5 --steps 50 --mesh 2 --out out/cbox-mesh2

u_y = -1 with a stronger regularization, gamma = 1e-5, alpha_r = 20 (Fig. 8), on the finer
medium (on mesh 1 the five-sided medium polygon at the C's mouth inverts at load 0.887 and the
run stops there)::

    mpirun -n 2 python3 demos/cbox.py --uy -1 --alpha-r 20 --steps 100 --mesh 2 --out out/cbox-uy1

Further options: ``python3 demos/cbox.py --help``; PETSc options are passed through, e.g.
``-tmc_snes_monitor -tmc_snes_linesearch_type bt``.
"""
from __future__ import annotations

import argparse
import sys
import typing

import dolfinx_sfvem as sf
from dolfinx_sfvem import paper

import _common as common

#: solid bulk and shear modulus (the medium has the same mu)
K, MU = 5 / 3, 5 / 14
#: wall thickness: the largest mesh size that still resolves the beams
T = 0.1
#: cells of the FEM reference (``--fem-cells``), the default first
FEM_CELLS = ("quads", "triangles")


def make_parser() -> argparse.ArgumentParser:
    """The shared demo options with the C-box defaults, plus ``--uy``."""
    p = common.parser("cbox", __doc__, steps=50, meshes=(1, 2), h=paper.DEFAULT_H["cbox"], h_max=T, gamma=1e-5,
                      alpha_r=1.0, regularization="rotation",
                      mesh_help="medium density: 1 = quads of size h, 2 = h/2 (solid unchanged)")
    common.add_uy(p, -0.5, "the top right point")
    p.add_argument("--column", type=common.positive_float, default=sf.meshes.CBOX_COLUMN,
                   help="width of the medium column right of the beams (default %(default)s)")
    p.add_argument("--fem-cells", choices=FEM_CELLS, default=None,
                   help="--method fem only: quads = Q2 on the medium's grid continued through the solid "
                        "(default), triangles = P2 on a triangulation with about the SFVEM's unknowns "
                        "(docs/fem-reference.md)")
    return p


def build(args: argparse.Namespace) -> tuple[sf.ContactProblem, dict]:
    """The C-box contact problem of the command line.

    Parameters
    ----------
    args
        Parsed command line (``--h --mesh --column --uy`` and the medium options).

    Returns
    -------
    problem
        Clamped left side, u_y prescribed at the top right point (boundary condition ``load``).
    observers
        ``tip_ux``, ``tip_uy``: displacement of the top right point, recorded per step.
    """
    box = sf.meshes.cbox(h_solid=args.h, medium_refinement=args.mesh, column=args.column)
    options = common.discretization(args)
    if args.method == "fem" and (args.fem_cells or FEM_CELLS[0]) == "quads":
        options["fem_mesh"] = sf.meshes.cbox_grid(h_solid=args.h, medium_refinement=args.mesh, column=args.column).mesh
    problem = sf.ContactProblem(box.mesh, {sf.meshes.SOLID: sf.Hyperelastic(K=K, mu=MU),
                                           sf.meshes.MEDIUM: common.third_medium(args, mu=MU)}, **options)
    problem.fix(common.on_segment(*box.segments["fixed"]))
    tip = common.at_point(box.points["load"])
    problem.prescribe(tip, uy=args.uy, name="load")
    observers = {"tip_ux": common.displacement_observer(problem, tip, 0),
                 "tip_uy": common.displacement_observer(problem, tip, 1)}
    return problem, observers


def main(argv: typing.Sequence[str] | None = None) -> int:
    """Parse ``argv`` (default ``sys.argv[1:]``), build and solve; returns the exit code (0 or 1)."""
    args = common.parse_args(make_parser(), argv)
    problem, observers = build(args)
    return common.run(problem, args, observers)


if __name__ == "__main__":
    sys.exit(common.exit_code(main))
