"""3D cell meshes from gmsh: the volume cells of a gmsh model (tetrahedra or hexahedra) as a
:class:`~dolfinx_sfvem.mesh.cell_mesh.CellMesh`, from a ``.msh`` file, the caller's open model, or a
geometry builder meshed in a gmsh session of our own; and :func:`read_gmsh`, the reader of 2D and 3D
models with their physical groups as regions and named boundaries.

Parallel use: gmsh meshes identically on every rank (one thread, the same input), as the 2D
generators do; the caller needs no rank logic. A first-order mesh gives straight-sided cells (flat
faces), their vertices on the geometry (gmsh places boundary nodes on the curved surfaces); a
second-order one (``gmsh.model.mesh.setOrder(2)``: 10-node tetrahedra, 27-node hexahedra) a
:class:`~dolfinx_sfvem.mesh.cell_mesh.CellMesh` of degree-2 geometry, whose edge nodes gmsh places
on the curved surfaces too.
"""
from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from dolfinx_sfvem import _compat
from dolfinx_sfvem.mesh.cell_mesh import CellMesh, vertices_first
from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh
from dolfinx_sfvem.meshing.gmsh_io import (
    check_grouped, element_nodes, entity_regions, gmsh_model, gmsh_session, named_boundaries, read_polygons_of_model,
    region_names)
from dolfinx_sfvem.meshing.hexahedra import right_handed

#: gmsh geometry builder of a 3D model: ``build(gmsh)`` creates the geometry in a fresh gmsh model
#: (synchronised), sets the mesh size (options or fields) and returns {region tag: volume tags}
VolumeBuilder = Callable[[object], Mapping[int, Sequence[int]]]

#: gmsh's corner order of a hexahedron -> DOLFINx's tensor-product order
GMSH_TO_DOLFINX_HEXAHEDRON = np.array([0, 1, 3, 2, 4, 5, 7, 6])

#: relative size (times the mesh's extent) of the coordinates :func:`gmsh_tetrahedra` rounds to zero
ROUND_OFF = 1e-12

_CELL_TYPES = {4: "tetrahedron", 8: "hexahedron"}


