"""Hertz: a stiff cylinder pressed into an elastic block through a thin third-medium layer.

Plane strain, half model (symmetry axis x = 0). Block [0, L] x [0, L] (``--block``, default 2;
the right half of [-L, L] x [-L, 0], shifted up by L), K = 5/3, mu = 5/14 (E = 1, nu = 0.4).
Cylinder: the lower right quarter of a disc of radius R = 1 centred at (0, L + gap + R), moduli
x100 (``--stiffness``); its lowest point is ``--gap`` above the block. Medium: the box
[0, L] x [L, L + gap + R] minus the cylinder, mu = 5/14, ``--gamma``, ``--alpha-r`` (default 1),
``--regularization`` (default rotation). Block bottom clamped, u_x = 0 on the axis,
u_y = -load (gap + ``--indent``) on the flat top of the cylinder: the gap closes, then the
cylinder indents the block by about ``--indent``.

Mesh: gmsh triangles of size ``--h`` in the contact zone x < 0.8, L - 0.4 < y < L + gap + 0.3,
growing to ``--h-far`` (default 8 h, at most 0.2) away from it; ``--h-medium`` (default h) is the
size inside the medium layer below the cylinder (finer than h: non-matching densities across the
block's top, hanging nodes in the block's polygons). ``--cells triangles`` uses the triangles as
polygons, ``--cells dual`` their dual polygons (``sf.meshes.dual_polygons``).

Contact quantities come from the library (``problem.contact_pressure()``, recorded per step): the
force of the medium on the block, the largest pressure and the contact zone's length (pressure
above 1 % of the largest). Against Hertz for a cylinder on a half-space, with P = 2 x the half
model's contact force (force per unit thickness), E* = E / (1 - nu^2):
a = sqrt(4 P R / (pi E*)), p_max = 2 P / (pi a), p(x) = p_max sqrt(1 - x^2 / a^2).

Outputs in ``--out`` besides the usual ones: hertz.md (per converged step after contact: P, a and
a_Hertz, p_max and its Hertz value), pressure.csv (the block-top pressure at the last converged
step), hertz.png (pressure vs x with the Hertz curve; a vs P).

Example (a few minutes on 2 ranks)::

    mpirun -n 2 .venv/bin/python demos/hertz.py --h 0.05 --steps 20 --out out/hertz

Load stepping: fixed increments of 1/steps by default here (``--no-fixed-increments`` for the
library's adaptive ones). Once the cylinder presses on the block every step takes 10 to 20 Newton
iterations whatever its length, so shorter adaptive steps cost more in total (h = 0.05: 179
Newton iterations with 20 fixed steps, 401 with adaptive ones, docs/notes/2026-11-23-performance-rounds.md), and the
secant predictor saves almost nothing there (174).

All shared demo options (``--method``, ``--steps``, ``--gamma``, ``--out``, ``--resume``, PETSc
options) work as in the other demos. At gamma = 1e-6 Newton stalls just after contact
(docs/notes/2026-11-23-gamma-1e-6.md, docs/hertz.md): the demo stops there and says so; at h = 0.03
the last states before the stall have a negative pivot and are reported UNSTABLE, and neither
``--gamma-start 1e-5`` nor ``--alpha-r 10`` passes it; ``--gap 0.05`` does
(docs/notes/2026-11-26-weak-medium.md).
"""
from __future__ import annotations

import argparse
import csv
import math
import pathlib
import sys
import typing

import numpy as np

import dolfinx_sfvem as sf
from dolfinx_sfvem.output.figure_output import save_png
from dolfinx_sfvem.output.run_summary import RunSummary, read_summary

import _common as common

K, MU = 5 / 3, 5 / 14
R = 1.0
CYLINDER = 3
E = 9 * K * MU / (3 * K + MU)
NU = (3 * K - 2 * MU) / (2 * (3 * K + MU))
E_STAR = E / (1 - NU ** 2)


def make_parser() -> argparse.ArgumentParser:
    p = common.parser("hertz", __doc__, steps=20, meshes=(1,), h=0.05, gamma=1e-5, alpha_r=1.0,
                      regularization="rotation")
    p.set_defaults(fixed_increments=True)             # the module docstring says why
    p.add_argument("--gap", type=common.positive_float, default=0.2, help="initial gap (default %(default)s)")
    p.add_argument("--indent", type=common.positive_float, default=0.1,
                   help="cylinder top displacement after the gap has closed (default %(default)s)")
    p.add_argument("--block", type=common.positive_float, default=2.0,
                   help="block width and height L of the half model, > 1 (default %(default)s)")
    p.add_argument("--stiffness", type=common.positive_float, default=100.0,
                   help="cylinder moduli / block moduli (default %(default)s)")
    p.add_argument("--h-far", type=common.positive_float, default=None, help="mesh size away from the contact")
    p.add_argument("--h-medium", type=common.positive_float, default=None,
                   help="mesh size in the medium layer below the cylinder (default h)")
    p.add_argument("--cells", choices=("triangles", "dual"), default="triangles")
    return p


