"""A soft pneumatic bending actuator (PneuNet): chambers inflated by cavity pressure until their
walls touch through the third medium.

Geometry (``sf.meshes.pneumatic_actuator``, mm): the length-height section of a PneuNet bending
actuator after the Soft Robotics Toolkit (Harvard Biodesign Lab, "PneuNets Bending Actuators";
a fast PneuNet in the sense of Mosadegh et al. 2014, Adv. Funct. Mater. 24, 2163): chambers 8 mm
long and 15 mm high with 1 mm sidewalls and 2 mm roofs, 2 mm apart, on a 2 mm floor and a 1 mm
strain-limiting base layer (the toolkit's paper layer, here one stiff layer; our choice). The
toolkit's actuator has 11 chambers; the default here is ``--chambers 3`` at ``--h 1`` (one
polygon across a sidewall) so that SFVEM and FEM both run in a few minutes on 2 ranks.

Problem: plane strain (forces per unit depth, N/mm), clamped at x = 0 (the first chamber's outer
sidewall and the base layer's end face). Every chamber is filled with third medium and loaded by
``problem.cavity_pressure(chamber, λ p)`` (the energy term -λ p ∫ (J - 1) dΩ over it), the
pressure ``--p`` at load factor λ = 1; the gaps between neighbouring chambers are filled with
third medium too: the contact medium through which the bulging sidewalls touch.

Materials (paper Eq. 2, mm and MPa): the elastomer mu = 0.1 MPa (E about 0.3 MPa, a
silicone rubber of the Elastosil M4601 / Dragon Skin kind), K = 20 mu (Poisson's ratio 0.475,
nearly incompressible while Newton stays easy); the base layer ten times stiffer (mu = 1 MPa,
K = 20 MPa). Medium (Eqs. 3-5): mu = the elastomer's, ``--gamma`` (default 1e-4), ``--alpha-r``
(default 1), rotation regularization, the same in chambers and gaps.

Outputs: the bending angle θ of the tip: the clockwise rotation of the tip face x = L, measured by
its two corners (``tip_bottom``, ``tip_top``): θ = π/2 - atan2(Δy, Δx) of their deformed
difference (degrees; the actuator bends towards its base, θ > 0). The smallest gap between the
solids (the run's contact check, load_path.csv ``gap``; here the body faces itself across the
gaps), the chambers' area changes (the cavity loads' work-conjugate displacements ∫ (J - 1)).
First contact: the pressure at which the smallest gap falls below :data:`CONTACT_FRACTION` of
the initial 2 mm (linear interpolation between steps).

In ``--out``: one directory per method (``vem``, ``fem``: summary.json, load_path.csv,
deformed.png, ...), actuator.png (θ, gap and chamber area against the pressure, every method)
and actuator.md (unknowns, steps, Newton iterations, time, pressure at first contact, θ and gap
at full pressure).

Examples::

    mpirun -n 2 python3 demos/pneumatic_actuator.py --both              # a few minutes
    python3 demos/pneumatic_actuator.py --chambers 2 --h 1.5 --out out/actuator2
    python3 demos/pneumatic_actuator.py --method fem --chambers 5 --h 0.5
"""
from __future__ import annotations

import argparse
import math
import pathlib
import sys
import typing

import numpy as np
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem.output import markdown
from dolfinx_sfvem.output.figure_output import save_png
from dolfinx_sfvem.output.run_summary import RunSummary, read_summary

import _common as common

GEOMETRY = sf.meshes.PneuNet()
#: elastomer and base layer moduli (MPa)
MU_ELASTOMER, K_ELASTOMER = 0.1, 2.0
MU_BASE, K_BASE = 1.0, 20.0
#: contact: the smallest gap below this fraction of the initial gap between the chambers
CONTACT_FRACTION = 0.1


def make_parser() -> argparse.ArgumentParser:
    p = common.parser("pneumatic_actuator", __doc__, steps=20, h=1.0, h_max=GEOMETRY.sidewall, gamma=1e-4,
                      alpha_r=1.0, regularization="rotation")
    p.add_argument("--chambers", type=common.positive_int, default=3,
                   help="number of chambers (default %(default)s; the toolkit's actuator has 11)")
    p.add_argument("--p", type=common.positive_float, default=0.005,
                   help="chamber pressure at load factor 1, MPa (default %(default)s)")
    common.add_both(p)
    return p


def chamber_names(regions: typing.Mapping[str, int]) -> list[str]:
    """The chambers' region names (``chamber_1``, ...) of an actuator mesh, 2D or 3D."""
    return [name for name in regions if name.startswith("chamber_")]


