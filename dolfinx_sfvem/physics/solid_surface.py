"""Signed gaps between deformed 3D solids: the contact checks of :mod:`.contact` on surfaces.

The same rules as in 2D (docs/contact.md, "The gap" and "Contact checks in 3D"), on the
boundary surface of the solids of a tetrahedral or hexahedral mesh:

- *Solids* are the cells whose tag is in ``solid_tags``; *bodies* are the connected pieces of
  the solids (cells sharing a face), so one body may touch itself (the 3D C-box).
- The *surface* is every face of a solid cell not shared with another solid cell (faces against
  the medium and the outside), oriented outwards, each face followed through its degree-2 nodes:
  a P2 triangle (3 vertices + 3 edge midpoints) as 4 flat sub-triangles, a Q2 quadrilateral
  (4 vertices + 4 edge midpoints + centre) as 8; on curved cells (degree-2 geometry) the edge and
  face nodes are the geometry's, on the curved face, so the sub-triangles sample it.
- Every surface node p gets a signed gap g(p) in the deformed configuration: if p lies inside a
  body (generalized winding number of that body's deformed surface; for p's own body, at least
  one full turn beyond the part of the surface p sits on), g(p) = -(distance to that body's
  surface outside p's reference neighbourhood of two edge lengths); otherwise g(p) = +(distance
  to the nearest sub-triangle of another body, or of a surface of p's own body *facing* p:
  reference normals more than 120° apart, each in front of the other).
- Two surfaces can cross with every node outside the other body: the sub-triangles that cross
  another body's (or a non-neighbouring part of the own body's) sub-triangles are found with
  exact predicates, and points sampled on them are checked like nodes.
- The run's gap is the smallest g; the solids *overlap* when a node or a sample lies deeper
  inside than ``tolerance`` times its longest surface edge.

The geometry queries are libigl's (pinned in pyproject.toml): ``point_mesh_squared_distance``
(AABB trees), ``predicates.find_intersections`` / ``find_self_intersections`` (exact), and
``fast_winding_number`` (exact ``winding_number`` where it is close to a decision), evaluated only
for bodies whose surfaces cross: without a crossing a body lies wholly inside or outside another
and has no node inside itself. Depths inside the own body take their candidates from scipy's
k-d tree. The surface is read from the mesh's arrays (points, cells, tags, cell type) and, on
curved cells, its points in the middle of edges and faces (``edge_midpoints``, ``face_centres``):
the module needs nothing else of a ``CellMesh``. The own body's facing surfaces are found per
*cluster* of nodes and of sub-triangles (grouped by normal direction and position): cluster pairs
facing throughout are handed to libigl as one triangle set, pairs facing in part go through a
compiled loop over their node-triangle pairs, and pairs that cannot face, or are farther than a
distance already found, are skipped.
"""
from __future__ import annotations

import math
import typing

import igl
import igl.predicates
import numba
import numpy as np
import numpy.typing as npt
import scipy.sparse
import scipy.sparse.csgraph
import scipy.spatial

from dolfinx_sfvem.physics.contact import (
    FACING_COSINE, OVERLAP_TOLERANCE, BoundaryNodes, ContactPressure, Gap, contact_pressure, smallest_gap)
from dolfinx_sfvem.mesh.csr import edge_key

#: the faces of DOLFINx's reference cells, vertices in cyclic order (oriented outwards afterwards)
CELL_FACES = {"tetrahedron": np.array([[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]]),
              "hexahedron": np.array([[0, 1, 3, 2], [4, 5, 7, 6], [0, 1, 5, 4], [2, 3, 7, 6], [0, 2, 6, 4],
                                      [1, 3, 7, 5]])}
#: sub-triangles of a face in local node numbers: vertices 0..k-1, edge midpoints k..2k-1 (edge i
#: from vertex i to i+1), the quadrilateral's centre 8
SUB_TRIANGLES = {3: np.array([[0, 3, 5], [3, 1, 4], [5, 4, 2], [3, 4, 5]]),
                 4: np.array([[0, 4, 8], [4, 1, 8], [1, 5, 8], [5, 2, 8], [2, 6, 8], [6, 3, 8], [3, 7, 8],
                              [7, 0, 8]])}
#: barycentric sample points on a crossing sub-triangle: a lattice of step 1/4 on it, its vertices
#: (nodes, checked as such) left out
SAMPLES = np.array([(i, j, 4 - i - j) for i in range(5) for j in range(5 - i) if max(i, j, 4 - i - j) < 4]) / 4.0
#: nodes and sub-triangles per cluster of the facing search
CLUSTER_SIZE = 256


class SurfaceFaces(typing.NamedTuple):
    """The faces of a solid region's surface, from the cell arrays alone.

    Attributes
    ----------
    faces : (nf, 3|4) int64
        Mesh point indices in cyclic order, oriented so the normal points out of ``cell``.
    cell : (nf,) int64
        The solid cell of each face.
    neighbour : (nf,) int64
        The cell across the face (a medium cell), -1 on the boundary of the mesh.
    body : (n_cells,) int64
        Body of every cell (-1 for non-solid cells).
    """
    faces: np.ndarray
    cell: np.ndarray
    neighbour: np.ndarray
    body: np.ndarray