def mesh(L: float, h: float, h_far: float, h_medium: float, gap: float, cells: str) -> sf.PolygonMesh:
    """gmsh triangles of the three regions (block SOLID, medium MEDIUM, cylinder CYLINDER)."""
    if L <= R:
        raise ValueError(f"--block must exceed the cylinder radius {R}, got {L}")
    top = L + gap + R
    with sf.meshes.gmsh_session() as gmsh:
        occ = gmsh.model.occ
        block = occ.addRectangle(0.0, 0.0, 0.0, L, L)
        c = occ.addPoint(0.0, top, 0.0)
        p0, p1 = occ.addPoint(R, top, 0.0), occ.addPoint(0.0, top - R, 0.0)
        arc = occ.addCircleArc(p0, c, p1)
        cyl = occ.addPlaneSurface([occ.addCurveLoop([occ.addLine(c, p0), arc, occ.addLine(p1, c)])])
        box = occ.addRectangle(0.0, L, 0.0, L, gap + R)
        _, children = occ.fragment([(2, block), (2, cyl)], [(2, box)])
        occ.synchronize()
        regions = {sf.meshes.SOLID: [s for _, s in children[0]], CYLINDER: [s for _, s in children[1]]}
        taken = {s for v in regions.values() for s in v}
        regions[sf.meshes.MEDIUM] = [s for _, s in children[2] if s not in taken]
        for tag, surfaces in regions.items():
            gmsh.model.addPhysicalGroup(2, surfaces, tag)
        field = gmsh.model.mesh.field

        def box_field(size: float, x_max: float, y_min: float, y_max: float, thickness: float) -> int:
            f = field.add("Box")
            for name, value in (("VIn", size), ("VOut", h_far), ("XMin", -1.0), ("XMax", x_max),
                                ("YMin", y_min), ("YMax", y_max), ("Thickness", thickness)):
                field.setNumber(f, name, value)
            return f

        zone = box_field(h, 0.8, L - 0.4, L + gap + 0.3, 0.6)
        layer = box_field(h_medium, 0.8, L + 1e-9, L + gap + 0.3, 0.0)   # inside the medium only
        f = field.add("Min")
        field.setNumbers(f, "FieldsList", [zone, layer])
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


def build(args: argparse.Namespace) -> sf.ContactProblem:
    L = args.block
    h_far = args.h_far if args.h_far is not None else min(8 * args.h, 0.2)
    h_medium = args.h_medium if args.h_medium is not None else args.h
    poly = mesh(L, args.h, h_far, h_medium, args.gap, args.cells)
    top = L + args.gap + R
    s = args.stiffness
    problem = sf.ContactProblem(poly, {sf.meshes.SOLID: sf.Hyperelastic(K=K, mu=MU),
                                       CYLINDER: sf.Hyperelastic(K=s * K, mu=s * MU),
                                       sf.meshes.MEDIUM: common.third_medium(args, mu=MU)},
                                **common.discretization(args))
    problem.fix(common.on_segment((0.0, 0.0), (L, 0.0)), name="fixed")
    problem.fix(common.on_segment((0.0, 0.0), (0.0, top)), components=(0,), name="symmetry")
    problem.prescribe(common.on_segment((0.0, top), (R, top)), tags=[CYLINDER], uy=-(args.gap + args.indent),
                      name="load")
    problem.parameters["geometry"] = {"L": L, "R": R, "gap": args.gap, "h_far": h_far, "h_medium": h_medium,
                                      "E_star": E_STAR, "cells": args.cells}
    return problem


# --------------------------------------------------------------------------- Hertz's solution
def hertz_half_width(P: float) -> float:
    """a = sqrt(4 P R / (pi E*)) for the force P per unit thickness of the full model."""
    return math.sqrt(4 * max(P, 0.0) * R / (math.pi * E_STAR))


def hertz_pressure(x: np.ndarray, P: float) -> np.ndarray:
    """p(x) = p_max sqrt(1 - x^2/a^2), p_max = 2 P / (pi a); 0 outside |x| < a."""
    a = hertz_half_width(P)
    if a == 0.0:
        return np.zeros_like(x)
    return 2 * P / (math.pi * a) * np.sqrt(np.clip(1 - (x / a) ** 2, 0.0, None))


def block_contact(pairs: typing.Sequence[dict], block: int) -> dict | None:
    """The contact quantities of the block facing the cylinder (None before any contact)."""
    return next((c for c in pairs if c["body"] == block), None)


def block_body(pressure: sf.ContactPressure) -> int:
    """The body index of the block: the body of the boundary node at the origin."""
    return int(pressure.body[np.argmin(np.hypot(*pressure.X.T))])


