"""Sizes of the Hertz meshes by h_contact: the octree block under tetrahedra (SFVEM) against the
tetrahedra of ``hertz3d`` (P2, and the SFVEM on them), meshes only, no solve.

Usage::

    python3 bench/hertz_octree_sizes.py [--h 0.125 0.0625 0.03125] [--h-far 0.25] [--fine-radius 0.5] [--out FILE]

Per h_contact: cells (the block's, and of those the cubes with hanging vertices: more vertices than
their corners below the top plane, and the top cubes with more than their 4 corners on the top plane), the
unknowns of the SFVEM on the octree mesh (3 x (vertices + edges + faces + cells)) and of P2 on
hertz3d's tetrahedra at the same sizes (3 x (vertices + edges)), each in total and on the block's
cells alone, the SFVEM's unknowns on hertz3d's tetrahedra read as polyhedra, and the seconds to
make each mesh. Writes the Markdown table to ``FILE``
(default bench/hertz_octree_sizes.md).
"""
from __future__ import annotations

import argparse
import pathlib
import sys
import time

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
from dolfinx_sfvem.meshing.benchmarks3d import _cell_edges_and_faces, hertz3d, hertz3d_octree  # noqa: E402
from dolfinx_sfvem.meshes import SOLID  # noqa: E402
from dolfinx_sfvem.mesh.csr import concatenated_ranges, next_entries, segment_owner  # noqa: E402
from dolfinx_sfvem.discretizations.polyhedral_space import n_unknowns  # noqa: E402
from dolfinx_sfvem.mesh.polyhedron_mesh import PolyhedronMesh  # noqa: E402


def octree_counts(mesh) -> dict[str, int]:
    """Cells, block cubes, cubes with hanging vertices, cubes with a cut top, SFVEM unknowns (all and
    on the block's cells)."""
    cell = segment_owner(mesh.cell_offsets)
    sizes = np.diff(mesh.face_offsets)[mesh.cell_faces]
    entries = concatenated_ranges(mesh.face_offsets[mesh.cell_faces], sizes)
    owner = np.repeat(cell, sizes)
    block_cell = mesh.tags == SOLID
    in_block = block_cell[owner]
    pairs = np.unique(np.stack([owner, mesh.face_vertices[entries]], axis=1), axis=0)     # (cell, vertex)
    on_top = np.isclose(mesh.points[pairs[:, 1], 2], 1.0)
    below = np.bincount(pairs[~on_top, 0], minlength=mesh.n_cells)
    top = np.bincount(pairs[on_top, 0], minlength=mesh.n_cells)
    # a cube has 8 corners, 4 of them below the top plane if it touches it
    hanging = block_cell & (below > np.where(top > 0, 4, 8))
    cut_top = block_cell & (top > 4)
    nxt = mesh.face_vertices[next_entries(mesh.face_offsets)]
    edge_of_entry = np.sort(np.stack([mesh.face_vertices, nxt], axis=1), axis=1)[entries[in_block]]
    block_unknowns = 3 * (np.unique(mesh.face_vertices[entries[in_block]]).size
                          + np.unique(edge_of_entry, axis=0).shape[0]
                          + np.unique(mesh.cell_faces[block_cell[cell]]).size + int(block_cell.sum()))
    return {"cells": mesh.n_cells, "block": int(block_cell.sum()), "hanging": int(hanging.sum()),
            "cut_top": int(cut_top.sum()), "unknowns": n_unknowns(mesh), "block_unknowns": block_unknowns}


def p2_counts(mesh) -> dict[str, int]:
    """Cells, block tetrahedra, P2 unknowns (all and on the block's tetrahedra)."""
    edges, _ = _cell_edges_and_faces(mesh)
    block = mesh.cells[mesh.tags == SOLID]
    block_edges = np.unique(np.sort(block[:, [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]]].reshape(-1, 2),
                                    axis=1), axis=0)
    return {"cells": mesh.n_cells, "block": len(block), "unknowns": 3 * (mesh.n_points + len(edges)),
            "sfvem": n_unknowns(PolyhedronMesh.from_cell_mesh(mesh)),
            "block_unknowns": 3 * (np.unique(block).size + len(block_edges))}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--h", type=float, nargs="+", default=[0.125, 0.0625, 0.03125])
    p.add_argument("--h-far", type=float, default=0.25)
    p.add_argument("--fine-radius", type=float, default=0.5)
    p.add_argument("--out", type=pathlib.Path, default=HERE / "hertz_octree_sizes.md")
    args = p.parse_args()
    lines = ["# Hertz meshes by h_contact (bench/hertz_octree_sizes.py)", "",
             f"h_far = {args.h_far:g}, fine_radius = {args.fine_radius:g}, gap 0.1, no core. Octree: the block's "
             "cubes (hanging: cubes with hanging vertices below the top plane; top +: top cubes with more than "
             "their 4 corners on the top plane, gmsh points or hanging vertices) under gmsh tetrahedra; SFVEM unknowns 3 (v + e + f + c). P2: hertz3d's tetrahedra, 3 (v + e). 'block': the "
             "unknowns on the block's cells. SFVEM on the tets: the SFVEM's unknowns on hertz3d's tetrahedra read as "
             "polyhedra.", "",
             "| h_contact | octree cells | block cubes | hanging | top + | SFVEM unknowns | SFVEM block | mesh s "
             "| P2 tets | P2 block tets | P2 unknowns | P2 block | mesh s | SFVEM / P2 | block SFVEM / P2 "
             "| SFVEM on the tets |",
             "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for h in args.h:
        t = time.perf_counter()
        o = octree_counts(hertz3d_octree(h, args.h_far, fine_radius=args.fine_radius).mesh)
        t_octree = time.perf_counter() - t
        t = time.perf_counter()
        q = p2_counts(hertz3d(h, args.h_far, fine_radius=args.fine_radius).mesh)
        t_tets = time.perf_counter() - t
        lines.append(f"| {h:g} | {o['cells']:,} | {o['block']:,} | {o['hanging']:,} | {o['cut_top']:,} "
                     f"| {o['unknowns']:,} | {o['block_unknowns']:,} | {t_octree:.1f} | {q['cells']:,} | {q['block']:,} "
                     f"| {q['unknowns']:,} | {q['block_unknowns']:,} | {t_tets:.1f} "
                     f"| {o['unknowns'] / q['unknowns']:.2f} | {o['block_unknowns'] / q['block_unknowns']:.2f} "
                     f"| {q['sfvem']:,} |")
        print(lines[-1], flush=True)
    args.out.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
