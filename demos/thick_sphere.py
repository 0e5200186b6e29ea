"""Thick spherical shell under internal pressure: follower, dead and cavity pressure against exact answers.

Problem
-------
The solid of paper Eq. 2 in 3D with K = 5/3, mu = 1 (Lamé lambda = mu = 1, nu = 1/4), the 1/8
shell a < R < b (a = 1, b = 2, x, y, z >= 0) of ``sf.meshes.thick_sphere`` in P2 tetrahedra of
size ``--h`` (``--method vem``: the SFVEM on these tetrahedra read as polyhedra), u_x = 0 on
x = 0, u_y = 0 on y = 0, u_z = 0 on z = 0, the outer sphere free, the inner one loaded by the
pressure ``--p`` (default 0.2: u_r(a) = 0.074 a follower, 0.064 a dead) as

- ``--load follower``: ``problem.pressure(inner, p)``, on the deformed surface;
- ``--load dead``: ``problem.pressure(inner, p, follower=False)``, per unit reference area;
- ``--load cavity``: the ball R < a filled with third medium (``filled=True``; mu_m = 1, K_m = 5/3,
  ``--gamma`` default 1e-2, ``--alpha-r`` default 0: the medium deforms homogeneously, so a
  regularization would add nothing but compile time) and ``problem.cavity_pressure("cavity",
  p)``; the 1/8 cavity is closed by the symmetry planes.

Exact answers
-------------
``exact.thick_sphere``: the finite-strain radial solution of Eq. 2 as a 1D boundary value
problem, ``(R^2 P_r)' = 2 R P_theta``, P_r(b) = 0, with the follower, dead or medium-filled
condition at R = a; its ``lame`` (``exact.lame_sphere``) at the small pressure 1e-6 x p, where
the two differ by O(p) relative (about 1e-7). Compared: u_r at the inner sphere's mesh vertices
(their mean and their largest deviation, relative to the exact u_r(a)) and the load's recorded
work-conjugate displacement on the 1/8 model: the cavity's volume change (follower and cavity
pressure; ``cavity_volume_change / 8``) or ``int u . (-N) dA`` = pi a^2 u_r(a) / 2 (dead).

The mesh follows the spheres by flat triangles whose vertices lie on them; the P2 edge midpoints
lie a sagitta l^2 / (8 R) inside. The discrete shell is thinner and its cavity smaller than the
exact ones by O(h^2), and so is every answer: the geometry, not the P2 interpolation (O(h^3) in
L2), sets the rate, as on the thick cylinder (docs/thick-cylinder.md) -- there the polygonal
SFVEM mesh, here the straight-sided tetrahedra.

Study (``--study``, h in ``--study-h``)
---------------------------------------
Each case at each h; prints and writes thick-sphere.md and thick-sphere.csv in ``--out`` and
thick-sphere-convergence.png (docs/figures/); with ``--method vem`` thick-sphere-vem.md, .csv and
-convergence.png. The P2 FEM (the default), measured 2026-11-26, 1 rank (the study: 4 min):

p = 0.2 (the small p: 2e-7), cavity gamma = 1e-2, 2 load steps; relative errors (signed: the discrete
answers fall short) of the mean u_r at the inner vertices, its largest deviation, and of the
recorded conjugate; orders between consecutive meshes in the mean cell size h ~ unknowns^(-1/3)
(the cavity's unknowns include the medium's); s: set-up and solve.

===============  ====  ========  ===========  =====  ==============  =========  =====  ======  ==
case             h     unknowns  u_r(a) mean  order  u_r(a) largest  conjugate  order  Newton  s
===============  ====  ========  ===========  =====  ==============  =========  =====  ======  ==
small p vs Lamé  0.3   5451      -2.73e-02           3.39e-02        -2.90e-02         1       1
small p vs Lamé  0.2   13422     -1.49e-02    2.03   1.84e-02        -1.56e-02  2.06   1       3
small p vs Lamé  0.15  27807     -8.06e-03    2.52   9.46e-03        -8.64e-03  2.44   1       9
follower vs BVP  0.3   5451      -2.66e-02           3.20e-02        -3.07e-02         7       3
follower vs BVP  0.2   13422     -1.46e-02    2.01   1.69e-02        -1.66e-02  2.04   7       16
follower vs BVP  0.15  27807     -7.93e-03    2.50   8.91e-03        -9.21e-03  2.44   7       58
dead vs BVP      0.3   5451      -2.62e-02           3.20e-02        -2.93e-02         6       2
dead vs BVP      0.2   13422     -1.43e-02    2.01   1.73e-02        -1.59e-02  2.04   7       10
dead vs BVP      0.15  27807     -7.76e-03    2.51   8.89e-03        -8.79e-03  2.43   7       41
cavity vs BVP    0.3   6291      -2.64e-02           3.18e-02        -3.06e-02         7       4
cavity vs BVP    0.2   14844     -1.44e-02    2.12   1.70e-02        -1.66e-02  2.14   7       16
cavity vs BVP    0.15  31950     -7.84e-03    2.37   9.18e-03        -9.13e-03  2.33   7       64
===============  ====  ========  ===========  =====  ==============  =========  =====  ======  ==

All four cases converge at order 2 to 2.5 in h ~ unknowns^(-1/3) (1.5 and 2.1 in the requested
h, which gmsh's cells follow loosely) with nearly the same error: 2.7 % at h = 0.3, 1.5 % at
0.2, 0.8 % at 0.15, the same for the linear and the finite-strain answers and for each load. It
is the flat faces' geometric error; the P2 interpolation error of the smooth radial field is of
higher order. Follower and dead pressure differ by 14 % in u_r(a) at this p and the medium
(gamma K_m = 1/60) holds the cavity back by 1.7 %, far outside these errors at every mesh.

The SFVEM (``--method vem``: the same gmsh tetrahedra read as polyhedra; unknowns at the vertices
and edge midpoints, the face and cell means: 2.7-2.9 times P2's on the same mesh), measured
2026-11-26 at h = 0.3, 0.25, 0.2 on the shared 2-core machine (load average about 8; the study:
20 min), written to thick-sphere-vem.md (the study's files carry the method's name):

===============  ====  ========  ===========  =====  ==============  =========  =====  ======  ===
case             h     unknowns  u_r(a) mean  order  u_r(a) largest  conjugate  order  Newton  s
===============  ====  ========  ===========  =====  ==============  =========  =====  ======  ===
small p vs Lamé  0.3   14859     -2.82e-02           3.28e-02        -2.82e-02         1       26
small p vs Lamé  0.25  22221     -2.20e-02    1.85   2.51e-02        -2.18e-02  1.92   1       30
small p vs Lamé  0.2   38283     -1.53e-02    2.00   1.87e-02        -1.54e-02  1.94   1       86
follower vs BVP  0.3   14859     -2.69e-02           3.04e-02        -3.00e-02         7       109
follower vs BVP  0.25  22221     -2.10e-02    1.86   2.27e-02        -2.33e-02  1.91   7       102
follower vs BVP  0.2   38283     -1.47e-02    1.97   1.68e-02        -1.64e-02  1.92   7       173
dead vs BVP      0.3   14859     -2.66e-02           3.07e-02        -2.87e-02         7       45
dead vs BVP      0.25  22221     -2.08e-02    1.86   2.36e-02        -2.22e-02  1.91   7       83
dead vs BVP      0.2   38283     -1.45e-02    1.98   1.74e-02        -1.57e-02  1.92   7       159
cavity vs BVP    0.3   17427     -2.67e-02           3.03e-02        -2.99e-02         7       83
cavity vs BVP    0.25  25575     -2.07e-02    2.00   2.27e-02        -2.31e-02  2.03   7       82
cavity vs BVP    0.2   42711     -1.45e-02    2.09   1.68e-02        -1.64e-02  2.02   7       183
===============  ====  ========  ===========  =====  ==============  =========  =====  ======  ===

On the same meshes the SFVEM's errors are the P2 FEM's, sign and size (at h = 0.2: -1.53 % against
-1.49 % at the small p, -1.47 % against -1.46 % follower, -1.45 % against -1.43 % dead and -1.45 %
against -1.44 % cavity; both short), and fall at the same order 2 in h ~ unknowns^(-1/3), with the
same Newton iterations: the flat faces' geometric error, which no interpolation can remove, is
what both measure. Equal error therefore costs the SFVEM the 2.7-2.9 times more unknowns it has on
a mesh (38,283 against P2's 13,422 for 1.5 %), and its set-up and solve took 3 to 30 times the
FEM's on the same mesh (h = 0.2: small p 86 s against 3 s, follower 173 s against 16 s; the machine
was loaded differently for the two studies). Its advantage is for meshes P2 cannot use (octree cells with hanging
vertices, Voronoi cells), not on tetrahedra. (Before the face-mean nodes of the symmetry planes'
triangles were held too -- ``Benchmark3D.nodes_on`` -- the SFVEM's u_r(a) came out 0.4 % to 1.0 %
*long* at the small p and grew with refinement: the symmetry was imposed at the P2 nodes only.)

Commands
--------
::

    python3 demos/thick_sphere.py --load follower --h 0.35
    python3 demos/thick_sphere.py --load cavity --p 0.2 --steps 4
    python3 demos/thick_sphere.py --study --out out/thick_sphere_study
    python3 demos/thick_sphere.py --study --method vem --study-h 0.3 0.25 0.2 --out out/thick_sphere_study
"""
from __future__ import annotations

