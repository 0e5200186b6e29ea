"""A user's gmsh model of curved parts: an O-ring pressed between two plates through the third medium.

Problem
-------
An O-ring (a torus: centre-line radius ``R0`` = 1, cross-section radius ``r`` = 0.25, about the z
axis) lies between two plates ``--gap`` (0.1) above and below it; the third medium fills the
annular slot between the plates around the ring (radii R0 -+ (r + 0.15)). The plates, ``--stiffness``
(20) times stiffer than the ring, are pressed together by 2 (gap + ``--squeeze``): the gaps close
through the medium, then the ring is flattened by 2 ``--squeeze`` (default 0.05, 20 % of its
section's height). One eighth is modelled (x, y, z >= 0): u_x = 0 on x = 0, u_y = 0 on y = 0,
u_z = 0 on the mid-plane z = 0; the upper plate's top is moved by u_z = -(gap + squeeze) x load
factor. Ring K = 5/4, mu = 5/14 (E = 0.978, nu = 0.370); medium mu = 5/14, K = 5/4 scaled by
``--gamma``, ``--alpha-r``, ``--regularization``.

The mesh, as a user brings it
-----------------------------
The geometry is built here with gmsh's OpenCASCADE API (:func:`build_model`: a torus sector, the
slot and the plate fragmented together), its volumes and boundary surfaces put in named physical
groups (``oring``, ``medium``, ``plate``; ``symmetry_x``, ``symmetry_y``, ``symmetry_z``,
``plate_top``), meshed in tetrahedra of size ``--h`` (the ring's section resolved by
``--section-cells`` across) and second order (``--order 2``, the default: 10-node tetrahedra, their
edge nodes on the torus), and read by ``sf.meshes.read_gmsh`` from the open model. The materials
are given by the region names and the conditions by the surface names: nothing in the problem
refers to coordinates. ``--order 1`` reads straight-sided tetrahedra instead; ``--method vem``
reads the same cells as polyhedra (the SFVEM: faces taken flat, one warning says so); ``--keep-msh``
also writes the model to ``oring.msh`` in ``--out``.

What it prints and writes
-------------------------
Per step the load factor, Newton iterations, the plate's reaction and the smallest gap between the
solids; at the end the plate's force on the eighth model and the smallest gap. In ``--out``:
summary.json, load_path.csv, displacement.xdmf and the 3D pictures of the last state
(``final-deformed.png``, ``final-clip.png``, ``final-pressure.png``), and curves.png (the plate's
force and the smallest gap against its travel).

Measured
--------
2026-12-07, 1 rank, the default run (2,748 curved tetrahedra, 14,043 unknowns): the full load in 8
steps (31 Newton iterations, 33 s), plate force 0.1054 on the eighth model, the smallest gap
2.3e-3 at the end (positive throughout); on a finer mesh (h 0.08) 0.1035; straight-sided cells
(``--order 1``) 0.0971; the SFVEM on the coarse mesh (``--method vem --h 0.2 --section-cells 3``,
16,515 unknowns, 11.5 min) 0.0931 against P2's 0.1080 there (docs/notes/2026-12-07-curved-geometry.md).
The medium's gamma is 1e-3 by default: with 1e-5 it is crushed to J ~ 1e-4 before it carries the
ring, and the run takes many small steps.

Commands
--------
::

    python3 demos/user_mesh3d.py --out out/user_mesh3d                 # P2 on curved tetrahedra
    python3 demos/user_mesh3d.py --order 1 --out out/user_mesh3d-flat   # straight-sided tetrahedra
    python3 demos/user_mesh3d.py --method vem --h 0.2 --section-cells 3 --out out/user_mesh3d-vem
"""
from __future__ import annotations

import argparse
import math
import pathlib
import sys
import typing

import numpy as np

import dolfinx_sfvem as sf
from dolfinx_sfvem.mesh.cell_mesh import CellMesh

import _common as common

#: the ring's centre-line radius and cross-section radius
R0, R_SECTION = 1.0, 0.25
#: radial margin of the medium's slot beyond the ring, and the plate's thickness
MARGIN, PLATE = 0.15, 0.1
#: the ring's moduli (the Hertz model's block); the medium's before gamma
K, MU = 5 / 4, 5 / 14
#: region names and tags of the gmsh model's physical groups
REGIONS = {"oring": sf.meshes.SOLID, "medium": sf.meshes.MEDIUM, "plate": 3}
SURFACES = ("symmetry_x", "symmetry_y", "symmetry_z", "plate_top")


