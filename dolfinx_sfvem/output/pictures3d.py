"""Pictures of a 3D state that a person reads without ParaView: PNGs rendered offscreen.

Three views of a deformed :class:`~dolfinx_sfvem.mesh.cell_mesh.CellMesh` (docs/guide/outputs.md):

- ``<prefix>-deformed.png``: the solids, deformed, coloured by the displacement magnitude, the
  medium hidden, the undeformed solids' outline as thin grey lines;
- ``<prefix>-clip.png``: the mesh cut by a plane through the contact zone, the solids coloured by
  region and the medium as a translucent wireframe, so the gap between the solids shows;
- ``<prefix>-pressure.png``: the contact pressure on the solids' surface where it exceeds 1 % of
  its largest value, seen from the side it pushes on (of the surface where it is largest), the
  rest of the solids translucent.

Where the mesh's cells subdivide the discretization's cells (the SFVEM's polyhedra over their fan
tetrahedra, :class:`~dolfinx_sfvem.mesh.cell_mesh.CellOutlines`), the surfaces are drawn without their
own edges and the polyhedra's edges are drawn instead: those on the surface, and in the cut the
lines where the plane crosses the polyhedra's faces.

Rendering is PyVista on VTK's wheels (pinned in pyproject.toml). Offscreen, without a display:
VTK's EGL window on Mesa (Debian: libegl1, libegl-mesa0, libgl1-mesa-dri; installed by the
Makefile), chosen here before VTK is loaded, so a user sets nothing. VTK is loaded with its own
symbols first (``RTLD_DEEPBIND``): DOLFINx makes later libraries load into the global namespace
(``RTLD_GLOBAL``), where the C++ standard library's regex templates of DOLFINx's libraries (built
for the new string ABI) would replace those of the VTK wheel (old ABI) and abort the process at
the first scalar bar.
"""
from __future__ import annotations

import contextlib
import functools
import os
import pathlib
import sys
import typing

import numpy as np

from dolfinx_sfvem.mesh.cell_mesh import CellOutlines, reference_edges
from dolfinx_sfvem.mesh.csr import edge_key, next_entries, segment_owner

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

#: width and height of every picture (pixels)
WINDOW_SIZE = (1200, 900)
#: the contact zone drawn in colour: pressure above this fraction of the largest
PRESSURE_THRESHOLD = 0.01
#: the solid regions' colours in the cut (light, so the edges show)
REGION_COLOURS = ("#8fc1a9", "#e0b97a", "#a9b8d9", "#d99a9a", "#c4c4c4")
#: colour of the third medium's edges in the clipped view
MEDIUM_COLOUR = "#3060b0"
#: colour of the cells' edges on the solids
EDGE_COLOUR = "#404040"
#: DOLFINx's vertex order -> VTK's (the hexahedron's faces cyclic)
VTK_CELLS = {"tetrahedron": (10, [0, 1, 2, 3]), "hexahedron": (12, [0, 1, 3, 2, 4, 5, 7, 6])}


@functools.cache
def _pyvista():
    """PyVista, its VTK modules loaded with their own symbols first (module docstring)."""
    flags = sys.getdlopenflags()
    sys.setdlopenflags(os.RTLD_NOW | os.RTLD_LOCAL | os.RTLD_DEEPBIND)
    try:
        import pyvista
        import vtkmodules.all  # noqa: F401  (every VTK module now, not later under other flags)
    finally:
        sys.setdlopenflags(flags)
    return pyvista


def offscreen_unavailable() -> str | None:
    """Why no picture can be rendered here (None when it can): PyVista/VTK missing, or no offscreen
    OpenGL (the EGL libraries)."""
    try:
        pyvista = _pyvista()
    except ImportError as error:
        return f"PyVista is not installed ({error})"
    try:
        plotter = pyvista.Plotter(off_screen=True, window_size=(16, 16))
        plotter.add_mesh(pyvista.Sphere())
        plotter.screenshot(return_img=True)
        plotter.close()
    except Exception as error:      # VTK raises plain RuntimeErrors (or worse) without a GL context
        return f"no offscreen OpenGL context ({type(error).__name__}: {error})"
    return None