import argparse
import csv
import dataclasses
import math
import pathlib
import sys
import time
import typing

import numpy as np
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem import exact
from dolfinx_sfvem.output import markdown
from dolfinx_sfvem.output.figure_output import save_png
from dolfinx_sfvem.output.run_summary import RunSummary

import _common as common

A_IN, B_OUT = 1.0, 2.0
K, MU = 5 / 3, 1.0
#: the medium's moduli: with K = 0 (Eq. 5) it would carry no stress under the cavity's uniform
#: dilation in 3D (J^(-2/3) tr C = 3), so it is given the solid's bulk modulus
MU_MEDIUM, K_MEDIUM = 1.0, K
#: the finite pressure (u_r(a) = 0.074 a under the follower pressure, 0.064 a dead, Lamé 0.063 a)
P_REF = 0.2
#: the small pressure compared with Lamé
SMALL = 1e-6
LOADS = ("follower", "dead", "cavity")
STUDY_H = (0.3, 0.2, 0.15)
SYMMETRY = ("symmetry_x", "symmetry_y", "symmetry_z")


def make_parser() -> argparse.ArgumentParser:
    p = common.parser("thick_sphere", __doc__, steps=2, h=0.35, h_max=1.0, gamma=1e-2, alpha_r=0.0,
                      regularization="huhu")
    p.add_argument("--load", choices=LOADS, default="follower", help="what loads the cavity (default %(default)s)")
    p.add_argument("--p", type=common.finite_float, default=P_REF, help="internal pressure (default %(default)s)")
    p.add_argument("--study", action="store_true", help="run the refinement study instead (module docstring)")
    p.add_argument("--study-h", type=common.positive_float, nargs="+", default=STUDY_H, metavar="H",
                   help="mesh sizes of --study (default %(default)s)")
    p.add_argument("--order", type=int, choices=(1, 2), default=1,
                   help="geometry degree of the tetrahedra: 1 straight-sided, 2 gmsh's curved second order "
                        "(default %(default)s)")
    p.set_defaults(method="fem")
    return p