def hertz_rows(summary: RunSummary, block: int, touching: float) -> list[dict[str, float]]:
    """Per converged step in contact (smallest gap below ``touching``): load, P (full model),
    a (zone length), a_p = 2 P / (pi p_max) (the half-width Hertz's pressure profile would have
    with the measured peak), a_H, p_max and its Hertz value, smallest gap, P over the reaction of
    the loaded top."""
    rows = []
    for s in summary.converged_steps:
        c = block_contact(s.contact, block)
        if c is None or c["gap"] is None or c["gap"] > touching or -c["force"][1] <= 0.0:
            continue
        P = -2 * c["force"][1]
        a_h = hertz_half_width(P)
        rows.append({"load": s.load, "P": P, "a": c["zone_length"], "a_p": 2 * P / (math.pi * c["max_pressure"]),
                     "a_H": a_h, "p_max": c["max_pressure"],
                     "p_max_H": 2 * P / (math.pi * a_h), "gap": c["gap"],
                     "reaction": 2 * s.force("load")})
    return rows


def write_table(rows: list[dict[str, float]], path: pathlib.Path, title: str) -> None:
    """The rows of :func:`hertz_rows` as a Markdown table."""
    lines = [f"# {title}", "", "| load | P | a (zone) | a_p | a Hertz | a / a_H | a_p / a_H | p_max | p_max Hertz "
             "| smallest gap | P / reaction |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['load']:.4g} | {r['P']:.4g} | {r['a']:.4f} | {r['a_p']:.4f} | {r['a_H']:.4f} "
                     f"| {r['a'] / r['a_H']:.3f} | {r['a_p'] / r['a_H']:.3f} | {r['p_max']:.4g} | {r['p_max_H']:.4g} "
                     f"| {r['gap']:.2e} | {r['P'] / r['reaction']:.4f} |")
    path.write_text("\n".join(lines) + "\n")


def block_top_pressure(pressure: sf.ContactPressure, block: int, L: float) -> np.ndarray:
    """(n, 2) deformed x and pressure of the block's top nodes facing the cylinder, sorted by x."""
    on_top = (pressure.body == block) & np.isclose(pressure.X[:, 1], L) & (pressure.partner_body >= 0)
    xp = np.stack([pressure.x[on_top, 0], pressure.pressure[on_top]], axis=1)
    return xp[np.argsort(xp[:, 0])]


def plot(xp: np.ndarray, P: float, rows: list[dict[str, float]], path: pathlib.Path, title: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9, 3.6))
    a = hertz_half_width(P)
    x = np.linspace(0.0, max(1.5 * a, 1e-3), 200)
    ax1.plot(xp[:, 0], xp[:, 1], "o-", ms=3, label="medium on block")
    ax1.plot(x, hertz_pressure(x, P), "k--", label=f"Hertz, P = {P:.3g}")
    ax1.set(xlabel="x", ylabel="pressure p", xlim=(0.0, max(2 * a, 0.1)))
    ax1.legend(fontsize=8)
    P_all = np.array([r["P"] for r in rows])
    ax2.plot(P_all, [r["a"] for r in rows], "o", ms=4, label="zone length a (p > 1 % p_max)")
    ax2.plot(P_all, [r["a_p"] for r in rows], "s", ms=3, label="a_p = 2 P / (pi p_max)")
    Ps = np.linspace(0.0, P_all.max(initial=0.0), 100)
    ax2.plot(Ps, [hertz_half_width(p) for p in Ps], "k--", label="Hertz")
    ax2.set(xlabel="P (full model)", ylabel="half-width a")
    ax2.legend(fontsize=8)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    save_png(fig, path, dpi=90)


def main(argv: typing.Sequence[str] | None = None) -> int:
    args = common.parse_args(make_parser(), argv)
    problem = build(args)
    title = (f"hertz: {args.method}, gamma = {args.gamma:g}, h = {args.h:g}, gap = {args.gap:g}, "
             f"block = {args.block:g}, {args.cells}")
    if problem.comm.rank == 0:
        print(title, flush=True)
    code = common.run(problem, args)
    pressure = problem.contact_pressure()          # the last converged state (collective)
    if problem.comm.rank == 0:
        summary = read_summary(args.out)
        block = block_body(pressure)
        rows = hertz_rows(summary, block, touching=0.05 * args.gap)
        write_table(rows, args.out / "hertz.md", title)
        xp = block_top_pressure(pressure, block, args.block)
        with open(args.out / "pressure.csv", "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["x", "p"])
            w.writerows(xp.tolist())
        if rows:
            r = rows[-1]
            plot(xp, r["P"], rows, args.out / "hertz.png", title)
            print(f"final: load {r['load']:.4g}, P {r['P']:.5g}, a {r['a']:.4f}, Hertz {r['a_H']:.4f}, "
                  f"p_max {r['p_max']:.4g}, Hertz {r['p_max_H']:.4g}, gap {r['gap']:.2e}", flush=True)
        else:
            print("final: no contact reached", flush=True)
    return code


if __name__ == "__main__":
    sys.exit(common.exit_code(main))
