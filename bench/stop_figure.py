"""Picture and numbers of a stopped SFVEM run: the offending elements at the last converged state and
at the failed step's end (serial; docs/notes/2026-11-26-stops.md).

From the checkpoint of a stopped demo run (``--from DIR``; give the demo and the same options as
that run), this draws two panels of the deformed polygons in a window of the reference
configuration, each polygon coloured by the smallest J = det F at its quadrature points
(log scale, J <= 0 in red): the last converged state and the state where Newton ends on the
failed step to ``--target`` (the first attempt of the stopped run, the default line search and
its fallback). It prints per panel the polygons with the smallest J (index, region, vertices),
the smallest gap between the solids and the Newton outcome.

    .venv/bin/python bench/stop_figure.py cbox --uy -1 --alpha-r 20 --steps 100 --mesh 1 \\
        --from /tmp/cbox-uy1-m1 --target 0.8875 --window 0.0 0.3 0.25 0.55 --png docs/figures/stop-cbox-uy1-mesh1.png
"""
from __future__ import annotations

import argparse
import importlib
import pathlib
import sys
import typing

import numpy as np
from petsc4py import PETSc

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "demos"))
import _common as common  # noqa: E402
import dolfinx_sfvem as sf  # noqa: E402
from dolfinx_sfvem.output.figure_output import save_png  # noqa: E402
from dolfinx_sfvem.path_following.snes import SNESNewton  # noqa: E402


def polygon_min_J(problem: sf.ContactProblem) -> np.ndarray:
    """Smallest det F over the energy quadrature points of every polygon (serial, SFVEM)."""
    space = problem.disc.space
    _, _, _, grad = problem.disc.quadrature_fields(problem.x)
    J = (1 + grad[:, 0, 0]) * (1 + grad[:, 1, 1]) - grad[:, 0, 1] * grad[:, 1, 0]
    out = np.full(space.polygon_mesh.n_polygons, np.inf)
    out[space.cells] = np.minimum.reduceat(J, space.q_offsets[:-1])
    return out


def panel(ax, mesh: sf.PolygonMesh, u: np.ndarray, min_J: np.ndarray, window: tuple[float, ...], title: str,
          marked: typing.Sequence[int] = (), near: tuple | None = None):
    """Deformed polygons whose reference centroid lies in ``window``, coloured by log10 min J."""
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection
    from matplotlib.colors import Normalize

    x0, x1, y0, y1 = window
    off, verts = mesh.offsets, mesh.vertices
    centre = np.array([mesh.points[verts[off[e]:off[e + 1]]].mean(axis=0) for e in range(mesh.n_polygons)])
    chosen = np.flatnonzero((centre[:, 0] >= x0) & (centre[:, 0] <= x1) & (centre[:, 1] >= y0) & (centre[:, 1] <= y1))
    x = mesh.points + u
    norm = Normalize(-4.0, 0.5)
    cmap = plt.get_cmap("viridis")
    colours = [(1.0, 0.0, 0.0, 1.0) if min_J[e] <= 0 else cmap(norm(np.log10(min_J[e]))) for e in chosen]
    medium = [mesh.tags[e] == sf.meshes.MEDIUM for e in chosen]
    ax.add_collection(PolyCollection([x[verts[off[e]:off[e + 1]]] for e in chosen], facecolors=colours,
                                     edgecolors=["0.4" if m else "k" for m in medium],
                                     linewidths=[0.3 if m else 0.8 for m in medium]))
    worst = np.union1d(chosen[np.argsort(min_J[chosen])[:2]], np.intersect1d(np.asarray(marked, dtype=np.int64), chosen))
    for e in worst:
        c = x[verts[off[e]:off[e + 1]]].mean(axis=0)
        ax.plot(*c, "r.", ms=3)
        ax.annotate(f"{e} ({np.diff(off)[e]}-gon): J {min_J[e]:.2g}", c, fontsize=6, color="red",
                    xytext=(4, 4), textcoords="offset points")
    ax.autoscale()
    if near is not None:
        (X, x, pieces, centre), half = near
        for i, j in pieces:
            ax.plot(*np.stack([x[i], x[j]]).T, "-", color="tab:red", lw=1.2)
        ax.plot(*x[np.unique(pieces)].T, "o", color="tab:red", ms=3)
        ax.plot(*centre, "*", color="tab:blue", ms=9)
        if half:
            ax.set_xlim(centre[0] - half, centre[0] + half)
            ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_aspect("equal")
    ax.set_title(title, fontsize=8)
    return plt.cm.ScalarMappable(norm=norm, cmap=cmap)