def make_parser() -> argparse.ArgumentParser:
    """The shared demo options with this demo's defaults, plus ``--gap --squeeze --stiffness --order
    --section-cells --keep-msh``."""
    p = common.parser("user_mesh3d", __doc__, steps=8, h=0.12, gamma=1e-3, alpha_r=1.0, regularization="huhu")
    p.set_defaults(method="fem")
    p.add_argument("--gap", type=common.positive_float, default=0.1,
                   help="gap between the ring and each plate (default %(default)s)")
    p.add_argument("--squeeze", type=common.positive_float, default=0.05,
                   help="each plate's travel beyond the gap (default %(default)s)")
    p.add_argument("--stiffness", type=common.positive_float, default=20.0,
                   help="the plates' moduli over the ring's (default %(default)s)")
    p.add_argument("--order", type=int, choices=(1, 2), default=2,
                   help="gmsh's element order: 2 curved (10-node) tetrahedra, 1 straight-sided (default %(default)s)")
    p.add_argument("--section-cells", type=common.positive_int, default=4,
                   help="cells across the ring's section at least (its mesh size: min(h, 2 r / N); "
                        "default %(default)s)")
    p.add_argument("--keep-msh", action="store_true", help="also write the gmsh model to oring.msh in --out")
    return p


# --------------------------------------------------------------------------- the gmsh model
def _surfaces_in_box(gmsh, low: typing.Sequence[float], high: typing.Sequence[float]) -> list[int]:
    """Tags of the model's surfaces inside the box [low, high] (widened by 1e-6)."""
    eps = 1e-6
    return [tag for _, tag in gmsh.model.getEntitiesInBoundingBox(*(c - eps for c in low), *(c + eps for c in high), 2)]


def build_model(gmsh, gap: float, h: float, h_ring: float, order: int) -> None:
    """The eighth model in the current gmsh model, meshed: the ring's quarter-torus half (z >= 0),
    the slot of medium around it up to the plate (z <= r + gap) and the plate above, fragmented
    (conforming), with the physical groups of :data:`REGIONS` and :data:`SURFACES`."""
    occ = gmsh.model.occ
    inner, outer = R0 - R_SECTION - MARGIN, R0 + R_SECTION + MARGIN
    top = R_SECTION + gap
    quarter = math.pi / 2

    def slot(z0: float, height: float) -> int:
        ring = occ.addCylinder(0, 0, z0, 0, 0, height, outer, angle=quarter)
        hole = occ.addCylinder(0, 0, z0, 0, 0, height, inner, angle=quarter)
        return occ.cut([(3, ring)], [(3, hole)])[0][0][1]

    torus = occ.addTorus(0, 0, 0, R0, R_SECTION, angle=quarter)
    upper = occ.intersect([(3, torus)], [(3, occ.addBox(0, 0, 0, outer, outer, R_SECTION))])[0][0][1]
    medium, plate = slot(0.0, top), slot(top, PLATE)
    _, children = occ.fragment([(3, medium), (3, plate)], [(3, upper)])     # the pieces of each input
    occ.synchronize()
    ring = [tag for _, tag in children[2]]
    volumes = {"oring": ring, "medium": [tag for _, tag in children[0] if tag not in ring],
               "plate": [tag for _, tag in children[1]]}
    for name, tags in volumes.items():
        gmsh.model.setPhysicalName(3, gmsh.model.addPhysicalGroup(3, tags, REGIONS[name]), name)
    boxes = {"symmetry_x": ((0, 0, 0), (0, outer, top + PLATE)), "symmetry_y": ((0, 0, 0), (outer, 0, top + PLATE)),
             "symmetry_z": ((0, 0, 0), (outer, outer, 0)), "plate_top": ((0, 0, top + PLATE), (outer, outer, top + PLATE))}
    for name, (low, high) in boxes.items():
        gmsh.model.setPhysicalName(2, gmsh.model.addPhysicalGroup(2, _surfaces_in_box(gmsh, low, high)), name)
    # size h_ring in the ring, growing by half the distance from it up to h (a field of any gmsh version)
    ring_distance = f"Max(0, Sqrt((Sqrt(x^2 + y^2) - {R0!r})^2 + z^2) - {R_SECTION!r})"
    field = gmsh.model.mesh.field.add("MathEval")
    gmsh.model.mesh.field.setString(field, "F", f"Min({h!r}, {h_ring!r} + 0.5 * {ring_distance})")
    gmsh.model.mesh.field.setAsBackgroundMesh(field)
    for option in ("Mesh.MeshSizeExtendFromBoundary", "Mesh.MeshSizeFromPoints", "Mesh.MeshSizeFromCurvature"):
        gmsh.option.setNumber(option, 0)
    gmsh.option.setNumber("General.NumThreads", 1)
    gmsh.model.mesh.generate(3)
    gmsh.model.mesh.setOrder(order)
    if order == 2:              # untangle and smooth the curved cells (the curved boundary can squeeze a cell)
        gmsh.option.setNumber("Mesh.HighOrderOptimize", 2)
        gmsh.model.mesh.optimize("HighOrder")


