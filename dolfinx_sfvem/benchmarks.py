"""The paper's benchmark geometries, meshed: C-box (§5.2, dual polygons or quads), box with
cavity (§5.3), punch (§5.4) and several objects (§5.5), each with the named points and boundary
segments its demo needs.

Each generator that needs gmsh runs its own gmsh session, so do not call one while holding a gmsh
session of your own open — use ``meshes.from_gmsh(None)`` to read your current model instead.
"""
from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt

from .meshing.gmsh_duals import dual_of_gmsh, straight_region
from .meshing.grids import axis_nodes, quad_grid
from .meshing.polygon_sets import glue
from .polygon_mesh import PolygonMesh


#: region tag of the solid bodies (further solids: 3, 4, ...)
SOLID = 1


#: region tag of the third medium
MEDIUM = 2


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
    """

    mesh: PolygonMesh
    regions: dict[str, int]
    points: dict[str, tuple[float, float]]
    segments: dict[str, tuple[tuple[float, float], tuple[float, float]]]

    def __post_init__(self):
        self.mesh.region_names = dict(self.regions)

    def vertex(self, name: str) -> int:
        """Index of the mesh vertex at the named point (ValueError if there is none)."""
        distance = np.linalg.norm(self.mesh.points - np.asarray(self.points[name]), axis=1)
        index = int(np.argmin(distance))
        if distance[index] > self.mesh.tol:
            raise ValueError(f"named point {name!r} {self.points[name]} is not a mesh vertex")
        return index

    def vertices_on(self, name: str) -> np.ndarray:
        """Indices (k,) of the mesh vertices on the named segment."""
        points = self.mesh.points
        a, b = (np.asarray(p, dtype=np.float64) for p in self.segments[name])
        s = np.clip((points - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
        distance = np.linalg.norm(points - (a + s[:, None] * (b - a)), axis=1)
        return np.flatnonzero(distance <= self.mesh.tol)


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
    :meth:`~dolfinx_sfvem.fem.LagrangeDiscretization.from_polygon_mesh` with ``fem_mesh``.
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
