"""A 3D PneuNet bending actuator: chambers inflated by cavity pressure until their walls touch
through the third medium (the 3D counterpart of ``demos/pneumatic_actuator.py``).

Geometry and mesh (``sf.meshes.pneunet3d``, proportions ``sf.meshes.PneuNet3D``, mm)
------------------------------------------------------------------------------------
The 2D demo's section (chambers 8 mm long and 15 mm high, 1 mm sidewalls, 2 mm roofs, 2 mm
apart, a 2 mm floor on a stiff 1 mm base layer) extruded across a width of 15 mm, each chamber
closed by 2 mm side walls (facing +-y). Half model: 0 <= y <= 7.5, y = 0 a symmetry plane
(u_y = 0 there), along which each chamber's cavity is open. A tensor-product grid of boxes of
about ``--h`` (default 2; a wall thinner than h is one cell) whose lines fall on every wall,
``--cell hexahedron`` (Q2, default) or ``tetrahedron`` (P2, 6 per box). ``--chambers`` (default
2: one gap, through which the walls touch); x along the actuator, z up.

Problem
-------
Clamped on x = 0 (u = 0: the first chamber's outer sidewall and the base layer's end face), u_y
= 0 on y = 0. Every chamber is filled with third medium and loaded by
``problem.cavity_pressure("chamber_i", λ p)`` (the energy term -λ p ∫ (J - 1) dΩ over its half,
open along the symmetry plane), ``--p`` (default 0.01 MPa = 10 kPa) at load factor λ = 1. The
gaps between chambers (open at the top and the sides) hold third medium too, through which the
bulging sidewalls touch.

Materials (paper Eq. 2, mm and MPa) as in 2D: elastomer mu = 0.1, K = 2; base layer mu = 1, K =
20; medium (Eqs. 3-5, chambers and gaps) mu = 0.1, K = 0, ``--gamma`` (default 1e-4),
``--alpha-r`` (default 1), ``--regularization`` (default huhu; the rotation regularization's
3D form gives the same bending within 0.5 % and compiles for minutes per medium region without
clang, docs/pneunet3d.md). ``--method vem``: the SFVEM on the cells read as polyhedra.

Outputs
-------
Per step the pressure, θ the bending angle of the tip (the clockwise rotation, seen from -y, of
the tip face x = L by its corners ``tip_bottom`` and ``tip_top`` on y = 0: θ = π/2 - atan2(Δz,
Δx) of their deformed difference; the actuator bends towards its base, θ > 0), the smallest gap
between the solids' surfaces (the run's contact check; initially the 2 mm spacing between
chambers) and each chamber's volume change ∫ (J - 1) (the half model's). First contact: the
pressure at which the gap falls below a tenth of the spacing (linear between steps).

The progress line of each step shows the pressure (``chamber_1``) and the gap; at the end the
demo prints the whole path (pressure, θ, gap, volumes), unless ``--quiet``. In ``--out``:
summary.json, load_path.csv, displacement.xdmf, the pictures of the last state
(``final-deformed.png``: the solids, medium hidden; ``final-clip.png``: a cut normal to y through
the contact zone, so through the chambers and the gap; ``final-pressure.png``: the contact
pressure on the solids, seen along x), actuator.png (θ, gap and mean chamber volume change against
the pressure) and actuator.md (the numbers and the path).

Measured
--------
2026-11-26 (docs/pneunet3d.md, docs/notes/2026-11-26-pneunet3d.md), defaults: 10,557 unknowns, 14
load steps, 84 Newton iterations, 3 min on 1 core; first contact at 2.4 kPa, then the gap stays
at 0.034-0.035 mm; θ = 15.2° at 10 kPa; the same on 2 ranks. P2 tetrahedra on the same nodes: θ
= 15.2°, first contact at 2.5 kPa, gap 0.028 mm.

Examples::

    python3 demos/pneunet3d.py                                   # a few minutes on 1 core
    mpirun -n 2 python3 demos/pneunet3d.py --chambers 3 --out out/pneunet3d-3
    python3 demos/pneunet3d.py --cell tetrahedron --out out/pneunet3d-tet
"""
from __future__ import annotations

import argparse
import pathlib
import sys
import typing

from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem.output import markdown

import _common as common
import pneumatic_actuator as actuator2d

GEOMETRY = sf.meshes.PneuNet3D()
MU_ELASTOMER, K_ELASTOMER = actuator2d.MU_ELASTOMER, actuator2d.K_ELASTOMER
MU_BASE, K_BASE = actuator2d.MU_BASE, actuator2d.K_BASE