def surface_faces(points: np.ndarray, cells: np.ndarray, tags: np.ndarray, cell_type: str,
                  solid_tags: typing.Collection[int]) -> SurfaceFaces:
    """The faces of solid cells not shared with another solid cell, and the bodies.

    ``points`` (n, 3), ``cells`` (n_cells, 4|8) in DOLFINx vertex order of ``cell_type``
    ("tetrahedron" | "hexahedron"), ``tags`` (n_cells,).
    """
    local = CELL_FACES[cell_type]
    n_cells, k = cells.shape[0], local.shape[1]
    faces = cells[:, local].reshape(-1, k)
    owner = np.repeat(np.arange(n_cells), local.shape[0])
    _, face_id, count = np.unique(np.sort(faces, axis=1), axis=0, return_inverse=True, return_counts=True)
    face_id = face_id.reshape(-1)
    if count.max(initial=0) > 2:
        raise ValueError("a face is shared by more than two cells: the mesh is not conforming")
    # the other cell of every face entry (-1: none)
    order = np.argsort(face_id, kind="stable")
    first = np.searchsorted(face_id[order], face_id)
    other = np.full(face_id.size, -1, dtype=np.int64)
    pair = count[face_id] == 2
    a, b = order[first], order[np.minimum(first + 1, order.size - 1)]
    other[pair] = np.where(a[pair] == np.flatnonzero(pair), owner[b[pair]], owner[a[pair]])
    solid = np.isin(tags, list(solid_tags))
    # bodies: solid cells joined through shared faces
    joined = pair & solid[owner] & solid[np.maximum(other, 0)]
    graph = scipy.sparse.coo_matrix((np.ones(int(joined.sum())), (owner[joined], other[joined])), shape=(n_cells,) * 2)
    _, component = scipy.sparse.csgraph.connected_components(graph, directed=False)
    body = np.full(n_cells, -1, dtype=np.int64)
    body[solid] = np.unique(component[solid], return_inverse=True)[1].reshape(-1)
    keep = solid[owner] & ~joined
    faces, owner, other = faces[keep], owner[keep], other[keep]
    # outwards: the face's area vector points away from its cell's centroid
    p = points[faces]
    area = np.cross(p[:, 2] - p[:, 0], p[:, -1] - p[:, 1])        # the diagonals' (k = 4) or two edges' (k = 3)
    inward = np.einsum("ij,ij->i", area, p.mean(axis=1) - points[cells[owner]].mean(axis=1)) < 0.0
    faces[inward] = faces[inward][:, ::-1]
    return SurfaceFaces(faces.astype(np.int64), owner.astype(np.int64), other.astype(np.int64), body)


def default_face_centre_keys(n_points: int) -> typing.Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """Keys of the Q2 face-centre nodes of a mesh with ``n_points`` points, from a face's
    diagonal (a, c): ``n + n² + edge_key(a, c, n)``, after the point and edge-midpoint keys."""
    return lambda a, c: n_points + n_points * n_points + edge_key(a, c, n_points)


