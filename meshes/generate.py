"""Generate the demo meshes at their demos' default sizes into ``meshes/`` and summarise them.

Usage::

    python3 meshes/generate.py           # (re)write the files below into meshes/
    python3 meshes/generate.py --check   # regenerate in a temporary directory, compare with meshes/
    make meshes

For every mesh of :data:`MESHES`: ``<name>.npz``, the polygon mesh
(:func:`dolfinx_sfvem.meshes.read_polygons`), and ``<name>.png``, a picture of it coloured by
region; where gmsh makes the triangles whose dual polygons form the mesh (the solid of the box
and the C-box, everything in the punch and the multi-object meshes): ``<gmsh>.geo`` (geometry
and mesh options, ``gmsh <gmsh>.geo -2`` meshes it again) and ``<gmsh>.msh`` (the triangle mesh,
2D physical groups numbered by region tag). The summary (printed, and ``summary.md``) gives per
mesh the polygons by region and by vertex count, the hanging nodes and the projection order l
that the rank check chooses per polygon (docs/method.md §3: the smallest l >= 3 for which the
projected small-strain operator has exactly the 3 rigid-body modes in its null space; a polygon
without one is an error, and the script exits with 1).

``--check`` exits with 1 if a regenerated mesh differs from the one kept here (e.g. after a
gmsh upgrade), listing which.
"""
from __future__ import annotations

import argparse
import collections.abc
import pathlib
import sys
import tempfile
import typing

import numpy as np

from dolfinx_sfvem.output import markdown, post
from dolfinx_sfvem import meshes, paper
from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh
from dolfinx_sfvem.discretizations.projection import build_projections

HERE = pathlib.Path(__file__).resolve().parent
#: the demos' default mesh sizes
H = paper.DEFAULT_H

#: name -> (gmsh file stem or None, generator taking that stem as ``keep_gmsh``, which demo run uses it)
MESHES: dict[str, tuple[str | None, collections.abc.Callable[[str | None], meshes.Benchmark], str]] = {
    "box-mesh1": ("box-solid", lambda keep: meshes.box(1, H["box_self_contact"], keep),
                  "box_self_contact.py --mesh 1"),
    "box-mesh2": (None, lambda keep: meshes.box(2, H["box_self_contact"], keep),
                  "box_self_contact.py --mesh 2"),
    "box-mesh3": (None, lambda keep: meshes.box(3, H["box_self_contact"], keep),
                  "box_self_contact.py --mesh 3"),
    "cbox-mesh1": ("cbox-solid", lambda keep: meshes.cbox(H["cbox"], 1, keep), "cbox.py --mesh 1"),
    "cbox-mesh2": (None, lambda keep: meshes.cbox(H["cbox"], 2, keep), "cbox.py --mesh 2"),
    "cbox-grid1": (None, lambda keep: meshes.cbox_grid(H["cbox"], 1), "cbox.py --method fem --mesh 1"),
    "cbox-grid2": (None, lambda keep: meshes.cbox_grid(H["cbox"], 2), "cbox.py --method fem --mesh 2"),
    "punch": ("punch", lambda keep: meshes.punch(H["punch"], paper.PUNCH_GAP, keep), "punch.py"),
    "multi_object": ("multi_object", lambda keep: meshes.multi_object(H["multi_object"], paper.MULTI_OBJECT_GAP,
                                                                      keep), "multi_object.py"),
}


def generate(name: str, directory: pathlib.Path) -> tuple[PolygonMesh, list[str]]:
    """Write the files of one mesh into ``directory``; returns the mesh and the file names."""
    stem, build, _ = MESHES[name]
    bench = build(str(directory / stem) if stem else None)
    meshes.write_polygons(directory / f"{name}.npz", bench.mesh)
    post.plot_deformed_polygons(directory / f"{name}.png", bench.mesh, np.zeros_like(bench.mesh.points),
                                title=f"{name}: {bench.mesh.n_polygons} polygons")
    return bench.mesh, [f"{name}.npz", f"{name}.png"] + ([f"{stem}.geo", f"{stem}.msh"] if stem else [])