# --------------------------------------------------------------------------- the exact answers
@dataclasses.dataclass(frozen=True)
class Answer:
    """u_r(a) and the load's work-conjugate displacement on the 1/8 model (module docstring)."""

    name: str
    u_r_inner: float
    conjugate: float


def answer_for(load: str, p: float, gamma: float, lame: bool = False) -> Answer:
    """Lamé's answer (``lame``) or the finite-strain radial BVP of ``load`` at pressure p."""
    medium = exact.CavityMedium(gamma, MU_MEDIUM, K_MEDIUM) if load == "cavity" else None
    solution = exact.thick_sphere(A_IN, B_OUT, K, MU, p, follower=load != "dead", medium=medium)
    if lame:
        u_r = solution.lame.inner_radius_change
        return Answer("Lamé", u_r, math.pi * A_IN ** 2 * u_r / 2)
    u_r = solution.inner_radius_change
    conjugate = math.pi * A_IN ** 2 * u_r / 2 if load == "dead" else solution.cavity_volume_change / 8
    return Answer(f"BVP {load}", u_r, conjugate)


# --------------------------------------------------------------------------- the problem
def on_inner_sphere(x: np.ndarray) -> np.ndarray:
    """Marker of the cavity's boundary: its vertices and every point of its flat faces lie within
    R <= a (the wall's other points outside)."""
    return np.linalg.norm(x, axis=0) <= A_IN + 1e-9