def read_mesh(args: argparse.Namespace) -> CellMesh:
    """The model of the command line built in a gmsh session and read by ``sf.meshes.read_gmsh``
    (identically on every rank)."""
    h_ring = min(args.h, 2 * R_SECTION / args.section_cells)
    with sf.meshes.gmsh_session() as gmsh:
        build_model(gmsh, args.gap, args.h, h_ring, args.order)
        if args.keep_msh:
            args.out.mkdir(parents=True, exist_ok=True)
            gmsh.write(str(args.out / "oring.msh"))
        return sf.meshes.read_gmsh(None)


# --------------------------------------------------------------------------- the problem
def build(args: argparse.Namespace) -> sf.ContactProblem:
    """The eighth model of the command line: materials by region name, conditions by surface name."""
    mesh = read_mesh(args)
    s = args.stiffness
    materials = {"oring": sf.Hyperelastic(K=K, mu=MU), "plate": sf.Hyperelastic(K=s * K, mu=s * MU),
                 "medium": common.third_medium(args, mu=MU, K=K)}
    problem = sf.ContactProblem(mesh, materials, **common.discretization(args))
    for axis in "xyz":
        problem.fix(f"symmetry_{axis}", components=axis, name=f"symmetry_{axis}")
    problem.prescribe("plate_top", uz=-(args.gap + args.squeeze), name="press")
    problem.parameters["geometry"] = {"R0": R0, "r": R_SECTION, "margin": MARGIN, "plate": PLATE, "K": K, "mu": MU}
    return problem


def plot_curves(out: pathlib.Path, travel: float, title: str) -> None:
    """curves.png: the plate's force (-R_z of ``press``) and the smallest gap between the solids
    against the plate's travel, on one pair of axes."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from dolfinx_sfvem.output.figure_output import save_png

    rows = common.read_load_path(out / "load_path.csv")
    if not rows:
        return
    u = [travel * r["load"] for r in rows]
    fig, force = plt.subplots(figsize=(6, 3.6))
    force.plot(u, [-r["press_Rz"] for r in rows], "o-", ms=3, color="C0")
    force.set_xlabel("plate travel")
    force.set_ylabel("plate force (1/8 model)", color="C0")
    gap = force.twinx()
    gap.plot(u, [r.get("gap", np.nan) for r in rows], "s--", ms=3, color="C3")
    gap.set_ylabel("smallest gap between the solids", color="C3")
    gap.set_ylim(bottom=0.0)
    force.set_title(title, fontsize=8)
    fig.tight_layout()
    save_png(fig, out / "curves.png", dpi=90)


def main(argv: typing.Sequence[str] | None = None) -> int:
    """Parse ``argv`` (default ``sys.argv[1:]``), build and solve; the exit code (0 or 1)."""
    args = common.parse_args(make_parser(), argv)
    problem = build(args)
    code = common.run(problem, args)
    if problem.comm.rank == 0:
        rows = common.read_load_path(args.out / "load_path.csv")
        geometry = "curved" if args.order == 2 else "straight-sided"
        title = (f"user_mesh3d: {'SFVEM' if args.method == 'vem' else 'P2'} on {geometry} tetrahedra, h = {args.h:g}, "
                 f"gamma = {args.gamma:g}, {args.regularization} alpha_r = {args.alpha_r:g}")
        plot_curves(args.out, args.gap + args.squeeze, title)
        if rows:
            r = rows[-1]
            print(f"final: load {r['load']:.4g}, plate travel {(args.gap + args.squeeze) * r['load']:.4f}, "
                  f"plate force {-r['press_Rz']:.4g} (1/8 model), smallest gap {r.get('gap', math.nan):.3e}",
                  flush=True)
    return code


if __name__ == "__main__":
    sys.exit(common.exit_code(main))