def materials(regions: typing.Mapping[str, int], args: argparse.Namespace) -> dict[int, sf.Energy]:
    """The actuator's energies by region tag, 2D or 3D: the elastomer, the stiffer base, and the
    third medium (the command line's) in the gaps and every chamber."""
    medium = common.third_medium(args, mu=MU_ELASTOMER)
    return {regions["elastomer"]: sf.Hyperelastic(K=K_ELASTOMER, mu=MU_ELASTOMER),
            regions["base"]: sf.Hyperelastic(K=K_BASE, mu=MU_BASE),
            regions["gaps"]: medium, **{regions[name]: medium for name in chamber_names(regions)}}


def build(benchmark: sf.meshes.Benchmark, args: argparse.Namespace) -> sf.ContactProblem:
    """The clamped actuator with every chamber under the cavity pressure λ p (loads
    ``chamber_1`` ... ``chamber_n``)."""
    regions = benchmark.regions
    chambers = chamber_names(regions)
    problem = sf.ContactProblem(benchmark.mesh, materials(regions, args), **common.discretization(args))
    problem.fix(common.on_segment(*benchmark.segments["clamp"]), name="clamp")
    for name in chambers:
        problem.cavity_pressure(name, args.p, name=name)
    problem.parameters["geometry"] = {**vars(GEOMETRY), "chambers": args.chambers, "mu": MU_ELASTOMER,
                                      "K": K_ELASTOMER, "mu_base": MU_BASE, "K_base": K_BASE}
    return problem


def observers(problem: sf.ContactProblem, benchmark: sf.meshes.Benchmark) -> dict:
    """u_x, u_y of the tip face's two corners (``tip_bottom_ux``, ...)."""
    return {f"{corner}_u{'xy'[k]}": common.displacement_observer(problem, common.at_point(benchmark.points[corner]), k)
            for corner in ("tip_bottom", "tip_top") for k in range(2)}


def run(method: str, benchmark: sf.meshes.Benchmark, args: argparse.Namespace) -> tuple[int, pathlib.Path]:
    """One load path, written to ``<out>/<method>``; its exit code and directory."""
    out = args.out / method
    sub = common.sub_run(args, method, out)
    problem = build(benchmark, sub)
    if problem.comm.rank == 0:
        print(f"pneumatic actuator: {method}, {args.chambers} chambers, h = {args.h:g}, p = {args.p:g} MPa", flush=True)
    return common.run(problem, sub, observers(problem, benchmark)), out


# --------------------------------------------------------------------------- the curves
def bending_angle(tip_bottom: np.ndarray, tip_top: np.ndarray, height: float) -> np.ndarray:
    """Clockwise rotation (degrees) of the tip face from the displacements (n, 2) of its bottom and
    top corner, ``height`` apart in the reference (the face vertical): π/2 - atan2(Δy, Δx)."""
    d = np.asarray(tip_top, dtype=np.float64) - np.asarray(tip_bottom, dtype=np.float64)
    return np.degrees(np.pi / 2 - np.arctan2(height + d[:, 1], d[:, 0]))


class Curve(typing.NamedTuple):
    """A run's path from the unloaded state on: pressure λ p (MPa), bending angle θ (degrees),
    smallest gap (mm; the initial spacing at λ = 0), the chambers' area changes (mm², (n, chambers))."""
    label: str
    pressure: np.ndarray
    angle: np.ndarray
    gap: np.ndarray
    area: np.ndarray
    summary: RunSummary

    def first_contact(self) -> float:
        """Pressure at which the gap first falls below CONTACT_FRACTION of the initial spacing
        (linear between the steps), NaN if it never does."""
        level = CONTACT_FRACTION * GEOMETRY.spacing
        below = np.flatnonzero(self.gap < level)
        if below.size == 0:
            return math.nan
        k = below[0]
        return float(np.interp(level, self.gap[k - 1:k + 1][::-1], self.pressure[k - 1:k + 1][::-1]))


#: what the chambers' changes are, by the dimension: (name, unit)
CHANGES = {"area": "mm²", "volume": "mm³"}


def read_curve(out: pathlib.Path, label: str, geometry: sf.meshes.PneuNet = GEOMETRY, vertical: str = "y") -> Curve:
    """The converged steps of the run in ``out`` with the unloaded state first; θ from the tip
    corners' displacements along x and ``vertical`` (the height axis: y in 2D, z in 3D)."""
    summary = read_summary(out)
    rows = common.read_load_path(out / "load_path.csv")
    chambers = sorted((k for k in rows[0] if k.startswith("chamber_") and k.endswith("_displacement")),
                      key=lambda k: int(k.split("_")[1])) if rows else []
    pressure = [r["chamber_1_magnitude"] for r in rows]
    corners = [np.array([[r[f"{c}_ux"], r[f"{c}_u{vertical}"]] for r in rows]).reshape(-1, 2)
               for c in ("tip_bottom", "tip_top")]
    angle = bending_angle(*corners, geometry.top)
    gap = [r["gap"] for r in rows]
    area = np.array([[r[k] for k in chambers] for r in rows]).reshape(len(rows), len(chambers))
    return Curve(label, np.concatenate([[0.0], pressure]), np.concatenate([[0.0], angle]),
                 np.concatenate([[geometry.spacing], gap]), np.vstack([np.zeros((1, len(chambers))), area]), summary)


