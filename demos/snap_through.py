"""Snap-through of a shallow clamped arch under a point force at its apex, traced by arc-length.

Problem: plane strain, the solid of paper Eq. 2 with K = 5/3, mu = 1 (E' = E / (1 - nu^2) = 8/3),
the arch of ``sf.meshes.shallow_arch`` (span 1, rise 0.1, thickness 0.03: a circular band,
polygons ``--cells``, size ``--h``), clamped at both end faces. A downward point force lambda F
(F = ``--force``) acts at the apex, the top surface's vertex at x = 0.

- Arc-length control (``sf.ArcLength``, cylindrical, first increment ``--load-step``, arc length
  at most ``--max-growth`` times the first) passes the upper limit point, follows the unstable
  branch (negative pivots of the tangent > 0) past the lower limit point and up the inverted
  arch until the apex has moved down by ``--stop`` (default 0.2, twice the rise).
- Displacement control for comparison: u_y = -stop prescribed at the apex in ``--steps`` equal
  steps; the force is the reaction there.

``--method vem|fem`` runs both controls with one method, ``--both`` with SFVEM and FEM (P2 on a
triangulation matched to the SFVEM unknowns, the apex kept as a vertex).

The beam model of docs/validation-loads.md (shallow extensible clamped arch, apex displacement
control) estimates the upper limit load at 19.8 E'I/L^2 = 1.19e-4 (I = thickness^3/12, L = span)
at an apex deflection of 0.0415 and the lower one at 0.59 of it near 0.117.

Outputs in ``--out``: one directory per run (``vem-arc_length``, ``vem-displacement``, ...; the
usual summary.json, load_path.csv, pictures), load_displacement.png (force against the apex's
downward displacement, every run, the points with negative pivots marked), snap_through.md
(per run: unknowns, upper and lower limit loads and the apex displacements there, from a cubic
spline through the path's points, the largest recorded force, steps, Newton iterations, time).

Examples::

    python3 demos/snap_through.py --both --h 0.01                     # about 1 min
    mpirun -n 2 python3 demos/snap_through.py --method fem --h 0.005 --out out/snap_fem
"""
from __future__ import annotations

import argparse
import pathlib
import sys
import typing

import numpy as np
import scipy.interpolate
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem.output import markdown
from dolfinx_sfvem.output.figure_output import save_png
from dolfinx_sfvem.output.run_summary import RunSummary, read_summary

import _common as common

K, MU = 5 / 3, 1.0
SPAN, RISE, THICKNESS = 1.0, 0.1, 0.03
E_PLANE = 4 * MU * (3 * K + MU) / (3 * K + 4 * MU)       # E / (1 - nu^2) in plane strain: 8/3
#: the beam model's limit loads (docs/validation-loads.md): 19.8 E'I/L^2, the lower one 0.59 of it
BEAM_LIMIT = 19.8 * E_PLANE * THICKNESS ** 3 / 12 / SPAN ** 2
BEAM_LIMIT_DEFLECTION, BEAM_LOWER_RATIO, BEAM_LOWER_DEFLECTION = 0.0415, 0.59, 0.117
CONTROLS = ("arc_length", "displacement")


def make_parser() -> argparse.ArgumentParser:
    p = common.parser("snap_through", __doc__, steps=40, h=0.01, h_max=THICKNESS)
    p.add_argument("--cells", choices=("dual", "triangles", "quads"), default="dual",
                   help="polygons of the mesh (default %(default)s)")
    p.add_argument("--force", type=common.positive_float, default=1e-3,
                   help="point force F at load factor 1 (default %(default)s; arc-length ends at lambda = 1 "
                        "if the stop is not passed before)")
    p.add_argument("--stop", type=common.positive_float, default=0.2,
                   help="downward apex displacement that ends both paths (default %(default)s)")
    p.add_argument("--load-step", type=common.positive_float, default=0.01,
                   help="arc-length: load factor increment of the first step (default %(default)s)")
    p.add_argument("--max-growth", type=common.positive_float, default=4.0,
                   help="arc-length: largest arc length / first arc length (default %(default)s)")
    common.add_both(p)
    return p


