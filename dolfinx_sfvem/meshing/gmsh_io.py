"""gmsh I/O: a session of our own, the cells of a gmsh model, ``.msh`` input and ``.geo``/``.msh``
output.

gmsh is imported lazily (its import changes the SIGINT handler and fails outside the main
thread).
"""
from __future__ import annotations

import contextlib
import inspect
import os
from collections.abc import Iterator, Mapping

import numpy as np
from scipy.spatial import cKDTree

from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh
from dolfinx_sfvem.meshing.polygon_sets import PolygonSet, compact_points, length_tolerance, split_csr


_sessions_opened = 0  # gmsh sessions opened by gmsh_session and not yet finalised


@contextlib.contextmanager
def gmsh_session() -> Iterator[object]:
    """A quiet gmsh model of our own; yields the gmsh module.

    If the caller has no gmsh session open, one is initialised and finalised here. If the
    caller's session is open, it is left open: a new model is added and removed afterwards,
    and the caller's current model and terminal option are restored. (gmsh 4.8, which cannot
    say whether it is initialised, counts an open session with one empty unnamed model as
    nobody's and finalises it.)
    """
    import gmsh

    global _sessions_opened
    ours = _sessions_opened == 0 and _open_session(gmsh)
    _sessions_opened += ours
    previous, terminal = gmsh.model.getCurrent(), gmsh.option.getNumber("General.Terminal")
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        if not ours:
            gmsh.model.add("dolfinx_sfvem")
        yield gmsh
    finally:
        if ours:
            _sessions_opened -= 1
            gmsh.finalize()
        else:
            gmsh.model.remove()
            if previous in gmsh.model.list():
                gmsh.model.setCurrent(previous)
            gmsh.option.setNumber("General.Terminal", terminal)


def _open_session(gmsh) -> bool:
    """Initialise gmsh unless a session is open; whether this call opened one.

    No gmsh function but ``initialize`` and ``isInitialized`` is called before the session is
    known to be open: gmsh 4.8 may ``exit()`` the process when asked anything before it is
    initialised, and has no ``isInitialized``. Its ``initialize`` is harmless on an open session
    (a warning), after which a fresh session is told apart by its single empty unnamed model.
    """
    if hasattr(gmsh, "isInitialized"):
        if gmsh.isInitialized():
            return False
        newer = "interruptible" in inspect.signature(gmsh.initialize).parameters  # skip its SIGINT handler
        gmsh.initialize(readConfigFiles=False, **({"interruptible": False} if newer else {}))
        return True
    gmsh.initialize(readConfigFiles=False)
    return gmsh.model.list() == [""] and not gmsh.model.getEntities()


def entity_regions(gmsh, region_tags: Mapping[str, int] | None, dim: int = 2) -> dict[int, int]:
    """Region tag of every ``dim``-dimensional entity to read from the current gmsh model.

    With ``region_tags`` (physical-group name -> tag), the entities of those groups; without,
    the entities of all ``dim``-dimensional physical groups tagged by the group's number, or every
    entity with tag 0 when the model has no such physical group.
    """
    groups = [tag for _, tag in gmsh.model.getPhysicalGroups(dim)]
    if region_tags is None:
        if not groups:
            return {entity: 0 for _, entity in gmsh.model.getEntities(dim)}
        selected = {group: group for group in groups}
    else:
        names = {gmsh.model.getPhysicalName(dim, group): group for group in groups}
        missing = sorted(set(region_tags) - set(names))
        if missing:
            raise ValueError(f"{dim}D physical group(s) {missing} not found in the gmsh model; it has "
                             f"{sorted(names) if names else f'no {dim}D physical groups'}")
        selected = {names[name]: tag for name, tag in region_tags.items()}
    regions: dict[int, int] = {}
    for group, tag in selected.items():
        for entity in gmsh.model.getEntitiesForPhysicalGroup(dim, group):
            if regions.setdefault(int(entity), tag) != tag:
                raise ValueError(f"{'surface' if dim == 2 else 'volume'} {entity} belongs to two physical groups "
                                 "with different tags")
    return regions


def element_nodes(gmsh, dim: int, entity: int, node_tags: np.ndarray, node_order: np.ndarray
                  ) -> Iterator[tuple[str, np.ndarray, int]]:
    """The elements of a ``dim``-dimensional entity of the current gmsh model, one block per
    element type: (gmsh's type name, all nodes (m, n_nodes) in gmsh's order as indices into the
    arrays of ``gmsh.model.mesh.getNodes()``, whose tags are ``node_tags`` and ``node_order`` their
    argsort, the number of corner nodes, which come first)."""
    for etype, enodes in zip(*gmsh.model.mesh.getElements(dim, entity)[::2]):
        name, _, _, n_nodes, _, n_corners = gmsh.model.mesh.getElementProperties(etype)
        nodes = np.asarray(enodes, dtype=np.int64).reshape(-1, n_nodes)
        yield name, node_order[np.searchsorted(node_tags, nodes, sorter=node_order)], int(n_corners)