def projection_orders(mesh: PolygonMesh) -> dict[int, int]:
    """{l: polygon count} chosen by the rank check (raises ValueError naming a polygon without one)."""
    return build_projections(mesh.points, mesh.offsets, mesh.vertices).histogram()


def summary_row(name: str, mesh: PolygonMesh, orders: dict[int, int] | str, files: typing.Sequence[str]) -> list[str]:
    """One row of summary.md: counts by region and vertex number, hanging nodes, l, files."""
    _, per_region = np.unique(mesh.tags, return_counts=True)
    sizes, per_size = np.unique(np.diff(mesh.offsets), return_counts=True)
    l_text = orders if isinstance(orders, str) else ", ".join(f"l={l}: {n}" for l, n in orders.items())
    return [name, MESHES[name][2], f"{mesh.n_polygons} ({' / '.join(map(str, per_region))})",
            ", ".join(f"{k}: {n}" for k, n in zip(sizes, per_size)), str(mesh.n_points),
            str(meshes.t_junctions(mesh).size), str(mesh.hanging_nodes.size), l_text,
            ", ".join(f"`{f}`" for f in files)]


def write_summary(rows: typing.Sequence[list[str]], path: pathlib.Path) -> None:
    """summary.md: the table of :func:`summary_row` rows."""
    header = ["mesh", "used by", "polygons (by region tag 1 / 2 / 3)", "polygons by vertex count", "points",
              "T-junctions", "collinear vertices", "projection order l (rank check)", "files"]
    lines = ["# Demo meshes at their default sizes", "", "Written by `meshes/generate.py` (`make meshes`).", ""]
    lines += markdown.table(header, rows)
    lines += ["", "T-junctions: vertices where one polygon has a straight angle and another a corner (where "
                  "meshes of different densities meet); collinear vertices: every vertex straight in some "
                  "polygon (also the straight boundary vertices of dual meshes), see `meshes.describe`."]
    post.atomic_write_text(path, "\n".join(lines) + "\n")


def same_mesh(a: PolygonMesh, b: PolygonMesh) -> bool:
    """Same polygons, tags and (to 1e-12) points."""
    return (a.points.shape == b.points.shape and np.allclose(a.points, b.points, rtol=0, atol=1e-12)
            and all(np.array_equal(x, y) for x, y in ((a.offsets, b.offsets), (a.vertices, b.vertices),
                                                       (a.tags, b.tags))))


def check(names: typing.Sequence[str]) -> int:
    """Regenerate in a temporary directory and compare with the kept ``.npz``; the exit code."""
    differ = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            mesh, _ = generate(name, pathlib.Path(tmp))
            kept = HERE / f"{name}.npz"
            same = kept.is_file() and same_mesh(mesh, meshes.read_polygons(kept))
            print(f"{name}: {'same' if same else 'DIFFERS from' if kept.is_file() else 'missing:'} {kept}")
            differ += [] if same else [name]
    if differ:
        print(f"regenerated meshes differ from meshes/: {', '.join(differ)} (run meshes/generate.py to update)")
    return 1 if differ else 0


def main(argv: typing.Sequence[str] | None = None) -> int:
    """Write (or ``--check``) the meshes; returns the exit code."""
    p = argparse.ArgumentParser(prog="generate.py", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--check", action="store_true", help="compare regenerated meshes with the kept ones")
    p.add_argument("--only", nargs="+", choices=tuple(MESHES), default=list(MESHES), help="these meshes only")
    args = p.parse_args(argv)
    if args.check:
        return check(args.only)
    rows, failed = [], False
    for name in args.only:
        mesh, files = generate(name, HERE)
        try:
            orders: dict[int, int] | str = projection_orders(mesh)
        except ValueError as err:
            orders, failed = f"rank check FAILED: {err}", True
        print(f"== {name} ({MESHES[name][2]}): {', '.join(files)}\n{meshes.describe(mesh)}\n"
              f"projection order l: {orders if isinstance(orders, str) else orders}\n", flush=True)
        rows.append(summary_row(name, mesh, orders, files))
    if set(args.only) == set(MESHES):
        write_summary(rows, HERE / "summary.md")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