def model_volume_cells(gmsh, region_tags: Mapping[str, int] | None = None
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
    """The 3D cells of the current gmsh model, one cell type.

    Returns
    -------
    points : (n, 3) float64
        Nodes used by the cells.
    cells : (m, k) int64
        First order (k = 4 or 8): tetrahedra right-handed, or hexahedra in DOLFINx's vertex order;
        second order (k = 10 or 27): all nodes in DOLFINx's order (oriented by
        :class:`~dolfinx_sfvem.mesh.cell_mesh.CellMesh`).
    tags : (m,) int64
        Region tag of every cell (:func:`~dolfinx_sfvem.meshing.gmsh_io.entity_regions` of dim 3).
    cell_type : "tetrahedron" or "hexahedron"

    Raises
    ------
    ValueError
        If the selected volumes have no cells, or cells of another type (prisms, pyramids, 20-node
        hexahedra) or of two types.
    """
    node_tags, coords, _ = gmsh.model.mesh.getNodes()
    xyz = coords.reshape(-1, 3)
    node_order = np.argsort(node_tags)
    blocks, tags, corners = [], [], set()
    for entity, tag in entity_regions(gmsh, region_tags, dim=3).items():
        for name, cells, n_corners in element_nodes(gmsh, 3, entity, node_tags, node_order):
            if n_corners not in _CELL_TYPES:
                raise ValueError(f"gmsh volume {entity} has {name} cells; only tetrahedra or hexahedra are read")
            if cells.shape[1] > n_corners:             # second order: gmsh's node order -> DOLFINx's
                try:
                    _compat.geometry_degree(_CELL_TYPES[n_corners], cells.shape[1])
                except ValueError as err:
                    raise ValueError(f"gmsh volume {entity} has {name} cells: {err}; for hexahedra set "
                                     "Mesh.SecondOrderIncomplete = 0") from None
                cells = cells[:, _compat.gmsh_node_permutation(_CELL_TYPES[n_corners], cells.shape[1])]
            blocks.append(cells)
            corners.add(n_corners)
            tags.append(np.full(len(cells), tag, dtype=np.int64))
    if not blocks:
        raise ValueError("the gmsh model has no 3D elements in the selected volumes")
    if len({block.shape[1] for block in blocks}) > 1:
        raise ValueError("the gmsh model mixes tetrahedra and hexahedra, or orders 1 and 2; a CellMesh has one "
                         "cell type and one geometry degree")
    cells = np.concatenate(blocks)
    used, renumbered = np.unique(cells, return_inverse=True)
    points, cells = xyz[used], renumbered.reshape(cells.shape).astype(np.int64)
    cell_type = _CELL_TYPES[corners.pop()]
    if cells.shape[1] in _CELL_TYPES:                   # first order
        cells = right_handed(points, cells) if cell_type == "tetrahedron" else cells[:, GMSH_TO_DOLFINX_HEXAHEDRON]
    return points, cells, np.concatenate(tags), cell_type


def read_gmsh(source: str | os.PathLike | None = None,
              region_tags: Mapping[str, int] | None = None) -> PolygonMesh | CellMesh:
    """The mesh of a gmsh ``.msh`` file or of the caller's current gmsh model, 2D or 3D, with its
    physical groups as named regions and named boundaries.

    A model with 3D elements gives a :class:`~dolfinx_sfvem.mesh.cell_mesh.CellMesh` of its
    tetrahedra or hexahedra (:func:`from_gmsh_3d`), else a
    :class:`~dolfinx_sfvem.mesh.polygon_mesh.PolygonMesh` of its 2D cells
    (:func:`~dolfinx_sfvem.meshing.gmsh_io.from_gmsh`). The physical groups of the mesh's dimension
    become regions (``region_names``, name -> tag: materials by name); the named ones of one
    dimension less (surfaces in 3D, curves in 2D) become ``boundary_names``, which ``fix``,
    ``prescribe``, ``traction`` and ``pressure`` of :class:`~dolfinx_sfvem.ContactProblem` take by
    name. A second-order model (10-node tetrahedra, 27-node hexahedra) gives a mesh of degree-2
    (curved) geometry; 2D models are read as polygons of their corner nodes (straight-sided).

    Parameters
    ----------
    source : path or None
        A ``.msh`` file (read in a gmsh session of its own), or ``None`` for the current model of
        the caller's open gmsh session (left open, its model current).
    region_tags : mapping of physical-group name -> region tag, optional
        Read the cells of these physical groups with these tags (a missing group is a ValueError
        naming it). Default: every physical group of the mesh's dimension tagged by its number,
        or all cells with tag 0 if the model has none.

    Raises
    ------
    ValueError
        For a model mixing tetrahedra and hexahedra (or with prisms or pyramids), or with cells
        outside every physical group when the model has groups (and no ``region_tags`` select
        some).
    """
    with gmsh_model(source) as gmsh:
        if len(gmsh.model.mesh.getElementTypes(3)):
            return _read_model(gmsh, region_tags)
        return read_polygons_of_model(gmsh, region_tags)


def from_gmsh_3d(source: str | os.PathLike | None = None,
                 region_tags: Mapping[str, int] | None = None) -> CellMesh:
    """CellMesh of the 3D cells (tetrahedra or hexahedra) of a gmsh mesh (:func:`read_gmsh` reads
    2D and 3D models alike).

    Parameters
    ----------
    source : path or None
        A ``.msh`` file (read in a gmsh session of its own), or ``None`` for the current model of
        the caller's open gmsh session (left open).
    region_tags : mapping of physical-group name -> region tag, optional
        Read the volumes of these 3D physical groups with these tags (a missing group is a
        ValueError naming it). Default: every 3D physical group tagged by its number, or all
        volumes with tag 0 if the model has none; then a meshed volume outside every 3D physical
        group is a ValueError. ``region_names`` of the result: these, or the named 3D physical
        groups; ``boundary_names``: the named 2D physical groups, as faces (m, 3 | 4) of the mesh.
    """
    with gmsh_model(source) as gmsh:
        return _read_model(gmsh, region_tags)


def _read_model(gmsh, region_tags: Mapping[str, int] | None) -> CellMesh:
    if region_tags is None:
        check_grouped(gmsh, 3)
    points, cells, tags, cell_type = model_volume_cells(gmsh, region_tags)
    points, cells, n_vertex_points, _ = vertices_first(points, cells, 4 if cell_type == "tetrahedron" else 8)
    return CellMesh(points, cells, tags, cell_type, region_names(gmsh, region_tags, dim=3),
                    named_boundaries(gmsh, 3, points[:n_vertex_points]))


def gmsh_tetrahedra(build: VolumeBuilder, names: Mapping[str, int],
                    keep_gmsh: str | os.PathLike | None = None, order: int = 1) -> CellMesh:
    """Tetrahedra of the geometry ``build`` makes (:data:`VolumeBuilder`), meshed by gmsh's 3D
    Delaunay in one thread (the same mesh on every rank and every run). Coordinates within
    :data:`ROUND_OFF` x the mesh size of zero are set to zero (gmsh leaves ~1e-16 on the planes
    x = 0, y = 0, z = 0, where symmetry conditions go).

    ``names`` (region name -> tag) becomes the mesh's ``region_names``. With ``keep_gmsh`` the
    mesh is also written to ``<keep_gmsh>.msh``. ``order=2``: gmsh's second-order tetrahedra (its
    edge nodes on the curved surfaces), a mesh of degree-2 geometry.
    """
    if order not in _compat.GEOMETRY_DEGREES:
        raise ValueError(f"order must be one of {_compat.GEOMETRY_DEGREES}, not {order!r}")
    with gmsh_session() as gmsh:
        gmsh.option.setNumber("General.NumThreads", 1)
        gmsh.option.setNumber("Mesh.Algorithm3D", 1)
        for tag, volumes in build(gmsh).items():
            gmsh.model.addPhysicalGroup(3, list(volumes), tag)
        gmsh.model.mesh.generate(3)
        gmsh.model.mesh.setOrder(order)
        if keep_gmsh is not None:
            gmsh.write(os.fspath(keep_gmsh) + ".msh")
        points, cells, tags, cell_type = model_volume_cells(gmsh, None)
    points[np.abs(points) <= ROUND_OFF * np.ptp(points, axis=0).max()] = 0.0
    return CellMesh(points, cells, tags, cell_type, dict(names))


def graded_size(distance: np.ndarray, h_near: float, h_far: float, radius: float, width: float,
                core: tuple[float, float, float] | None = None) -> np.ndarray:
    """The mesh size of :func:`size_field` at ``distance`` (any shape) from its centre."""
    size = h_near + (h_far - h_near) * np.clip((distance - radius) / width, 0.0, 1.0)
    if core is not None:
        h_core, r_core, w_core = core
        size = np.minimum(size, h_core + (h_near - h_core) * np.maximum(0.0, (distance - r_core) / w_core))
    return size


def size_field(gmsh, h_near: float, h_far: float, centre: Sequence[float], radius: float, width: float,
               core: tuple[float, float, float] | None = None) -> None:
    """Background mesh size ``h_near`` within ``radius`` of ``centre``, growing linearly to ``h_far``
    over a shell of ``width`` beyond (a gmsh MathEval field; sizes from points, curvature and the
    boundary switched off; :func:`graded_size` evaluates it).

    ``core = (h_core, r_core, w_core)``: besides, size ``h_core`` within ``r_core`` of ``centre``,
    growing linearly beyond, by ``h_near - h_core`` over ``w_core`` (the smaller size holds).
    """
    x0, y0, z0 = (float(c) for c in centre)          # plain floats: NumPy 2's repr of its scalars is no number
    h_near, h_far, radius, width = float(h_near), float(h_far), float(radius), float(width)
    distance = f"Sqrt((x - {x0!r})^2 + (y - {y0!r})^2 + (z - {z0!r})^2)"

    size = f"{h_near!r} + {h_far - h_near!r} * Min(1, Max(0, ({distance} - {radius!r}) / {width!r}))"
    if core is not None:
        h_core, r_core, w_core = (float(c) for c in core)
        inner = f"{h_core!r} + {h_near - h_core!r} * Max(0, ({distance} - {r_core!r}) / {w_core!r})"
        size = f"Min({size}, {inner})"
    field = gmsh.model.mesh.field.add("MathEval")
    gmsh.model.mesh.field.setString(field, "F", size)
    gmsh.model.mesh.field.setAsBackgroundMesh(field)
    for option in ("Mesh.MeshSizeExtendFromBoundary", "Mesh.MeshSizeFromPoints", "Mesh.MeshSizeFromCurvature"):
        gmsh.option.setNumber(option, 0)
