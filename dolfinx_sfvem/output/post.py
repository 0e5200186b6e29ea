"""File writers of a run: JSON, CSV, NPZ and PNG pictures.

Every file is written to a temporary name and renamed into place, so a run that is
interrupted never leaves a half-written file behind. Only rank 0 writes JSON/CSV/PNG.
"""
from __future__ import annotations

import csv
import io
import json
import os
import pathlib
import typing

import numpy as np
from mpi4py import MPI

from dolfinx_sfvem.output.figure_output import save_png


def atomic_write_text(path: pathlib.Path, text: str) -> None:
    """Write ``text`` to ``path`` via a temporary file and an atomic rename."""
    path = pathlib.Path(path)
    tmp = path.with_name(f".{path.name}.tmp")
    with open(tmp, "w") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def write_npz(path: pathlib.Path, **arrays) -> None:
    """``numpy.savez`` via a temporary file and an atomic rename."""
    path = pathlib.Path(path)
    tmp = path.with_name(f".{path.name}.tmp.npz")
    np.savez(tmp, **arrays)
    os.replace(tmp, path)


def write_json(path: pathlib.Path, data: typing.Mapping) -> None:
    atomic_write_text(path, json.dumps(data, indent=1, default=json_default) + "\n")


def json_default(obj):
    """``json.dumps`` default for numpy scalars and arrays."""
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.floating,)):
        return float(obj)
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


def write_load_path_csv(path: pathlib.Path, steps: typing.Sequence[typing.Mapping]) -> None:
    """One row per converged step: step, load, Newton iterations, smallest gap between the solids
    and its deformed position (``gap``, ``gap_x``, ``gap_y`` (, ``gap_z`` in 3D); empty where not measured), negative
    pivots of the tangent (``negative_pivots``, empty without an LDL^T factorization), reactions,
    per pair of bodies b-c in contact the medium's force on b, its largest pressure and the contact
    zone's length (``contact_b-c_Fx``, ``_Fy`` (, ``_Fz``), ``_p_max``, ``_zone``), every load's magnitude and
    work-conjugate displacement (``<load>_magnitude``, ``<load>_displacement``), extras, the
    unknowns of the step's mesh and the polygons an adaptive refinement split after it (``dofs``,
    ``refined_polygons``)."""
    rows = [s for s in steps if s["converged"]]
    names = sorted({n for s in rows for n in s.get("reaction", {})})
    loads = sorted({n for s in rows for n in s.get("loads", {})})
    extras = sorted({k for s in rows for k in s.get("extra", {})})
    pairs = sorted({(c["body"], c["partner_body"]) for s in rows for c in s.get("contact", [])})
    axes = "xyz"[:max([len(r) for s in rows for r in s.get("reaction", {}).values()], default=2)]
    header = ["step", "load", "newton_iterations", "gap", *(f"gap_{c}" for c in axes), "negative_pivots"] + \
        [f"{n}_R{c}" for n in names for c in axes] + \
        [f"contact_{b}-{c}_{q}" for b, c in pairs for q in (*(f"F{c}" for c in axes), "p_max", "zone")] + \
        [f"{n}_{q}" for n in loads for q in ("magnitude", "displacement")] + extras + ["dofs", "refined_polygons"]
    lines = []
    for s in rows:
        gap = s.get("gap") or {}
        contact = {(c["body"], c["partner_body"]): c for c in s.get("contact", [])}
        r = [s["step"], s["load"], s["newton_iterations"], gap.get("value"), *gap.get("x", [None] * len(axes)),
             s.get("negative_pivots")]
        r += [s["reaction"].get(n, [np.nan] * len(axes))[c] for n in names for c in range(len(axes))]
        r += [value for pair in pairs for value in
              ([*contact[pair]["force"], contact[pair]["max_pressure"], contact[pair]["zone_length"]]
               if pair in contact else [None] * (len(axes) + 2))]
        r += [s.get("loads", {}).get(n, {}).get(q) for n in loads for q in ("magnitude", "displacement")]
        r += [s["extra"].get(k, np.nan) for k in extras]
        r += [s.get("dofs"), s.get("refined_polygons", 0)]
        lines.append(r)
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(header)
    w.writerows(lines)
    atomic_write_text(path, buf.getvalue())