def build(load: str, p: float, h: float, args: argparse.Namespace) -> sf.ContactProblem:
    """The 1/8 shell of mesh size h under ``load`` at pressure p (P2 tetrahedra)."""
    bench = sf.meshes.thick_sphere(A_IN, B_OUT, h, filled=load == "cavity", order=args.order)
    materials = {"solid": sf.Hyperelastic(K=K, mu=MU)}
    if load == "cavity":
        materials["cavity"] = common.third_medium(args, mu=MU_MEDIUM, K=K_MEDIUM)
    problem = sf.ContactProblem(bench.mesh, materials, **common.discretization(args))
    for axis, plane in zip("xyz", SYMMETRY):
        problem.fix(bench.marker(plane), components=axis, name=plane)
    if load == "cavity":
        problem.cavity_pressure("cavity", p, name="p")
    else:
        problem.pressure(on_inner_sphere, p, follower=load == "follower", name="p")
    problem.parameters["geometry"] = {"a": A_IN, "b": B_OUT, "K": K, "mu": MU, "mu_medium": MU_MEDIUM,
                                      "K_medium": K_MEDIUM, "h": h, "order": args.order}
    return problem


def inner_radial_displacements(problem: sf.ContactProblem) -> np.ndarray:
    """u_h . e_r at the mesh vertices on R = a (every rank)."""
    disc = problem.disc
    X = disc.x_nodes[:disc.n_owned_nodes]
    on = np.abs(np.linalg.norm(X, axis=1) - A_IN) < 1e-9
    _, u = disc.get_state(problem.x)
    return np.concatenate(problem.comm.allgather(np.einsum("ij,ij->i", u[on], X[on]) / A_IN))


def compare(problem: sf.ContactProblem, run: RunSummary, answer: Answer) -> dict:
    """The solved ``problem`` against ``answer`` (collective): relative error of the mean u_r at
    the inner vertices and their largest, of the work conjugate; unknowns, Newton iterations, time."""
    u_r = inner_radial_displacements(problem)
    conjugate = run.final_step.loads["p"]["displacement"] if run.final_step else math.nan
    return {"unknowns": run.dofs, "converged": run.converged,
            "u_r_mean": (u_r.mean() - answer.u_r_inner) / answer.u_r_inner,
            "u_r_max": float(np.abs(u_r - answer.u_r_inner).max() / answer.u_r_inner),
            "mean_u_r_inner": float(u_r.mean()), "u_r_exact": answer.u_r_inner,
            "conjugate": conjugate, "conjugate_exact": answer.conjugate,
            "conjugate_error": (conjugate - answer.conjugate) / answer.conjugate,
            "newton": run.newton_iterations, "time_s": run.wall_time_s}


def solve(load: str, p: float, h: float, args: argparse.Namespace, lame: bool = False) -> dict:
    """Build, solve (one step at a small p, ``--steps`` otherwise) and compare."""
    problem = build(load, p, h, args)
    result = problem.solve(1 if lame else args.steps)
    return compare(problem, RunSummary.from_dict(result.summary), answer_for(load, p, args.gamma, lame))


HEADER = ["case", "method", "h", "unknowns", "mean u_r(a) error", "rate", "largest u_r(a) error", "conjugate error",
          "rate", "Newton", "time s"]


def single(args: argparse.Namespace) -> int:
    """One run of the command line's load, p and h against the BVP; prints the comparison."""
    r = solve(args.load, args.p, args.h, args)
    if MPI.COMM_WORLD.rank == 0:
        print(f"{args.load}, p = {args.p:g}, h = {args.h:g}: {r['unknowns']} unknowns; mean u_r(a) "
              f"{r['mean_u_r_inner']:.6f} against {r['u_r_exact']:.6f} ({r['u_r_mean']:+.3e}), largest deviation "
              f"{r['u_r_max']:.3e}; conjugate {r['conjugate']:.6f} against {r['conjugate_exact']:.6f} "
              f"({r['conjugate_error']:+.3e})", flush=True)
    return 0 if r["converged"] else 1


# --------------------------------------------------------------------------- the study
CASES = (("small p vs Lamé", "follower", True), ("follower vs BVP", "follower", False),
         ("dead vs BVP", "dead", False), ("cavity vs BVP", "cavity", False))


def rates(values: typing.Sequence[float], unknowns: typing.Sequence[int]) -> list[str]:
    """Observed orders in the mean cell size h ~ unknowns^(-1/3) (gmsh's cells are not exactly of
    the requested size): 3 log(e_i / e_i+1) / log(N_i+1 / N_i) of |e|, "" for the first."""
    e, n = np.abs(values), np.asarray(unknowns, dtype=float)
    return [""] + [f"{3 * math.log(e[i] / e[i + 1]) / math.log(n[i + 1] / n[i]):.2f}" for i in range(len(e) - 1)]