def _grid(mesh, x: np.ndarray, cells: np.ndarray):
    """A PyVista grid of ``cells`` (rows of ``mesh.cells``) at point positions ``x`` (n_points, 3), every
    cell turned positive in VTK's convention (by its reference volume), so that the faces of the
    surface point outwards."""
    pyvista = _pyvista()
    vtk_type, order = VTK_CELLS[mesh.cell_type]
    p = np.asarray(mesh.points, dtype=float)[cells]
    # the reference cell's volume sign: edges from vertex 0 to 1, 2 and (tetrahedra) 3 / (hexahedra) 4
    edges = p[:, [1, 2, 3 if mesh.cell_type == "tetrahedron" else 4]] - p[:, [0]]
    negative = np.linalg.det(edges) < 0.0
    flip = [0, 2, 1, 3] if mesh.cell_type == "tetrahedron" else [0, 2, 1, 3, 4, 6, 5, 7]
    cells = np.where(negative[:, None], cells[:, flip], cells)[:, order]
    k = len(order)
    conn = np.hstack([np.full((cells.shape[0], 1), k), cells]).astype(np.int64)
    return pyvista.UnstructuredGrid(conn.ravel(), np.full(cells.shape[0], vtk_type, dtype=np.uint8), x)


def _polygon_sides(polys) -> tuple[np.ndarray, np.ndarray]:
    """The sides of the polygons of a PyVista surface: pairs of its points (n_sides, 2) and the
    polygon of each side (n_sides,)."""
    pyvista = _pyvista()
    offsets = pyvista.convert_array(polys.GetPolys().GetOffsetsArray()).astype(np.int64)
    vertices = pyvista.convert_array(polys.GetPolys().GetConnectivityArray()).astype(np.int64)
    return np.column_stack([vertices, vertices[next_entries(offsets)]]), segment_owner(offsets)


def _outlines_among(edges: np.ndarray, pairs: np.ndarray, n_points: int) -> np.ndarray:
    """The rows of ``edges`` (k, 2) that are among the point ``pairs`` (m, 2), either way round."""
    return edges[np.isin(edge_key(edges[:, 0], edges[:, 1], n_points), edge_key(pairs[:, 0], pairs[:, 1], n_points))]


def surface_outlines(grid, outlines: CellOutlines, n_points: int) -> np.ndarray:
    """The edges of ``outlines`` (k, 2) that are sides of the polygons of ``grid``'s boundary surface
    (a grid of :func:`_grid` or a surface, with the mesh's point of each of its points as point data
    ``"point"``): the cells' edges that the surface shows."""
    surface = grid if isinstance(grid, _pyvista().PolyData) else grid.extract_surface(algorithm="dataset_surface")
    return _outlines_among(outlines.edges, surface.point_data["point"][_polygon_sides(surface)[0]], n_points)


def cells_outlines(mesh, cells: np.ndarray, outlines: CellOutlines) -> np.ndarray:
    """The edges of ``outlines`` (k, 2) that are edges of the mesh's ``cells`` (rows of ``mesh.cells``)."""
    pairs = cells[:, np.asarray(reference_edges(mesh.cell_type))].reshape(-1, 2)
    return _outlines_among(outlines.edges, pairs, mesh.points.shape[0])


def _lines(x: np.ndarray, edges: np.ndarray):
    """The ``edges`` (k, 2) between the points ``x`` (n, 3) as PyVista lines."""
    return _pyvista().PolyData(x, lines=np.column_stack([np.full(len(edges), 2), edges]).ravel())


def _cut_outlines(grid, normal: np.ndarray, origin: np.ndarray):
    """The lines where the plane (``normal``, ``origin``) cuts the faces of the cells that the cells
    of ``grid`` lie in (its cell data ``"cell"``, :class:`CellOutlines`): the sides of its cut
    polygons on the boundary of the cut or between two cells' cuts (None where it cuts nothing).
    Cut a millionth of the grid's size inside the side that the clip keeps (−``normal``) and put
    back on the plane, so that a plane along faces cuts the kept cells, not the faces' fans."""
    unit = normal / np.linalg.norm(normal)
    cut = grid.slice(normal=unit, origin=origin - 1e-6 * _size(np.asarray(grid.points)) * unit)
    if cut.n_cells == 0:
        return None
    cut = cut.clean(tolerance=1e-9, absolute=False)      # one point where the plane crosses an edge
    sides, polygon = _polygon_sides(cut)
    key = edge_key(sides[:, 0], sides[:, 1], cut.n_points)
    order = np.argsort(key, kind="stable")
    _, first, count = np.unique(key[order], return_index=True, return_counts=True)
    cell = np.asarray(cut.cell_data["cell"])[polygon[order]]
    drawn = (count == 1) | (np.minimum.reduceat(cell, first) != np.maximum.reduceat(cell, first))
    points = np.asarray(cut.points)
    return _lines(points - np.outer((points - origin) @ unit, unit), sides[order[first[drawn]]])