def _keep_worst_trial(newton: SNESNewton) -> dict:
    """{"x": copy of the state of smallest J at which ``newton`` evaluates a residual, "J": that J},
    kept up to date during its solves."""
    worst = {"x": None, "J": np.inf}
    residual = newton.equilibrium.residual

    def keeping(x, b):
        info = residual(x, b)
        if info.min_J < worst["J"]:
            worst["J"] = info.min_J
            worst["x"] = x.copy()
        return info
    newton.equilibrium.residual = keeping
    return worst


def node_depths(problem: sf.ContactProblem, X: typing.Sequence[float]) -> str:
    """For the boundary node at reference ``X``: the winding of its own body's deformed boundary
    around it (pieces at the node left out, contact.py) and its distance to the nearest piece of
    that body outside its 2 h neighbourhood (the depth the overlap check reports for a node
    inside its own body) and to the nearest piece at all (the node's adjacent pieces left out)."""
    b = problem.boundary
    keys, values = problem.disc.get_state(problem.x)
    x = b.X + b._in_node_order(b.gather(problem.comm, keys, values))
    p = int(np.argmin(np.hypot(*(b.X - np.asarray(X)).T)))
    own = b.node_body[p]
    total, near, far = 0.0, (np.inf, None), (np.inf, None)
    for s in range(b.body_offsets[own], b.body_offsets[own + 1]):
        i, j = b.pieces[s]
        if p in (i, j):
            continue
        a, c = x[i] - x[p], x[j] - x[p]
        total += np.arctan2(a[0] * c[1] - a[1] * c[0], a @ c)
        t = np.clip((x[p] - x[i]) @ (x[j] - x[i]) / max((x[j] - x[i]) @ (x[j] - x[i]), 1e-300), 0.0, 1.0)
        d = float(np.linalg.norm(x[p] - x[i] - t * (x[j] - x[i])))
        near = min(near, (d, tuple(b.piece_middle[s])))
        if np.sum((b.piece_middle[s] - b.X[p]) ** 2) > 4.0 * b.node_h[p] ** 2:
            far = min(far, (d, tuple(b.piece_middle[s])))
    return (f"node {tuple(b.X[p])} (h {b.node_h[p]:.4g}) at {tuple(x[p])}: winding {total / (2 * np.pi):.4f} turns; "
            f"nearest piece outside 2 h {far[0]:.3e} (reference midpoint {far[1]}), nearest piece {near[0]:.3e} "
            f"(reference midpoint {near[1]})")


def boundary_near(problem: sf.ContactProblem, X: typing.Sequence[float]) -> tuple:
    """(reference and deformed boundary node positions, the boundary pieces within 4 h of the
    node at reference ``X``, the node's deformed position)."""
    b = problem.boundary
    keys, values = problem.disc.get_state(problem.x)
    x = b.X + b._in_node_order(b.gather(problem.comm, keys, values))
    p = int(np.argmin(np.hypot(*(b.X - np.asarray(X)).T)))
    close = np.hypot(*(b.piece_middle - b.X[p]).T) < 4 * b.node_h[p]
    return b.X, x, b.pieces[close], x[p]


def report(label: str, problem: sf.ContactProblem, min_J: np.ndarray, show: typing.Sequence[int]) -> None:
    mesh = problem.disc.output_mesh
    order = np.union1d(np.argsort(min_J)[:4], np.asarray(show, dtype=np.int64))
    sizes = np.diff(mesh.offsets)
    print(f"{label}: gap {problem.contact_gap().describe()}")
    for e in order:
        c = mesh.points[mesh.vertices[mesh.offsets[e]:mesh.offsets[e + 1]]].mean(axis=0)
        print(f"  polygon {e}: region {mesh.tags[e]}, {sizes[e]} vertices, reference centroid ({c[0]:.4f}, "
              f"{c[1]:.4f}), min J {min_J[e]:.3e}")