def build(method: str, benchmark: sf.meshes.Benchmark, args: argparse.Namespace, control: str) -> sf.ContactProblem:
    """The clamped arch with the apex force (arc-length) or the apex displacement (displacement control)."""
    problem = sf.ContactProblem(benchmark.mesh, {"solid": sf.Hyperelastic(K=K, mu=MU)}, method=method,
                                verbose=not args.quiet)
    problem.fix(common.on_segment(*benchmark.segments["left_end"]), name="left")
    problem.fix(common.on_segment(*benchmark.segments["right_end"]), name="right")
    apex = benchmark.points["apex"]
    if control == "arc_length":
        problem.point_force(apex, fy=-args.force, name="apex")
    else:
        problem.prescribe(common.at_point(apex), uy=-args.stop, name="apex")
    problem.parameters["geometry"] = {"span": SPAN, "rise": RISE, "thickness": THICKNESS, "cells": args.cells,
                                      "control": control}
    return problem


def observers(problem: sf.ContactProblem, benchmark: sf.meshes.Benchmark) -> dict:
    """u_y at the apex (the loaded vertex) and at the bottom vertex below it."""
    return {name: common.displacement_observer(problem, common.at_point(benchmark.points[name]), 1)
            for name in ("apex", "apex_bottom")}


def run(method: str, control: str, benchmark: sf.meshes.Benchmark, args: argparse.Namespace) -> tuple[int, pathlib.Path]:
    """One path, written to ``<out>/<method>-<control>``; its exit code and directory."""
    out = args.out / f"{method}-{control}"
    sub = common.sub_run(args, method, out)
    problem = build(method, benchmark, sub, control)
    if problem.comm.rank == 0:
        print(f"snap-through: {method}, {control} control, h = {args.h:g}", flush=True)
    options = {}
    if control == "arc_length":
        options["control"] = sf.ArcLength(load_step=args.load_step, max_growth=args.max_growth,
                                          stop=("apex", args.stop))
    return common.run(problem, sub, observers(problem, benchmark), **options), out


# --------------------------------------------------------------------------- the curves
class Path(typing.NamedTuple):
    """A run's load-displacement curve: apex displacement w (downward), force, negative pivots."""
    label: str
    w: np.ndarray
    force: np.ndarray
    w_bottom: np.ndarray
    pivots: np.ndarray
    summary: RunSummary


def read_path(out: pathlib.Path, label: str) -> Path:
    """The converged steps of the run in ``out`` (force: λ F of the point force, or minus the apex
    reaction under displacement control), starting from the unloaded state."""
    summary = read_summary(out)
    steps = summary.converged_steps
    force = [s.loads["apex"]["magnitude"] if "apex" in s.loads else s.force("apex") for s in steps]
    w = [-s.extra["apex"] for s in steps]
    w_bottom = [-s.extra["apex_bottom"] for s in steps]
    pivots = [s.negative_pivots if s.negative_pivots is not None else -1 for s in steps]
    return Path(label, *(np.concatenate([[0.0], v]) for v in (w, force, w_bottom)),
                np.concatenate([[0], pivots]).astype(int), summary)


class Limit(typing.NamedTuple):
    """A limit point of a path: force and apex displacements there (cubic spline through the
    points), and the force of the path's own point nearest to it."""
    force: float
    w: float
    w_bottom: float
    recorded: float


def limit_points(path: Path) -> list[Limit]:
    """The upper limit point (first maximum of the force along the path) and the lower one (the
    next minimum), as far as the path has them, each refined by a cubic spline of force and
    bottom displacement against w over the path's points (w grows monotonically on these paths)."""
    if np.any(np.diff(path.w) <= 0):
        raise ValueError(f"{path.label}: the apex displacement does not grow monotonically along the path")
    force = scipy.interpolate.CubicSpline(path.w, path.force)
    bottom = scipy.interpolate.CubicSpline(path.w, path.w_bottom)
    turns = np.flatnonzero(np.diff(np.sign(np.diff(path.force))) != 0) + 1     # points where the force turns
    found = []
    for i, sign in zip(turns[:2], (1.0, -1.0)):
        fine = np.linspace(path.w[i - 1], path.w[i + 1], 2001)
        k = int(np.argmax(sign * force(fine)))
        found.append(Limit(float(force(fine[k])), float(fine[k]), float(bottom(fine[k])), float(path.force[i])))
    return found


