"""The paper's benchmark geometries, meshed: C-box (§5.2, dual polygons or quads), box with
cavity (§5.3), punch (§5.4) and several objects (§5.5), each with the named points and boundary
segments its demo needs; and two geometries for validating loads: a thick-walled cylinder (exact
answers in :mod:`dolfinx_sfvem.exact`) and a shallow clamped arch (snap-through).

Each generator that needs gmsh runs its own gmsh session, so do not call one while holding a gmsh
session of your own open — use ``meshes.from_gmsh(None)`` to read your current model instead.
"""
from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable, Sequence
from typing import Literal, NamedTuple

import numpy as np
import numpy.typing as npt

from dolfinx_sfvem.meshing.gmsh_duals import GmshBuilder, dual_of_gmsh, gmsh_triangles, straight_region
from dolfinx_sfvem.meshing.grids import axis_nodes, n_segments, quad_grid
from dolfinx_sfvem.meshing.polygon_sets import PolygonSet, csr, glue, length_tolerance
from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh
from dolfinx_sfvem.mesh.csr import next_entries


#: region tag of the solid bodies (further solids: 3, 4, ...)
SOLID = 1


#: region tag of the third medium
MEDIUM = 2


class Arc(NamedTuple):
    """A circular arc: ``centre + radius (cos t, sin t)`` for ``start <= t <= end`` (radians,
    counter-clockwise, ``end - start <= 2 pi``)."""

    centre: tuple[float, float]
    radius: float
    start: float
    end: float

    def contains(self, points: np.ndarray, tol: float) -> np.ndarray:
        """Whether each point (n, 2) lies on the arc, within ``tol`` (a length)."""
        d = points - np.asarray(self.centre)
        on_circle = np.abs(np.hypot(d[:, 0], d[:, 1]) - self.radius) <= tol
        angle = np.mod(np.arctan2(d[:, 1], d[:, 0]) - self.start + tol / self.radius, 2 * np.pi)
        return on_circle & (angle <= self.end - self.start + 2 * tol / self.radius)


