"""Local refinement of a simplex :class:`~dolfinx_sfvem.mesh.cell_mesh.CellMesh` (tetrahedra; the FEM's
cells), and the one entry that refines a problem's mesh whatever it is (:func:`refine_mesh`).

A level splits the edges of the selected cells with DOLFINx's refinement (Plaza's algorithm,
:func:`~dolfinx_sfvem._compat.plaza_refine`), which bisects neighbours as far as needed to stay
conforming: the Lagrange FEM has no hanging nodes, so the closure of a refinement reaches beyond
the selection. Every new cell lies inside one cell of the mesh refined, its *parent*. The refined
mesh is made independent of DOLFINx's numbering: the points of the mesh refined keep their
index, the new points follow sorted by their coordinates, the cells are sorted by parent; so
every rank that refines the same mesh gets the same one. Region tags pass from parent to child,
and a named boundary (``boundary_names``) takes the new facets lying on its facets.

Hexahedra (Q2) are not refined: splitting a hexahedron leaves hanging nodes on its neighbours,
which a conforming Lagrange space does not have.
"""
from __future__ import annotations

import typing
import numpy as np
import numpy.typing as npt

from dolfinx_sfvem import _compat
from dolfinx_sfvem.mesh.cell_mesh import CellMesh, reference_facets
from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh, Refinement
from dolfinx_sfvem.mesh.refine import Selection, select_polygons

#: a barycentric coordinate this close to 0 puts a point on the facet opposite its vertex
ZERO = 1e-10
#: cell types this module refines
SIMPLICES = ("triangle", "tetrahedron")


