"""Convergence rates of the order-2 SFVEM on polyhedra (issue 31 item 4): a manufactured solution.

Linear elasticity (E = 1, nu = 0.3) on the unit cube with the smooth displacement

    u_c(x) = sin(kappa_c . x + phi_c),   c = 0, 1, 2   (plane waves, not polynomials),

the body force f = -div sigma(u) = mu |kappa_j|^2 u_j + (lambda + mu) sum_c kappa_cc kappa_cj u_c
(f_j for component j), and u's DOFs on the whole boundary. Solved serially with scipy
(:mod:`vem3d_solve`) on four mesh families, the errors ||u - Pi^nabla_2 u_h|| (L2) and
||grad u - Pi^0_l grad u_h|| (H1) should fall like h^3 and h^2, h = (volume / n_cells)^(1/3).

Usage: ``python bench/vem3d_rates.py [--families cubes octree ...] [--levels N]``; writes
bench/vem3d_rates.json and bench/vem3d_rates.md.
"""
from __future__ import annotations

import argparse
import json
import pathlib
import time
from collections.abc import Callable

import numpy as np
import numpy.typing as npt
from vem3d_solve import error_norms, solve

from dolfinx_sfvem import meshes
from dolfinx_sfvem.mesh.polyhedron import polyhedron_edges, polyhedron_geometry
from dolfinx_sfvem.mesh.polyhedron_mesh import PolyhedronMesh
from dolfinx_sfvem.discretizations.projection3d import polyhedron_projections

YOUNG, POISSON = 1.0, 0.3
MU = YOUNG / (2 * (1 + POISSON))
LAMBDA = YOUNG * POISSON / ((1 + POISSON) * (1 - 2 * POISSON))
#: wave vectors kappa_c (rows) and phases of the three components
KAPPA = np.pi * np.array([[1.0, 0.5, -0.3], [0.4, -1.1, 0.6], [-0.5, 0.7, 0.9]])
PHASE = np.array([0.3, -0.2, 0.5])