def main() -> int:
    demo_name = sys.argv[1]
    demo = importlib.import_module(demo_name)
    extra = argparse.ArgumentParser(add_help=False)
    extra.add_argument("--from", dest="src", type=pathlib.Path, required=True)
    extra.add_argument("--target", type=float, required=True)
    extra.add_argument("--window", type=float, nargs=4, required=True)
    extra.add_argument("--png", type=pathlib.Path, required=True)
    extra.add_argument("--zoom", type=float, default=None,
                       help="with --node: half-width of the drawn box around the node's deformed position")
    extra.add_argument("--show", type=int, nargs="*", default=(), help="polygons to report and mark as well")
    extra.add_argument("--node", type=float, nargs=2, default=None, help="a boundary node's reference position: "
                       "its winding and depths (overlap check) in both states")
    extra.add_argument("--line-search", default=None, help="the failed attempt's line search (default: bt, then l2)")
    extra.add_argument("--worst-trial", action="store_true",
                       help="right panel: the trial state (line search included) of smallest J of the attempt")
    extra.add_argument("--first-step", action="store_true",
                       help="right panel: the state after the first full Newton step (basic line search, 1 iteration)")
    mine, rest = extra.parse_known_args(sys.argv[2:])
    args = common.parse_args(demo.make_parser(), rest)
    built = demo.build(args)
    problem = built[0] if isinstance(built, tuple) else built
    constraints = problem.constraints()
    problem.disc.set_constraints(constraints.dofs)
    options = {"snes_linesearch_type": mine.line_search} if mine.line_search else {}
    if mine.first_step:
        options = {"snes_linesearch_type": "basic", "snes_max_it": 1}
    newton = SNESNewton(problem.equilibrium(), options, problem.petsc_options_prefix)
    data = np.load(mine.src / "checkpoint.npz")
    problem.disc.set_state(data["keys"], data["values"], problem.x)
    problem.x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
    load = float(data["control_load"])
    mesh = problem.disc.output_mesh
    states = [(f"last converged state, load {load:.6g}", problem.point_displacements(), polygon_min_J(problem))]
    neighbourhoods = [boundary_near(problem, mine.node) if mine.node else None]
    report(states[0][0], problem, states[0][2], mine.show)
    if mine.node:
        print("  " + node_depths(problem, mine.node))
    before = problem.point_displacements()
    worst = _keep_worst_trial(newton)
    result = newton.solve(problem.x, mine.target * constraints.final, mine.target)
    if mine.worst_trial and worst["x"] is not None:
        worst["x"].copy(problem.x)
        problem.x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
    step = np.hypot(*(problem.point_displacements() - before).T)
    print(f"largest nodal move to the state drawn: {step.max():.3e} at reference {mesh.points[step.argmax()]}")
    outcome = "converged" if result.converged else f"SNES reason {result.reason}, min J {result.min_J:.2g}"
    what = ("trial state of smallest J on the way" if mine.worst_trial else
            "one full Newton step" if mine.first_step else "end of Newton")
    states.append((f"{what} to load {mine.target:.6g}\n({result.iterations} its, {outcome})",
                   problem.point_displacements(), polygon_min_J(problem)))
    neighbourhoods.append(boundary_near(problem, mine.node) if mine.node else None)
    report(states[1][0], problem, states[1][2], mine.show)
    if mine.node:
        print("  " + node_depths(problem, mine.node))
    print(f"Newton to {mine.target}: {result.iterations} its, {'converged' if result.converged else result.failure}")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.4), dpi=130)
    for ax, (title, u, min_J), near in zip(axes, states, neighbourhoods):
        mappable = panel(ax, mesh, u, min_J, mine.window, title, mine.show, (near, mine.zoom) if near else None)
    fig.colorbar(mappable, ax=axes, shrink=0.8, label="log10 min J per polygon (red: J <= 0)")
    save_png(fig, mine.png)
    print(f"wrote {mine.png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
