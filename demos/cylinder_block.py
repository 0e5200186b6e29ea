"""Cylinder on block: a stiff cylinder pressed into a soft block through a third-medium layer.

Plane strain, half model (symmetry axis x = 0). Block [0, 2] x [0, 2] (the right half of
[-2, 2] x [-2, 0], shifted up by 2), K = 5/3, mu = 5/14 (E = 1, nu = 0.4). Cylinder: the
lower right quarter of a disc of radius R = 1 centred at (0, 2 + gap + R), moduli x100
(``--stiffness``); its lowest point is ``--gap`` (default 0.2) above the block. Medium: the
box [0, 2] x [2, 2 + gap + R] minus the cylinder, mu = 5/14, ``--gamma`` (default 1e-6),
``--alpha-r`` (default 1), regularization ``--regularization`` (default rotation), as the
punch demo. Block bottom clamped, u_x = 0 on the axis, u_y = load * ``--uy`` (default -0.3:
the gap closes at 0.2, then 0.1 of indentation) on the flat top of the cylinder.

Mesh: gmsh triangles (Frontal-Delaunay) of size ``--h`` in the contact zone x < 0.8,
1.6 < y < 2 + gap + 0.3, growing to ``--h-far`` (default 8 h, at most 0.2) away from it;
``--cells triangles`` uses the triangles as polygons (default), ``--cells dual`` their dual
polygons (``sf.meshes.dual_polygons``).

Per converged step: the gap on the axis, the punch force (reaction of ``load``), and the
Hertz half-width a_H = sqrt(4 P R / (pi E*)), E* = E / (1 - nu^2), P = 2 x the force of
the half model, beside the contact half-width a measured as the largest x of a block-top
node whose vertical distance to the deformed cylinder is below ``--contact-tol`` (default
5 x the gap on the axis; a is 0 before contact).

Example (a few minutes on 2 ranks)::

    mpirun -n 2 .venv/bin/python demos/cylinder_block.py --h 0.05 --steps 20 --out out/cyl -snes_monitor

All shared demo options (``--method``, ``--steps``, ``--out``, ``--resume``, PETSc options)
work as in the other demos. At gamma = 1e-6 Newton stalls just after contact (docs/gamma-1e-6.md).
"""
from __future__ import annotations

import argparse
import math
import sys
import typing

import numpy as np
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem.run_summary import read_summary

import _common as common

K, MU = 5 / 3, 5 / 14
L, H, R = 2.0, 2.0, 1.0
CYLINDER = 3


def make_parser() -> argparse.ArgumentParser:
    p = common.parser("cylinder_block", __doc__, steps=20, meshes=(1,), h=0.05, gamma=1e-6, alpha_r=1.0,
                      regularization="rotation")
    common.add_uy(p, -0.3, "the cylinder top")
    p.add_argument("--gap", type=common.positive_float, default=0.2, help="initial gap (default %(default)s)")
    p.add_argument("--stiffness", type=common.positive_float, default=100.0,
                   help="cylinder moduli / block moduli (default %(default)s)")
    p.add_argument("--h-far", type=common.positive_float, default=None, help="mesh size away from the contact")
    p.add_argument("--cells", choices=("triangles", "dual"), default="triangles")
    p.add_argument("--contact-tol", type=common.positive_float, default=None)
    common.add_min_increment(p)
    return p


def mesh(h: float, h_far: float, gap: float, cells: str) -> sf.PolygonMesh:
    """gmsh triangles of the three regions (block SOLID, medium MEDIUM, cylinder CYLINDER)."""
    top = H + gap + R
    with sf.meshes.gmsh_session() as gmsh:
        occ = gmsh.model.occ
        block = occ.addRectangle(0.0, 0.0, 0.0, L, H)
        c = occ.addPoint(0.0, top, 0.0)
        p0, p1 = occ.addPoint(R, top, 0.0), occ.addPoint(0.0, top - R, 0.0)
        arc = occ.addCircleArc(p0, c, p1)
        cyl = occ.addPlaneSurface([occ.addCurveLoop([occ.addLine(c, p0), arc, occ.addLine(p1, c)])])
        box = occ.addRectangle(0.0, H, 0.0, L, gap + R)
        _, children = occ.fragment([(2, block), (2, cyl)], [(2, box)])
        occ.synchronize()
        regions = {sf.meshes.SOLID: [s for _, s in children[0]], CYLINDER: [s for _, s in children[1]]}
        taken = {s for v in regions.values() for s in v}
        regions[sf.meshes.MEDIUM] = [s for _, s in children[2] if s not in taken]
        for tag, surfaces in regions.items():
            gmsh.model.addPhysicalGroup(2, surfaces, tag)
        field = gmsh.model.mesh.field
        f = field.add("Box")
        for name, value in (("VIn", h), ("VOut", h_far), ("XMin", -1.0), ("XMax", 0.8), ("YMin", H - 0.4),
                            ("YMax", H + gap + 0.3), ("Thickness", 0.6)):
            field.setNumber(f, name, value)
        field.setAsBackgroundMesh(f)
        for name in ("Mesh.MeshSizeExtendFromBoundary", "Mesh.MeshSizeFromPoints", "Mesh.MeshSizeFromCurvature"):
            gmsh.option.setNumber(name, 0)
        gmsh.option.setNumber("Mesh.Algorithm", 6)
        gmsh.model.mesh.generate(2)
        points, offsets, flat, tags = sf.meshes.model_cells(gmsh, None)
    triangles = flat.reshape(-1, 3)
    if cells == "dual":
        return sf.meshes.dual_polygons(points, triangles, tags).to_mesh()
    return sf.PolygonMesh(points, triangles, tags)