def element_corners(gmsh, dim: int, entity: int, node_tags: np.ndarray, node_order: np.ndarray
                    ) -> Iterator[tuple[str, np.ndarray]]:
    """:func:`element_nodes` without the higher-order nodes: (gmsh's type name, corner nodes
    (m, n_corners))."""
    for name, nodes, n_corners in element_nodes(gmsh, dim, entity, node_tags, node_order):
        yield name, nodes[:, :n_corners]


def model_cells(gmsh, region_tags: Mapping[str, int] | None
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """All 2D cells of the current gmsh model as polygons of their corner nodes.

    Higher-order nodes are dropped (edges are straight); nodes no cell uses are removed.

    Returns
    -------
    points : (n, 2) float64
    offsets : (m + 1,) int64 and flat : (offsets[-1],) int64
        Cell i has the points ``flat[offsets[i]:offsets[i+1]]`` (gmsh's node order).
    tags : (m,) int32
        Region tag of every cell (see :func:`entity_regions`).
    """
    node_tags, coords, _ = gmsh.model.mesh.getNodes()
    xyz = coords.reshape(-1, 3)
    if np.abs(xyz[:, 2]).max(initial=0.0) > length_tolerance(xyz[:, :2]):
        raise ValueError("the gmsh mesh is not in the plane z = 0")
    node_order = np.argsort(node_tags)
    blocks, tags = [], []
    for entity, tag in entity_regions(gmsh, region_tags).items():
        for _, cells in element_corners(gmsh, 2, entity, node_tags, node_order):
            blocks.append(cells)
            tags.append(np.full(len(cells), tag, dtype=np.int32))
    if not blocks:
        raise ValueError("the gmsh model has no 2D elements in the selected surfaces")
    sizes = np.concatenate([np.full(len(block), block.shape[1]) for block in blocks])
    points, flat = compact_points(xyz[:, :2], np.concatenate([block.ravel() for block in blocks]))
    return points, np.concatenate([[0], np.cumsum(sizes)]), flat, np.concatenate(tags)


def from_gmsh(source: str | os.PathLike | None = None,
              region_tags: Mapping[str, int] | None = None) -> PolygonMesh:
    """PolygonMesh of the 2D cells of a gmsh mesh, one polygon per cell
    (:func:`~dolfinx_sfvem.meshes.read_gmsh` reads 2D and 3D models alike).

    Triangles, quadrilaterals and any other 2D element type of fixed size are read as
    polygons of their corner ("primary") nodes; higher-order nodes are ignored. The mesh's
    ``region_names`` (name -> tag) let :class:`~dolfinx_sfvem.ContactProblem` take materials keyed
    by the physical groups' names; its ``boundary_names`` (name -> (m, 2) point pairs, the segments
    of the named 1D physical groups) let boundary conditions and loads take curves by name. A
    gmsh session the caller has open stays open.

    Parameters
    ----------
    source : path or None
        A ``.msh`` file (read in a gmsh session of its own), or ``None`` for the current
        model of the caller's open gmsh session.
    region_tags : mapping of physical-group name -> region tag, optional
        Read the surfaces of these 2D physical groups with these tags; a missing group is
        a ValueError naming it. Default: every 2D physical group, tagged by its number,
        or all surfaces with tag 0 if the model has no 2D physical group; then a meshed
        surface outside every 2D physical group is a ValueError.
    """
    with gmsh_model(source) as gmsh:
        return read_polygons_of_model(gmsh, region_tags)


@contextlib.contextmanager
def gmsh_model(source: str | os.PathLike | None) -> Iterator[object]:
    """The gmsh module with the model to read current: ``source`` merged into a session of our own
    (:func:`gmsh_session`), or, for ``None``, the caller's current model."""
    if source is None:
        import gmsh

        yield gmsh
        return
    path = os.fspath(source)
    if not os.path.isfile(path):
        raise FileNotFoundError(path)
    with gmsh_session() as gmsh:
        gmsh.merge(path)
        yield gmsh


def read_polygons_of_model(gmsh, region_tags: Mapping[str, int] | None) -> PolygonMesh:
    """:func:`from_gmsh` of the current gmsh model."""
    if region_tags is None:
        check_grouped(gmsh, 2)
    points, offsets, flat, tags = model_cells(gmsh, region_tags)
    mesh = PolygonSet(points, split_csr(offsets, flat), tags).to_mesh()
    mesh.region_names = region_names(gmsh, region_tags)
    mesh.boundary_names = named_boundaries(gmsh, 2, mesh.points)
    return mesh


def check_grouped(gmsh, dim: int) -> None:
    """ValueError naming an entity of dimension ``dim`` with elements that no ``dim``-dimensional
    physical group holds, when the current model has such groups (its cells would be dropped)."""
    groups = gmsh.model.getPhysicalGroups(dim)
    if not groups:
        return
    grouped = {int(e) for _, group in groups for e in gmsh.model.getEntitiesForPhysicalGroup(dim, group)}
    for _, entity in gmsh.model.getEntities(dim):
        if entity not in grouped and len(gmsh.model.mesh.getElements(dim, entity)[1]):
            names = sorted(gmsh.model.getPhysicalName(dim, group) or str(group) for _, group in groups)
            raise ValueError(f"gmsh {'volume' if dim == 3 else 'surface'} {entity} has cells but belongs to none of "
                             f"the model's {dim}D physical groups {names}; add it to one (or select groups by "
                             "region_tags)")


def named_boundaries(gmsh, dim: int, points: np.ndarray) -> dict[str, np.ndarray]:
    """The named ``dim - 1``-dimensional physical groups of the current gmsh model (curves in 2D,
    surfaces in 3D) as facets of the mesh read from it.

    Parameters
    ----------
    points : (n, dim) float
        The points of the mesh read from the model (the corner nodes of its cells).

    Returns
    -------
    dict name -> (m, 2 | 3 | 4) int64
        The group's elements as indices into ``points`` (corner nodes, gmsh's cyclic order);
        those with a corner off the cells read (outside the selected physical groups) are left
        out, and a group with none left.

    Raises
    ------
    ValueError
        For a named group without elements or with elements of two types.
    """
    node_tags, coords, _ = gmsh.model.mesh.getNodes()
    node_order = np.argsort(node_tags)
    xyz = coords.reshape(-1, 3)[:, :dim]
    tree = cKDTree(points)
    tol = length_tolerance(points)
    out: dict[str, np.ndarray] = {}
    for _, group in gmsh.model.getPhysicalGroups(dim - 1):
        name = gmsh.model.getPhysicalName(dim - 1, group)
        if not name:
            continue
        blocks = []
        for entity in gmsh.model.getEntitiesForPhysicalGroup(dim - 1, group):
            for _, corners in element_corners(gmsh, dim - 1, entity, node_tags, node_order):
                blocks.append(xyz[corners])
        if not blocks or len({block.shape[1] for block in blocks}) > 1:
            raise ValueError(f"boundary {name!r}: the {dim - 1}D physical group has "
                             f"{'no elements' if not blocks else 'elements of two types'}")
        x = np.concatenate(blocks)
        distance, index = tree.query(x.reshape(-1, dim))
        read = (distance <= tol).reshape(x.shape[:2]).all(axis=1)
        if read.any():
            out[name] = index.reshape(x.shape[:2])[read].astype(np.int64)
    return out


def region_names(gmsh, region_tags: Mapping[str, int] | None, dim: int = 2) -> dict[str, int]:
    """Region tag by name of the current gmsh model's ``dim``-dimensional physical groups
    (``region_tags`` itself when given; unnamed groups are left out)."""
    if region_tags is not None:
        return dict(region_tags)
    return {name: int(group) for _, group in gmsh.model.getPhysicalGroups(dim)
            if (name := gmsh.model.getPhysicalName(dim, group))}


def write_gmsh(gmsh, stem: str | os.PathLike) -> None:
    """Write the current gmsh model: ``<stem>.geo``, the geometry with the mesh options
    ``Mesh.Algorithm`` and ``Mesh.MeshSizeMax`` in force (``gmsh <stem>.geo -2`` meshes it
    again), and ``<stem>.msh``, its mesh (2D physical groups numbered by region tag)."""
    stem = os.fspath(stem)
    gmsh.write(stem + ".msh")
    gmsh.write(stem + ".geo_unrolled")
    with open(stem + ".geo_unrolled") as f:
        geometry = f.read()
    os.remove(stem + ".geo_unrolled")
    options = "".join(f"{name} = {gmsh.option.getNumber(name)!r};\n" for name in ("Mesh.Algorithm", "Mesh.MeshSizeMax"))
    with open(stem + ".geo", "w") as f:
        f.write(f"// written by dolfinx_sfvem.meshes.write_gmsh; `gmsh {os.path.basename(stem)}.geo -2` meshes it\n"
                + options + geometry)
