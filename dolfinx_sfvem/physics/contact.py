"""Signed gaps between the deformed solids: the penetration measure of a contact run.

A third-medium run can converge to a state in which the solids overlap (the medium between
them dragged out sideways) while J > 0 at every quadrature point, so every converged state
is checked here, from the region tags alone:

- *Solids* are the regions whose energy is not a third medium (:attr:`Energy.is_medium`);
  *bodies* are the connected pieces of the solids (polygons sharing an edge), so one region
  may hold several bodies (the seven discs of the multi-object example) and one body may
  touch itself (the C-box, the box).
- The *boundary* of the solids is every solid edge not shared with another solid polygon,
  oriented with the solid on its left, each edge followed through its midpoint node (two
  straight pieces through the degree-2 trace's three nodes).
- Every boundary node p gets a signed gap g(p) in the deformed configuration: if p lies
  inside a body (winding number of that body's deformed boundary; for p's own body, more
  than the part p sits on), g(p) = -(distance to the nearest boundary piece of that body that
  is not p's neighbourhood); otherwise g(p) = +(distance to the nearest boundary piece of
  another body, or of a surface of p's own body *facing* p: reference normals more than 120°
  apart, each in front of the other).
- The run's gap is min_p g(p), with where it occurs. Solids *overlap* when some node lies
  deeper inside than ``tolerance`` times the length of its boundary edge (a fraction of the
  local mesh size).

The bookkeeping is made once per mesh (:class:`SolidBoundary`); the per-state evaluation
gathers the boundary nodes' displacements on rank 0 (a few thousand values) and runs a
compiled loop over node-piece pairs.
"""
from __future__ import annotations

import abc
import dataclasses
import math
import typing
from dataclasses import dataclass

import numba
import numpy as np
import scipy.sparse
import scipy.sparse.csgraph
from mpi4py import MPI

from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh

#: default overlap tolerance, as a fraction of the length of the boundary edge at the node
OVERLAP_TOLERANCE = 0.02
#: the contact zone of a pair: pressure above this fraction of the pair's largest
ZONE_THRESHOLD = 0.01
#: two surfaces of one body face each other when their reference normals are more than 120° apart
FACING_COSINE = -0.5


@dataclass
class Gap:
    """The smallest signed gap between the deformed solids at one state.

    Attributes
    ----------
    value : float
        min_p g(p) (length unit of the mesh); negative: overlap; ``inf`` when no boundary node
        has a partner (one body without facing surfaces).
    x, X : (2,) or (3,) float
        Deformed and reference position of the node (3D: or the point sampled on a crossing
        face) where it occurs.
    region, partner_region : int
        Region tag of that node and of the boundary piece it is measured to (-1 if none).
    body, partner_body : int
        Their bodies (connected pieces of the solids).
    overlap : float
        Largest depth / (tolerance x local edge length) over all nodes inside a body; > 1
        means the solids overlap beyond the tolerance.
    """
    value: float
    x: tuple[float, float]
    X: tuple[float, float]
    region: int
    partner_region: int
    body: int
    partner_body: int
    overlap: float

    @property
    def overlapping(self) -> bool:
        return self.overlap > 1.0

    def describe(self) -> str:
        """One sentence naming the regions and the place."""
        x, X = (", ".join(f"{c:.4g}" for c in v) for v in (self.x, self.X))
        where = f"node at ({x}), reference ({X}), of region {self.region} (body {self.body})"
        partner = f"region {self.partner_region} (body {self.partner_body})"
        if self.value < 0.0:
            return f"{where} lies {-self.value:.3e} inside {partner}"
        return f"{where} is {self.value:.3e} from {partner}"

    def as_dict(self) -> dict:
        """JSON-ready record (``value`` None when infinite)."""
        return {"value": self.value if math.isfinite(self.value) else None, "x": list(self.x), "X": list(self.X),
                "region": self.region, "partner_region": self.partner_region, "body": self.body,
                "partner_body": self.partner_body, "overlap": self.overlap}