def report(curves: list[Curve], args: argparse.Namespace, title: str | None = None, change: str = "area") -> None:
    """actuator.md and actuator.png in ``--out``; ``title`` of the plot (default: the 2D demo's),
    ``change`` a key of :data:`CHANGES` (what ``Curve.area`` holds)."""
    unit = CHANGES[change]
    header = ["run", "unknowns", "steps", "Newton", "time [s]", "load reached", "p at first contact [kPa]",
              "θ at full p [°]", "gap at full p [mm]", "smallest gap [mm]", f"chamber {change} change at full p [{unit}]"]
    rows = [[c.label, str(c.summary.dofs), str(len(c.summary.converged_steps)), str(c.summary.newton_iterations),
             f"{c.summary.wall_time_s:.1f}", f"{c.pressure[-1] / args.p:.4g}", f"{1e3 * c.first_contact():.3g}",
             f"{c.angle[-1]:.2f}", f"{c.gap[-1]:.4f}", f"{c.gap.min():.4f}",
             ", ".join(f"{a:.2f}" for a in c.area[-1])] for c in curves]
    lines = [f"# Pneumatic actuator: {args.chambers} chambers, h = {args.h:g} mm, p = {1e3 * args.p:g} kPa, "
             f"gamma = {args.gamma:g}, alpha_r = {args.alpha_r:g}", "",
             "θ: clockwise rotation of the tip face (its two corners); gap: smallest gap between the solids "
             f"(initially {GEOMETRY.spacing:g} mm); first contact: the gap below {CONTACT_FRACTION:g} of it.", ""]
    lines += markdown.table(header, rows)
    (args.out / "actuator.md").write_text("\n".join(lines) + "\n")
    plot(curves, args.out / "actuator.png", title or f"PneuNet, {args.chambers} chambers, h = {args.h:g} mm",
         change)


def plot(curves: list[Curve], path_png: pathlib.Path, title: str, change: str = "area") -> None:
    """θ, smallest gap and the mean chamber ``change`` (a key of :data:`CHANGES`) against the
    pressure (kPa), one line per run."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(10.5, 3.2))
    for curve, (style, colour) in zip(curves, (("-o", "C0"), ("--^", "C1"))):
        label = {"vem": "SFVEM", "fem": "FEM (P2)"}.get(curve.label, curve.label)
        kpa = 1e3 * curve.pressure
        for ax, values in zip(axes, (curve.angle, curve.gap, curve.area.mean(axis=1))):
            ax.plot(kpa, values, style, color=colour, ms=3, mfc="none", lw=1, label=label)
        contact = 1e3 * curve.first_contact()
        if math.isfinite(contact):
            for ax in axes:
                ax.axvline(contact, color=colour, lw=0.7, ls=":")
    axes[1].axhline(CONTACT_FRACTION * GEOMETRY.spacing, color="0.5", lw=0.7, ls="--", label="contact level")
    axes[1].set_ylim(bottom=0.0)
    for ax, name in zip(axes, ("tip bending angle θ [°]", "smallest gap [mm]", f"mean chamber {change} change [{CHANGES[change]}]")):
        ax.set(xlabel="chamber pressure [kPa]", ylabel=name)
        ax.grid(True, alpha=0.3)
    axes[1].legend(fontsize=7)
    fig.suptitle(title + " (dotted: first contact)", fontsize=9)
    fig.tight_layout()
    save_png(fig, path_png, dpi=80)


def main(argv: typing.Sequence[str] | None = None) -> int:
    args = common.parse_args(make_parser(), argv)
    benchmark = sf.meshes.pneumatic_actuator(args.h, args.chambers, geometry=GEOMETRY)
    runs = [run(method, benchmark, args) for method in common.methods(args)]
    if MPI.COMM_WORLD.rank == 0:
        curves = [read_curve(out, out.name) for _, out in runs]
        report(curves, args)
        for c in curves:
            print(f"{c.label}: θ = {c.angle[-1]:.2f}° at p = {1e3 * c.pressure[-1]:.4g} kPa, first contact at "
                  f"{1e3 * c.first_contact():.4g} kPa, smallest gap {c.gap.min():.4f} mm", flush=True)
    return max(code for code, _ in runs)


if __name__ == "__main__":
    sys.exit(common.exit_code(main))