def build(args: argparse.Namespace) -> tuple[sf.ContactProblem, dict]:
    h_far = args.h_far if args.h_far is not None else min(8 * args.h, 0.2)
    poly = mesh(args.h, h_far, args.gap, args.cells)
    top = H + args.gap + R
    s = args.stiffness
    problem = sf.ContactProblem(poly, {sf.meshes.SOLID: sf.Hyperelastic(K=K, mu=MU),
                                       CYLINDER: sf.Hyperelastic(K=s * K, mu=s * MU),
                                       sf.meshes.MEDIUM: common.third_medium(args, mu=MU)},
                                **common.discretization(args))
    problem.fix(common.on_segment((0.0, 0.0), (L, 0.0)), name="fixed")
    problem.fix(common.on_segment((0.0, 0.0), (0.0, top)), components=(0,), name="symmetry")
    problem.prescribe(common.on_segment((0.0, top), (R, top)), tags=[CYLINDER], uy=args.uy, name="load")
    tip = common.displacement_observer(problem, common.at_point((0.0, H + args.gap)), 1)
    block_top = common.displacement_observer(problem, common.at_point((0.0, H)), 1)

    # contact half-width: block-top nodes vs the deformed cylinder arc (vertex nodes only)
    pts = poly.points
    on_top = np.flatnonzero(np.isclose(pts[:, 1], H) & (pts[:, 0] <= L - 1e-9))
    on_arc = np.flatnonzero(np.isclose(np.hypot(pts[:, 0], pts[:, 1] - top), R) & (pts[:, 1] < top - 1e-9))
    top_dofs = [problem.disc.locate_dofs(common.at_point(pts[i]), component=c) for i in on_top for c in (0, 1)]
    arc_dofs = [problem.disc.locate_dofs(common.at_point(pts[i]), component=c) for i in on_arc for c in (0, 1)]

    def values(dofs_list) -> np.ndarray:
        n_owned = problem.disc.n_owned_dofs
        with problem.x.localForm() as xl:
            local = np.array([float(xl.array_r[d[d < n_owned]].sum()) for d in dofs_list])
        return problem.comm.allreduce(local, op=MPI.SUM).reshape(-1, 2)

    E = 9 * K * MU / (3 * K + MU)
    nu = (3 * K - 2 * MU) / (2 * (3 * K + MU))
    e_star = E / (1 - nu ** 2)

    def half_width(p: sf.ContactProblem) -> float:
        bt = pts[on_top] + values(top_dofs)
        ar = pts[on_arc] + values(arc_dofs)
        order = np.argsort(ar[:, 0])
        ycyl = np.interp(bt[:, 0], ar[order, 0], ar[order, 1], right=np.inf)
        dist = ycyl - bt[:, 1]
        g_axis = dist[np.argmin(bt[:, 0])]
        tol = args.contact_tol if args.contact_tol is not None else 5 * max(g_axis, 0.0)
        if g_axis > 0.05 * args.gap:
            return 0.0
        return float(bt[dist <= tol, 0].max(initial=0.0))

    observers = {"tip_uy": tip, "block_uy": block_top, "gap": lambda p: args.gap + tip(p) - block_top(p),
                 "half_width": half_width}
    problem.parameters["geometry"] = {"L": L, "H": H, "R": R, "gap": args.gap, "h_far": h_far,
                                      "E_star": e_star, "cells": args.cells}
    return problem, observers


def hertz_half_width(force_half_model: float) -> float:
    """a = sqrt(4 P R / (pi E*)) for the full-model force P = 2 x the half model's."""
    E = 9 * K * MU / (3 * K + MU)
    nu = (3 * K - 2 * MU) / (2 * (3 * K + MU))
    return math.sqrt(max(4 * 2 * force_half_model * R / (math.pi * E / (1 - nu ** 2)), 0.0))


def main(argv: typing.Sequence[str] | None = None) -> int:
    args = common.parse_args(make_parser(), argv)
    problem, observers = build(args)
    if problem.comm.rank == 0:
        print(f"cylinder_block: h = {args.h}, gamma = {args.gamma}, {args.cells}", flush=True)
    code = common.run(problem, args, observers, min_increment=args.min_increment)
    if problem.comm.rank == 0:
        summary = read_summary(args.out)
        s = summary.final_step if summary else None
        if s is not None:
            force = s.force("load")
            a_h = hertz_half_width(force)
            print(f"final: load {s.load:.4g}, force (half model) {force:.5g}, gap {s.extra['gap']:.3e}, "
                  f"half-width {s.extra['half_width']:.4f}, Hertz {a_h:.4f}", flush=True)
    return code


if __name__ == "__main__":
    sys.exit(common.exit_code(main))