def _add_lines(plotter, drawn, **style) -> None:
    """Lines (PyVista, or None) into the picture, unless there are none."""
    if drawn is not None and drawn.n_cells:
        plotter.add_mesh(drawn, **style)


def _add_clipped_outlines(plotter, x: np.ndarray, edges: np.ndarray, grid, normal: np.ndarray,
                          origin: np.ndarray, **style) -> None:
    """The outline ``edges`` (k, 2) between the points ``x`` on the side of the clip plane
    (``normal``, ``origin``) that the clip keeps, and the lines where it cuts the cells of ``grid``
    (:func:`_cut_outlines`)."""
    _add_lines(plotter, _lines(x, edges).clip(normal=normal, origin=origin), **style)
    _add_lines(plotter, _cut_outlines(grid, normal, origin), **style)


@contextlib.contextmanager
def _lines_in_front(on: bool):
    """While rendering (``on``): VTK's polygons pushed behind the lines that lie on them (its global
    polygon offset), as a surface's own edges are when shown; VTK's global setting restored after."""
    _pyvista()
    import vtkmodules.vtkRenderingCore as core
    previous = core.vtkMapper.GetResolveCoincidentTopology()
    if on:
        core.vtkMapper.SetResolveCoincidentTopologyToPolygonOffset()
    try:
        yield
    finally:
        core.vtkMapper.SetResolveCoincidentTopology(previous)


def _medium_normals(surface) -> np.ndarray:
    """Unit reference outward normals (n_nodes, 3) of the surface's nodes from its sub-triangles that
    face the medium alone (0 where none does): the direction the contact pressure acts along, which
    the faces on symmetry planes and outer sides would tilt (the surface's ``node_normal``)."""
    facing = surface.face_faces_medium[surface.triangle_face]
    normal = np.zeros((surface.X.shape[0], 3))
    for corner in range(3):
        np.add.at(normal, surface.triangles[facing, corner], surface.triangle_normal[facing])
    return normal / np.maximum(np.linalg.norm(normal, axis=1), 1e-300)[:, None]


def _contact_view(mesh, x, surface, pressure):
    """Where the contact is and its normal: the centre of the contact zone on the surface that carries
    the largest pressure (the surface's vertices with pressure above :data:`PRESSURE_THRESHOLD` of the
    largest whose normal towards the medium is within 90° of that where it is largest) and their mean
    reference normal towards the medium (None, None without a pressure). The zone lies on both
    surfaces pressed together (two bodies', or two of one body's in self-contact), whose normals are
    opposite: taken together, their mean normal would be arbitrary."""
    if surface is None or pressure is None or not np.any(pressure > 0.0):
        return None, None
    keys = surface.node_keys
    vertex = keys < mesh.points.shape[0]
    p = np.where(vertex, pressure, 0.0)
    peak = int(np.argmax(p))
    normals = _medium_normals(surface)
    zone = (p > PRESSURE_THRESHOLD * p[peak]) & (normals @ normals[peak] > 0.0)
    normal = normals[zone].sum(axis=0)
    return x[keys[zone]].mean(axis=0), normal / max(np.linalg.norm(normal), 1e-300)


def _default_clip(mesh, x, solid, origin, normal, contact_normal):
    """The clip plane: through the contact (else the solids' centre), normal to the axis most
    perpendicular to the contact normal, of the smallest extent of the solids (the C-box: its
    thickness direction), unless given."""
    used = x[np.unique(mesh.cells[solid])]
    if origin is None:
        origin = 0.5 * (used.min(axis=0) + used.max(axis=0))
    if normal is None:
        extent = used.max(axis=0) - used.min(axis=0)
        score = extent.copy()
        if contact_normal is not None:
            score = np.where(np.abs(contact_normal) < 0.5, score, np.inf)
        normal = np.eye(3)[int(np.argmin(score))]
    return np.asarray(origin, dtype=float), np.asarray(normal, dtype=float)


