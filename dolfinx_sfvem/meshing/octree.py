"""Octree meshes of a box: cubes refined where the user says, 2:1 balanced, read as polyhedra.

An :class:`OctreeMesh` is the set of leaves of a forest of octrees over an ``n[0] x n[1] x n[2]``
grid of base boxes: leaf ``c`` has the level ``level[c]`` (0 for a base box, +1 per split) and the
integer position ``ijk[c]`` on the grid of its level (``n * 2**level`` boxes per axis). Leaves are
never moved: a refinement returns a new mesh. Where a coarse leaf meets finer ones,
:meth:`OctreeMesh.polyhedra` makes it a polyhedron with the finer leaves' corners as hanging
vertices on its edges and its faces split into the finer neighbours' faces, so that every
geometric face is one face of two cells (no transition elements).

Leaves are found through their keys on the finest grid: the base box index times 8**L plus the
Morton code (bits of the three coordinates interleaved) of the leaf's lowest finest cell, with L
the finest level. In Morton order the leaves of a complete octree are contiguous ranges, so the
leaf containing a finest cell is the last leaf whose key is at most the cell's key (one
``searchsorted``).
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Literal, Union

import numpy as np
import numpy.typing as npt

from dolfinx_sfvem.mesh.polyhedron_mesh import PolyhedronMesh

Balance = Literal["faces", "edges", "vertices"]
#: a marker of leaf centres (3, n) -> bool (n,), a boolean mask over the leaves, or leaf indices
Where = Union[Callable[[np.ndarray], np.ndarray], npt.ArrayLike]

_STEPS = np.array([[i, j, k] for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1) if (i, j, k) != (0, 0, 0)])
#: neighbour directions of each balance: across faces (6), also edges (18), also vertices (26)
NEIGHBOURS = {kind: _STEPS[np.abs(_STEPS).sum(axis=1) <= most]
              for kind, most in (("faces", 1), ("edges", 2), ("vertices", 3))}
#: children of a leaf, offsets (8, 3) in tensor-product order (the first axis fastest)
_CHILDREN = np.array([[i, j, k] for k in (0, 1) for j in (0, 1) for i in (0, 1)], dtype=np.int64)


def _morton(x: npt.NDArray[np.int64], bits: int) -> npt.NDArray[np.int64]:
    """Morton codes (m,) of non-negative integer coordinates (m, 3) below 2**bits."""
    code = np.zeros(x.shape[0], dtype=np.int64)
    for b in range(bits):
        for d in range(3):
            code |= ((x[:, d] >> b) & 1) << (3 * b + d)
    return code


class OctreeMesh:
    """The leaves of an octree forest over the box [lower, upper] (module docstring).

    Parameters
    ----------
    lower, upper : (3,) float
        Corners of the box (upper > lower).
    n : (3,) int
        Base boxes per axis.
    level : (m,) int
        Level of every leaf.
    ijk : (m, 3) int
        Position of every leaf on the grid of its level.
    parent : (m,) int, optional
        The leaf of the mesh this one was refined from that contains each leaf (default: itself).

    The leaves must tile the box (not checked here: :func:`octree_box` and :meth:`refine` make
    them so).
    """

    def __init__(self, lower: npt.ArrayLike, upper: npt.ArrayLike, n: npt.ArrayLike, level: npt.ArrayLike,
                 ijk: npt.ArrayLike, parent: npt.ArrayLike | None = None) -> None:
        self.lower = np.asarray(lower, dtype=np.float64).reshape(3)
        self.upper = np.asarray(upper, dtype=np.float64).reshape(3)
        self.n = np.asarray(n, dtype=np.int64).reshape(3)
        self.level = np.asarray(level, dtype=np.int64).reshape(-1)
        self.ijk = np.asarray(ijk, dtype=np.int64).reshape(-1, 3)
        self.parent = np.arange(self.n_cells) if parent is None else np.asarray(parent, dtype=np.int64)
        self.finest = int(self.level.max())
        if self.finest > 20 or np.prod(self.n) * 8.0 ** self.finest > 2.0 ** 62:
            raise ValueError(f"octree: {self.finest} levels on a {self.n.tolist()} grid exceed the 62-bit leaf keys")
        order = np.argsort(self._keys(self.level, self.ijk))
        self._sorted_keys = self._keys(self.level, self.ijk)[order]
        self._order = order

    # ----------------------------------------------------------------------- geometry
    @property
    def n_cells(self) -> int:
        return int(self.level.size)

    @property
    def sizes(self) -> npt.NDArray[np.float64]:
        """Edge lengths (m, 3) of every leaf."""
        return (self.upper - self.lower) / (self.n * 2.0 ** self.level[:, None])

    @property
    def centres(self) -> npt.NDArray[np.float64]:
        """Centres (m, 3) of the leaves."""
        return self.lower + (self.ijk + 0.5) * self.sizes

    # ----------------------------------------------------------------------- lookup
    def _keys(self, level: npt.NDArray[np.int64], ijk: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
        """Keys of the lowest finest cells of boxes ``ijk`` (k, 3) of levels ``level`` (k,)."""
        shift = self.finest - level
        fine = ijk << shift[:, None]
        base = fine >> self.finest
        index = (base[:, 2] * self.n[1] + base[:, 1]) * self.n[0] + base[:, 0]
        return (index << (3 * self.finest)) + _morton(fine - (base << self.finest), self.finest)

    def covering(self, level: npt.ArrayLike, ijk: npt.ArrayLike) -> npt.NDArray[np.int64]:
        """The leaf containing each box ``ijk`` (k, 3) of level ``level`` (k,) if that leaf is the
        box or coarser, -1 if the box is split into finer leaves or lies outside the grid."""
        level = np.broadcast_to(np.asarray(level, dtype=np.int64), (len(ijk),))
        ijk = np.asarray(ijk, dtype=np.int64).reshape(-1, 3)
        inside = np.all((ijk >= 0) & (ijk < self.n << level[:, None]), axis=1) & (level <= self.finest)
        out = np.full(level.size, -1, dtype=np.int64)
        keys = self._keys(level[inside], ijk[inside])
        leaf = self._order[np.searchsorted(self._sorted_keys, keys, side="right") - 1]
        out[np.flatnonzero(inside)] = np.where(self.level[leaf] <= level[inside], leaf, -1)
        return out

    # ----------------------------------------------------------------------- refinement
    def _split(self, chosen: npt.NDArray[np.bool_]) -> tuple["OctreeMesh", npt.NDArray[np.bool_]]:
        """Every chosen leaf replaced by its 8 children in place: (mesh whose ``parent`` indexes
        this one, mask of the new leaves that are children)."""
        count = np.where(chosen, 8, 1)
        parent = np.repeat(np.arange(self.n_cells), count)
        child = np.repeat(chosen, count)
        which = np.arange(parent.size) - np.repeat(np.cumsum(count) - count, count)    # 0..7 within a split
        level = self.level[parent] + child
        ijk = np.where(child[:, None], 2 * self.ijk[parent] + _CHILDREN[which % 8], self.ijk[parent])
        return OctreeMesh(self.lower, self.upper, self.n, level, ijk, parent), child

    def unbalanced(self, balance: Balance = "edges") -> npt.NDArray[np.int64]:
        """Leaves (sorted) that touch a leaf more than one level finer across a face (``"faces"``),
        a face or an edge (``"edges"``), or also a vertex (``"vertices"``): for every leaf of level
        m >= 2, the leaves covering the neighbours of its parent box at level m - 1 that are
        coarser than m - 1."""
        fine = np.flatnonzero(self.level >= 2)
        steps = NEIGHBOURS[balance]
        boxes = ((self.ijk[fine] >> 1)[:, None, :] + steps[None]).reshape(-1, 3)
        level = np.repeat(self.level[fine] - 1, steps.shape[0])
        leaf = self.covering(level, boxes)
        return np.unique(leaf[(leaf >= 0) & (self.level[np.maximum(leaf, 0)] < level)])

    def refine(self, where: Where, levels: int = 1, *, balance: Balance | None = "edges") -> "OctreeMesh":
        """Split the selected leaves ``levels`` times into 8 (level k + 1 splits the children of
        level k), then their neighbours as needed for 2:1 balance.

        Parameters
        ----------
        where
            A marker ``f(x) -> bool (n,)`` of the leaf centres ``x`` (3, n) (as the markers of the
            loads), a boolean mask (n_cells,) or leaf indices.
        levels
            Number of splits (>= 1).
        balance
            The neighbours that differ by at most one level: across faces, faces and edges
            (default), or also vertices; None: no balancing.

        Returns
        -------
        OctreeMesh
            The refined mesh; its ``parent`` is the leaf of this mesh containing each new leaf.
        """
        if isinstance(levels, bool) or not isinstance(levels, (int, np.integer)) or levels < 1:
            raise ValueError(f"refine: levels must be an integer >= 1, got {levels!r}")
        if balance is not None and balance not in NEIGHBOURS:
            raise ValueError(f"refine: balance must be one of {sorted(NEIGHBOURS)} or None, got {balance!r}")
        chosen = self._selection(where)
        current, ancestor = self, np.arange(self.n_cells)
        for _ in range(int(levels)):
            current, chosen = current._split(chosen)
            ancestor = ancestor[current.parent]
            while balance is not None:
                split = np.zeros(current.n_cells, dtype=bool)
                split[current.unbalanced(balance)] = True
                if not split.any():
                    break
                current, _ = current._split(split)
                chosen = chosen[current.parent] & ~split[current.parent]
                ancestor = ancestor[current.parent]
        return OctreeMesh(self.lower, self.upper, self.n, current.level, current.ijk, ancestor)

    def refine_to(self, size: Callable[[np.ndarray, np.ndarray], np.ndarray], *,
                  balance: Balance | None = "edges") -> "OctreeMesh":
        """Split leaves (and their neighbours for 2:1 balance, as :meth:`refine`) until no leaf is
        larger than the size asked for its box.

        Parameters
        ----------
        size
            ``size(lower, upper) -> (n,)``: the largest edge length wanted in each of the boxes with
            corners ``lower``, ``upper`` (3, n) (e.g. small where the box comes near a point).
        balance
            As for :meth:`refine`.

        Returns
        -------
        OctreeMesh
            The refined mesh (itself if no leaf is too large); ``parent`` as for :meth:`refine`.
            A leaf is split while its longest edge exceeds the size by more than 1e-9 relative, so
            the leaves end at the largest size ``(upper - lower) / (n 2**k)`` within the size.
        """
        current, ancestor = self, np.arange(self.n_cells)
        while True:
            lower = current.centres - 0.5 * current.sizes
            wanted = np.asarray(size(lower.T.copy(), (lower + current.sizes).T.copy()), dtype=np.float64)
            if wanted.shape != (current.n_cells,) or not np.all(wanted > 0.0):
                raise ValueError(f"refine_to: size must return {current.n_cells} positive sizes, got shape "
                                 f"{wanted.shape}")
            split = current.sizes.max(axis=1) > wanted * (1.0 + 1e-9)
            if not split.any():
                return current if current is self else OctreeMesh(self.lower, self.upper, self.n, current.level,
                                                                  current.ijk, ancestor)
            current = current.refine(split, 1, balance=balance)
            ancestor = ancestor[current.parent]

    def _selection(self, where: Where) -> npt.NDArray[np.bool_]:
        """Mask (n_cells,) of the leaves chosen by a marker, a mask or indices; ValueError if empty."""
        if callable(where):
            chosen = np.asarray(where(self.centres.T.copy()))
            if chosen.shape != (self.n_cells,):
                raise ValueError(f"refine: the marker must return a bool array of shape ({self.n_cells},) "
                                 f"(one entry per leaf centre), got shape {chosen.shape}")
            chosen = chosen.astype(bool)
        else:
            given = np.asarray(where)
            if given.dtype == bool:
                if given.shape != (self.n_cells,):
                    raise ValueError(f"refine: a leaf mask must have shape ({self.n_cells},), got {given.shape}")
                chosen = given.copy()
            elif given.dtype.kind in "iu" and given.ndim <= 1:
                given = given.reshape(-1)
                if np.any((given < 0) | (given >= self.n_cells)):
                    raise ValueError(f"refine: leaf indices must lie in [0, {self.n_cells})")
                chosen = np.zeros(self.n_cells, dtype=bool)
                chosen[given] = True
            else:
                raise ValueError("refine: 'where' must be a centre marker, a boolean mask or leaf indices")
        if not chosen.any():
            raise ValueError("refine: the selection is empty (no leaf chosen)")
        return chosen

    # ----------------------------------------------------------------------- polyhedra
    def polyhedra(self, tag_of: Callable[[np.ndarray], np.ndarray] | None = None,
                  region_names: Mapping[str, int] | None = None) -> PolyhedronMesh:
        """The leaves as a conforming :class:`~dolfinx_sfvem.mesh.polyhedron_mesh.PolyhedronMesh`.

        Cell ``c`` is leaf ``c``. Its faces are, on each of its six sides, its own square where the
        leaf across is as coarse or coarser (or the box's boundary), else the squares of the finer
        leaves across (a coarse side split into their faces); every face lists, in cyclic order,
        its corners and the corners of other leaves lying on its edges (hanging vertices: with
        2:1 balance across edges at most the edges' midpoints). Faces are stored once; a face
        between two leaves of the same level points out of the lower index. The cells' faces are
        ordered by side (-x, +x, -y, +y, -z, +z).

        Parameters
        ----------
        tag_of
            Region tag ``f(x) -> int (n,)`` of the leaf centres ``x`` (3, n); default 0.
        region_names
            Names of region tags.
        """
        a, b, axis, direction, corners = self._squares()
        L = self.finest
        size = 1 << (L - self.level)
        anchor = self.ijk << (L - self.level)[:, None]
        extent = (self.n << L) + 1                                 # grid points per axis on the finest grid
        all_corners = (anchor[:, None, :] + _CHILDREN[None] * size[:, None, None]).reshape(-1, 3)
        point_keys = np.unique(_point_key(all_corners, extent))     # every leaf corner, numbered in key order
        face_offsets, face_vertices = _face_vertex_lists(corners, point_keys, extent)
        # the cells' faces: (a, +1) and (b, -1), ordered by cell and side
        face = np.concatenate([np.arange(a.size), np.flatnonzero(b >= 0)])
        cell = np.concatenate([a, b[b >= 0]])
        sign = np.concatenate([np.ones(a.size, np.int64), -np.ones((b >= 0).sum(), np.int64)])
        side = 2 * axis[face] + (direction[face] * sign > 0)
        order = np.lexsort((face, side, cell))
        cell_offsets = np.concatenate([[0], np.cumsum(np.bincount(cell, minlength=self.n_cells))])
        fine = np.stack([point_keys // (extent[1] * extent[2]), point_keys // extent[2] % extent[1],
                         point_keys % extent[2]], axis=1)
        points = self.lower + (self.upper - self.lower) * fine / (self.n << L)
        tags = None if tag_of is None else np.asarray(tag_of(self.centres.T.copy()), dtype=np.int64)
        return PolyhedronMesh(points, face_offsets, face_vertices, cell_offsets, face[order], sign[order], tags,
                              region_names)

    def _squares(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The faces of the polyhedra as squares: a leaf side across which the leaf is as coarse or
        coarser, or the boundary (a side between two leaves of one level taken from the lower
        index). Returns the leaf a it points out of (k,), the leaf b across or -1 (k,), its axis
        (k,) and direction +-1 (k,), its corners on the finest grid (k, 4, 3), counter-clockwise
        about the outward normal of a."""
        sides = np.array([[d, s] for d in range(3) for s in (-1, 1)])               # (6, 2): axis, direction
        a = np.repeat(np.arange(self.n_cells), 6)
        axis, direction = np.tile(sides[:, 0], self.n_cells), np.tile(sides[:, 1], self.n_cells)
        across = self.ijk[a] + direction[:, None] * np.eye(3, dtype=np.int64)[axis]
        outside = np.any((across < 0) | (across >= self.n << self.level[a][:, None]), axis=1)
        b = self.covering(self.level[a], across)
        keep = outside | ((b >= 0) & ((self.level[np.maximum(b, 0)] < self.level[a]) | (b > a)))
        a, axis, direction, b = a[keep], axis[keep], direction[keep], np.where(outside[keep], -1, b[keep])
        s = 1 << (self.finest - self.level[a])
        anchor = self.ijk[a] << (self.finest - self.level[a])[:, None]
        plane = anchor[np.arange(a.size), axis] + np.where(direction > 0, s, 0)
        uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]])
        uv = np.where((direction > 0)[:, None, None], uv, uv[::-1])                  # (k, 4, 2)
        corners = np.empty((a.size, 4, 3), dtype=np.int64)
        for d in range(3):
            on = axis == d
            e1, e2 = (d + 1) % 3, (d + 2) % 3
            corners[on, :, d] = plane[on, None]
            corners[on, :, e1] = anchor[on, e1][:, None] + uv[on, :, 0] * s[on, None]
            corners[on, :, e2] = anchor[on, e2][:, None] + uv[on, :, 1] * s[on, None]
        return a, b, axis, direction, corners