@dataclass
class ContactPair:
    """The contact of body ``body`` with body ``partner_body`` across the medium, seen from ``body``.

    Attributes
    ----------
    force : (2,) or (3,) float
        Total force of the medium (its whole energy, regularization included) on ``body``'s
        surface facing the partner (force per unit thickness, the units of the reactions).
    max_pressure : float
        Largest normal pressure there (:attr:`ContactPressure.pressure`; force per unit length).
    zone_length : float
        Deformed length of the contact zone (pressure above the threshold fraction of the largest);
        in 3D its deformed area.
    gap : float
        Smallest signed gap of ``body``'s nodes facing the partner.
    """
    body: int
    partner_body: int
    region: int
    partner_region: int
    force: tuple[float, float]
    max_pressure: float
    zone_length: float
    gap: float

    def as_dict(self) -> dict:
        return {**dataclasses.asdict(self), "force": list(self.force),
                "gap": self.gap if math.isfinite(self.gap) else None}


@dataclass
class ContactPressure:
    """Normal contact pressure at every boundary node of the solids, and the contacts per pair.

    Attributes
    ----------
    X, x : (n, 2) or (n, 3)
        Reference and deformed positions of the boundary nodes.
    pressure : (n,)
        Normal pressure of the medium's material response on the solid (compressive positive;
        its regularization left out, docs/contact.md "Pressure recovery"), 0 at nodes on no
        medium-facing edge.
    force : (n, 2) or (n, 3)
        The medium's force on the solid at the node, -∂W_medium/∂ũ of its whole energy (the
        consistent nodal force of its traction: the pairs' forces are its sums), 0 off the medium.
    body, partner_body : (n,) int
        The node's body and the body across the medium it faces (-1: none).
    zone : (n,) bool
        In the contact zone: pressure above :data:`ZONE_THRESHOLD` times its pair's largest.
    surface : (n,) int
        The facing surface the node lies on, numbered from 0: a stretch of boundary joined
        through pieces whose two nodes face the same body (the two beams of the C-box are two
        surfaces of one pair); -1: none.
    pairs : list of ContactPair
    """
    X: np.ndarray
    x: np.ndarray
    pressure: np.ndarray
    force: np.ndarray
    body: np.ndarray
    partner_body: np.ndarray
    zone: np.ndarray
    surface: np.ndarray
    pairs: list[ContactPair]


class BoundaryNodes(abc.ABC):
    """Boundary nodes named by discretization keys, with the gap at their displacements: what the
    2D :class:`SolidBoundary` and the 3D
    :class:`~dolfinx_sfvem.physics.solid_surface.SolidSurface` share.

    Attributes
    ----------
    node_keys : (n_nodes,) int64
        Sorted discretization keys of the boundary nodes.
    tolerance : float
        Overlap tolerance as a fraction of the local mesh size.
    """

    node_keys: np.ndarray
    tolerance: float

    @abc.abstractmethod
    def gap(self, u: np.ndarray) -> Gap:
        """The smallest signed gap at displacements ``u`` (n_nodes, d) of the boundary nodes (in
        the order of :attr:`node_keys`)."""

    def gather(self, comm: MPI.Comm, keys: np.ndarray, values: np.ndarray) -> np.ndarray | None:
        """The boundary nodes' rows of each rank's owned nodal ``values`` (k, d) with node ``keys``
        (k,) (``get_state`` of a discretization), in :attr:`node_keys` order on rank 0 (None
        elsewhere; collective)."""
        mine = np.isin(keys, self.node_keys)
        pieces = comm.gather((keys[mine], values[mine]), root=0)
        if comm.rank != 0:
            return None
        k = np.concatenate([piece[0] for piece in pieces])
        v = np.concatenate([piece[1] for piece in pieces])
        _, first = np.unique(k, return_index=True)
        if not np.array_equal(k[first], self.node_keys):
            raise RuntimeError("boundary nodes missing from the state")
        return v[first]

    def gap_of_state(self, comm: MPI.Comm, keys: np.ndarray, values: np.ndarray) -> Gap:
        """:meth:`gap` from each rank's owned nodal values (``get_state`` of a discretization;
        collective, the result on every rank)."""
        u = self.gather(comm, keys, values)
        return comm.bcast(self.gap(u) if comm.rank == 0 else None, root=0)