def plot_contact_pressure(path: pathlib.Path, pressure, title: str = "") -> None:
    """PNG of the normal contact pressure along each body's surfaces facing another body, one line
    per surface, against the position along the pair's contact zone (its principal direction in
    the deformed configuration).

    Parameters
    ----------
    pressure : ContactPressure
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4), dpi=110, layout="constrained")
    for pair in pressure.pairs:
        on = (pressure.body == pair.body) & (pressure.partner_body == pair.partner_body)
        if pair.max_pressure <= 0.0:
            continue
        x = pressure.x[on]
        zone = pressure.zone[on]
        centre = x[zone].mean(axis=0)
        direction = np.linalg.svd(x[zone] - centre, full_matrices=False)[2][0] if zone.sum() > 1 else np.array([1.0, 0.0])
        s = (x - centre) @ direction
        surfaces = np.unique(pressure.surface[on])
        for k in surfaces:
            mine = pressure.surface[on] == k
            order = np.argsort(s[mine])
            label = f"region {pair.region} (body {pair.body}) against body {pair.partner_body}"
            ax.plot(s[mine][order], pressure.pressure[on][mine][order], ".-", ms=3,
                    label=label + (f", surface {k}" if surfaces.size > 1 else ""))
    ax.set_xlabel("position along the contact zone")
    ax.set_ylabel("normal pressure of the medium")
    ax.set_title(title)
    if ax.lines:
        ax.legend(fontsize=7)
    save_png(fig, path)


def plot_deformed_polygons(path: pathlib.Path, polygon_mesh, displacement: np.ndarray,
                           node_values: np.ndarray | None = None, title: str = "") -> None:
    """PNG of the deformed polygon mesh, polygons coloured by region.

    Parameters
    ----------
    polygon_mesh : PolygonMesh
    displacement : (n_points, 2)
        Displacement of every polygon-mesh point.
    node_values : (n_points,), optional
        A scalar (e.g. u_y) drawn as a contour on the deformed points instead of region colours.
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection

    x = polygon_mesh.points + displacement
    off, verts = polygon_mesh.offsets, polygon_mesh.vertices
    polys = [x[verts[off[e]:off[e + 1]]] for e in range(polygon_mesh.n_polygons)]
    fig, ax = plt.subplots(figsize=(8, 5), dpi=120)
    tags = polygon_mesh.tags
    colours = plt.get_cmap("Pastel1")(np.searchsorted(np.unique(tags), tags) % 9)
    if node_values is not None:
        tri = polygon_mesh.triangles
        nodes = np.vstack([x, polygon_mesh.extra_points + _extra_values(polygon_mesh, displacement)])
        values = np.concatenate([node_values, _extra_values(polygon_mesh, node_values)])
        tpc = ax.tripcolor(nodes[:, 0], nodes[:, 1], tri, values, shading="gouraud", cmap="viridis")
        fig.colorbar(tpc, ax=ax, shrink=0.8)
        coll = PolyCollection(polys, facecolors="none", edgecolors="k", linewidths=0.2)
    else:
        coll = PolyCollection(polys, facecolors=colours, edgecolors="k", linewidths=0.3)
    ax.add_collection(coll)
    ax.autoscale()
    ax.set_aspect("equal")
    ax.set_title(title)
    save_png(fig, path, bbox_inches="tight")


def _extra_values(polygon_mesh, values: np.ndarray) -> np.ndarray:
    n_extra = polygon_mesh.extra_points.shape[0]
    if n_extra == 0:
        return values[:0]
    out = np.zeros((n_extra,) + values.shape[1:])
    count = np.zeros(n_extra)
    n = polygon_mesh.n_points
    tri = polygon_mesh.triangles
    for c in range(3):
        is_extra = tri[:, c] >= n
        for other in range(3):
            if other != c:
                np.add.at(out, tri[is_extra, c] - n, values[tri[is_extra, other]])
                np.add.at(count, tri[is_extra, c] - n, 1.0)
    return out / count.reshape((-1,) + (1,) * (values.ndim - 1))


def gather_to_root(comm: MPI.Comm, indices: np.ndarray, values: np.ndarray, size: int) -> np.ndarray | None:
    """Assemble a global array of ``size`` rows on rank 0 from (indices, values) pieces."""
    pieces = comm.gather((indices, values), root=0)
    if comm.rank != 0:
        return None
    out = np.full((size,) + values.shape[1:], np.nan)
    for idx, val in pieces:
        out[idx] = val
    return out