def u_exact(x: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """u (n, 3) at x (n, 3)."""
    return np.sin(x @ KAPPA.T + PHASE)


def grad_exact(x: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """du_c/dx_d (n, 3, 3) at x (n, 3)."""
    return np.cos(x @ KAPPA.T + PHASE)[:, :, None] * KAPPA[None]


def body_force(x: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """f = -div sigma(u) (n, 3) at x (n, 3) (module docstring)."""
    s = np.sin(x @ KAPPA.T + PHASE)                        # (n, 3): sin(kappa_c . x + phi_c)
    return MU * s * np.sum(KAPPA ** 2, axis=1) + (LAMBDA + MU) * s @ (np.diag(KAPPA)[:, None] * KAPPA)


# --------------------------------------------------------------------------- mesh families
def cubes(n: int) -> PolyhedronMesh:
    """n^3 equal cubes (hexahedra read as polyhedra)."""
    return meshes.octree_box([0, 0, 0], [1, 1, 1], n).polyhedra()


def octree(n: int) -> PolyhedronMesh:
    """n^3 cubes, those with centre in the ball |x| < 0.45 about the corner 0 split once (2:1 balance
    across edges): coarse cubes next to them carry hanging vertices and split faces."""
    return meshes.octree_box([0, 0, 0], [1, 1, 1], n).refine(
        lambda x: np.linalg.norm(x, axis=0) < 0.45, 1).polyhedra()


def _lattice(n: int) -> npt.NDArray[np.float64]:
    """Centres of the n^3 cubes of size 1/n, (n^3, 3)."""
    return (np.stack(np.meshgrid(*[np.arange(n)] * 3, indexing="ij"), axis=-1).reshape(-1, 3) + 0.5) / n


def octree_two_levels(n: int) -> PolyhedronMesh:
    """As :func:`octree`, the ball's cubes split twice: three sizes, coarse cubes with up to 6 finer
    neighbours."""
    return meshes.octree_box([0, 0, 0], [1, 1, 1], n).refine(
        lambda x: np.linalg.norm(x, axis=0) < 0.45, 2).polyhedra()


def voronoi(n: int) -> PolyhedronMesh:
    """Voronoi cells of a perturbed body-centred cubic lattice: the n^3 cube centres and the (n-1)^3
    inner cube corners, shifted by 1/(8n) along every axis and each moved by up to 0.05 spacings per
    axis (fixed rng). The cells are deformed truncated octahedra (squares and hexagons), cut by the
    box near the boundary.

    The shift keeps the box's planes 1/(8n) away from the lattice's Voronoi vertices (unshifted, they
    lie on them, and the perturbation makes edges of 1e-4 of the cell size there); not a perturbed
    simple cubic lattice, where 8 seeds are nearly cospherical around every lattice point: on the
    short edges and small faces of both the element failed (docs/notes/2026-11-26-sfvem-3d-rates.md,
    :func:`voronoi_cubic`) until voronoi_box collapsed the edges shorter than 1e-2 of their cell
    (docs/notes/2026-11-26-voronoi-short-edges.md)."""
    rng = np.random.default_rng(31)
    seeds = np.concatenate([_lattice(n), _lattice(n - 1) * (n - 1) / n + 0.5 / n]) + 0.125 / n
    return meshes.voronoi_box(seeds + rng.uniform(-0.05, 0.05, seeds.shape) / n, [0, 0, 0], [1, 1, 1])


def voronoi_cubic(n: int) -> PolyhedronMesh:
    """Voronoi cells of a perturbed simple cubic n^3 lattice (each seed moved by up to 0.3 spacings per
    axis, fixed rng): short edges and small faces occur (collapsed by voronoi_box)."""
    rng = np.random.default_rng(31)
    seeds = _lattice(n)
    return meshes.voronoi_box(seeds + rng.uniform(-0.3, 0.3, seeds.shape) / n, [0, 0, 0], [1, 1, 1])


def voronoi_random(n: int) -> PolyhedronMesh:
    """Voronoi cells of n^3 uniformly random seeds (fixed rng): tiny edges and faces occur (collapsed
    by voronoi_box)."""
    rng = np.random.default_rng(31)
    return meshes.voronoi_box(rng.uniform(0.0, 1.0, (n ** 3, 3)), [0, 0, 0], [1, 1, 1])


def prisms(n: int) -> PolyhedronMesh:
    """Prisms over Voronoi-like polygons of size 1/n (gmsh dual mesh), n layers."""
    return meshes.extrude_polygons(meshes.polygon_rectangle(1.0, 1.0, 1.0 / n), 1.0, n)


FAMILIES: dict[str, tuple[Callable[[int], PolyhedronMesh], tuple[int, ...]]] = {
    "cubes": (cubes, (2, 4, 8, 12)),
    "octree": (octree, (2, 4, 6, 8)),
    "octree_two_levels": (octree_two_levels, (2, 4, 6, 8)),
    "voronoi": (voronoi, (3, 4, 5, 6)),
    "voronoi_cubic": (voronoi_cubic, (3, 4, 6, 8)),
    "voronoi_random": (voronoi_random, (3, 4, 6, 8)),
    "prisms": (prisms, (2, 4, 6, 8)),
}


def run_level(mesh: PolyhedronMesh) -> dict:
    """Solve on ``mesh``; h, errors, unknowns, l counts and times."""
    t0 = time.perf_counter()
    solution = solve(mesh, u_exact, body_force, YOUNG, POISSON)
    e0, e1 = error_norms(solution, u_exact, grad_exact)
    ls, counts = np.unique(solution.ls, return_counts=True)
    return {"cells": mesh.n_cells, "h": float((mesh.volumes.sum() / mesh.n_cells) ** (1 / 3)),
            "unknowns": solution.n_free, "L2": e0, "H1": e1,
            "l": {int(a): int(b) for a, b in zip(ls, counts)},
            "faces_per_cell": float(np.diff(mesh.cell_offsets).mean()),
            "seconds": {**{k: round(v, 2) for k, v in solution.seconds.items()},
                        "total": round(time.perf_counter() - t0, 2)}}


def slopes(levels: list[dict], norm: str) -> tuple[float, float]:
    """(least-squares slope over all levels, slope of the last two) of log error vs log h."""
    h = np.log([r["h"] for r in levels])
    e = np.log([r[norm] for r in levels])
    return float(np.polyfit(h, e, 1)[0]), float((e[-1] - e[-2]) / (h[-1] - h[-2]))


def markdown(results: dict) -> str:
    """The results table."""
    lines = ["# Order-2 SFVEM on polyhedral meshes: manufactured-solution rates", "",
             "Written by `bench/vem3d_rates.py` (linear elasticity on the unit cube, plane-wave displacement; "
             "L2 = ||u - Pi^nabla_2 u_h||, H1 = ||grad u - Pi^0_l grad u_h||, h = (volume / cells)^(1/3); "
             "times on 2 shared cores). Discussion: docs/notes/2026-11-26-sfvem-3d-rates.md.", "",
             "| family | cells | h | unknowns | L2 error | rate | H1 error | rate | l (cells) | time s |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    fits = []
    for name, levels in results.items():
        for i, r in enumerate(levels):
            rate = ["", ""] if i == 0 else [
                f"{np.log(r[k] / levels[i - 1][k]) / np.log(r['h'] / levels[i - 1]['h']):.2f}" for k in ("L2", "H1")]
            l_text = ", ".join(f"{l}: {c}" for l, c in r["l"].items())
            lines.append(f"| {name} | {r['cells']} | {r['h']:.4f} | {r['unknowns']} | {r['L2']:.3e} | {rate[0]} | "
                         f"{r['H1']:.3e} | {rate[1]} | {l_text} | {r['seconds']['total']:.0f} |")
        if len(levels) > 1:
            (f0, _), (f1, _) = slopes(levels, "L2"), slopes(levels, "H1")
            fits.append(f"| {name} | {f0:.2f} | {f1:.2f} |")
    return "\n".join(lines + ["", "Least-squares slopes over all levels:", "",
                              "| family | L2 | H1 |", "|---|---|---|", *fits]) + "\n"


def census(mesh: PolyhedronMesh) -> list[dict]:
    """The cells on which the element fails (ValueError of polyhedron_projections): index, centroid,
    vertex and face counts, shortest edge and smallest face area relative to the cell's diameter h,
    and the reason."""
    failures = []
    for c in range(mesh.n_cells):
        points, faces = mesh.polyhedron(c)
        try:
            polyhedron_projections(points, faces)
        except ValueError as error:
            g = polyhedron_geometry(points, faces)
            edges = polyhedron_edges(faces)
            shortest = np.linalg.norm(points[edges[:, 0]] - points[edges[:, 1]], axis=1).min()
            failures.append({"cell": c, "centroid": np.round(mesh.centroids[c], 3).tolist(), "vertices": len(points),
                             "faces": len(faces), "min_edge/h": float(shortest / g.diameter),
                             "min_area/h^2": float(g.face_areas.min() / g.diameter ** 2), "reason": str(error)})
    return failures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--families", nargs="+", default=list(FAMILIES), choices=list(FAMILIES))
    parser.add_argument("--levels", type=int, default=4, help="number of levels per family (coarsest first)")
    parser.add_argument("--census", type=int, metavar="N", help="only list the failing cells of the families at size N")
    parser.add_argument("--out", default=str(pathlib.Path(__file__).with_name("vem3d_rates.json")))
    args = parser.parse_args()
    if args.census:
        for name in args.families:
            mesh = FAMILIES[name][0](args.census)
            failures = census(mesh)
            print(f"{name} n={args.census}: {len(failures)} of {mesh.n_cells} cells fail")
            for f in failures:
                print(" ", json.dumps(f))
        return
    out = pathlib.Path(args.out)
    results = json.loads(out.read_text()) if out.exists() else {}
    for name in args.families:
        make, sizes = FAMILIES[name]
        results[name] = []
        for n in sizes[:args.levels]:
            results[name].append({"n": n, **run_level(make(n))})
            print(name, json.dumps(results[name][-1]), flush=True)
            out.write_text(json.dumps(results, indent=1))
    out.with_suffix(".md").write_text(markdown(results))
    print(markdown(results))


if __name__ == "__main__":
    main()