class SolidSurface(BoundaryNodes):
    """The boundary surface of the solid bodies of a 3D mesh, as flat sub-triangles between its
    degree-2 nodes: :class:`.contact.SolidBoundary` in 3D (the same public interface).

    Parameters
    ----------
    mesh
        A :class:`~dolfinx_sfvem.mesh.cell_mesh.CellMesh` of tetrahedra or hexahedra (used: ``points``
        (n, 3), ``cells``, ``tags``, ``cell_type``; where ``geometry_degree`` is 2, the curved
        geometry's points in the middle of edges and quadrilateral faces, ``edge_midpoints`` and
        ``face_centres``), identical on every rank.
    solid_tags
        Region tags of the solids (the others are third medium).
    midpoint_keys
        ``midpoint_keys(a, b)`` -> keys (m,) of the edge-midpoint nodes between points ``a``, ``b``
        (m,); the key of a vertex node is its point index.
    tolerance
        Overlap tolerance as a fraction of the longest surface edge at a node.
    face_centre_keys
        ``face_centre_keys(a, c)`` -> keys of the Q2 face-centre nodes of the quadrilateral faces
        with diagonal (a, c), a the face's smallest vertex (hexahedra only; default:
        :func:`default_face_centre_keys`).

    Attributes
    ----------
    node_keys : (n_nodes,) int64
        Sorted keys of the surface nodes.
    X : (n_nodes, 3)
        Their reference positions, in :attr:`node_keys` order.
    n_bodies : int
    triangles : (n_tri, 3) int64
        Sub-triangles (indices into :attr:`X`), outward, grouped by body (:attr:`body_offsets`).
    recovered : (n_nodes,) bool
        The nodes of ``pressure_keys``, at which the pressure is recovered from their faces.
    """

    def __init__(self, mesh, solid_tags: typing.Collection[int],
                 midpoint_keys: typing.Callable[[np.ndarray, np.ndarray], np.ndarray],
                 tolerance: float = OVERLAP_TOLERANCE,
                 face_centre_keys: typing.Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
                 pressure_keys: npt.ArrayLike | None = None):
        if not (np.isfinite(tolerance) and tolerance > 0.0):
            raise ValueError(f"overlap tolerance must be a positive fraction of the mesh size, not {tolerance!r}")
        self.tolerance = float(tolerance)
        points = np.asarray(mesh.points, dtype=float)
        n = points.shape[0]
        sf = surface_faces(points, np.asarray(mesh.cells, dtype=np.int64), np.asarray(mesh.tags), mesh.cell_type,
                           solid_tags)
        faces, k = sf.faces, sf.faces.shape[1]
        self.n_bodies = int(sf.body.max(initial=-1)) + 1
        # the faces' nodes by key: vertices, edge midpoints, (quadrilaterals) centres
        a, b = faces, np.roll(faces, -1, axis=1)
        columns = [faces, np.asarray(midpoint_keys(a.ravel(), b.ravel()), dtype=np.int64).reshape(a.shape)]
        curved = getattr(mesh, "geometry_degree", 1) > 1
        positions = [points[faces], mesh.edge_midpoints(a.ravel(), b.ravel()).reshape(a.shape + (3,)) if curved
                     else 0.5 * (points[a] + points[b])]
        if k == 4:
            centre_keys = face_centre_keys or default_face_centre_keys(n)
            low = np.argmin(faces, axis=1)
            rows = np.arange(faces.shape[0])
            columns.append(np.asarray(centre_keys(faces[rows, low], faces[rows, (low + 2) % 4]),
                                      dtype=np.int64)[:, None])
            positions.append((mesh.face_centres(faces) if curved else points[faces].mean(axis=1))[:, None])
        face_keys = np.concatenate(columns, axis=1)
        self.node_keys, first, face_nodes = np.unique(face_keys.ravel(), return_index=True, return_inverse=True)
        self.face_nodes = face_nodes.reshape(face_keys.shape).astype(np.int64)
        self.X = np.concatenate(positions, axis=1).reshape(-1, 3)[first]
        self.face_faces_medium = sf.neighbour >= 0
        self.recovered = (np.ones(self.node_keys.size, dtype=bool) if pressure_keys is None
                          else np.isin(self.node_keys, np.asarray(pressure_keys, dtype=np.int64)))
        face_body, face_tag = sf.body[sf.cell], np.asarray(mesh.tags, dtype=np.int64)[sf.cell]
        # sub-triangles, grouped by body
        local = SUB_TRIANGLES[k]
        tri = self.face_nodes[:, local].reshape(-1, 3)
        tri_face = np.repeat(np.arange(faces.shape[0]), local.shape[0])
        by_body = np.argsort(face_body[tri_face], kind="stable")
        self.triangles, self.triangle_face = tri[by_body], tri_face[by_body]
        self.piece_body, self.piece_tag = face_body[self.triangle_face], face_tag[self.triangle_face]
        self.body_offsets = np.searchsorted(self.piece_body, np.arange(self.n_bodies + 1))
        area_vector = self._area_vectors(self.X)
        self.triangle_normal = area_vector / np.linalg.norm(area_vector, axis=1)[:, None]
        self.triangle_centre = self.X[self.triangles].mean(axis=1)
        # per node: body, tag, normal (area-weighted), longest surface edge of its faces
        n_nodes = self.X.shape[0]
        self.node_body = np.zeros(n_nodes, dtype=np.int64)
        self.node_tag = np.zeros(n_nodes, dtype=np.int64)
        normal = np.zeros((n_nodes, 3))
        self.node_h = np.zeros(n_nodes)
        edge = np.linalg.norm(points[b] - points[a], axis=2).max(axis=1)
        self.triangle_h = edge[self.triangle_face]
        for corner in range(3):
            nodes = self.triangles[:, corner]
            self.node_body[nodes], self.node_tag[nodes] = self.piece_body, self.piece_tag
            np.add.at(normal, nodes, area_vector)
            np.maximum.at(self.node_h, nodes, self.triangle_h)
        self.node_normal = normal / np.linalg.norm(normal, axis=1)[:, None]
        self._facing = [_FacingClusters(self, body) for body in range(self.n_bodies)]

    @property
    def n_nodes(self) -> int:
        return self.X.shape[0]

    @property
    def pieces(self) -> np.ndarray:
        """The sub-triangles, under the name :func:`.contact.contact_pressure` reads."""
        return self.triangles

    def _area_vectors(self, x: np.ndarray) -> np.ndarray:
        """Area vectors (n_tri, 3) of the sub-triangles at node positions ``x``: outward, |.| = 2 area."""
        p = x[self.triangles]
        return np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])

    @staticmethod
    def _in_node_order(values: np.ndarray) -> np.ndarray:
        """Nodal ``values`` as given: the nodes are numbered in :attr:`node_keys` order."""
        return np.asarray(values, dtype=float)

    def _body_triangles(self, body: int) -> np.ndarray:
        return self.triangles[self.body_offsets[body]:self.body_offsets[body + 1]]

    def _deformed(self, u: np.ndarray):
        """Deformed positions x (n_nodes, 3) for displacements ``u`` (node_keys order), the signed gaps
        g, partner sub-triangles and depths of the nodes, and the crossing samples (positions,
        reference positions, depths, sub-triangles, partner sub-triangles)."""
        x = self.X + self._in_node_order(u)
        flagged, crossing = self._crossing_triangles(x)
        g = np.full(self.n_nodes, np.inf)
        partner = np.full(self.n_nodes, -1, dtype=np.int64)
        inside = self._inside(x, x, self.node_body, crossing)
        for body in range(self.n_bodies):                      # other bodies: every sub-triangle counts
            query = np.flatnonzero((self.node_body != body) & (inside < 0))
            if query.size:
                d2, i, _ = igl.point_mesh_squared_distance(x[query], x, self._body_triangles(body))
                nearer = d2 < g[query] ** 2
                g[query[nearer]], partner[query[nearer]] = np.sqrt(d2[nearer]), i[nearer] + self.body_offsets[body]
        for body in range(self.n_bodies):                      # the own body: facing surfaces
            self._facing[body].nearest(x, g, partner, inside < 0)
        depth = np.zeros(self.n_nodes)
        for body in range(self.n_bodies):
            here = np.flatnonzero(inside == body)
            if here.size:
                d, s = self._depth(x, x[here], self.X[here], self.node_h[here], body, self.node_body[here] == body)
                depth[here], g[here], partner[here] = d, -d, s
        return x, g, partner, depth, self._samples(x, flagged, crossing)

    def _crossing_triangles(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The sub-triangles (sorted) that cross a sub-triangle of another body, or of their own body
        beyond two edge lengths (reference centres), by libigl's exact predicates; and which bodies'
        surfaces cross (n_bodies, n_bodies) bool, symmetric (the diagonal: a body crossing itself)."""
        flagged = [np.zeros(0, dtype=np.int64)]
        crossing = np.zeros((self.n_bodies, self.n_bodies), dtype=bool)
        for body in range(self.n_bodies):
            tri, first = self._body_triangles(body), self.body_offsets[body]
            found, pairs, _ = igl.predicates.find_self_intersections(x, tri)
            if found:
                i, j = pairs[:, 0] + first, pairs[:, 1] + first
                far = np.linalg.norm(self.triangle_centre[i] - self.triangle_centre[j], axis=1) > \
                    2.0 * np.maximum(self.triangle_h[i], self.triangle_h[j])
                flagged += [i[far], j[far]]
                crossing[body, body] = far.any()
            for other in range(body + 1, self.n_bodies):
                found, pairs, _ = igl.predicates.find_intersections(x, tri, x, self._body_triangles(other))
                if found:
                    flagged += [pairs[:, 0] + first, pairs[:, 1] + self.body_offsets[other]]
                    crossing[body, other] = crossing[other, body] = True
        return np.unique(np.concatenate(flagged)), crossing

    def _inside(self, x: np.ndarray, q: np.ndarray, q_body: np.ndarray, crossing: np.ndarray,
                own: float = 1.0) -> np.ndarray:
        """The body each point ``q`` (m, 3) of body ``q_body`` (m,) lies inside (-1: none): winding number
        of another body's deformed surface above 1/2, of the own body's at least ``own`` (1 for a node:
        a full turn beyond the surface it sits on). Only where the surfaces cross (``crossing``, from
        :meth:`_crossing_triangles`) can some points of a body be inside and others not: there every
        point is tested (libigl's fast winding number, the exact one where it is within 0.25 of the
        decision); a body whose surface crosses no other lies wholly inside or outside it (its first
        point decides), and one that does not cross itself has no point inside itself."""
        inside = np.full(q.shape[0], -1, dtype=np.int64)
        for body in range(self.n_bodies):
            tri = self._body_triangles(body)
            corners = x[tri].reshape(-1, 3)
            lo, hi = corners.min(axis=0), corners.max(axis=0)
            test = (inside < 0) & np.all((q >= lo) & (q <= hi), axis=1) & crossing[body][q_body]
            for other in np.unique(q_body[(inside < 0) & ~crossing[body][q_body] & (q_body != body)]):
                first = np.flatnonzero(q_body == other)[:1]
                if igl.winding_number(x, tri, q[first])[0] > 0.5:
                    inside[(q_body == other) & (inside < 0)] = body
            query = np.flatnonzero(test)
            if not query.size:
                continue
            w = igl.fast_winding_number(x, tri, q[query])
            threshold = np.where(q_body[query] == body, own, 0.5)
            close = np.abs(w - threshold) < 0.25
            if close.any():
                w[close] = igl.winding_number(x, tri, q[query[close]])
            inside[query[w > threshold - 1e-6]] = body
        return inside

    def _depth(self, x: np.ndarray, q: np.ndarray, Q: np.ndarray, h: np.ndarray, body: int,
               own: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Distances (m,) of points ``q`` (m, 3), reference ``Q``, inside ``body`` to its surface and the
        sub-triangles (m,) where they occur; for points of the body itself (``own`` (m,) bool) the
        sub-triangles within two edge lengths ``h`` (m,) of the reference point are left out: their
        candidates are the 32 sub-triangles with the nearest deformed centres, then every one whose
        centre is near enough to beat the nearest of those (scipy's k-d tree), all of them if none of
        the 32 is beyond the neighbourhood."""
        first = self.body_offsets[body]
        tri = self._body_triangles(body)
        d, s = np.zeros(q.shape[0]), np.zeros(q.shape[0], dtype=np.int64)
        other = ~own
        if other.any():
            d2, s[other], _ = igl.point_mesh_squared_distance(q[other], x, tri)
            d[other] = np.sqrt(d2)
        if own.any():
            corners = x[tri]
            centre = corners.mean(axis=1)
            reach = float(np.linalg.norm(corners - centre[:, None], axis=2).max())
            tree = scipy.spatial.cKDTree(centre)
            qo, k = q[own], min(32, tri.shape[0])
            near = tree.query(qo, k)[1].reshape(qo.shape[0], k)
            args = (qo, Q[own], h[own], x, tri, self.triangle_centre[first:first + tri.shape[0]])
            bound, _ = _nearest_beyond(*args, np.arange(qo.shape[0] + 1) * k, near.ravel())
            lists = [np.arange(tri.shape[0])] * qo.shape[0]
            finite = np.flatnonzero(np.isfinite(bound))
            for i, found in zip(finite, tree.query_ball_point(qo[finite], bound[finite] + reach)):
                lists[i] = np.asarray(found, dtype=np.int64)
            offsets = np.concatenate([[0], np.cumsum([len(c) for c in lists])])
            d[own], s[own] = _nearest_beyond(*args, offsets, np.concatenate(lists))
        return d, s + first

    def _samples(self, x: np.ndarray, flagged: np.ndarray, crossing: np.ndarray):
        """Points sampled on the crossing sub-triangles ``flagged`` (positions, reference positions), their
        depth inside another body or their own (0 outside), the sub-triangles they lie on and those where
        the depth is measured."""
        tri = np.repeat(flagged, SAMPLES.shape[0])
        weights = np.tile(SAMPLES, (flagged.size, 1))
        q = np.einsum("ik,ikj->ij", weights, x[self.triangles[tri]])
        Q = np.einsum("ik,ikj->ij", weights, self.X[self.triangles[tri]])
        # a winding number is not defined on the surface itself: the samples' is taken 1e-6 h outside it,
        # along the normal interpolated from the nodes' (outward on edges, convex or re-entrant)
        normal = np.zeros_like(x)
        for corner in range(3):
            np.add.at(normal, self.triangles[:, corner], self._area_vectors(x))
        normal = _unit(np.einsum("ik,ikj->ij", weights, _unit(normal)[self.triangles[tri]]))
        off = q + 1e-6 * self.triangle_h[tri][:, None] * normal
        inside = self._inside(x, off, self.piece_body[tri], crossing, own=0.5)
        depth, partner = np.zeros(tri.size), np.full(tri.size, -1, dtype=np.int64)
        for body in range(self.n_bodies):
            here = np.flatnonzero(inside == body)
            if here.size:
                depth[here], partner[here] = self._depth(x, q[here], Q[here], self.triangle_h[tri[here]], body,
                                                         self.piece_body[tri[here]] == body)
        return q, Q, depth, tri, partner

    def gap(self, u: np.ndarray) -> Gap:
        """The smallest signed gap at displacements ``u`` (n_nodes, 3) of the surface nodes (in the
        order of :attr:`node_keys`)."""
        return self._gap(*self._deformed(u))

    def gap_and_pressure(self, u: np.ndarray, f: np.ndarray, f_material: np.ndarray) -> tuple[Gap, ContactPressure]:
        """:meth:`gap` and the contact pressure from one evaluation of the deformed surface.

        Parameters
        ----------
        u, f, f_material : (n_nodes, 3)
            Displacements, the third medium's internal nodal forces ∂W_medium/∂ũ at the surface nodes
            (its whole energy: the pairs' forces) and those of its material response alone (the
            pressure), in :attr:`node_keys` order.
        """
        deformed = self._deformed(u)
        return self._gap(*deformed), self._pressure(*deformed[:3], self._in_node_order(f),
                                                    self._in_node_order(f_material))

    def _gap(self, x, g, partner, depth, crossings) -> Gap:
        q, Q, q_depth, q_tri, q_partner = crossings
        overlap = max(float((depth / (self.tolerance * self.node_h)).max(initial=0.0)),
                      float((q_depth / (self.tolerance * self.triangle_h[q_tri])).max(initial=0.0)))
        if q_depth.max(initial=0.0) > 0.0 and -q_depth.max() < g.min():   # a sample deeper than every node
            k, t = int(np.argmax(q_depth)), int(q_tri[np.argmax(q_depth)])
            s = int(q_partner[k])
            return Gap(-float(q_depth[k]), tuple(map(float, q[k])), tuple(map(float, Q[k])), int(self.piece_tag[t]),
                       int(self.piece_tag[s]), int(self.piece_body[t]), int(self.piece_body[s]), overlap)
        return smallest_gap(self, x, g, partner, overlap)

    def _pressure(self, x: np.ndarray, g: np.ndarray, partner: np.ndarray, f: np.ndarray,
                  f_material: np.ndarray) -> ContactPressure:
        """Normal pressure per node and the contact per pair of bodies: the 2D recovery
        (:meth:`.contact.SolidBoundary._pressure`) with areas for lengths. Per face facing the medium,
        the resultant of ``f_material`` on its nodes, each node's force shared between its
        medium-facing faces in proportion to their deformed areas (exact for a uniform traction on
        P2 triangles and Q2 quadrilaterals of any sizes), over the face's deformed area, along its
        outward mean normal; at a node the area-weighted mean of its faces'. A pair's force sums the
        whole medium force ``f``; its ``zone_length`` is the deformed area of its contact zone. At the
        nodes outside ``pressure_keys`` the mean of the corners (:meth:`_interpolated`)."""
        facing = self.face_faces_medium
        vector = np.zeros((self.face_nodes.shape[0], 3))
        np.add.at(vector, self.triangle_face, 0.5 * self._area_vectors(x))
        area = np.where(facing, np.linalg.norm(vector, axis=1), 0.0)
        nodes = self.face_nodes.ravel()
        face_area = np.repeat(area, self.face_nodes.shape[1])
        area_at = np.bincount(nodes, face_area, self.n_nodes)
        share = np.divide(face_area, area_at[nodes], out=np.zeros_like(face_area), where=face_area > 0.0)
        resultant = np.zeros_like(vector)
        np.add.at(resultant, np.repeat(np.arange(area.size), self.face_nodes.shape[1]), share[:, None] * f_material[nodes])
        p_face = np.divide(np.einsum("ij,ij->i", resultant, vector), area ** 2, out=np.zeros_like(area), where=area > 0.0)
        p = np.divide(np.bincount(nodes, face_area * np.repeat(p_face, self.face_nodes.shape[1]), self.n_nodes), area_at,
                      out=np.zeros(self.n_nodes), where=area_at > 0.0)
        p = self._interpolated(p, facing)
        return contact_pressure(self, x, g, partner, p, f, 0.5 * np.linalg.norm(self._area_vectors(x), axis=1))

    def _interpolated(self, p: np.ndarray, facing: np.ndarray) -> np.ndarray:
        """``p`` (n_nodes,) kept at the :attr:`recovered` nodes and replaced at the others, on the
        faces facing the medium (``facing`` (n_faces,) bool): at a face corner by the mean of the
        recovered corners of the facing faces around it, then at an edge midpoint by the mean of
        its edge's two ends and at a quadrilateral's centre by the mean of its four corners."""
        if self.recovered.all():
            return p
        faces = self.face_nodes[facing]
        k = 4 if faces.shape[1] == 9 else 3
        corners, following = faces[:, :k], np.roll(faces[:, :k], -1, axis=1)     # edge j from corner j to j + 1
        kept = self.recovered[corners]
        # every face's recovered corners, summed and counted, to each of its corners
        total = np.bincount(corners.ravel(), np.repeat(np.where(kept, p[corners], 0.0).sum(axis=1), k), self.n_nodes)
        count = np.bincount(corners.ravel(), np.repeat(kept.sum(axis=1), k), self.n_nodes)
        out = p.copy()
        at = ~self.recovered[corners] & (count[corners] > 0)
        out[corners[at]] = total[corners[at]] / count[corners[at]]
        for j in range(k):
            mid = faces[:, k + j]
            free = ~self.recovered[mid]
            out[mid[free]] = 0.5 * (out[corners[free, j]] + out[following[free, j]])
        if k == 4:
            centre = faces[:, 8]
            free = ~self.recovered[centre]
            out[centre[free]] = out[corners[free]].mean(axis=1)
        return out


#: the directions the clusters of the facing search are sorted by: towards the faces, edges and corners of a cube
DIRECTIONS = np.array([d for d in np.ndindex(3, 3, 3) if d != (1, 1, 1)], dtype=float) - 1.0
DIRECTIONS /= np.linalg.norm(DIRECTIONS, axis=1)[:, None]


def _unit(v: np.ndarray) -> np.ndarray:
    """Rows of ``v`` (m, 3) scaled to length 1 (rows of zeros, on a collapsed surface, stay 0)."""
    length = np.linalg.norm(v, axis=1)[:, None]
    return np.divide(v, length, out=np.zeros_like(v), where=length > 0.0)


def _clusters(points: np.ndarray, normals: np.ndarray, size: int) -> list[np.ndarray]:
    """Groups of at most ``size`` indices of ``points`` (m, 3): by the one of :data:`DIRECTIONS`
    nearest to their ``normals``, then halved: across that direction at the middle while the group
    spreads along it (parallel layers apart: a plate's two sides, a slot's floor and the top), then
    at the median of its longest extent."""
    direction = np.argmax(normals @ DIRECTIONS.T, axis=1)
    todo = [np.flatnonzero(direction == k) for k in range(DIRECTIONS.shape[0])]
    out = []
    while todo:
        group = todo.pop()
        if group.size <= size:
            if group.size:
                out.append(group)
            continue
        p = points[group]
        extent = p.max(axis=0) - p.min(axis=0)
        level = p @ DIRECTIONS[direction[group[0]]]
        if level.max() - level.min() > 1e-9 * extent.max():
            below = level < 0.5 * (level.min() + level.max())
        else:
            along = p[:, np.argmax(extent)]
            below = np.zeros(group.size, dtype=bool)
            below[np.argsort(along, kind="stable")[:group.size // 2]] = True
        todo += [group[below], group[~below]]
    return out


class _FacingClusters:
    """The facing search of one body (module docstring): its nodes and sub-triangles in clusters,
    and per pair of clusters whether every, some or no node-triangle pair faces (reference
    configuration, bounds over each cluster's boxes and normal cones)."""

    def __init__(self, surface: SolidSurface, body: int):
        lo, hi = surface.body_offsets[body], surface.body_offsets[body + 1]
        self.triangles = surface.triangles[lo:hi]
        self.offset = lo
        nodes = np.flatnonzero(surface.node_body == body)
        X, N = surface.X[nodes], surface.node_normal[nodes]
        c, m = surface.triangle_centre[lo:hi], surface.triangle_normal[lo:hi]
        self.node_groups = [nodes[g] for g in _clusters(X, N, CLUSTER_SIZE)]
        self.tri_groups = _clusters(c, m, CLUSTER_SIZE)
        # per triangle cluster: centre box, mean normal, cone half-angle, range of c.mean
        box = np.array([[c[g].min(axis=0), c[g].max(axis=0)] for g in self.tri_groups]).reshape(-1, 2, 3)
        mean = np.array([m[g].sum(axis=0) for g in self.tri_groups]).reshape(-1, 3)
        mean /= np.maximum(np.linalg.norm(mean, axis=1), 1e-300)[:, None]
        cone = np.array([np.arccos(np.clip((m[g] @ mean[i]).min(), -1.0, 1.0)) for i, g in enumerate(self.tri_groups)])
        offset = [c[g] @ mean[i] for i, g in enumerate(self.tri_groups)]
        off_lo = np.array([o.min() for o in offset])
        off_hi = np.array([o.max() for o in offset])
        self.all, self.some = [], []
        for group in self.node_groups:
            Xg, Ng = surface.X[group], surface.node_normal[group]
            # normals: angle between n_p and the cluster's normals in [theta - cone, theta + cone]
            theta = np.arccos(np.clip(Ng @ mean.T, -1.0, 1.0))
            facing = math.acos(FACING_COSINE)
            n_all, n_none = theta - cone > facing, theta + cone < facing     # facing: n_p.n_s <= cos(120°)
            # (c_s - X_p).n_p > 0: range of c_s.n_p over the box
            box_lo = np.einsum("pk,tk->pt", np.maximum(Ng, 0.0), box[:, 0]) + np.einsum("pk,tk->pt", np.minimum(Ng, 0.0), box[:, 1])
            box_hi = np.einsum("pk,tk->pt", np.maximum(Ng, 0.0), box[:, 1]) + np.einsum("pk,tk->pt", np.minimum(Ng, 0.0), box[:, 0])
            level = np.einsum("pk,pk->p", Xg, Ng)[:, None]
            f_all, f_none = box_lo > level, box_hi <= level
            # (c_s - X_p).n_s < 0: (c_s - X_p).mean + (c_s - X_p).(n_s - mean), the latter within r * eps
            far = np.linalg.norm(np.maximum(np.abs(Xg[:, None, :] - box[None, :, 0]),
                                            np.abs(Xg[:, None, :] - box[None, :, 1])), axis=2)
            eps = far * 2.0 * np.sin(cone / 2.0)
            along = Xg @ mean.T
            b_all, b_none = off_hi - along + eps < 0.0, off_lo - along - eps >= 0.0
            every = (n_all & f_all & b_all).all(axis=0)
            never = (n_none | f_none | b_none).all(axis=0)
            self.all.append(np.flatnonzero(every))
            self.some.append(np.flatnonzero(~every & ~never))
        self.node_normal, self.X = surface.node_normal, surface.X
        self.triangle_normal, self.triangle_centre = surface.triangle_normal[lo:hi], c

    def nearest(self, x: np.ndarray, g: np.ndarray, partner: np.ndarray, outside: np.ndarray) -> None:
        """Lower ``g`` (n_nodes,) and set ``partner`` where a facing sub-triangle of the body is nearer
        than the distance already there, for the nodes ``outside`` every body."""
        boxes = np.array([[x[self.triangles[t]].reshape(-1, 3).min(axis=0), x[self.triangles[t]].reshape(-1, 3).max(axis=0)]
                          for t in self.tri_groups]).reshape(-1, 2, 3)
        for group, every, some in zip(self.node_groups, self.all, self.some):
            group = group[outside[group]]
            if not group.size or not (every.size or some.size):
                continue
            xg = x[group]
            lo, hi = xg.min(axis=0), xg.max(axis=0)
            near = np.linalg.norm(np.maximum(np.maximum(boxes[:, 0] - hi, lo - boxes[:, 1]), 0.0), axis=1)
            farthest = np.linalg.norm(np.maximum(np.abs(hi - boxes[:, 0]), np.abs(boxes[:, 1] - lo)), axis=1)
            bound = min(float(farthest[every].min(initial=np.inf)), float(g[group].max()))
            every, some = every[near[every] <= bound], some[near[some] <= bound]
            if every.size:
                tri = np.concatenate([self.tri_groups[t] for t in every])
                d2, i, _ = igl.point_mesh_squared_distance(xg, x, self.triangles[tri])
                nearer = d2 < g[group] ** 2
                g[group[nearer]], partner[group[nearer]] = np.sqrt(d2[nearer]), tri[i[nearer]] + self.offset
            if some.size:
                tri = np.concatenate([self.tri_groups[t] for t in some])
                _facing_nearest(group, tri, x, self.X, self.node_normal, self.triangles, self.triangle_centre,
                                self.triangle_normal, FACING_COSINE, self.offset, g, partner)


@numba.njit(cache=True, inline="always")
def _dot(u, v):
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


@numba.njit(cache=True, inline="always")
def _sub(u, v):
    return (u[0] - v[0], u[1] - v[1], u[2] - v[2])


@numba.njit(cache=True, inline="always")
def _along(a, t, d):
    return (a[0] + t * d[0], a[1] + t * d[1], a[2] + t * d[2])


@numba.njit(cache=True)
def _triangle_distance(x, p, i, j, k):
    """Distance from x[p] to the triangle (x[i], x[j], x[k]) (Ericson, Real-Time Collision Detection,
    §5.1.5: the closest point by the Voronoi region of the query)."""
    P, a, b, c = (x[p, 0], x[p, 1], x[p, 2]), (x[i, 0], x[i, 1], x[i, 2]), (x[j, 0], x[j, 1], x[j, 2]), \
        (x[k, 0], x[k, 1], x[k, 2])
    ab, ac, ap = _sub(b, a), _sub(c, a), _sub(P, a)
    d1, d2 = _dot(ab, ap), _dot(ac, ap)
    if d1 <= 0.0 and d2 <= 0.0:
        q = a
    else:
        bp = _sub(P, b)
        d3, d4 = _dot(ab, bp), _dot(ac, bp)
        cp = _sub(P, c)
        d5, d6 = _dot(ab, cp), _dot(ac, cp)
        vc, vb, va = d1 * d4 - d3 * d2, d5 * d2 - d1 * d6, d3 * d6 - d5 * d4
        if d3 >= 0.0 and d4 <= d3:
            q = b
        elif vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
            q = _along(a, d1 / (d1 - d3), ab)
        elif d6 >= 0.0 and d5 <= d6:
            q = c
        elif vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
            q = _along(a, d2 / (d2 - d6), ac)
        elif va <= 0.0 and d4 - d3 >= 0.0 and d5 - d6 >= 0.0:
            q = _along(b, (d4 - d3) / ((d4 - d3) + (d5 - d6)), _sub(c, b))
        else:
            denom = 1.0 / (va + vb + vc)
            q = _along(_along(a, vb * denom, ab), vc * denom, ac)
    e = _sub(P, q)
    return math.sqrt(_dot(e, e))


@numba.njit(cache=True)
def _facing_nearest(nodes, tris, x, X, node_normal, triangles, centre, normal, facing, offset, g, partner):
    """For every node of ``nodes``, the nearest sub-triangle of ``tris`` facing it (module docstring),
    if nearer than ``g``: updates ``g`` and ``partner`` (global sub-triangle index = tri + offset)."""
    for p in nodes:
        n_p = (node_normal[p, 0], node_normal[p, 1], node_normal[p, 2])
        X_p = (X[p, 0], X[p, 1], X[p, 2])
        for t in tris:
            n_s = (normal[t, 0], normal[t, 1], normal[t, 2])
            if _dot(n_p, n_s) > facing:
                continue
            d = _sub((centre[t, 0], centre[t, 1], centre[t, 2]), X_p)
            if _dot(d, n_p) <= 0.0 or _dot(d, n_s) >= 0.0:
                continue
            dist = _triangle_distance(x, p, triangles[t, 0], triangles[t, 1], triangles[t, 2])
            if dist < g[p]:
                g[p], partner[p] = dist, t + offset


@numba.njit(cache=True)
def _nearest_beyond(q, Q, h, x, triangles, centre, offsets, candidates):
    """Distance of each point q[k] (m, 3) to the nearest of the ``triangles`` listed in
    ``candidates[offsets[k]:offsets[k + 1]]`` whose reference centre lies beyond 2 h[k] of the
    reference point Q[k] (outside its neighbourhood), and that triangle (inf and -1 if none)."""
    m, n = q.shape[0], x.shape[0]
    points = np.concatenate((x, q))             # the query points after the triangles' vertices
    d = np.full(m, np.inf)
    s = np.full(m, -1, dtype=np.int64)
    for k in range(m):
        for t in candidates[offsets[k]:offsets[k + 1]]:
            e = _sub((centre[t, 0], centre[t, 1], centre[t, 2]), (Q[k, 0], Q[k, 1], Q[k, 2]))
            if _dot(e, e) <= 4.0 * h[k] * h[k]:
                continue
            dist = _triangle_distance(points, n + k, triangles[t, 0], triangles[t, 1], triangles[t, 2])
            if dist < d[k]:
                d[k], s[k] = dist, t
    return d, s