def study(args: argparse.Namespace) -> int:
    """The refinement study: the CASES at each ``--study-h``; thick-sphere.md, .csv and
    thick-sphere-convergence.png in ``--out`` (rank 0)."""
    args.out.mkdir(parents=True, exist_ok=True)
    hs = sorted(args.study_h, reverse=True)
    rows = []
    for label, load, lame in CASES:
        for h in hs:
            t0 = time.perf_counter()
            r = solve(load, SMALL * args.p if lame else args.p, h, args, lame)
            r.update(case=label, method=args.method, h=h, setup_and_solve_s=time.perf_counter() - t0)
            rows.append(r)
            if MPI.COMM_WORLD.rank == 0:
                print(f"{label}, {args.method}, h = {h:g}: {r['unknowns']} unknowns, mean u_r(a) "
                      f"{r['u_r_mean']:+.3e}, largest {r['u_r_max']:.3e}, conjugate {r['conjugate_error']:+.3e}, "
                      f"{r['setup_and_solve_s']:.0f} s", flush=True)
    if MPI.COMM_WORLD.rank == 0:
        write_study(args, rows)
    return 0 if all(r["converged"] for r in rows) else 1


def study_table(rows: list[dict]) -> list[list[str]]:
    """The rows of the study as the cells of :data:`HEADER`, with the observed orders."""
    table = []
    for label, _, _ in CASES:
        group = [r for r in rows if r["case"] == label]
        unknowns = [r["unknowns"] for r in group]
        u_rate, c_rate = (rates([r[key] for r in group], unknowns) for key in ("u_r_mean", "conjugate_error"))
        for r, ur, cr in zip(group, u_rate, c_rate):
            table.append([label, r["method"], f"{r['h']:g}", str(r["unknowns"]), f"{r['u_r_mean']:+.2e}", ur,
                          f"{r['u_r_max']:.2e}", f"{r['conjugate_error']:+.2e}", cr, str(r["newton"]),
                          f"{r['setup_and_solve_s']:.0f}"])
    return table


#: what each ``--method`` solves the thick sphere with (the study's title)
DISCRETIZATIONS = {"fem": "P2 tetrahedra", "vem": "SFVEM, the tetrahedra read as polyhedra"}


def study_stem(method: str) -> str:
    """The study's file names in ``--out`` without suffix: thick-sphere (FEM), thick-sphere-vem (SFVEM)."""
    return "thick-sphere" if method == "fem" else f"thick-sphere-{method}"


def write_study(args: argparse.Namespace, rows: list[dict]) -> None:
    """STEM.md, STEM.csv and STEM-convergence.png in ``--out`` (STEM: :func:`study_stem` of
    ``--method``); prints the table."""
    table, stem = study_table(rows), study_stem(args.method)
    lines = [f"# Thick sphere (1/8, {DISCRETIZATIONS[args.method]}): refinement study (p = {args.p:g}, "
             f"small p = {SMALL * args.p:.3g}, cavity gamma = {args.gamma:g})", "",
             "Errors relative to the exact u_r(a) and conjugate; observed orders between consecutive meshes in the "
             "mean cell size h ~ unknowns^(-1/3).", ""]
    lines += markdown.table(HEADER, table)
    (args.out / f"{stem}.md").write_text("\n".join(lines) + "\n")
    with open(args.out / f"{stem}.csv", "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(HEADER)
        writer.writerows(table)
    print("\n".join(lines), flush=True)
    plot_study(args.out / f"{stem}-convergence.png", rows)


def plot_study(path: pathlib.Path, rows: list[dict]) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(9, 3.4))
    for ax, key, title in zip(axes, ("u_r_mean", "conjugate_error"),
                              ("mean u_r at the inner vertices", "work conjugate")):
        for k, (label, _, _) in enumerate(CASES):
            group = [r for r in rows if r["case"] == label]
            ax.loglog([r["unknowns"] for r in group], [abs(r[key]) for r in group], "-o", color=f"C{k}", ms=4,
                      label=label)
        n = np.array(sorted({r["unknowns"] for r in rows if r["case"] == CASES[1][0]}), dtype=float)
        ref = max(abs(r[key]) for r in rows if r["unknowns"] == n[0])
        ax.loglog(n, ref * (n / n[0]) ** (-2 / 3), "k:", lw=1, label="h^2 (unknowns^(-2/3))")
        ax.set(xlabel="unknowns", title=f"|relative error|, {title}")
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    save_png(fig, path, dpi=80)


def main(argv: typing.Sequence[str] | None = None) -> int:
    args = common.parse_args(make_parser(), argv)
    return study(args) if args.study else single(args)


if __name__ == "__main__":
    sys.exit(common.exit_code(main))