def _point_key(x: np.ndarray, extent: np.ndarray) -> np.ndarray:
    """Key of the finest-grid points ``x`` (..., 3) on a grid of ``extent`` (3,) points per axis."""
    return (x[..., 0] * extent[1] + x[..., 1]) * extent[2] + x[..., 2]


def _face_vertex_lists(corners: np.ndarray, point_keys: np.ndarray, extent: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:
    """CSR (offsets (k + 1,), vertices) of the squares ``corners`` (k, 4, 3) with every point of
    ``point_keys`` (sorted keys; a vertex's index is its position there) that lies inside a side
    inserted in order along it: the midpoint of a side if it is a point, then recursively the
    midpoints of its halves (a leaf corner inside a side implies one at its midpoint)."""
    start, end = corners.reshape(-1, 3), np.roll(corners, -1, axis=1).reshape(-1, 3)
    length = np.abs(end - start).sum(axis=1)
    along = lambda side, t: start[side] + (end[side] - start[side]) // length[side, None] * t[:, None]  # noqa: E731
    side, t0, t1 = np.arange(start.shape[0]), np.zeros(start.shape[0], np.int64), length
    entry_side, entry_t = [side], [t0]                             # every side's start corner at t = 0
    while side.size:
        even = (t1 - t0) % 2 == 0
        side, t0, t1 = side[even], t0[even], t1[even]
        tm = (t0 + t1) // 2
        key = _point_key(along(side, tm), extent)
        hit = point_keys[np.minimum(np.searchsorted(point_keys, key), point_keys.size - 1)] == key
        entry_side.append(side[hit])
        entry_t.append(tm[hit])
        side, t0, t1 = (np.concatenate([side[hit]] * 2), np.concatenate([t0[hit], tm[hit]]),
                        np.concatenate([tm[hit], t1[hit]]))
    side, t = np.concatenate(entry_side), np.concatenate(entry_t)
    order = np.lexsort((t, side))
    vertices = np.searchsorted(point_keys, _point_key(along(side[order], t[order]), extent))
    offsets = np.concatenate([[0], np.cumsum(np.bincount(side // 4, minlength=corners.shape[0]))])
    return offsets, vertices


def octree_box(lower: npt.ArrayLike, upper: npt.ArrayLike, n: int | npt.ArrayLike) -> OctreeMesh:
    """An octree mesh of the box [lower, upper] with ``n`` (an int or one per axis) base boxes per
    axis, all of level 0; refine it with :meth:`OctreeMesh.refine`, and read it as polyhedra
    with the method :meth:`OctreeMesh.polyhedra`."""
    lower, upper = np.asarray(lower, dtype=np.float64), np.asarray(upper, dtype=np.float64)
    n = np.broadcast_to(np.asarray(n, dtype=np.int64), (3,))
    if lower.shape != (3,) or upper.shape != (3,) or np.any(upper <= lower):
        raise ValueError(f"octree_box: lower and upper must be 3 coordinates with upper > lower, got {lower}, {upper}")
    if np.any(n < 1):
        raise ValueError(f"octree_box: n must be >= 1 per axis, got {n.tolist()}")
    grid = np.stack(np.meshgrid(*(np.arange(k) for k in n), indexing="ij"), axis=-1).reshape(-1, 3)
    grid = grid[np.lexsort((grid[:, 0], grid[:, 1], grid[:, 2]))]          # x fastest
    return OctreeMesh(lower, upper, n, np.zeros(grid.shape[0], np.int64), grid)