class SolidBoundary(BoundaryNodes):
    """The boundary of the solid bodies of a mesh, as pieces between degree-2 nodes.

    Parameters
    ----------
    mesh
        The mesh whose nodes carry the displacement (the polygon mesh for the SFVEM, the
        FEM's cells for the FEM), identical on every rank.
    solid_tags
        Region tags of the solids (the others are third medium).
    midpoint_keys
        ``midpoint_keys(a, b)`` -> keys (n,) of the nodes at the midpoints of the edges
        between mesh points ``a`` and ``b`` (n,), in the discretization's node numbering
        (``get_state``); the key of a vertex node is its point index.
    tolerance
        Overlap tolerance as a fraction of the local boundary edge length.

    Attributes
    ----------
    node_keys : (n_nodes,) int64
        Discretization keys of the boundary nodes (vertices, then edge midpoints), sorted
        by :attr:`order`.
    X : (n_nodes, 2)
        Their reference positions.
    n_bodies : int
    """

    def __init__(self, mesh: PolygonMesh, solid_tags: typing.Collection[int],
                 midpoint_keys: typing.Callable[[np.ndarray, np.ndarray], np.ndarray],
                 tolerance: float = OVERLAP_TOLERANCE):
        if not (np.isfinite(tolerance) and tolerance > 0.0):
            raise ValueError(f"overlap tolerance must be a positive fraction of the mesh size, not {tolerance!r}")
        self.tolerance = float(tolerance)
        solid = np.isin(mesh.tags, list(solid_tags))
        sides = mesh.sides
        in_solid = solid[sides.polygon]
        a, b, polygon, across = (x[in_solid] for x in (sides.start, sides.end, sides.polygon, sides.neighbour))
        # bodies: solid polygons joined through shared edges
        shared = (across >= 0) & solid[across]
        graph = scipy.sparse.coo_matrix((np.ones(int(shared.sum())), (polygon[shared], across[shared])),
                                        shape=(mesh.n_polygons, mesh.n_polygons))
        _, component = scipy.sparse.csgraph.connected_components(graph, directed=False)
        solid_polygons = np.flatnonzero(solid)
        _, body_of = np.unique(component[solid_polygons], return_inverse=True)
        body = np.full(mesh.n_polygons, -1, dtype=np.int64)
        body[solid_polygons] = body_of
        self.n_bodies = int(body_of.max(initial=-1)) + 1

        boundary = ~shared
        a, b, polygon = a[boundary], b[boundary], polygon[boundary]
        faces_medium = across[boundary] >= 0
        vertices = np.unique(np.concatenate([a, b]))
        n_v, n_e = vertices.size, a.size
        ia, ib = np.searchsorted(vertices, a), np.searchsorted(vertices, b)
        im = n_v + np.arange(n_e)
        self.X = np.concatenate([mesh.points[vertices], 0.5 * (mesh.points[a] + mesh.points[b])])
        keys = np.concatenate([vertices, np.asarray(midpoint_keys(a, b), dtype=np.int64)])
        self.order = np.argsort(keys)
        self.node_keys = keys[self.order]
        # pieces [a, m], [m, b] of every boundary edge, solid on the left
        self.n_vertices = n_v
        self.pieces = np.stack([np.concatenate([ia, im]), np.concatenate([im, ib])], axis=1).astype(np.int64)
        self.piece_edge = np.tile(np.arange(n_e), 2)
        self.edge_nodes = np.stack([ia, im, ib], axis=1).astype(np.int64)
        self.edge_faces_medium = faces_medium
        self.piece_body = np.tile(body[polygon], 2)
        self.piece_tag = np.tile(mesh.tags[polygon], 2).astype(np.int64)
        d = self.X[self.pieces[:, 1]] - self.X[self.pieces[:, 0]]
        self.piece_normal = np.stack([d[:, 1], -d[:, 0]], axis=1) / np.linalg.norm(d, axis=1)[:, None]
        self.piece_middle = 0.5 * (self.X[self.pieces[:, 0]] + self.X[self.pieces[:, 1]])
        # per node: body, tag, normal (sum of its pieces'), length of its longest boundary edge
        n_nodes = n_v + n_e
        self.node_body = np.zeros(n_nodes, dtype=np.int64)
        self.node_tag = np.zeros(n_nodes, dtype=np.int64)
        normal = np.zeros((n_nodes, 2))
        self.node_h = np.zeros(n_nodes)
        edge_length = np.tile(np.linalg.norm(mesh.points[b] - mesh.points[a], axis=1), 2)
        for end in (0, 1):
            nodes = self.pieces[:, end]
            self.node_body[nodes] = self.piece_body
            self.node_tag[nodes] = self.piece_tag
            np.add.at(normal, nodes, self.piece_normal)
            np.maximum.at(self.node_h, nodes, edge_length)
        self.node_normal = normal / np.maximum(np.linalg.norm(normal, axis=1), 1e-300)[:, None]
        by_body = np.argsort(self.piece_body, kind="stable")
        self.pieces, self.piece_body, self.piece_tag = self.pieces[by_body], self.piece_body[by_body], self.piece_tag[by_body]
        self.piece_normal, self.piece_middle = self.piece_normal[by_body], self.piece_middle[by_body]
        self.piece_edge = self.piece_edge[by_body]
        self.body_offsets = np.searchsorted(self.piece_body, np.arange(self.n_bodies + 1)).astype(np.int64)

    @property
    def n_nodes(self) -> int:
        return self.X.shape[0]

    def _deformed(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Deformed node positions for displacements ``u`` (in :attr:`node_keys` order) and the
        signed gaps, partner pieces and depths of :func:`_signed_gaps`."""
        x = self.X + self._in_node_order(u)
        g, partner, depth = _signed_gaps(x, self.X, self.pieces, self.body_offsets, self.node_body, self.node_normal,
                                         self.piece_normal, self.piece_middle, self.node_h, FACING_COSINE)
        return x, g, partner, depth

    def _in_node_order(self, values: np.ndarray) -> np.ndarray:
        out = np.empty_like(self.X)
        out[self.order] = values
        return out

    def gap(self, u: np.ndarray) -> Gap:
        """The smallest signed gap at displacements ``u`` (n_nodes, 2) of the boundary nodes
        (in the order of :attr:`node_keys`)."""
        return self._gap(*self._deformed(u))

    def gap_and_pressure(self, u: np.ndarray, f: np.ndarray, f_material: np.ndarray) -> tuple[Gap, ContactPressure]:
        """:meth:`gap` and the contact pressure from one evaluation of the deformed boundary.

        Parameters
        ----------
        u, f, f_material : (n_nodes, 2)
            Displacements, the third medium's internal nodal forces ∂W_medium/∂ũ at the boundary
            nodes (its whole energy: the pairs' forces) and those of its material response alone,
            the regularization left out (the pressure), in :attr:`node_keys` order.
        """
        deformed = self._deformed(u)
        return self._gap(*deformed), self._pressure(*deformed[:3], self._in_node_order(f),
                                                    self._in_node_order(f_material))

    def _gap(self, x: np.ndarray, g: np.ndarray, partner: np.ndarray, depth: np.ndarray) -> Gap:
        overlap = float((depth / (self.tolerance * self.node_h)).max(initial=0.0))
        return smallest_gap(self, x, g, partner, overlap)

    def _pressure(self, x: np.ndarray, g: np.ndarray, partner: np.ndarray, f: np.ndarray,
                  f_material: np.ndarray) -> ContactPressure:
        """Normal pressure per node and the contact per pair of bodies (docs/contact.md, "Pressure
        recovery"). Per edge facing the medium, the mean normal traction of the medium's material
        response: the resultant of ``f_material`` on its midpoint and on its two vertices, a
        vertex's force shared between its medium-facing edges in proportion to their deformed
        lengths (so that the resultant is exact for a traction linear along the boundary, whatever
        the edge lengths), over the edge's deformed length, normal to its chord; at a midpoint its
        edge's value, at a vertex the length-weighted mean of its edges'. A pair's force sums the
        whole medium force ``f`` (regularization included: what the reactions balance)."""
        a, m, b = self.edge_nodes.T
        facing = self.edge_faces_medium
        length = np.where(facing, np.linalg.norm(x[m] - x[a], axis=1) + np.linalg.norm(x[b] - x[m], axis=1), 0.0)
        ends = np.concatenate([a, b])
        length_at = np.bincount(ends, np.tile(length, 2), self.n_nodes)      # medium-facing length at a vertex
        resultant = f_material[m].copy()
        for v in (a, b):
            resultant += np.divide(length, length_at[v], out=np.zeros_like(length), where=facing)[:, None] * f_material[v]
        chord = x[b] - x[a]
        # the force on the solid is -f: compressive pressure f·n / length, n the chord's outward unit normal
        p_edge = np.divide(resultant[:, 0] * chord[:, 1] - resultant[:, 1] * chord[:, 0],
                           np.linalg.norm(chord, axis=1) * length, out=np.zeros_like(length), where=facing)
        p = np.divide(np.bincount(ends, np.tile(length * p_edge, 2), self.n_nodes), length_at,
                      out=np.zeros(self.n_nodes), where=length_at > 0.0)
        p[m[facing]] = p_edge[facing]
        piece_length = np.linalg.norm(x[self.pieces[:, 1]] - x[self.pieces[:, 0]], axis=1)
        return contact_pressure(self, x, g, partner, p, f, piece_length)


class _Pieces(typing.Protocol):
    """What :func:`smallest_gap` and :func:`contact_pressure` read of a :class:`SolidBoundary` (pieces:
    straight segments) or a :class:`~dolfinx_sfvem.physics.solid_surface.SolidSurface` (flat sub-triangles)."""
    X: np.ndarray
    n_bodies: int
    node_body: np.ndarray
    node_tag: np.ndarray
    pieces: np.ndarray
    piece_body: np.ndarray
    piece_tag: np.ndarray


def smallest_gap(boundary: _Pieces, x: np.ndarray, g: np.ndarray, partner: np.ndarray, overlap: float) -> Gap:
    """The :class:`Gap` of the smallest ``g`` (n_nodes,) of the nodes, at deformed positions ``x``,
    measured to the pieces ``partner`` (n_nodes,)."""
    if not np.isfinite(g).any():
        nowhere = (math.nan,) * x.shape[1]
        return Gap(math.inf, nowhere, nowhere, -1, -1, -1, -1, overlap)
    p = int(np.argmin(g))
    s = int(partner[p])
    return Gap(float(g[p]), tuple(map(float, x[p])), tuple(map(float, boundary.X[p])), int(boundary.node_tag[p]),
               int(boundary.piece_tag[s]), int(boundary.node_body[p]), int(boundary.piece_body[s]), overlap)


def contact_pressure(boundary: _Pieces, x: np.ndarray, g: np.ndarray, partner: np.ndarray, p: np.ndarray,
                     f: np.ndarray, piece_size: np.ndarray) -> ContactPressure:
    """The :class:`ContactPressure` of the nodal pressure ``p`` (n_nodes,): the pairs of bodies (each
    node's partner: the body of its piece ``partner``), each with the whole medium force ``f``
    (n_nodes, dim) on its nodes, its largest pressure, the deformed size (``piece_size`` (m,): lengths
    or areas) of its zone and its smallest gap ``g``; and the facing surfaces."""
    n_nodes = boundary.X.shape[0]
    force = -f                                                             # the medium's force on the solids
    partner_body = np.where(partner >= 0, boundary.piece_body[np.maximum(partner, 0)], -1)
    pairs, zone = [], np.zeros(n_nodes, dtype=bool)
    for body, other in sorted({(int(i), int(j)) for i, j in zip(boundary.node_body, partner_body) if j >= 0}):
        on = (boundary.node_body == body) & (partner_body == other)
        p_max = float(p[on].max(initial=0.0))
        mine = on & (p > ZONE_THRESHOLD * p_max) & (p_max > 0.0)
        zone |= mine
        in_zone = mine[boundary.pieces].all(axis=1)
        region = int(boundary.node_tag[np.argmax(on)])
        pairs.append(ContactPair(body, other, region, int(boundary.piece_tag[np.argmax(boundary.piece_body == other)]),
                                 tuple(map(float, force[on].sum(axis=0))), p_max, float(piece_size[in_zone].sum()),
                                 float(g[on].min(initial=math.inf))))
    return ContactPressure(boundary.X, x, p, force, boundary.node_body, partner_body, zone,
                           _surfaces(boundary, partner_body), pairs)


def _surfaces(boundary: _Pieces, partner_body: np.ndarray) -> np.ndarray:
    """:attr:`ContactPressure.surface` of every node, from the body each node faces (n,) (-1: none):
    nodes joined through the sides of pieces whose two nodes face the same body."""
    n_nodes = boundary.X.shape[0]
    pair = np.where(partner_body >= 0, boundary.node_body * (boundary.n_bodies + 1) + partner_body, -1)
    i, j = boundary.pieces.ravel(), np.roll(boundary.pieces, -1, axis=1).ravel()
    joined = (pair[i] == pair[j]) & (pair[i] >= 0)
    graph = scipy.sparse.coo_matrix((np.ones(int(joined.sum())), (i[joined], j[joined])), shape=(n_nodes,) * 2)
    _, label = scipy.sparse.csgraph.connected_components(graph, directed=False)
    surface = np.full(n_nodes, -1, dtype=np.int64)
    facing = pair >= 0
    surface[facing] = np.unique(label[facing], return_inverse=True)[1].reshape(-1)
    return surface


@numba.njit(cache=True)
def _distance_to_piece(p, a, b):
    dx, dy = b[0] - a[0], b[1] - a[1]
    L2 = dx * dx + dy * dy
    t = 0.0 if L2 == 0.0 else min(1.0, max(0.0, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / L2))
    ex, ey = p[0] - a[0] - t * dx, p[1] - a[1] - t * dy
    return math.sqrt(ex * ex + ey * ey)


@numba.njit(cache=True)
def _signed_gaps(x, X, pieces, body_offsets, node_body, node_normal, piece_normal, piece_middle, node_h, facing):
    """g(p), the piece it is measured to, and the depth of p inside a body (0 outside), for
    every boundary node (module docstring).

    x, X : (n, 2) deformed and reference node positions; pieces (m, 2) node pairs grouped by
    body (``body_offsets``); node_body (n,); node_normal (n, 2) and piece_normal (m, 2),
    piece_middle (m, 2) reference normals and midpoints; node_h (n,) local edge lengths.
    """
    n, n_bodies = x.shape[0], body_offsets.size - 1
    g = np.full(n, np.inf)
    partner = np.full(n, -1, dtype=np.int64)
    depth = np.zeros(n)
    lo = np.full((n_bodies, 2), np.inf)
    hi = np.full((n_bodies, 2), -np.inf)
    for B in range(n_bodies):
        for s in range(body_offsets[B], body_offsets[B + 1]):
            for k in range(2):
                for c in range(2):
                    lo[B, c] = min(lo[B, c], x[pieces[s, k], c])
                    hi[B, c] = max(hi[B, c], x[pieces[s, k], c])
    for p in range(n):
        own = node_body[p]
        inside = -1
        for B in range(n_bodies):
            if B != own and not (lo[B, 0] <= x[p, 0] <= hi[B, 0] and lo[B, 1] <= x[p, 1] <= hi[B, 1]):
                continue
            total = 0.0
            for s in range(body_offsets[B], body_offsets[B + 1]):
                i, j = pieces[s, 0], pieces[s, 1]
                if i == p or j == p:
                    continue
                ax, ay = x[i, 0] - x[p, 0], x[i, 1] - x[p, 1]
                bx, by = x[j, 0] - x[p, 0], x[j, 1] - x[p, 1]
                total += math.atan2(ax * by - ay * bx, ax * bx + ay * by)
            turns = total / (2.0 * math.pi)
            # own body: the pieces beyond p's two sweep its interior angle in (0, 1) turns
            k = math.floor(turns + 1e-9) if B == own else math.floor(turns + 0.5)
            if k >= 1:
                inside = B
                break
        for B in range(n_bodies):
            if inside >= 0 and B != inside:
                continue
            for s in range(body_offsets[B], body_offsets[B + 1]):
                i, j = pieces[s, 0], pieces[s, 1]
                if i == p or j == p:
                    continue
                if B == own and inside >= 0:        # not p's neighbourhood
                    dx, dy = piece_middle[s, 0] - X[p, 0], piece_middle[s, 1] - X[p, 1]
                    if dx * dx + dy * dy <= 4.0 * node_h[p] * node_h[p]:
                        continue
                elif B == own:                      # a surface of p's own body facing p
                    if node_normal[p, 0] * piece_normal[s, 0] + node_normal[p, 1] * piece_normal[s, 1] > facing:
                        continue
                    dx, dy = piece_middle[s, 0] - X[p, 0], piece_middle[s, 1] - X[p, 1]
                    if dx * node_normal[p, 0] + dy * node_normal[p, 1] <= 0.0 or \
                            dx * piece_normal[s, 0] + dy * piece_normal[s, 1] >= 0.0:
                        continue
                d = _distance_to_piece(x[p], x[i], x[j])
                if inside >= 0:         # depth: distance to the nearest eligible piece of that body
                    if partner[p] < 0 or d < depth[p]:
                        depth[p], g[p], partner[p] = d, -d, s
                elif d < g[p]:
                    g[p], partner[p] = d, s
    return g, partner, depth