@dataclasses.dataclass(frozen=True)
class Benchmark:
    """A meshed benchmark with the named points and boundary segments its demo needs.

    Attributes
    ----------
    mesh : PolygonMesh
        Polygons tagged :data:`SOLID`, :data:`MEDIUM`, ...
    regions : dict name -> tag
        Region tags by body name (materials are assigned per region).
    points : dict name -> (x, y)
        Named points; each is a mesh vertex.
    segments : dict name -> ((x0, y0), (x1, y1))
        Named straight boundary pieces (e.g. clamped sides).
    arcs : dict name -> Arc
        Named circular boundary pieces; the mesh follows them by chords whose end points lie on
        the circle (the straight edges' midpoints are then inside the circle by the sagitta).
    """

    mesh: PolygonMesh
    regions: dict[str, int]
    points: dict[str, tuple[float, float]]
    segments: dict[str, tuple[tuple[float, float], tuple[float, float]]]
    arcs: dict[str, Arc] = dataclasses.field(default_factory=dict)

    def __post_init__(self):
        self.mesh.region_names = dict(self.regions)

    def vertex(self, name: str) -> int:
        """Index of the mesh vertex at the named point (ValueError if there is none)."""
        distance = np.linalg.norm(self.mesh.points - np.asarray(self.points[name]), axis=1)
        index = int(np.argmin(distance))
        if distance[index] > self.mesh.tol:
            raise ValueError(f"named point {name!r} {self.points[name]} is not a mesh vertex")
        return index

    def _on(self, name: str, points: np.ndarray) -> np.ndarray:
        """Whether each point (n, 2) lies on the named segment or arc."""
        if name in self.arcs:
            return self.arcs[name].contains(points, self.mesh.tol)
        if name not in self.segments:
            raise KeyError(f"no segment or arc named {name!r}; segments {sorted(self.segments)}, "
                           f"arcs {sorted(self.arcs)}")
        a, b = (np.asarray(p, dtype=np.float64) for p in self.segments[name])
        s = np.clip((points - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
        return np.linalg.norm(points - (a + s[:, None] * (b - a)), axis=1) <= self.mesh.tol

    def vertices_on(self, name: str) -> np.ndarray:
        """Indices (k,) of the mesh vertices on the named segment or arc."""
        return np.flatnonzero(self._on(name, self.mesh.points))

    def edges_on(self, name: str) -> np.ndarray:
        """Mesh edges (k, 2) on the named segment or arc: pairs of vertex indices, each edge once,
        both ends on it and the edge on the outer boundary or on an interface between two regions
        (an arc's chords; a chord across a region, between two points of its arc, is not one)."""
        mesh, sides = self.mesh, self.mesh.sides
        _, first = np.unique(sides.edge, return_index=True)        # the first side of every edge
        pairs = np.stack([sides.start[first], sides.end[first]], axis=1)
        p, q = mesh.edge_polygons.T
        boundary = (p < 0) | (q < 0) | (mesh.tags[p] != mesh.tags[q])
        on = self._on(name, mesh.points)
        return pairs[boundary & on[pairs[:, 0]] & on[pairs[:, 1]]]

    def nodes_on(self, name: str) -> np.ndarray:
        """Coordinates (k, 2) of the vertices and edge midpoints of :meth:`edges_on`: the nodes of
        the degree-2 edge traces on the named segment or arc (sorted)."""
        pairs = self.edges_on(name)
        points = self.mesh.points
        return np.unique(np.concatenate([points[pairs.ravel()], points[pairs].mean(axis=1)]), axis=0)


def _solid_with_quad_medium(solid_loops: Sequence[npt.ArrayLike], h: float, xs: np.ndarray,
                            ys: np.ndarray, medium: Callable[[np.ndarray, np.ndarray], np.ndarray] | None,
                            keep_gmsh: str | os.PathLike | None = None) -> PolygonMesh:
    """Dual polygons of the solid glued to a quadrilateral medium grid (hanging nodes)."""
    return glue(dual_of_gmsh(straight_region(solid_loops, SOLID), h, keep_gmsh),
                quad_grid(xs, ys, MEDIUM, medium))


#: C-box of paper §5.2: length, wall thickness, height
_CBOX_L, _CBOX_T, _CBOX_H = 1.0, 0.1, 0.5


#: default width of the C-box's medium column right of the beams: the wall thickness, fixed
#: whatever the mesh size (a column as thin as one small element lets the medium between the
#: beams be dragged out sideways and the beams pass through each other, docs/contact.md)
CBOX_COLUMN = 0.1


def _cbox_benchmark(mesh: PolygonMesh) -> Benchmark:
    """The C-box's regions, named points and segments around ``mesh``."""
    L, t, H = _CBOX_L, _CBOX_T, _CBOX_H
    return Benchmark(mesh, {"solid": SOLID, "medium": MEDIUM},
                     {"load": (L, H), "gap_top": (L, H - t), "gap_bottom": (L, t)},
                     {"fixed": ((0.0, 0.0), (0.0, H))})


def _cbox_medium(cx: np.ndarray, cy: np.ndarray) -> np.ndarray:
    """Whether the points (cx, cy) of the C-box's bounding grid lie in the medium."""
    return (cx > _CBOX_L) | ((cx > _CBOX_T) & (cy > _CBOX_T) & (cy < _CBOX_H - _CBOX_T))


def cbox(h_solid: float = 0.05, medium_refinement: int = 1, keep_gmsh: str | os.PathLike | None = None,
         column: float = CBOX_COLUMN) -> Benchmark:
    """C-box of paper §5.2 (Bluhm et al. 2021) with a quadrilateral third medium.

    Geometry (L = 1, wall thickness t = 0.1, height 0.5, initial gap 0.3): solid = left
    wall [0, 0.1] x [0, 0.5], bottom beam [0, 1] x [0, 0.1] and top beam [0, 1] x [0.4, 0.5];
    medium = the cavity [0.1, 1] x [0.1, 0.4] and a column [1, 1 + column] x [0, 0.5] to
    the right of the structure (default width :data:`CBOX_COLUMN`, independent of the mesh).

    Mesh: the solid is the dual (:func:`dual_polygons`) of a gmsh triangle mesh of size
    ``h_solid`` whose straight sides carry ``round(length / h_solid)`` equal segments; the
    medium is a grid of quads ``medium_refinement`` times finer than those segments
    (column: ``medium_refinement * round(column / h_solid)`` quads across). The solid mesh does not depend on
    ``medium_refinement``. With 1, the triangle vertices on the interface are quad
    vertices and the dual midpoints between them are hanging nodes in the quads; with 2,
    the quads end exactly at the solid polygons' interface points (the triangle vertices
    there stay collinear vertices of the solid polygons, T-junctions against the quads).

    Named points: ``load`` (1, 0.5), the top-right corner where u_y is prescribed;
    ``gap_top`` (1, 0.4) and ``gap_bottom`` (1, 0.1), the inner corners at the beam tips.
    Named segments: ``fixed``, the left side x = 0.

    ``keep_gmsh``: write the solid's gmsh model to ``<keep_gmsh>.geo`` / ``.msh`` (:func:`write_gmsh`).
    """
    xs, ys = _cbox_axes(h_solid, medium_refinement, column)
    L, t, H = _CBOX_L, _CBOX_T, _CBOX_H
    outline = [(0, 0), (L, 0), (L, t), (t, t), (t, H - t), (L, H - t), (L, H), (0, H)]
    mesh = _solid_with_quad_medium([outline], h_solid, xs[xs >= t - 1e-12], ys, _cbox_medium, keep_gmsh)
    return _cbox_benchmark(mesh)


def cbox_grid(h_solid: float = 0.05, medium_refinement: int = 1, column: float = CBOX_COLUMN) -> Benchmark:
    """The C-box of :func:`cbox` (same geometry and ``column``) meshed entirely
    by its medium grid: rectangles of size ``h_solid / medium_refinement``, solid included,
    no hanging nodes. The mesh for degree-2 Lagrange FEM on quadrilaterals (Q2), see
    :meth:`~dolfinx_sfvem.discretizations.fem.LagrangeDiscretization.from_polygon_mesh` with ``fem_mesh``.
    """
    xs, ys = _cbox_axes(h_solid, medium_refinement, column)
    return _cbox_benchmark(glue(quad_grid(xs, ys, SOLID, lambda cx, cy: ~_cbox_medium(cx, cy)),
                                quad_grid(xs, ys, MEDIUM, _cbox_medium)))


def _cbox_axes(h_solid: float, medium_refinement: int, column: float) -> tuple[np.ndarray, np.ndarray]:
    """Grid lines of the C-box's bounding box [0, 1 + column] x [0, 0.5] (the medium's quads)."""
    if int(medium_refinement) != medium_refinement or medium_refinement < 1:
        raise ValueError(f"medium_refinement must be a positive integer, got {medium_refinement!r}")
    if not (np.isfinite(column) and column > 0.0):
        raise ValueError(f"the C-box's medium column width must be a number > 0, got {column!r}")
    L, t, H = _CBOX_L, _CBOX_T, _CBOX_H
    return (axis_nodes([0.0, t, L, L + column], h_solid, medium_refinement),
            axis_nodes([0.0, t, H - t, H], h_solid, medium_refinement))


def box(mesh: int = 1, h_solid: float = 0.05, keep_gmsh: str | os.PathLike | None = None) -> Benchmark:
    """Box self-contact of paper §5.1: three medium densities, one solid mesh.

    Geometry: box [0, 2] x [0, 0.5] with walls of thickness 0.1; the cavity
    [0.1, 1.9] x [0.1, 0.4] is filled with medium.

    Mesh: the solid is the dual of a gmsh triangle mesh of size ``h_solid``, its straight
    sides split at x = 1 and carrying ``round(length / h_solid)`` equal segments; the
    medium is a grid of quads ``mesh`` times finer than those segments (mesh 1, 2, 3 =
    quads of size h_solid, h_solid/2, h_solid/3). Mesh 1: interface midpoints of the
    solid hang in the quads; mesh 2: quads end at the solid's interface points; mesh 3:
    hanging nodes on both sides. The solid mesh is the same for all three.

    Named points: ``fixed`` (0, 0) lower-left corner (u = 0); ``roller`` (2, 0)
    lower-right corner (u_y = 0); ``load`` (1, 0.5) middle of the top; ``gap_top``
    (1, 0.4) and ``gap_bottom`` (1, 0.1), the inner surfaces at mid-span where the gap is
    measured. No named segments.

    ``keep_gmsh``: write the solid's gmsh model to ``<keep_gmsh>.geo`` / ``.msh`` (:func:`write_gmsh`).
    """
    if mesh not in (1, 2, 3):
        raise ValueError(f"box mesh must be 1, 2 or 3, got {mesh!r}")
    L, H, t = 2.0, 0.5, 0.1
    outer = [(0, 0), (L / 2, 0), (L, 0), (L, H), (L / 2, H), (0, H)]
    cavity = [(t, t), (L / 2, t), (L - t, t), (L - t, H - t), (L / 2, H - t), (t, H - t)]
    xs = axis_nodes([t, L / 2, L - t], h_solid, mesh)
    ys = axis_nodes([t, H - t], h_solid, mesh)
    polygon_mesh = _solid_with_quad_medium([outer, cavity], h_solid, xs, ys, None, keep_gmsh)
    return Benchmark(polygon_mesh, {"solid": SOLID, "medium": MEDIUM},
                     {"fixed": (0.0, 0.0), "roller": (L, 0.0), "load": (L / 2, H),
                      "gap_top": (L / 2, H - t), "gap_bottom": (L / 2, t)}, {})


def _occ_sector(gmsh, centre: Sequence[float], radius: float, angles: Sequence[float]) -> int:
    """OCC surface of a disc sector: centre -> rim at ``angles[0]`` -> arcs through the
    other rim angles (degrees, each step below 180) -> back to the centre. Every rim angle
    gives a geometry point, hence a mesh vertex."""
    cx, cy = centre
    occ = gmsh.model.occ
    c = occ.addPoint(cx, cy, 0.0)
    rim = [occ.addPoint(cx + radius * np.cos(a), cy + radius * np.sin(a), 0.0) for a in np.radians(angles)]
    arcs = [occ.addCircleArc(rim[i], c, rim[i + 1]) for i in range(len(rim) - 1)]
    loop = occ.addCurveLoop([occ.addLine(c, rim[0])] + arcs + [occ.addLine(rim[-1], c)])
    return occ.addPlaneSurface([loop])


def _occ_regions(gmsh, solids: Sequence[tuple[int, int]], medium_box: int) -> dict[int, list[int]]:
    """Fragment solid surfaces ``(region tag, surface)`` and a box around the medium into a
    conforming model; the parts of the box outside every solid are :data:`MEDIUM`."""
    objects = [(2, surface) for _, surface in solids]
    _, children = gmsh.model.occ.fragment(objects, [(2, medium_box)])
    gmsh.model.occ.synchronize()
    regions: dict[int, list[int]] = {}
    for (tag, _), parts in zip(solids, children):
        regions.setdefault(tag, []).extend(surface for _, surface in parts)
    taken = {surface for surfaces in regions.values() for surface in surfaces}
    regions[MEDIUM] = [surface for _, surface in children[-1] if surface not in taken]
    return regions


def punch(h: float = 0.05, gap: float = 1.0, keep_gmsh: str | os.PathLike | None = None) -> Benchmark:
    """Punch problem of paper §5.3, half model, polygonal (dual) meshes everywhere.

    Geometry (the paper's figure is missing; choices made here): symmetry axis x = 0;
    block [0, 2] x [0, 1] (L x H = 2 x 1 in the half model) tagged :data:`SOLID`; punch =
    quarter of a disc of radius R = 1 centred at (0, 1 + gap + R), i.e. the lower right
    quarter with its flat top at y = 1 + gap + R and its lowest point (0, 1 + gap),
    tagged 3; medium = the box [0, 2] x [1, 1 + gap + R] minus the punch. The default
    gap 1.0 with the paper's u_y = -1.3 gives an indentation of 0.3 of the block.

    Mesh: one gmsh triangle mesh of size ``h`` of all three regions (conforming along
    the curved punch surface), converted by :func:`dual_polygons`; curved boundaries are
    followed by chords (vertices on the arc).

    Named segments: ``fixed`` the block bottom y = 0; ``symmetry`` the axis x = 0 (u_x = 0);
    ``load`` the punch top where u_y is prescribed. Named points: ``punch_tip``
    (0, 1 + gap), ``block_top`` (0, 1).

    ``keep_gmsh``: write the gmsh model to ``<keep_gmsh>.geo`` / ``.msh`` (:func:`write_gmsh`).
    """
    L, H, R = 2.0, 1.0, 1.0
    top = H + gap + R

    def build(gmsh, h: float) -> dict[int, list[int]]:
        block = gmsh.model.occ.addRectangle(0.0, 0.0, 0.0, L, H)
        tool = _occ_sector(gmsh, (0.0, top), R, [0.0, -90.0])
        return _occ_regions(gmsh, [(SOLID, block), (3, tool)], gmsh.model.occ.addRectangle(0.0, H, 0.0, L, gap + R))

    return Benchmark(dual_of_gmsh(build, h, keep_gmsh).to_mesh(), {"block": SOLID, "medium": MEDIUM, "punch": 3},
                     {"punch_tip": (0.0, H + gap), "block_top": (0.0, H)},
                     {"fixed": ((0.0, 0.0), (L, 0.0)), "symmetry": ((0.0, 0.0), (0.0, top)),
                      "load": ((0.0, top), (R, top))})


def multi_object(h: float = 0.04, gap: float = 0.1, keep_gmsh: str | os.PathLike | None = None) -> Benchmark:
    """Contact of multiple objects, paper §5.4, polygonal (dual) meshes everywhere.

    Geometry (the paper's figure is missing; choices made here): block [0, 8] x [0, 0.2]
    tagged :data:`SOLID`; 7 half-discs of radius R = 0.2 above it, centred at
    x_i = 1, 2, ..., 7 and y = 0.2 + gap + R, flat side up, round side down with its lowest
    point ``gap`` above the block, tagged 3; medium = the box [0, 8] x [0.2, 0.2 + gap + R]
    minus the discs (the cavities between all parts).

    Mesh: one gmsh triangle mesh of size ``h``, converted by :func:`dual_polygons`.

    Named segments: ``left_end`` x = 0 and ``right_end`` x = 8 of the block (clamped or
    simply supported); ``disc_top_i`` (i = 1..7) the flat top of disc i where u_y is
    prescribed. Named points: ``disc_tip_i``, the lowest point of disc i.

    ``keep_gmsh``: write the gmsh model to ``<keep_gmsh>.geo`` / ``.msh`` (:func:`write_gmsh`).
    """
    L, T, R, n = 8.0, 0.2, 0.2, 7
    top = T + gap + R
    centres = [L * (i + 1) / (n + 1) for i in range(n)]

    def build(gmsh, h: float) -> dict[int, list[int]]:
        block = gmsh.model.occ.addRectangle(0.0, 0.0, 0.0, L, T)
        discs = [(3, _occ_sector(gmsh, (x, top), R, [0.0, -90.0, -180.0])) for x in centres]
        return _occ_regions(gmsh, [(SOLID, block)] + discs, gmsh.model.occ.addRectangle(0.0, T, 0.0, L, gap + R))

    return Benchmark(dual_of_gmsh(build, h, keep_gmsh).to_mesh(), {"block": SOLID, "medium": MEDIUM, "discs": 3},
                     {f"disc_tip_{i + 1}": (x, T + gap) for i, x in enumerate(centres)},
                     {"left_end": ((0.0, 0.0), (0.0, T)), "right_end": ((L, 0.0), (L, T)),
                      **{f"disc_top_{i + 1}": ((x - R, top), (x + R, top)) for i, x in enumerate(centres)}})


# --------------------------------------------------------------------------- geometries for validating loads
#: how a validation geometry is meshed: duals of gmsh triangles, the triangles themselves, or mapped quads
Polygons = Literal["dual", "triangles", "quads"]


def _unit(angles: np.ndarray) -> np.ndarray:
    """Unit vectors (n, 2) at ``angles`` (radians), components below 1e-15 set to exact zeros (so the
    points at multiples of pi/2 lie exactly on the axes)."""
    vectors = np.stack([np.cos(angles), np.sin(angles)], axis=-1)
    vectors[np.abs(vectors) < 1e-15] = 0.0
    return vectors


def _polar_quads(centre: Sequence[float], radii: np.ndarray, angles: np.ndarray, tag: int) -> PolygonSet:
    """Quadrilaterals between the circles ``radii`` and the rays ``angles`` (both increasing) around
    ``centre``: straight-sided, their vertices on the circles."""
    grid = quad_grid(radii, angles, tag)
    r, t = grid.points.T
    return grid._replace(points=np.asarray(centre) + r[:, None] * _unit(t))


def _quarter_disc_quads(a: float, n: int, m: int, tag: int) -> list[PolygonSet]:
    """Quadrilaterals on the quarter disc R < a, an O-grid in three parts: the square [0, a/2]^2
    of n x n quads and two patches of m x n quads between its sides x = a/2 and y = a/2 and the
    arc, whose 2 n equal segments are those of :func:`_polar_quads` with 2 n angle steps on [0, pi/2]."""
    s = a / 2
    parts = [quad_grid(np.linspace(0.0, s, n + 1), np.linspace(0.0, s, n + 1), tag)]
    for side, first_angle in ((lambda eta: np.stack([np.full_like(eta, s), s * eta], axis=-1), 0.0),
                              (lambda eta: np.stack([s * (1 - eta), np.full_like(eta, s)], axis=-1), np.pi / 4)):
        patch = quad_grid(np.linspace(0.0, 1.0, m + 1), np.linspace(0.0, 1.0, n + 1), tag)
        t, eta = patch.points.T
        rim = a * _unit(first_angle + np.pi / 4 * eta)
        parts.append(patch._replace(points=(1 - t)[:, None] * side(eta) + t[:, None] * rim))
    return parts


def _round_chord_midpoints(polygons: PolygonSet, arcs: Sequence[Arc]) -> PolygonSet:
    """Move the dual's boundary midpoints on chords of the arcs radially onto the circles.

    In a dual polygon (:func:`dual_polygons`) a triangle vertex v on a region boundary is next to the
    midpoints m of its two boundary edges, and to no other point. Where v and the edge's other end
    ``2 m - v`` lie on an arc, m (on the chord) is moved onto the circle: every boundary vertex of
    the polygons then lies on the circle, as every boundary vertex of the triangles did.
    """
    points = polygons.points.copy()
    offsets, flat = csr(polygons.polygons)
    following = flat[next_entries(offsets)]
    v, m = np.concatenate([flat, following]), np.concatenate([following, flat])
    tol = length_tolerance(points)
    for arc in arcs:
        on = arc.contains(points, tol)
        midpoints = np.unique(m[on[v] & ~on[m] & arc.contains(2 * points[m] - points[v], tol)])
        outward = points[midpoints] - np.asarray(arc.centre)
        points[midpoints] = arc.centre + arc.radius * outward / np.linalg.norm(outward, axis=1)[:, None]
    return polygons._replace(points=points)


def _gmsh_polygons(build: GmshBuilder, h: float, polygons: Polygons, arcs: Sequence[Arc],
                   keep_gmsh: str | os.PathLike | None) -> PolygonSet:
    """The gmsh triangles of ``build`` (``polygons = "triangles"``) or their duals with the chord
    midpoints on ``arcs`` rounded onto the circles (``"dual"``)."""
    if polygons == "triangles":
        return gmsh_triangles(build, h, keep_gmsh)
    return _round_chord_midpoints(dual_of_gmsh(build, h, keep_gmsh), arcs)


def _check_polygons_option(polygons: str) -> None:
    if polygons not in ("dual", "triangles", "quads"):
        raise ValueError(f"polygons must be 'dual', 'triangles' or 'quads', got {polygons!r}")


def _check_lengths(**lengths: float) -> None:
    """ValueError naming the first length that is not a finite number > 0."""
    for name, value in lengths.items():
        if not (isinstance(value, (int, float, np.floating)) and np.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a number > 0, got {value!r}")


def _rotated(part: PolygonSet, quarter_turns: int) -> PolygonSet:
    """The part turned by ``quarter_turns`` x 90 degrees about the origin (exact in floating point)."""
    x, y = part.points.T
    for _ in range(quarter_turns):
        x, y = -y, x
    return part._replace(points=np.stack([x, y], axis=1))


def _mirrored(part: PolygonSet) -> PolygonSet:
    """The part reflected in the axis x = 0, its polygons kept counter-clockwise."""
    return PolygonSet(part.points * np.array([-1.0, 1.0]), [p[::-1] for p in part.polygons], part.tags)


def thick_cylinder(a: float = 1.0, b: float = 2.0, h: float = 0.1, *, filled: bool = False, quarter: bool = True,
                   polygons: Polygons = "dual", keep_gmsh: str | os.PathLike | None = None) -> Benchmark:
    """Thick-walled cylinder a < R < b (plane strain) for internal, cavity or follower pressure;
    exact answers in :mod:`dolfinx_sfvem.exact`.

    Geometry: the quarter annulus a < R < b, x >= 0, y >= 0 (``quarter=True``; the symmetry
    conditions u_y = 0 on y = 0 and u_x = 0 on x = 0 are the user's), or the whole annulus.
    With ``filled=True`` the hole R < a is a third-medium region :data:`MEDIUM` named
    ``"cavity"`` (for ``cavity_pressure``), meshed conformingly with the wall.

    Mesh (``polygons``), refining one fixed geometry uniformly with ``h``: the radial sides carry
    ``N = round((b - a) / h)`` equal segments, each quarter of both arcs ``n_theta = 2 k N`` with
    the fixed ``k = round(pi b / (4 (b - a)))`` (outer segments about h), so all counts double
    exactly when N does (h = (b - a) / N);

    * ``"dual"``: dual polygons (:func:`dual_polygons`) of a gmsh Frontal-Delaunay triangle mesh
      of size h with these boundary nodes, the midpoints of its boundary edges on the arcs moved
      radially onto the circles, so every boundary vertex lies on its circle;
    * ``"triangles"``: that triangle mesh itself (for P2 FEM and comparisons);
    * ``"quads"``: straight-sided quadrilaterals between the circles of N equal radial steps and
      ``n_theta`` equal angle steps (not parallelograms: bilinear cells for the Q2 FEM); the hole
      as an O-grid: a square of side a/2 with ``k N`` x ``k N`` quads and two mapped patches of
      ``k N`` x ``k N // 2`` quads between it and the arc.

    The curved boundaries are followed by straight edges between vertices on the circles: an edge
    of length l misses its arc by the sagitta l^2 / (8 R) (its midpoint, where the degree-2 trace
    has its node, lies inside the circle by that much), so the region areas fall short of the exact
    ones by O(h^2) and so does every answer of the discrete problem.

    The whole annulus (``quarter=False``) is the quarter mesh turned by 90, 180 and 270 degrees
    and glued (the symmetric node distribution on the two axes makes the copies match).

    Named points: ``inner_x`` (a, 0), ``inner_y`` (0, a), ``outer_x`` (b, 0), ``outer_y`` (0, b),
    and ``centre`` (0, 0) when filled. Named arcs (:class:`Arc`): ``inner`` (R = a, the cavity
    surface) and ``outer`` (R = b). Named segments (quarter only): ``axis_x`` on y = 0 and
    ``axis_y`` on x = 0, from the centre when filled, else from R = a, to R = b.

    ``keep_gmsh``: write the gmsh model of the quarter to ``<keep_gmsh>.geo`` / ``.msh``
    (:func:`write_gmsh`; not with quads).
    """
    _check_lengths(a=a, b=b, h=h)
    if not b > a:
        raise ValueError(f"outer radius b = {b!r} must exceed inner radius a = {a!r}")
    _check_polygons_option(polygons)
    n_r = n_segments(b - a, h)
    n_theta = 2 * n_r * n_segments(np.pi * b / 4, b - a)
    inner, outer = (Arc((0.0, 0.0), r, 0.0, np.pi / 2 if quarter else 2 * np.pi) for r in (a, b))
    if polygons == "quads":
        angles = np.linspace(0.0, np.pi / 2, n_theta + 1)
        parts = [_polar_quads((0.0, 0.0), np.linspace(a, b, n_r + 1), angles, SOLID)]
        if filled:
            parts += _quarter_disc_quads(a, n_theta // 2, max(1, n_theta // 4), MEDIUM)
    else:
        n_disc = n_r * n_segments(a, b - a)
        parts = [_gmsh_polygons(_cylinder_builder(a, b, filled, n_theta, n_r, n_disc), h, polygons,
                                [inner._replace(end=np.pi / 2), outer._replace(end=np.pi / 2)], keep_gmsh)]
    if not quarter:
        parts = [_rotated(part, k) for k in range(4) for part in parts]
    regions = {"solid": SOLID, "cavity": MEDIUM} if filled else {"solid": SOLID}
    points = {"inner_x": (a, 0.0), "inner_y": (0.0, a), "outer_x": (b, 0.0), "outer_y": (0.0, b)}
    if filled:
        points["centre"] = (0.0, 0.0)
    start = 0.0 if filled else a
    segments = {"axis_x": ((start, 0.0), (b, 0.0)), "axis_y": ((0.0, start), (0.0, b))} if quarter else {}
    return Benchmark(glue(*parts), regions, points, segments, {"inner": inner, "outer": outer})


def _cylinder_builder(a: float, b: float, filled: bool, n_theta: int, n_r: int, n_disc: int) -> GmshBuilder:
    """gmsh builder of the quarter annulus (and the quarter disc R < a when ``filled``) with
    ``n_theta`` segments on each arc, ``n_r`` on the radial sides of the wall, ``n_disc`` on those
    of the disc."""
    def build(gmsh, h: float) -> dict[int, list[int]]:
        geo = gmsh.model.geo
        centre, inner_x, inner_y, outer_x, outer_y = (geo.addPoint(x, y, 0.0, h) for x, y in
                                                      ((0, 0), (a, 0), (0, a), (b, 0), (0, b)))
        inner, outer = geo.addCircleArc(inner_x, centre, inner_y), geo.addCircleArc(outer_x, centre, outer_y)
        axis_x, axis_y = geo.addLine(inner_x, outer_x), geo.addLine(outer_y, inner_y)
        regions = {SOLID: [geo.addPlaneSurface([geo.addCurveLoop([axis_x, outer, axis_y, -inner])])]}
        counts = {inner: n_theta, outer: n_theta, axis_x: n_r, axis_y: n_r}
        if filled:
            to_rim, from_rim = geo.addLine(centre, inner_x), geo.addLine(inner_y, centre)
            regions[MEDIUM] = [geo.addPlaneSurface([geo.addCurveLoop([to_rim, inner, from_rim])])]
            counts.update({to_rim: n_disc, from_rim: n_disc})
        for curve, n in counts.items():
            geo.mesh.setTransfiniteCurve(curve, n + 1)
        geo.synchronize()
        return regions

    return build


def shallow_arch(h: float = 0.01, *, span: float = 1.0, rise: float = 0.1, thickness: float = 0.03,
                 polygons: Polygons = "dual", keep_gmsh: str | os.PathLike | None = None) -> Benchmark:
    """Shallow clamped circular arch for an apex point force: a limit point (snap-through).

    Geometry: the mid-surface is the circular arc through (-span/2, 0), (0, rise) and (span/2, 0),
    of radius ``R = (span^2/4 + rise^2) / (2 rise)`` about ``(0, rise - R)`` and half-angle
    ``asin(span / (2 R))``; the arch is the band R -/+ thickness/2 about it, cut at its ends along
    radii (the clamped faces). The defaults (span 1, rise 0.1, thickness 0.03: rise over radius of
    gyration 11.5) are the classical clamped shallow arch under a central point force, chosen
    where the symmetric limit point comes well before any antisymmetric bifurcation
    (docs/validation-loads.md).

    Mesh: the half x >= 0 meshed (``polygons`` as in :func:`thick_cylinder`: duals of gmsh
    triangles of size h, their chord midpoints rounded onto the arcs, the triangles, or quads
    between circles and rays) and mirrored, so the mesh is symmetric about x = 0; the ends and
    the axis carry ``N = round(thickness / h)`` equal segments, the top and bottom arcs of the half
    ``N round(R_top * half-angle / thickness)`` (all counts double exactly with N). Curved sides
    are followed by chords (O(h^2) geometric error, see :func:`thick_cylinder`).

    Named points: ``apex`` (0, rise + thickness/2) on the top surface, where the force acts, and
    ``apex_bottom`` (0, rise - thickness/2). Named segments: ``left_end``, ``right_end``, the
    clamped faces. Named arcs: ``top`` and ``bottom`` surfaces.

    ``keep_gmsh``: write the gmsh model of the half to ``<keep_gmsh>.geo`` / ``.msh`` (not with quads).
    """
    _check_lengths(h=h, span=span, rise=rise, thickness=thickness)
    _check_polygons_option(polygons)
    R = (span ** 2 / 4 + rise ** 2) / (2 * rise)
    if not (rise < span / 2 and thickness < R):
        raise ValueError(f"shallow_arch: rise {rise!r} must be below span/2 = {span / 2!r} and thickness "
                         f"{thickness!r} below the mid-surface radius {R!r}")
    centre = (0.0, rise - R)
    half_angle = float(np.arcsin(span / (2 * R)))
    radii = (R - thickness / 2, R + thickness / 2)
    n_t = n_segments(thickness, h)
    n_arc = n_t * n_segments(radii[1] * half_angle, thickness)
    bottom, top = (Arc(centre, r, np.pi / 2 - half_angle, np.pi / 2 + half_angle) for r in radii)
    if polygons == "quads":
        half = _polar_quads(centre, np.linspace(*radii, n_t + 1),
                            np.linspace(np.pi / 2 - half_angle, np.pi / 2, n_arc + 1), SOLID)
    else:
        half = _gmsh_polygons(_arch_builder(centre, radii, half_angle, n_arc, n_t), h, polygons, [bottom, top],
                              keep_gmsh)
    ends = [tuple(map(tuple, np.asarray(centre) + np.outer(radii, _unit(np.array([angle]))[0])))
            for angle in (np.pi / 2 + half_angle, np.pi / 2 - half_angle)]
    return Benchmark(glue(half, _mirrored(half)), {"solid": SOLID},
                     {"apex": (0.0, centre[1] + radii[1]), "apex_bottom": (0.0, centre[1] + radii[0])},
                     {"left_end": ends[0], "right_end": ends[1]}, {"top": top, "bottom": bottom})


def _arch_builder(centre: tuple[float, float], radii: tuple[float, float], half_angle: float, n_arc: int,
                  n_t: int) -> GmshBuilder:
    """gmsh builder of the right half (x >= 0) of the arch band ``radii`` about ``centre``."""
    def build(gmsh, h: float) -> dict[int, list[int]]:
        geo = gmsh.model.geo
        cx, cy = centre
        hub = geo.addPoint(cx, cy, 0.0, h)
        ends = [geo.addPoint(cx + r * np.sin(half_angle), cy + r * np.cos(half_angle), 0.0, h) for r in radii]
        apexes = [geo.addPoint(cx, cy + r, 0.0, h) for r in radii]
        bottom, top = (geo.addCircleArc(end, hub, apex) for end, apex in zip(ends, apexes))
        end, axis = geo.addLine(ends[0], ends[1]), geo.addLine(apexes[1], apexes[0])
        for curve, n in ((bottom, n_arc), (top, n_arc), (end, n_t), (axis, n_t)):
            geo.mesh.setTransfiniteCurve(curve, n + 1)
        surface = geo.addPlaneSurface([geo.addCurveLoop([end, top, axis, -bottom])])
        geo.synchronize()
        return {SOLID: [surface]}

    return build


# --------------------------------------------------------------------------- a soft pneumatic actuator
#: region tag of the actuator's strain-limiting base layer; its chambers are tagged from
#: :data:`FIRST_CHAMBER` on, one tag per chamber
BASE_LAYER = 3
FIRST_CHAMBER = 4


@dataclasses.dataclass(frozen=True)
class PneuNet:
    """Proportions of a PneuNet bending actuator in its length-height plane (mm).

    Defaults: the PneuNets bending actuator of the Soft Robotics Toolkit (Harvard Biodesign Lab,
    softroboticstoolkit.com, "PneuNets Bending Actuators", Mold Design CAD Tutorial), a fast
    PneuNet in the sense of Mosadegh et al. 2014 (Adv. Funct. Mater. 24, 2163): chambers 8 mm
    long and 15 mm high, 1 mm sidewalls (the walls facing the neighbouring chambers), the other
    walls 2 mm, 2 mm between neighbouring chambers, 11 chambers. The toolkit's strain-limiting
    layer (paper embedded in a cast elastomer plate) is modelled as one stiff layer of thickness
    ``base`` under the main body (our choice: 1 mm).

    Attributes
    ----------
    length, height : float
        Outer length (along the actuator) and height (above the base layer) of one chamber.
    sidewall : float
        Thickness of the walls between neighbouring chambers.
    wall : float
        Thickness of the chambers' roofs and of the main body's floor under them.
    spacing : float
        Gap between the sidewalls of neighbouring chambers.
    base : float
        Thickness of the strain-limiting base layer.
    """

    length: float = 8.0
    height: float = 15.0
    sidewall: float = 1.0
    wall: float = 2.0
    spacing: float = 2.0
    base: float = 1.0

    def check(self) -> None:
        """ValueError naming the first length that is not > 0 or a cavity that does not fit."""
        _check_lengths(**dataclasses.asdict(self))
        if not (2 * self.sidewall < self.length and 2 * self.wall < self.height):
            raise ValueError(f"PneuNet: the walls leave no cavity: 2 x sidewall {self.sidewall!r} must be below "
                             f"length {self.length!r} and 2 x wall {self.wall!r} below height {self.height!r}")

    def chamber_x(self, i: int) -> tuple[float, float]:
        """Left and right outer side x of chamber i (0-based; chamber 0 at the clamped end x = 0)."""
        left = i * (self.length + self.spacing)
        return left, left + self.length

    def actuator_length(self, n_chambers: int) -> float:
        return self.chamber_x(n_chambers - 1)[1]

    @property
    def floor(self) -> float:
        """y of the floor's top: the bottom of the cavities and of the gaps between chambers."""
        return self.base + self.wall

    @property
    def top(self) -> float:
        """y of the chambers' tops."""
        return self.base + self.height

    def cavity(self, i: int) -> tuple[float, float, float, float]:
        """Cavity of chamber i as (x0, x1, y0, y1)."""
        left, right = self.chamber_x(i)
        return left + self.sidewall, right - self.sidewall, self.floor, self.top - self.wall

    def gap(self, i: int) -> tuple[float, float, float, float]:
        """The gap between chambers i and i + 1 as (x0, x1, y0, y1), open at the top."""
        return self.chamber_x(i)[1], self.chamber_x(i + 1)[0], self.floor, self.top

    def body_outline(self, n_chambers: int) -> list[tuple[float, float]]:
        """Counter-clockwise outline of the elastomer body (floor and chambers, a comb)."""
        L = self.actuator_length(n_chambers)
        outline = [(0.0, self.base), (L, self.base)]
        for i in reversed(range(n_chambers)):
            left, right = self.chamber_x(i)
            if i < n_chambers - 1:
                outline.append((right, self.floor))
            outline += [(right, self.top), (left, self.top)]
            if i > 0:
                outline.append((left, self.floor))
        return outline


def _rectangle(x0: float, x1: float, y0: float, y1: float) -> list[tuple[float, float]]:
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


def pneumatic_actuator(h: float = 0.5, n_chambers: int = 11, *, geometry: PneuNet = PneuNet(),
                       medium_refinement: int = 2, keep_gmsh: str | os.PathLike | None = None) -> Benchmark:
    """A PneuNet soft bending actuator in plane strain (the length-height section): an elastomer
    body of closed chambers in a row on a strain-limiting base layer, the chambers filled with third
    medium (for ``cavity_pressure``), the gaps between neighbouring chambers too (through them the
    bulging sidewalls come into contact).

    Geometry (:class:`PneuNet`, mm; defaults after the Soft Robotics Toolkit's PneuNet, Mosadegh et
    al. 2014): x along the actuator, clamped end x = 0, free end x = L = n (length + spacing) -
    spacing. Base layer [0, L] x [0, base]; on it the body: a floor [0, L] x [base, base + wall]
    and the chambers [x_i, x_i + length] x [base, base + height], x_i = i (length + spacing), each
    with the cavity [x_i + sidewall, x_i + length - sidewall] x [base + wall, base + height - wall];
    between chambers i and i + 1 the gap [x_i + length, x_(i+1)] x [base + wall, base + height],
    open at the top.

    Mesh: the body and the base layer are duals (:func:`dual_polygons`) of gmsh triangle meshes of
    size ``h`` whose straight sides carry ``round(length / h)`` equal segments, glued along y = base;
    each cavity is a grid of quads of about h (the solid's interface midpoints hang in them), each
    gap a grid of quads ``medium_refinement`` times finer (``axis_nodes``; 2: the quads end at the
    sidewalls' dual midpoints too).

    Regions: ``"elastomer"`` :data:`SOLID`, ``"gaps"`` :data:`MEDIUM`, ``"base"`` :data:`BASE_LAYER`,
    ``"chamber_1"`` ... ``"chamber_n"`` tags :data:`FIRST_CHAMBER` + 0 ... n - 1 (each enclosed by
    the body). Named points: ``clamp_bottom`` (0, 0), ``clamp_top`` (0, base + height),
    ``tip_bottom`` (L, 0), ``tip_top`` (L, base + height) (the corners of the end faces), and
    ``gap_i_left`` / ``gap_i_right`` (i = 1 ... n - 1) the mid-height points of the two sidewalls
    facing each other across gap i. Named segments: ``clamp`` (x = 0) and ``tip`` (x = L).

    ``keep_gmsh``: write the body's gmsh model to ``<keep_gmsh>.geo`` / ``.msh`` (:func:`write_gmsh`).
    """
    _check_lengths(h=h)
    geometry.check()
    if not (isinstance(n_chambers, (int, np.integer)) and n_chambers >= 1):
        raise ValueError(f"n_chambers must be an integer >= 1, got {n_chambers!r}")
    if int(medium_refinement) != medium_refinement or medium_refinement < 1:
        raise ValueError(f"medium_refinement must be a positive integer, got {medium_refinement!r}")
    g, n = geometry, int(n_chambers)
    L = g.actuator_length(n)
    cavities, gaps = [g.cavity(i) for i in range(n)], [g.gap(i) for i in range(n - 1)]
    parts = [dual_of_gmsh(straight_region([g.body_outline(n)] + [_rectangle(*c) for c in cavities], SOLID), h,
                          keep_gmsh),
             dual_of_gmsh(straight_region([_rectangle(0.0, L, 0.0, g.base)], BASE_LAYER), h)]
    parts += [quad_grid(axis_nodes([x0, x1], h), axis_nodes([y0, y1], h), FIRST_CHAMBER + i)
              for i, (x0, x1, y0, y1) in enumerate(cavities)]
    parts += [quad_grid(axis_nodes([x0, x1], h, medium_refinement), axis_nodes([y0, y1], h, medium_refinement),
                        MEDIUM) for x0, x1, y0, y1 in gaps]
    regions = {"elastomer": SOLID, "gaps": MEDIUM, "base": BASE_LAYER,
               **{f"chamber_{i + 1}": FIRST_CHAMBER + i for i in range(n)}}
    middle = 0.5 * (g.floor + g.top)
    points = {"clamp_bottom": (0.0, 0.0), "clamp_top": (0.0, g.top), "tip_bottom": (L, 0.0), "tip_top": (L, g.top)}
    for i, (x0, x1, _, _) in enumerate(gaps):
        points.update({f"gap_{i + 1}_left": (x0, middle), f"gap_{i + 1}_right": (x1, middle)})
    return Benchmark(glue(*parts), regions, points, {"clamp": ((0.0, 0.0), (0.0, g.top)), "tip": ((L, 0.0), (L, g.top))})