def make_parser() -> argparse.ArgumentParser:
    p = common.parser("pneunet3d", __doc__, steps=10, h=2.0, h_max=2 * GEOMETRY.wall, gamma=1e-4, alpha_r=1.0,
                      regularization="huhu")
    p.set_defaults(method="fem")
    p.add_argument("--chambers", type=common.positive_int, default=2,
                   help="number of chambers (default %(default)s; the toolkit's actuator has 11)")
    p.add_argument("--p", type=common.positive_float, default=0.01,
                   help="chamber pressure at load factor 1, MPa (default %(default)s)")
    p.add_argument("--cell", choices=("hexahedron", "tetrahedron"), default="hexahedron",
                   help="Q2 hexahedra or P2 tetrahedra, 6 per box (default %(default)s)")
    return p


def benchmark(args: argparse.Namespace) -> sf.meshes.Benchmark3D:
    """The half actuator of the command line (``--h --chambers --cell``)."""
    return sf.meshes.pneunet3d(args.h, args.chambers, geometry=GEOMETRY, cell=args.cell)


def build(bench: sf.meshes.Benchmark3D, args: argparse.Namespace,
          comm: MPI.Comm = MPI.COMM_WORLD) -> tuple[sf.ContactProblem, dict]:
    """The clamped half actuator with every chamber under the cavity pressure λ p (loads
    ``chamber_1`` ... ``chamber_n``; boundary conditions ``clamp`` and ``symmetry``, the latter
    without the nodes on the clamp, so that each reaction is its own) and the observers
    ``tip_bottom_ux``, ``tip_bottom_uz``, ``tip_top_ux``, ``tip_top_uz``."""
    regions = bench.regions
    chambers = actuator2d.chamber_names(regions)
    problem = sf.ContactProblem(bench.mesh, actuator2d.materials(regions, args), comm=comm,
                                **common.discretization(args))
    clamp, symmetry = bench.marker("clamp"), bench.marker("symmetry")
    problem.fix(clamp, name="clamp")
    problem.fix(lambda x: symmetry(x) & ~clamp(x), components="y", name="symmetry")  # the clamp holds its edge
    for name in chambers:
        problem.cavity_pressure(name, args.p, name=name)
    problem.parameters["geometry"] = {**vars(GEOMETRY), "chambers": args.chambers, "mu": MU_ELASTOMER,
                                      "K": K_ELASTOMER, "mu_base": MU_BASE, "K_base": K_BASE, "cell": args.cell}
    observers = {f"{corner}_u{axis}": common.displacement_observer(problem, common.at_point(bench.points[corner]), k)
                 for corner in ("tip_bottom", "tip_top") for k, axis in ((0, "x"), (2, "z"))}
    return problem, observers


# --------------------------------------------------------------------------- the curve
def read_curve(out: pathlib.Path, label: str) -> actuator2d.Curve:
    """The converged steps of the run in ``out`` with the unloaded state first: pressure, θ, the
    smallest gap and the chambers' volume changes (in the Curve's ``area``, mm³ of the half model)."""
    return actuator2d.read_curve(out, label, geometry=GEOMETRY, vertical="z")


def path_table(curve: actuator2d.Curve) -> list[str]:
    """The load path step by step as markdown: pressure (kPa), θ (°), smallest gap (mm), each
    chamber's volume change (mm³, half model)."""
    chambers = curve.area.shape[1]
    header = ["p [kPa]", "θ [°]", "smallest gap [mm]", *(f"ΔV chamber {i + 1} [mm³]" for i in range(chambers))]
    rows = [[f"{1e3 * p:.3f}", f"{a:.2f}", f"{g:.4f}", *(f"{v:.2f}" for v in dv)]
            for p, a, g, dv in zip(curve.pressure, curve.angle, curve.gap, curve.area)]
    return markdown.table(header, rows)


def main(argv: typing.Sequence[str] | None = None) -> int:
    args = common.parse_args(make_parser(), argv)
    bench = benchmark(args)
    problem, observers = build(bench, args)
    if problem.comm.rank == 0 and not args.quiet:
        print(f"pneunet3d: {args.chambers} chambers, {args.cell}, h = {args.h:g}, p = {args.p:g} MPa", flush=True)
    code = common.run(problem, args, observers)
    if problem.comm.rank == 0:
        curve = read_curve(args.out, f"FEM ({'Q2' if args.cell == 'hexahedron' else 'P2'})")
        title = f"3D PneuNet (half), {args.chambers} chambers, {args.cell}, h = {args.h:g} mm"
        actuator2d.report([curve], args, title=title, change="volume")
        table = path_table(curve)
        with open(args.out / "actuator.md", "a") as f:
            f.write("\nThe load path:\n\n" + "\n".join(table) + "\n")
        if not args.quiet:
            print("\n".join(table), flush=True)
        print(f"θ = {curve.angle[-1]:.2f}° at p = {1e3 * curve.pressure[-1]:.4g} kPa, first contact at "
              f"{1e3 * curve.first_contact():.4g} kPa, smallest gap {curve.gap.min():.4f} mm", flush=True)
    return code


if __name__ == "__main__":
    sys.exit(common.exit_code(main))