def report(paths: list[Path], args: argparse.Namespace) -> None:
    """snap_through.md and load_displacement.png in ``--out``."""
    header = ["run", "unknowns", "upper limit load", "w there", "bottom w there", "nearest point", "lower limit load",
              "w there", "steps", "Newton", "negative pivots (max)", "time [s]"]
    rows = []
    for path in paths:
        limits = limit_points(path) + [None, None]
        upper, lower = (["-"] * 4 if limit is None else
                        [f"{limit.force:.6e}", f"{limit.w:.5f}", f"{limit.w_bottom:.5f}", f"{limit.recorded:.6e}"]
                        for limit in limits[:2])
        rows.append([path.label, str(path.summary.dofs), *upper, *lower[:2], str(len(path.summary.converged_steps)),
                     str(path.summary.newton_iterations), str(path.pivots.max()), f"{path.summary.wall_time_s:.1f}"])
    lines = [f"# Shallow arch snap-through: h = {args.h:g}, cells {args.cells}, F = {args.force:g}, stop at w = "
             f"{args.stop:g}", "",
             f"w: downward displacement of the apex (the loaded vertex); bottom w: of the vertex below it. Beam-model "
             f"estimate (docs/validation-loads.md): upper limit {BEAM_LIMIT:.4e} at w = {BEAM_LIMIT_DEFLECTION}, "
             f"lower {BEAM_LOWER_RATIO * BEAM_LIMIT:.4e} near w = {BEAM_LOWER_DEFLECTION}.", ""]
    lines += markdown.table(header, rows)
    (args.out / "snap_through.md").write_text("\n".join(lines) + "\n")
    plot(paths, args.out / "load_displacement.png", f"shallow arch: h = {args.h:g}, {args.cells} polygons")


#: line style, marker, colour of each run in the plot
STYLE = {"vem-arc_length": ("-", "o", "C0"), "fem-arc_length": ("-", "^", "C1"),
         "vem-displacement": ("none", "s", "C2"), "fem-displacement": ("none", "D", "C3")}


def plot(paths: list[Path], path_png: pathlib.Path, title: str) -> None:
    """Force against apex displacement of every run (arc-length: lines; displacement control:
    open markers), the points with negative pivots filled, the limit points as stars; the force
    axis cut at 1.5 times the beam model's limit load (the inverted arch stiffens beyond)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8.6, 3.9))
    for path in paths:
        line, marker, colour = STYLE[path.label]
        method, control = path.label.split("-")
        ax.plot(path.w, path.force, ls=line, color=colour, marker=marker, ms=3.5, mfc="none", lw=1,
                label=f"{'SFVEM' if method == 'vem' else 'FEM'}, {control.replace('_', '-')} control")
        unstable = path.pivots > 0
        ax.plot(path.w[unstable], path.force[unstable], marker, color=colour, ms=3.5, ls="none")
        if unstable.any() and path is paths[0]:
            ax.axvspan(path.w[unstable].min(), path.w[unstable].max(), color="0.9", zorder=0,
                       label=f"negative pivots > 0 along\n{path.label}: unstable")
        limits = limit_points(path)
        ax.plot([limit.w for limit in limits], [limit.force for limit in limits], "*", color=colour, ms=9)
    ax.axhline(BEAM_LIMIT, color="k", lw=0.7, ls=":", label="beam model: upper and lower limit load")
    ax.axhline(BEAM_LOWER_RATIO * BEAM_LIMIT, color="k", lw=0.7, ls=":")
    ax.plot([], [], "ko", ms=3.5, ls="none", label="filled markers: negative pivots > 0")
    ax.plot([], [], "k*", ms=9, ls="none", label="limit points (spline)")
    ax.set(xlabel="apex displacement w (downward)", ylabel="apex force (per unit depth)", title=title,
           ylim=(0.0, 1.5 * BEAM_LIMIT))
    ax.ticklabel_format(axis="y", style="sci", scilimits=(0, 0))
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    save_png(fig, path_png, dpi=90)


def main(argv: typing.Sequence[str] | None = None) -> int:
    args = common.parse_args(make_parser(), argv)
    benchmark = sf.meshes.shallow_arch(args.h, span=SPAN, rise=RISE, thickness=THICKNESS, polygons=args.cells)
    runs = [run(method, control, benchmark, args) for method in common.methods(args) for control in CONTROLS]
    if MPI.COMM_WORLD.rank == 0:
        paths = [read_path(out, out.name) for _, out in runs]
        report(paths, args)
        for path in paths:
            print(f"{path.label}: " + ", ".join(f"{name} limit {limit.force:.5e} at w = {limit.w:.4f}" for name, limit
                                                in zip(("upper", "lower"), limit_points(path))), flush=True)
    return max(code for code, _ in runs)


if __name__ == "__main__":
    sys.exit(common.exit_code(main))