def write_pictures_3d(out_dir: str | os.PathLike, prefix: str, mesh, point_displacement: np.ndarray,
                      solid_tags: typing.Collection[int], surface=None, pressure: np.ndarray | None = None,
                      clip_origin: typing.Sequence[float] | None = None,
                      clip_normal: typing.Sequence[float] | None = None,
                      outlines: CellOutlines | None = None) -> list[pathlib.Path]:
    """Render the pictures of one 3D state (module docstring) into ``out_dir``; not collective (call it
    on one rank, with the gathered mesh and displacement).

    Parameters
    ----------
    out_dir, prefix
        The PNGs are ``out_dir/<prefix>-deformed.png``, ``-clip.png`` and ``-pressure.png``.
    mesh
        A :class:`~dolfinx_sfvem.mesh.cell_mesh.CellMesh` of tetrahedra or hexahedra (``points``,
        ``cells``, ``tags``, ``cell_type`` are read).
    point_displacement : (n_points, 3)
        The displacement at the mesh's points (the vertices; the pictures draw straight edges).
    solid_tags
        Region tags of the solids; the others are third medium.
    surface, pressure
        The state's :class:`~dolfinx_sfvem.physics.solid_surface.SolidSurface` and the contact pressure
        (n_nodes,) in its :attr:`node_keys` order (``ContactPressure.pressure``); without them no
        pressure picture.
    clip_origin, clip_normal
        The clip plane (default: through the centre of the contact zone, else the solids' centre;
        normal to the coordinate axis of smallest solid extent among those across the contact normal).
    outlines
        The cells that the mesh's cells subdivide (the SFVEM's polyhedra over their fan tetrahedra):
        their edges are drawn instead of the mesh's (module docstring); None: the mesh's own.

    Returns
    -------
    The paths of the pictures written.
    """
    pyvista = _pyvista()
    out = pathlib.Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    points = np.asarray(mesh.points, dtype=float)
    x = points + np.asarray(point_displacement, dtype=float)
    cells, tags = np.asarray(mesh.cells), np.asarray(mesh.tags)
    solid = np.isin(tags, list(solid_tags))
    solids, medium = _grid(mesh, x, cells[solid]), _grid(mesh, x, cells[~solid])
    solids.cell_data["region"] = tags[solid]
    solids.point_data["|u|"] = np.linalg.norm(point_displacement, axis=1)
    own_edges = outlines is None                 # else the outlines' edges, drawn as lines
    if not own_edges:
        for grid, chosen in ((solids, solid), (medium, ~solid)):
            grid.point_data["point"] = np.arange(points.shape[0])
            grid.cell_data["cell"] = np.asarray(outlines.cell)[chosen]
        lines = dict(color=EDGE_COLOUR, line_width=1)
    contact_point, contact_normal = _contact_view(mesh, x, surface, pressure)
    origin, normal = _default_clip(mesh, x, solid, clip_origin if clip_origin is not None else contact_point,
                                   clip_normal, contact_normal)
    paths = []

    def save(plotter, name: str) -> None:
        path = out / f"{prefix}-{name}.png"
        with _lines_in_front(not own_edges):
            plotter.screenshot(str(path))
        plotter.close()
        paths.append(path)

    bar = dict(title_font_size=22, label_font_size=18, n_labels=5, fmt="%.3g", vertical=True,
               position_x=0.86, position_y=0.2, height=0.6)
    # the deformed solids
    plotter = pyvista.Plotter(off_screen=True, window_size=WINDOW_SIZE)
    plotter.add_mesh(solids, scalars="|u|", cmap="viridis", show_edges=own_edges, edge_color=EDGE_COLOUR,
                     line_width=0.5, scalar_bar_args={**bar, "title": "displacement"})
    if not own_edges:
        _add_lines(plotter, _lines(x, surface_outlines(solids, outlines, points.shape[0])), **lines)
    plotter.add_mesh(_grid(mesh, points, cells[solid]).extract_feature_edges(45.0), color="#909090", line_width=1)
    plotter.add_title(f"{prefix}: deformed solids (medium hidden)", font_size=14)
    plotter.view_isometric()
    plotter.enable_parallel_projection()
    plotter.add_axes()
    save(plotter, "deformed")
    # the clip through the contact zone
    plotter = pyvista.Plotter(off_screen=True, window_size=WINDOW_SIZE)
    clipped = solids.clip(normal=normal, origin=origin, crinkle=False)
    key = []
    for k, tag in enumerate(sorted(set(int(t) for t in tags[solid]))):
        part = clipped.threshold((tag - 0.5, tag + 0.5), scalars="region") if clipped.n_cells else clipped
        if part.n_cells:
            colour = REGION_COLOURS[k % len(REGION_COLOURS)]
            plotter.add_mesh(part, color=colour, show_edges=own_edges, edge_color=EDGE_COLOUR, line_width=0.5,
                             lighting=False)
            key.append((f"solid, region {tag}", colour))
    if not own_edges:
        _add_clipped_outlines(plotter, x, surface_outlines(solids, outlines, points.shape[0]), solids, normal,
                              origin, **lines)
    if medium.n_cells:
        medium_style = dict(color=MEDIUM_COLOUR, opacity=0.5, line_width=1)
        if own_edges:
            plotter.add_mesh(medium.clip(normal=normal, origin=origin, crinkle=False), style="wireframe",
                             **medium_style)
        else:
            _add_clipped_outlines(plotter, x, cells_outlines(mesh, cells[~solid], outlines), medium, normal,
                                  origin, **medium_style)
        key.append(("third medium (edges)", MEDIUM_COLOUR))
    _add_key(plotter, key)
    plotter.add_title(f"{prefix}: cut through the contact, normal {_vector(normal)}", font_size=14)
    plotter.camera_position = [tuple(origin + 4.0 * normal * _size(x)), tuple(origin), _up(normal)]
    plotter.reset_camera()
    plotter.enable_parallel_projection()
    plotter.add_axes()
    save(plotter, "clip")
    if contact_point is None:
        return paths
    # the contact pressure, seen along the contact normal onto the surface that carries it, the rest
    # of the solids faint in front of it
    values = np.full(points.shape[0], np.nan)
    vertex = surface.node_keys < points.shape[0]
    values[surface.node_keys[vertex]] = pressure[vertex]
    solids.point_data["pressure"] = values
    skin = solids.extract_surface(algorithm="dataset_surface")
    p_max = float(np.nanmax(values))
    loaded = skin.threshold(PRESSURE_THRESHOLD * p_max, scalars="pressure", all_scalars=True)
    plotter = pyvista.Plotter(off_screen=True, window_size=WINDOW_SIZE)
    plotter.add_mesh(skin, color="#b0b0b0", opacity=0.12)
    loaded = loaded.extract_surface(algorithm="dataset_surface")
    plotter.add_mesh(loaded, scalars="pressure", cmap="inferno", clim=(0.0, p_max), culling="back",
                     show_edges=own_edges, edge_color="#505050", line_width=0.5,
                     scalar_bar_args={**bar, "title": "contact pressure"})
    plotter.add_title(f"{prefix}: contact pressure, on the surface facing {_vector(contact_normal)}",
                      font_size=14)
    # from the side the pressure pushes on, turned a little across the clip plane's normal and along it
    across = np.cross(contact_normal, normal)
    view = contact_normal + 0.35 * normal + 0.25 * across / max(np.linalg.norm(across), 1e-300)
    if not own_edges:     # on the faces towards the camera (the others culled)
        front = loaded.extract_cells(np.flatnonzero(loaded.cell_normals @ view > 0.0))
        _add_lines(plotter, _lines(x, surface_outlines(front, outlines, points.shape[0])), **{**lines, "color": "#505050"})
    plotter.camera_position = [tuple(contact_point + 4.0 * view * _size(x)), tuple(contact_point), _up(view)]
    low, high = np.reshape(loaded.bounds, (3, 2)).T
    pad = 0.3 * (high - low).max()
    plotter.reset_camera(bounds=np.column_stack([low - pad, high + pad]).ravel())
    plotter.enable_parallel_projection()
    plotter.add_axes()
    save(plotter, "pressure")
    return paths


def _add_key(plotter, key: list[tuple[str, str]]) -> None:
    """A colour key in the lower right corner, one line of text per (label, colour), at a fixed
    font size inside the window (VTK's legend box scaled its text beyond the window's edge)."""
    for i, (label, colour) in enumerate(reversed(key)):
        plotter.add_text(label, position=(int(0.72 * WINDOW_SIZE[0]), 24 + 30 * i), font_size=12,
                         color=colour)


def _vector(v: np.ndarray) -> str:
    """A direction for a title: an axis ("+z") when within 18° of one, else its components."""
    k = int(np.argmax(np.abs(v)))
    if abs(v[k]) > 0.95 * np.linalg.norm(v):
        return ("+" if v[k] > 0 else "-") + "xyz"[k]
    return "(" + ", ".join(f"{c:.2f}" for c in v) + ")"


def _size(x: np.ndarray) -> float:
    return float(np.linalg.norm(x.max(axis=0) - x.min(axis=0)))


def _up(direction: np.ndarray) -> tuple[float, float, float]:
    """A view-up vector across the viewing ``direction``: z, unless looking along z (then y)."""
    return (0.0, 1.0, 0.0) if abs(direction[2]) > 0.9 else (0.0, 0.0, 1.0)