def barycentric(vertices: npt.NDArray[np.float64], x: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Barycentric coordinates of points in simplices.

    Parameters
    ----------
    vertices : (n, d + 1, d)
        The vertices of n simplices.
    x : (n, k, d)
        k points per simplex.

    Returns
    -------
    (n, k, d + 1)
        λ with Σ λ = 1 and x = Σ λ_i v_i; λ_i is that of vertex i.
    """
    edges = np.swapaxes(vertices[:, 1:] - vertices[:, :1], 1, 2)                  # (n, d, d)
    xi = np.linalg.solve(edges[:, None], (x - vertices[:, :1])[..., None])[..., 0]  # (n, k, d)
    return np.concatenate([1.0 - xi.sum(axis=2, keepdims=True), xi], axis=2)


class CellRefinement(Refinement):
    """A refined simplex mesh and how it derives from the mesh it was cut from (made by
    :func:`refine_cells`): the attributes of :class:`~dolfinx_sfvem.mesh.polygon_mesh.Refinement`
    with cells for polygons (``coarse`` and ``mesh`` are :class:`CellMesh` es, the first
    ``coarse.n_points`` points of ``mesh`` those of ``coarse``; ``selected`` the cells marked, the
    closure splits some neighbours too)."""

    def describe(self) -> str:
        """One line: cells and points before and after."""
        split = int(np.count_nonzero(np.bincount(self.parent, minlength=self.coarse.n_cells) > 1))
        return (f"refined {int(self.selected.sum())} of {self.coarse.n_cells} {self.coarse.cell_type}s "
                f"{self.levels} time(s) ({split} split with the closure): {self.mesh.n_cells} cells, "
                f"{self.mesh.n_points} points")


def _canonical(coarse: CellMesh, points: np.ndarray, cells: np.ndarray, parent: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The refined mesh numbered independently of DOLFINx (module docstring): (points, cells, parent)."""
    _, inverse = np.unique(np.vstack([coarse.points, points]), axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    old_of_class = np.full(inverse.max() + 1, -1, dtype=np.int64)
    old_of_class[inverse[:coarse.n_points]] = np.arange(coarse.n_points)
    index = old_of_class[inverse[coarse.n_points:]]                               # (n_fine,) old index or -1
    new = np.flatnonzero(index < 0)
    new = new[np.lexsort(points[new].T[::-1])]
    index[new] = coarse.n_points + np.arange(new.size)
    out_points = np.vstack([coarse.points, points[new]])
    cells = index[cells]
    order = np.lexsort(np.vstack([np.sort(cells, axis=1).T[::-1], parent[None]]))
    return out_points, cells[order], parent[order]


def _named_facets(coarse: CellMesh, points: np.ndarray, cells: np.ndarray, parent: np.ndarray
                  ) -> dict[str, np.ndarray]:
    """The coarse mesh's ``boundary_names`` on the refined cells: every facet of a refined cell lying
    on a named facet of its parent."""
    if not coarse.boundary_names:
        return {}
    local = np.asarray(reference_facets(coarse.cell_type))                       # (d + 1, d)
    n_vertices = coarse.cells.shape[1]
    lam = barycentric(coarse.points[coarse.cells[parent]], points[cells])       # (n, d + 1, d + 1)
    facets = cells[:, local].reshape(-1, local.shape[1])                         # (n (d + 1), d), cell by cell
    on = (np.abs(lam[:, local].reshape(-1, local.shape[1], n_vertices)) <= ZERO).all(axis=1)
    row, k = np.nonzero(on)                 # facet ``row`` lies on its parent's facet opposite vertex k
    corners = coarse.cells[parent[row // local.shape[0]]]
    parent_facet = np.sort(corners[np.arange(n_vertices)[None] != k[:, None]].reshape(-1, n_vertices - 1), axis=1)
    out = {}
    for name, named in coarse.boundary_names.items():
        wanted = {tuple(f) for f in np.sort(named, axis=1).tolist()}
        hit = np.fromiter((tuple(f) in wanted for f in parent_facet.tolist()), dtype=bool, count=row.size)
        chosen = facets[row[hit]]
        _, first = np.unique(np.sort(chosen, axis=1), axis=0, return_index=True)
        out[name] = chosen[np.sort(first)]
    return out


def refine_cells(mesh: CellMesh, where: Selection = None, levels: int = 1, *,
                 tags: typing.Iterable[int | str] | None = None) -> CellRefinement:
    """Split the selected cells of a simplex mesh ``levels`` times (module docstring).

    Parameters
    ----------
    where
        A marker ``f(x) -> bool (n,)`` of the cell centroids ``x`` (d, n), a boolean mask
        (n_cells,) or cell indices (:func:`~dolfinx_sfvem.mesh.refine.select_polygons`).
    levels
        Number of splits (>= 1); level k + 1 splits the children of the cells selected at level k.
    tags
        Region tags or names (combined with ``where`` by "and").

    Returns
    -------
    CellRefinement

    Raises
    ------
    ValueError
        For hexahedra or quadrilaterals, ``levels`` out of range, a selection that
        :func:`~dolfinx_sfvem.mesh.refine.select_polygons` refuses.
    """
    if mesh.cell_type not in SIMPLICES:
        raise ValueError(f"refine: a mesh of {mesh.cell_type}s (Q2) cannot be refined locally: splitting some of "
                         "its cells leaves hanging nodes on their neighbours, which the conforming FEM does not "
                         "have; use tetrahedra (P2), or method='vem' on an octree mesh")
    if isinstance(levels, bool) or not isinstance(levels, (int, np.integer)) or levels < 1:
        raise ValueError(f"refine: levels must be an integer >= 1, got {levels!r}")
    chosen = select_polygons(mesh, where, tags, what="cell")
    current, ancestor, marked = mesh, np.arange(mesh.n_cells, dtype=np.int64), chosen
    for _ in range(int(levels)):
        points, cells, parent = _compat.plaza_refine(current.cells, current.points, current.cell_type,
                                                     np.flatnonzero(marked))
        points, cells, parent = _canonical(current, points, cells, parent)
        refined = CellMesh(points, cells, current.tags[parent], current.cell_type, current.region_names,
                           _named_facets(current, points, cells, parent))
        volume = np.bincount(parent, weights=refined.volumes, minlength=current.n_cells)
        if not np.allclose(volume, current.volumes, rtol=1e-10, atol=0.0):
            raise RuntimeError("refine: the refined cells do not fill their parents (DOLFINx's parent cells)")
        marked = marked[parent]
        current, ancestor = refined, ancestor[parent]
    return CellRefinement(mesh, current, ancestor, chosen, int(levels))


def refine_mesh(mesh: PolygonMesh | CellMesh, where: Selection = None, levels: int = 1, *,
                tags: typing.Iterable[int | str] | None = None, max_l: int = 6) -> Refinement | CellRefinement:
    """A problem's mesh refined locally: :meth:`PolygonMesh.refine
    <dolfinx_sfvem.mesh.polygon_mesh.PolygonMesh.refine>` (hanging nodes, closure by ``max_l``) or
    :func:`refine_cells` (tetrahedra; ``max_l`` unused)."""
    if isinstance(mesh, CellMesh):
        return refine_cells(mesh, where, levels, tags=tags)
    return mesh.refine(where, levels, tags=tags, max_l=max_l)
