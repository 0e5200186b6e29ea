"""Thick-walled cylinder under internal pressure: pressure and cavity pressure against exact answers.

Problem: plane strain, the solid of paper Eq. 2 with K = 5/3, mu = 1 (Lamé lambda = mu = 1), the
quarter a < R < b (a = 1, b = 2) of ``sf.meshes.thick_cylinder`` with the symmetry conditions
u_y = 0 on the x axis and u_x = 0 on the y axis; the outer surface is free, the inner one is
loaded by the internal pressure ``--p`` (default 2/15: Lamé's u_r(a) = 0.1 a) as

- ``--load follower``: ``problem.pressure(inner arc, p)``, on the deformed surface;
- ``--load dead``: ``problem.pressure(inner arc, p, follower=False)``, on the reference normal;
- ``--load cavity``: the hole R < a filled with third medium (mu_m = 1, ``--gamma`` default
  1e-2, ``--alpha-r`` default 1, rotation regularization) and ``problem.cavity_pressure("cavity",
  p)``; the quarter cavity is closed by the symmetry lines.

Exact answers (``dolfinx_sfvem/exact.py``, docs/validation-loads.md): the radial solution of the
1D boundary value problem of Eq. 2 for the follower, dead and medium-filled load
(``exact.pressurized_cylinder``), and Lamé's solution (``exact.lame_cylinder``) at small p. The
exact field is compared on the discrete (polygonal) domain: the wall's radial solution continued
smoothly a sagitta inside R = a, the medium's homogeneous stretch inside the chords of the arc.

Mesh: ``--cells dual`` (default; dual polygons, twice the chords on the arcs), ``triangles`` or
``quads`` of size ``--h``. ``--method fem``: P2 on a triangulation of that mesh matched to the
SFVEM unknowns (the arc vertices kept), or with ``--fem-mesh triangles`` on the gmsh triangles of
the ``triangles`` variant.

Outputs in ``--out`` besides the usual ones: cylinder.md (unknowns, relative L2 and H1 errors of
the displacement, errors of u_r at the inner and outer arc vertices, the recorded work-conjugate
displacement against its exact value, Newton iterations, time) and cylinder.png (u_r along the
x axis against the exact and Lamé's, and its error).

``--study`` runs the refinement sequences instead (h in ``--study-h``, default 0.2 0.1 0.05;
``--steps`` load steps at the finite p, one at the small p) for small p = 1e-6 x 2/15 against
Lamé, and the finite ``--p`` with the follower, dead and cavity load against the BVP, each with
SFVEM and FEM, and writes study.md, study.json and convergence.png (docs/thick-cylinder.md).

Examples::

    python3 demos/thick_cylinder.py --load follower --h 0.1
    python3 demos/thick_cylinder.py --load cavity --method fem --h 0.05
    mpirun -n 2 python3 demos/thick_cylinder.py --load dead --p 0.3 --steps 8
    python3 demos/thick_cylinder.py --study --out out/thick_cylinder_study     # about 3 min
"""
from __future__ import annotations

import argparse
import dataclasses
import json
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
from dolfinx_sfvem.output.run_summary import RunSummary, read_summary

import _common as common

A_IN, B_OUT = 1.0, 2.0
K, MU = 5 / 3, 1.0
MU_MEDIUM = 1.0
#: Lamé's u_r(a) = 0.1 a at this pressure (the reference case of docs/validation-loads.md)
P_REF = 2 / 15
#: the small pressure compared with Lamé: the finite-strain answer differs by about 2e-7 relative
P_SMALL = 1e-6 * P_REF
LOADS = ("follower", "dead", "cavity")
STUDY_H = (0.2, 0.1, 0.05)


def make_parser() -> argparse.ArgumentParser:
    p = common.parser("thick_cylinder", __doc__, steps=4, h=0.1, h_max=0.5, gamma=1e-2, alpha_r=1.0,
                      regularization="rotation")
    p.add_argument("--load", choices=LOADS, default="follower", help="what loads the bore (default %(default)s)")
    p.add_argument("--p", type=common.finite_float, default=P_REF, help="internal pressure (default 2/15)")
    p.add_argument("--cells", choices=("dual", "triangles", "quads"), default="dual",
                   help="polygons of the mesh (default %(default)s)")
    p.add_argument("--fem-mesh", choices=("matched", "triangles"), default=None,
                   help="--method fem: P2 on a triangulation matched to the SFVEM unknowns (default) or on the "
                        "gmsh triangles of --cells triangles")
    p.add_argument("--study", action="store_true", help="run the refinement study instead (module docstring)")
    p.add_argument("--study-h", type=common.positive_float, nargs="+", default=STUDY_H, metavar="H",
                   help="mesh sizes of --study (default %(default)s)")
    return p


# --------------------------------------------------------------------------- the exact answers
@dataclasses.dataclass(frozen=True)
class Answer:
    """The exact answer a run is compared with.

    Attributes
    ----------
    name : str
    stretches : callable
        ``stretches(R) -> (lambda_r, lambda_theta)`` of the wall at reference radii R (n,), also a
        little inside R = a (continued smoothly).
    c : float or None
        The homogeneous stretch of the medium-filled hole (None without medium).
    u_r_inner, u_r_outer : float
        u_r(a) and u_r(b).
    conjugate : float
        Exact value of the load's recorded work-conjugate displacement on the quarter: the area
        change of the quarter cavity (follower pressure, cavity pressure), ``int u . (-N) dS``
        = pi a u_r(a) / 2 (dead pressure, and the small-strain answer).
    """

    name: str
    stretches: typing.Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
    c: float | None
    u_r_inner: float
    u_r_outer: float
    conjugate: float


def medium_of(gamma: float) -> exact.CavityMedium:
    return exact.CavityMedium(gamma, MU_MEDIUM)


def lame_answer(p: float, bulk: float = K) -> Answer:
    """Lamé's small-strain solution u_r = A R + B / R (of the bulk modulus ``bulk``)."""
    lame = exact.lame_cylinder(A_IN, B_OUT, bulk, MU, p)

    def stretches(R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return 1 + lame.A - lame.B / R ** 2, 1 + lame.A + lame.B / R ** 2
    return Answer("Lamé", stretches, None, lame.inner_radius_change, float(lame.u_r(B_OUT)),
                  math.pi * A_IN * lame.inner_radius_change / 2)


def radial_answer(load: str, p: float, gamma: float) -> Answer:
    """The finite-strain radial solution of the BVP of Eq. 2 for ``load`` (cavity: the medium of
    ``gamma``, mu_m = 1)."""
    condition = medium_of(gamma) if load == "cavity" else load
    solution = exact.pressurized_cylinder(A_IN, B_OUT, K, MU, p, condition)

    def stretches(R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        rho, lambda_r = solution.state(R)     # the ODE's dense output, continued beyond [a, b]
        return lambda_r, rho / R
    conjugate = (math.pi * A_IN * solution.inner_radius_change / 2 if load == "dead"
                 else solution.cavity_area_change / 4)
    return Answer(f"BVP {load}", stretches, solution.c if load == "cavity" else None,
                  solution.inner_radius_change, solution.outer_radius_change, conjugate)


def answer_for(load: str, p: float, gamma: float, lame: bool) -> Answer:
    return lame_answer(p) if lame else radial_answer(load, p, gamma)


def inside_chords(arc_vertices: np.ndarray) -> typing.Callable[[np.ndarray], np.ndarray]:
    """Whether points X (2, n) lie inside the polygonal arc through ``arc_vertices`` (k, 2) about
    the origin: on the centre's side of the chord at their polar angle."""
    theta = np.arctan2(arc_vertices[:, 1], arc_vertices[:, 0])
    V = arc_vertices[np.argsort(theta)]
    theta = np.sort(theta)

    def inside(X: np.ndarray) -> np.ndarray:
        k = np.clip(np.searchsorted(theta, np.arctan2(X[1], X[0]), side="right") - 1, 0, len(V) - 2)
        chord, to_point = V[k + 1] - V[k], X.T - V[k]
        return chord[:, 0] * to_point[:, 1] - chord[:, 1] * to_point[:, 0] > 0
    return inside


def exact_field(answer: Answer, in_medium: typing.Callable[[np.ndarray], np.ndarray] | None):
    """``u_exact(X) -> (2, n)`` and ``grad_exact(X) -> (2, 2, n)`` of the radial answer in Cartesian
    components, for :meth:`~dolfinx_sfvem.discretizations.discretization.Discretization.error_norms`:
    u = (lambda_theta - 1) X and grad u = (lambda_theta - 1) I + (lambda_r - lambda_theta) e_r e_r,
    with lambda_r = lambda_theta = c in the medium."""
    def stretches(X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        R = np.hypot(X[0], X[1])
        medium = in_medium(X) if in_medium is not None else np.zeros(R.shape, dtype=bool)
        lambda_r, lambda_theta = np.full(R.shape, answer.c or 1.0), np.full(R.shape, answer.c or 1.0)
        if not medium.all():
            lambda_r[~medium], lambda_theta[~medium] = answer.stretches(R[~medium])
        return R, lambda_r, lambda_theta

    def u_exact(X: np.ndarray) -> np.ndarray:
        _, _, lambda_theta = stretches(X)
        return (lambda_theta - 1) * X[:2]

    def grad_exact(X: np.ndarray) -> np.ndarray:
        R, lambda_r, lambda_theta = stretches(X)
        e_r = X[:2] / R
        return ((lambda_theta - 1) * np.eye(2)[:, :, None]
                + (lambda_r - lambda_theta) * e_r[:, None, :] * e_r[None, :, :])
    return u_exact, grad_exact


# --------------------------------------------------------------------------- the problem
def on_inner_arc(benchmark: sf.meshes.Benchmark) -> typing.Callable[[np.ndarray], np.ndarray]:
    """Marker of the inner arc's nodes: vertices on R = a and chord midpoints, a sagitta inside
    (1.5 times the largest one as tolerance)."""
    pairs = benchmark.edges_on("inner")
    chord = np.linalg.norm(np.diff(benchmark.mesh.points[pairs], axis=1)[:, 0], axis=1).max()
    tol = 1.5 * chord ** 2 / (8 * A_IN) + 1e-12
    return lambda x: np.abs(np.hypot(x[0], x[1]) - A_IN) <= tol


def build(load: str, p: float, method: str, benchmark: sf.meshes.Benchmark, args: argparse.Namespace,
          petsc_options: dict | None = None) -> sf.ContactProblem:
    """The quarter cylinder of ``benchmark`` under ``load`` at pressure p."""
    materials = {"solid": sf.Hyperelastic(K=K, mu=MU)}
    if load == "cavity":
        materials["cavity"] = common.third_medium(args, mu=MU_MEDIUM)
    options = {"method": method, "verbose": not args.quiet}
    if method == "fem" and args.fem_mesh == "triangles":
        options["fem_mesh"] = benchmark.mesh
    problem = sf.ContactProblem(benchmark.mesh, materials, petsc_options=petsc_options, **options)
    problem.fix(common.on_segment(*benchmark.segments["axis_x"]), components=("y",), name="axis_x")
    problem.fix(common.on_segment(*benchmark.segments["axis_y"]), components=("x",), name="axis_y")
    if load == "cavity":
        problem.cavity_pressure("cavity", p, name="p")
    else:
        problem.pressure(on_inner_arc(benchmark), p, follower=load == "follower", name="p")
    problem.parameters["geometry"] = {"a": A_IN, "b": B_OUT, "K": K, "mu": MU, "mu_medium": MU_MEDIUM}
    return problem


def benchmark_for(load: str, h: float, method: str, args: argparse.Namespace) -> sf.meshes.Benchmark:
    """The mesh of a run: ``--cells``, or the triangles when the FEM takes them as its own mesh."""
    cells = "triangles" if method == "fem" and args.fem_mesh == "triangles" else args.cells
    return sf.meshes.thick_cylinder(A_IN, B_OUT, h, filled=load == "cavity", polygons=cells)


# --------------------------------------------------------------------------- comparison
def arc_radial_displacements(problem: sf.ContactProblem) -> tuple[np.ndarray, np.ndarray]:
    """Nodal u_h . e_r at the mesh vertices on the inner and on the outer arc (every rank)."""
    u = problem.point_displacements()
    found = None
    if problem.comm.rank == 0:
        X = problem.disc.output_mesh.points
        R = np.hypot(X[:, 0], X[:, 1])
        found = tuple(np.sum(u[on] * X[on], axis=1) / radius
                      for radius in (A_IN, B_OUT) for on in [np.abs(R - radius) < 1e-9])
    return problem.comm.bcast(found, root=0)


def compare(problem: sf.ContactProblem, run: RunSummary, answer: Answer, benchmark: sf.meshes.Benchmark) -> dict:
    """The numbers of the solved ``problem`` (its records ``run``) against ``answer`` (collective):
    relative L2 and H1 errors over the whole mesh, the largest u_r errors at the arc vertices
    relative to u_r(a), the mean u_r at the inner arc vertices, the recorded work-conjugate
    displacement and its exact value, Newton iterations (all attempts), solve time."""
    in_medium = inside_chords(benchmark.mesh.points[benchmark.vertices_on("inner")]) if answer.c else None
    u_exact, grad_exact = exact_field(answer, in_medium)
    e_L2, e_H1 = problem.disc.error_norms(problem.x, u_exact, grad_exact)
    zero = problem.disc.create_vector()
    zero.set(0.0)
    norm_L2, norm_H1 = problem.disc.error_norms(zero, u_exact, grad_exact)
    zero.destroy()
    inner, outer = arc_radial_displacements(problem)
    conjugate = run.final_step.loads["p"]["displacement"] if run.final_step else math.nan
    return {"unknowns": run.dofs, "converged": run.converged, "L2": e_L2 / norm_L2,
            "H1": e_H1 / norm_H1, "u_r_inner": np.abs(inner - answer.u_r_inner).max() / answer.u_r_inner,
            "u_r_outer": np.abs(outer - answer.u_r_outer).max() / answer.u_r_inner, "mean_u_r_inner": inner.mean(),
            "conjugate": conjugate, "conjugate_exact": answer.conjugate,
            "conjugate_error": (conjugate - answer.conjugate) / answer.conjugate,
            "newton": run.newton_iterations, "steps": len(run.converged_steps), "time_s": run.wall_time_s}


def axis_profile(problem: sf.ContactProblem) -> tuple[np.ndarray, np.ndarray] | None:
    """Reference x and nodal u_x (= u_r) of the mesh vertices on the x axis, sorted by x (rank 0;
    None elsewhere)."""
    u = problem.point_displacements()
    if problem.comm.rank != 0:
        return None
    X = problem.disc.output_mesh.points
    on_axis = np.flatnonzero(np.abs(X[:, 1]) < 1e-12)
    on_axis = on_axis[np.argsort(X[on_axis, 0])]
    return X[on_axis, 0], u[on_axis, 0]


def plot_profile(path: pathlib.Path, R: np.ndarray, u_h: np.ndarray, answer: Answer, lame: Answer,
                 filled: bool, title: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    def u_r(ans: Answer, R: np.ndarray) -> np.ndarray:
        lambda_theta = np.where(R < A_IN, ans.c or 1.0, 1.0)
        wall = R >= A_IN
        lambda_theta[wall] = ans.stretches(R[wall])[1]
        return (lambda_theta - 1) * R

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9, 3.4))
    fine = np.linspace(0.0 if filled else A_IN, B_OUT, 300)
    ax1.plot(fine, u_r(answer, fine), "k-", lw=1, label=answer.name)
    ax1.plot(fine[fine >= A_IN], u_r(lame, fine[fine >= A_IN]), "k--", lw=1, label="Lamé")
    ax1.plot(R, u_h, "o", ms=3, label="computed (vertices on the x axis)")
    ax1.set(xlabel="R", ylabel="u_r")
    ax1.legend(fontsize=8)
    ax2.plot(R, u_h - u_r(answer, R), "o-", ms=3)
    ax2.set(xlabel="R", ylabel=f"u_r - u_r({answer.name})")
    ax2.ticklabel_format(axis="y", style="sci", scilimits=(0, 0))
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    save_png(fig, path, dpi=90)


def row_cells(label: str, method: str, h: float, r: dict) -> list[str]:
    return [label, method, f"{h:g}", str(r["unknowns"]), f"{r['L2']:.2e}", f"{r['H1']:.2e}", f"{r['u_r_inner']:.2e}",
            f"{r['u_r_outer']:.2e}", f"{r['conjugate']:.8g}", f"{r['conjugate_error']:+.2e}", str(r["newton"]),
            f"{r['time_s']:.1f}"]


HEADER = ["case", "method", "h", "unknowns", "L2 rel.", "H1 rel.", "u_r(a) err.", "u_r(b) err.", "conjugate",
          "rel. err.", "Newton", "time [s]"]


def single(args: argparse.Namespace) -> int:
    benchmark = benchmark_for(args.load, args.h, args.method, args)
    problem = build(args.load, args.p, args.method, benchmark, args)
    title = (f"thick cylinder: {args.load} p = {args.p:g}, {args.method}, {args.cells}, h = {args.h:g}"
             + (f", gamma = {args.gamma:g}" if args.load == "cavity" else ""))
    if problem.comm.rank == 0:
        print(title, flush=True)
    code = common.run(problem, args)
    run = problem.comm.bcast(read_summary(args.out) if problem.comm.rank == 0 else None, root=0)
    answer = radial_answer(args.load, args.p, args.gamma)
    r = compare(problem, run, answer, benchmark)
    profile = axis_profile(problem)
    if problem.comm.rank == 0:
        lines = [f"# {title}", "", f"Compared with the {answer.name} (errors of u_r relative to u_r(a) = "
                 f"{answer.u_r_inner:.10f}; the conjugate's exact value {answer.conjugate:.10f}).", ""]
        lines += markdown.table(HEADER, [row_cells(args.load, args.method, args.h, r)])
        (args.out / "cylinder.md").write_text("\n".join(lines) + "\n")
        plot_profile(args.out / "cylinder.png", *profile, answer, lame_answer(args.p), args.load == "cavity", title)
        print(f"errors: L2 {r['L2']:.3e}, H1 {r['H1']:.3e} (relative), u_r(a) {r['u_r_inner']:.3e}, u_r(b) "
              f"{r['u_r_outer']:.3e} (of u_r(a)); conjugate {r['conjugate']:.8f} against {answer.conjugate:.8f}",
              flush=True)
    return code


# --------------------------------------------------------------------------- the study
@dataclasses.dataclass(frozen=True)
class Case:
    label: str
    load: str
    lame: bool


CASES = (Case("small p vs Lamé", "follower", True), Case("follower vs BVP", "follower", False),
         Case("dead vs BVP", "dead", False), Case("cavity vs BVP", "cavity", False))


def rates(values: typing.Sequence[float], hs: typing.Sequence[float]) -> list[str]:
    """Observed orders log(e_i / e_i+1) / log(h_i / h_i+1), "" for the first."""
    return [""] + [f"{math.log(values[i] / values[i + 1]) / math.log(hs[i] / hs[i + 1]):.2f}"
                   for i in range(len(values) - 1)]


def study(args: argparse.Namespace) -> int:
    """The refinement study (module docstring): study.md, study.json, convergence.png in ``--out``."""
    args.out.mkdir(parents=True, exist_ok=True)
    hs = sorted(args.study_h, reverse=True)
    rows = [run_case(case, method, h, args.p, args) for case in CASES for method in common.METHODS for h in hs]
    h_mid = hs[len(hs) // 2]           # follower - dead at half the pressure, on the middle mesh
    halves = [run_case(case, method, h_mid, args.p / 2, args) for case in CASES[1:3] for method in common.METHODS]
    if MPI.COMM_WORLD.rank == 0:
        write_study(args, hs, rows, halves)
    return 0 if all(r["converged"] for r in rows + halves) else 1


def run_case(case: Case, method: str, h: float, p: float, args: argparse.Namespace) -> dict:
    """One run of the study (:func:`compare`'s numbers with the case, method, h, p and the time of
    set-up and solve); the small-p case at P_SMALL in one step, the others at p in ``--steps``."""
    t0 = time.perf_counter()
    p = P_SMALL if case.lame else p
    benchmark = benchmark_for(case.load, h, method, args)
    problem = build(case.load, p, method, benchmark, args)
    result = problem.solve(1 if case.lame else args.steps)
    r = compare(problem, RunSummary.from_dict(result.summary), answer_for(case.load, p, args.gamma, case.lame),
                benchmark)
    r.update(case=case.label, method=method, h=h, p=p, setup_and_solve_s=time.perf_counter() - t0)
    if problem.comm.rank == 0:
        print(" | ".join(row_cells(case.label, method, h, r)), flush=True)
    return r


def write_study(args: argparse.Namespace, hs: typing.Sequence[float], rows: list[dict], halves: list[dict]) -> None:
    lines = [f"# Thick cylinder: refinement study (p = {args.p:g}, small p = {P_SMALL:.4g}, cells {args.cells}, "
             f"cavity gamma = {args.gamma:g}, alpha_r = {args.alpha_r:g})", "",
             "Errors relative: L2 and H1 to the exact field's norms, u_r at the arc vertices (largest) to u_r(a), "
             "the conjugate to its exact value. Rates between consecutive h in brackets.", ""]
    table = []
    for case in CASES:
        for method in common.METHODS:
            group = [r for r in rows if r["case"] == case.label and r["method"] == method]
            order = {key: rates([r[key] for r in group], hs) for key in ("L2", "H1", "u_r_inner", "u_r_outer")}
            for i, r in enumerate(group):
                cells = row_cells(case.label, method, r["h"], r)
                cells[4:8] = [f"{r[key]:.2e} ({order[key][i]})" if order[key][i] else f"{r[key]:.2e}"
                              for key in ("L2", "H1", "u_r_inner", "u_r_outer")]
                table.append(cells)
    lines += markdown.table(HEADER, table)
    h = halves[0]["h"]
    lines += ["", f"Follower minus dead, h = {h:g}: computed mean u_r at the inner arc vertices against the exact "
              "u_r(a); a difference O(p^2) falls by 4 when p halves.", ""]
    table = []
    for method in common.METHODS:
        computed, exact_difference = [], []
        for p in (args.p, args.p / 2):
            u_r = {r["case"]: r["mean_u_r_inner"] for r in rows + halves
                   if r["method"] == method and r["h"] == h and r["p"] == p}
            computed.append(u_r[CASES[1].label] - u_r[CASES[2].label])
            exact_difference.append(radial_answer("follower", p, args.gamma).u_r_inner
                                    - radial_answer("dead", p, args.gamma).u_r_inner)
        table.append([method, *(f"{v:.6e}" for pair in zip(computed, exact_difference) for v in pair),
                      f"{computed[0] / computed[1]:.4f}", f"{exact_difference[0] / exact_difference[1]:.4f}"])
    lines += markdown.table(["method", "at p: computed", "exact", "at p/2: computed", "exact", "ratio computed",
                             "ratio exact"], table)
    (args.out / "study.md").write_text("\n".join(lines) + "\n")
    (args.out / "study.json").write_text(json.dumps({"rows": rows, "half_pressure": halves}, indent=1))
    plot_study(args.out / "convergence.png", rows)


def plot_study(path: pathlib.Path, rows: list[dict]) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(11, 3.4))
    for k, case in enumerate(CASES):
        for method, style in zip(common.METHODS, ("-o", "--s")):
            group = [r for r in rows if r["case"] == case.label and r["method"] == method]
            h = [r["h"] for r in group]
            for ax, key in zip(axes, ("L2", "H1", "u_r_inner")):
                ax.loglog(h, [r[key] for r in group], style, color=f"C{k}", ms=4,
                          label=f"{case.label}, {method}" if ax is axes[0] else None)
    h = np.array(sorted({r["h"] for r in rows}))
    for ax, key, order in zip(axes, ("L2", "H1", "u_r_inner"), (2, 2, 2)):
        ref = max(r[key] for r in rows if r["h"] == h.max())
        ax.loglog(h, ref * (h / h.max()) ** order, "k:", lw=1)
        ax.set(xlabel="h", title={"L2": "L2 (relative)", "H1": "H1 (relative)",
                                  "u_r_inner": "u_r at the inner arc (rel.)"}[key] + ", dotted: h^2")
    axes[0].legend(fontsize=6)
    fig.tight_layout()
    save_png(fig, path, dpi=80)


def main(argv: typing.Sequence[str] | None = None) -> int:
    args = common.parse_args(make_parser(), argv)
    return study(args) if args.study else single(args)


if __name__ == "__main__":
    sys.exit(common.exit_code(main))
