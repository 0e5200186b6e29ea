"""The 3D benchmark geometries, meshed as :class:`~dolfinx_sfvem.mesh.cell_mesh.CellMesh`: the 3D C-box of
Wriggers et al. 2025, the quarter Hertz model of Xu, Xue & Wriggers 2026, 1/8 of a thick spherical
shell (exact answers in :mod:`dolfinx_sfvem.exact`) and a 3D PneuNet bellow; each with the named
points and surfaces its demo needs.

Structured geometries (C-box, PneuNet) are tensor-product grids of hexahedra (or of those split
into tetrahedra), made identically on every rank without gmsh; the curved ones (Hertz, thick
sphere) are gmsh tetrahedra, meshed identically on every rank (:mod:`dolfinx_sfvem.meshing.gmsh3d`).
Tags: :data:`SOLID` = 1 and :data:`MEDIUM` = 2 as in 2D, further solids 3, 4, ...
"""
from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Callable, Sequence
from typing import NamedTuple, Union

import numpy as np
import scipy.spatial

from dolfinx_sfvem.meshing.benchmarks import BASE_LAYER, FIRST_CHAMBER, MEDIUM, SOLID, PneuNet, _check_lengths
from dolfinx_sfvem.mesh.cell_mesh import CellMesh
from dolfinx_sfvem.meshing.gmsh3d import graded_size, gmsh_tetrahedra, size_field
from dolfinx_sfvem.meshing.grids import axis_nodes
from dolfinx_sfvem.meshing.hexahedra import GridCell, box_grid
from dolfinx_sfvem.meshing.octree import octree_box
from dolfinx_sfvem.meshing.octree_tetrahedra import octree_under_tetrahedra
from dolfinx_sfvem.mesh.polyhedron_mesh import PolyhedronMesh

Point3 = tuple[float, float, float]

#: relative tolerance (times the bounding-box diagonal) of the named points and surfaces
REL_TOL = 1e-9


class Plane(NamedTuple):
    """The plane through ``point`` with normal ``normal``, limited to the disc of ``radius`` about
    ``point`` (default: unlimited)."""

    point: Point3
    normal: Point3
    radius: float = math.inf

    def contains(self, x: np.ndarray, tol: float) -> np.ndarray:
        """Whether each point of ``x`` (n, 3) lies on the plane (within ``tol``) and the disc."""
        normal = np.asarray(self.normal, dtype=np.float64)
        d = x - np.asarray(self.point, dtype=np.float64)
        height = d @ normal / np.linalg.norm(normal)
        return (np.abs(height) <= tol) & (np.linalg.norm(d, axis=1) <= self.radius + tol)


class SphereSurface(NamedTuple):
    """The sphere of ``radius`` about ``centre``."""

    centre: Point3
    radius: float

    def contains(self, x: np.ndarray, tol: float) -> np.ndarray:
        """Whether each point of ``x`` (n, 3) lies on the sphere (within ``tol``)."""
        return np.abs(np.linalg.norm(x - np.asarray(self.centre), axis=1) - self.radius) <= tol


Surface = Union[Plane, SphereSurface]


@dataclasses.dataclass(frozen=True)
class Benchmark3D:
    """A meshed 3D benchmark with the named points and surfaces its demo needs.

    Attributes
    ----------
    mesh : CellMesh or PolyhedronMesh
        Cells tagged :data:`SOLID`, :data:`MEDIUM`, ...; its ``region_names`` are ``regions``.
    regions : dict name -> tag
        Region tags by body name.
    points : dict name -> (x, y, z)
        Named points; each is a mesh vertex.
    surfaces : dict name -> Plane or SphereSurface
        Named boundary surfaces (clamped faces, symmetry planes, loaded faces). Curved surfaces
        are followed by flat cell faces whose vertices lie on them.
    tol : float
        Length tolerance of the named points and surfaces (:data:`REL_TOL` x bounding-box diagonal).
    """

    mesh: CellMesh | PolyhedronMesh
    regions: dict[str, int]
    points: dict[str, Point3]
    surfaces: dict[str, Surface]
    tol: float = dataclasses.field(init=False)

    def __post_init__(self):
        self.mesh.region_names = dict(self.regions)
        extent = np.ptp(self.mesh.points, axis=0)
        object.__setattr__(self, "tol", REL_TOL * float(np.linalg.norm(extent)))

    def vertex(self, name: str) -> int:
        """Index of the mesh vertex at the named point (ValueError if there is none)."""
        distance = np.linalg.norm(self.mesh.points - np.asarray(self.points[name]), axis=1)
        index = int(np.argmin(distance))
        if distance[index] > self.tol:
            raise ValueError(f"named point {name!r} {self.points[name]} is not a mesh vertex")
        return index

    def _surface(self, name: str) -> Surface:
        if name not in self.surfaces:
            raise KeyError(f"no surface named {name!r}; surfaces {sorted(self.surfaces)}")
        return self.surfaces[name]

    def vertices_on(self, name: str) -> np.ndarray:
        """Indices (k,) of the mesh vertices on the named surface."""
        return np.flatnonzero(self._surface(name).contains(self.mesh.points, self.tol))

    def nodes_on(self, name: str) -> np.ndarray:
        """Coordinates (k, 3) of the nodes on the named surface, sorted: its vertices, the midpoints
        of the cell edges between two of them, and the centres (vertex means) of the cell faces
        whose corners are all on it: the degree-2 nodes of P2 and Q2 (a hexahedron's face centre)
        and the SFVEM's face-mean nodes (at the face centroids: a triangle's or a parallelogram's
        vertex mean; on a :class:`PolyhedronMesh` the faces' centroids, where the SFVEM's fans
        start on convex faces), which a boundary condition on the surface must hold too. On a
        curved surface the midpoints and centres lie off it (on the flat faces), unless the mesh has
        degree-2 geometry: there the edges' and quadrilaterals' nodes are the geometry's
        (:meth:`~dolfinx_sfvem.mesh.cell_mesh.CellMesh.edge_midpoints`, ``face_centres``), on the surface."""
        mesh = self.mesh
        on = self._surface(name).contains(mesh.points, self.tol)
        if isinstance(mesh, PolyhedronMesh):
            edges = mesh.edges()
            midpoints = mesh.points[edges].mean(axis=1)
            centres = mesh.face_centroids[np.logical_and.reduceat(on[mesh.face_vertices], mesh.face_offsets[:-1])]
        else:
            edges, faces = _cell_edges_and_faces(mesh)
            midpoints = mesh.edge_midpoints(edges[:, 0], edges[:, 1])
            faces = faces[on[faces].all(axis=1)]
            centres = mesh.face_centres(faces) if faces.shape[1] == 4 else mesh.points[faces].mean(axis=1)
        nodes = [mesh.points[on], midpoints[on[edges].all(axis=1)], centres]
        return np.unique(np.concatenate(nodes), axis=0)

    def marker(self, name: str) -> Callable[[np.ndarray], np.ndarray]:
        """Marker function of the named surface's nodes (:meth:`nodes_on`), for the
        ``where`` of :class:`~dolfinx_sfvem.ContactProblem`: coordinates (3, n) -> (n,) bool."""
        tree, tol = scipy.spatial.cKDTree(self.nodes_on(name)), self.tol

        def on_surface(x: np.ndarray) -> np.ndarray:
            distance, _ = tree.query(np.asarray(x, dtype=np.float64).T, distance_upper_bound=2 * tol)
            return distance <= tol

        return on_surface


#: local vertex pairs of the edges and local vertex triples or quadruples (cyclic) of the faces of each cell type
_EDGES = {"tetrahedron": [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)],
          "hexahedron": [(0, 1), (2, 3), (4, 5), (6, 7), (0, 2), (1, 3), (4, 6), (5, 7),
                         (0, 4), (1, 5), (2, 6), (3, 7)]}
_FACES = {"tetrahedron": [(0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)],
          "hexahedron": [(0, 1, 3, 2), (4, 5, 7, 6), (0, 1, 5, 4), (2, 3, 7, 6), (0, 2, 6, 4), (1, 3, 7, 5)]}


def _cell_edges_and_faces(mesh: CellMesh) -> tuple[np.ndarray, np.ndarray]:
    """Distinct cell edges (e, 2) and faces (f, 3) or (f, 4) of the mesh (vertex indices)."""
    edges = np.sort(mesh.cells[:, _EDGES[mesh.cell_type]].reshape(-1, 2), axis=1)
    faces = mesh.cells[:, _FACES[mesh.cell_type]].reshape(-1, len(_FACES[mesh.cell_type][0]))
    _, first = np.unique(np.sort(faces, axis=1), axis=0, return_index=True)
    return np.unique(edges, axis=0), faces[first]


# --------------------------------------------------------------------------- the 3D C-box
#: 3D C-box of Wriggers et al. 2025 (dolfiny's Cbox_Wriggers_3D): length, width, height, wall
CBOX3D_L, CBOX3D_W, CBOX3D_H, CBOX3D_T = 2.0, 0.7, 0.7, 0.1


def _cbox3d_tags(cx: np.ndarray, cy: np.ndarray, cz: np.ndarray) -> np.ndarray:
    """Medium where x > T and T < z < H - T (the inside of the C, extruded along y), else solid."""
    T, H = CBOX3D_T, CBOX3D_H
    return np.where((cx > T) & (cz > T) & (cz < H - T), MEDIUM, SOLID)


#: the part of the 3D C-box that ``cbox3d(tip_refinement=k)`` refines: the last CBOX3D_TIP_X of the
#: beams in x and the CBOX3D_TIP_Y next to the moved corner's face y = 0 in y (the medium under the
#: upper beam's tip corner, where the point contact squeezes it hardest)
CBOX3D_TIP_X, CBOX3D_TIP_Y = 0.4, 0.35


def split_intervals(axis: np.ndarray, lo: float, hi: float, k: int) -> np.ndarray:
    """The grid lines ``axis`` (increasing) with every interval that lies in [lo, hi] split into ``k``
    equal ones (k >= 1; k = 1 returns ``axis`` unchanged)."""
    a, b = axis[:-1], axis[1:]
    inside = (a >= lo - 1e-12) & (b <= hi + 1e-12)
    t = np.arange(1, k) / k
    extra = (a[inside, None] + t[None, :] * (b - a)[inside, None]).ravel()
    return np.sort(np.concatenate([axis, extra]))


def cbox3d(n: Sequence[int] | None = None, h: float | None = None,
           cell: GridCell = "hexahedron", tip_refinement: int = 1) -> Benchmark3D:
    """The 3D C-box of Wriggers et al. 2025 (Comput Mech, doi 10.1007/s00466-025-02628-y), as in
    dolfiny's ``demo/tmc/3D/Cbox_Wriggers_3D.py``.

    Geometry: the box [0, 2] x [0, 0.7] x [0, 0.7]; the C lies in the x-z plane and is extruded
    along y: a wall x <= 0.1 and two beams z <= 0.1 and z >= 0.6 (:data:`SOLID`); the medium
    (:data:`MEDIUM`) fills x >= 0.1, 0.1 <= z <= 0.6, open at x = 2 and at y = 0 and y = 0.7.

    Mesh: a tensor-product grid, ``n = (nx, ny, nz)`` equal cells per side (default (40, 14, 14),
    dolfiny's), or of size about ``h`` with the grid lines on x = 0.1, z = 0.1 and z = 0.6
    (``axis_nodes``; h = 0.05 gives 40 x 14 x 14); hexahedra, or each split into 6 tetrahedra
    (``cell="tetrahedron"``). With ``n``, the wall and beam faces must fall on grid lines.
    ``tip_refinement = k`` splits into k the grid intervals within :data:`CBOX3D_TIP_X` of x = 2 and
    within :data:`CBOX3D_TIP_Y` of y = 0 (whole grid planes: a tensor grid stays one), so the cells
    under the moved corner are k times smaller in x and y.

    Named points: ``load`` (2, 0, 0.7), the corner moved by (0, 0.5, -2.0) (line contact) or
    (0, 0.25, -1.0) (point contact); ``gap_top`` (2, 0, 0.6) and ``gap_bottom`` (2, 0, 0.1), the
    beam tips' inner corners on y = 0. Named surfaces: ``clamp``, the face x = 0.
    """
    L, W, H, T = CBOX3D_L, CBOX3D_W, CBOX3D_H, CBOX3D_T
    if n is not None and h is not None:
        raise ValueError("cbox3d: give the cell counts n or the size h, not both")
    if h is not None:
        _check_lengths(h=h)
        xs, ys, zs = axis_nodes([0.0, T, L], h), axis_nodes([0.0, W], h), axis_nodes([0.0, T, H - T, H], h)
    else:
        n = (40, 14, 14) if n is None else n
        if not (len(n) == 3 and all(isinstance(k, (int, np.integer)) and k >= 1 for k in n)):
            raise ValueError(f"cbox3d: n must be three integers >= 1, got {n!r}")
        xs, ys, zs = (np.linspace(0.0, length, k + 1) for length, k in zip((L, W, H), n))
        for axis, value, name in ((xs, T, "x"), (zs, T, "z"), (zs, H - T, "z")):
            if np.abs(axis - value).min() > 1e-9:
                raise ValueError(f"cbox3d: n = {tuple(n)} puts no grid line on {name} = {value:g} (the C's wall)")
            axis[np.argmin(np.abs(axis - value))] = value
    if not (isinstance(tip_refinement, (int, np.integer)) and tip_refinement >= 1):
        raise ValueError(f"cbox3d: tip_refinement must be an integer >= 1, got {tip_refinement!r}")
    xs = split_intervals(xs, L - CBOX3D_TIP_X, L, tip_refinement)
    ys = split_intervals(ys, 0.0, CBOX3D_TIP_Y, tip_refinement)
    mesh = box_grid(xs, ys, zs, _cbox3d_tags, {}, cell)
    return Benchmark3D(mesh, {"solid": SOLID, "medium": MEDIUM},
                       {"load": (L, 0.0, H), "gap_top": (L, 0.0, H - T), "gap_bottom": (L, 0.0, T)},
                       {"clamp": Plane((0.0, 0.0, 0.0), (1.0, 0.0, 0.0))})


# --------------------------------------------------------------------------- the Hertz sphere
#: quarter Hertz model (dolfiny's Hertz_Wriggers_3D): block side in x and y, block height, sphere radius
HERTZ3D_L, HERTZ3D_H, HERTZ3D_R = 2.0, 1.0, 1.0

#: region tag of the Hertz model's sphere
SPHERE = 3


def hertz3d(h_contact: float = 0.05, h_far: float = 0.25, gap: float = 0.1, *, fine_radius: float = 0.8,
            h_core: float | None = None, core_radius: float = 0.3, keep_gmsh: str | os.PathLike | None = None
            ) -> Benchmark3D:
    """Quarter model of a stiff sphere pressed into a block across a gap filled with third medium
    (Xu, Xue & Wriggers, JMPS 2026, doi 10.1016/j.jmps.2026.106617; as dolfiny's
    ``demo/tmc/3D/Hertz_Wriggers_3D.py``).

    Geometry (symmetry planes x = 0 and y = 0): the block [0, 2] x [0, 2] x [0, 1] (:data:`SOLID`,
    "block"); the lower quarter hemisphere of radius R = 1 about (0, 0, 1 + gap + R), its lowest
    point ``gap`` above the block and its flat top on z = 1 + gap + R (:data:`SPHERE` = 3,
    "sphere"); the medium fills the box [0, 2] x [0, 2] x [1, 1 + gap + R] around the sphere
    (:data:`MEDIUM`, "medium").

    Mesh: gmsh tetrahedra of size ``h_contact`` within ``fine_radius`` of the contact point
    (0, 0, 1 + gap / 2), growing linearly to ``h_far`` over a shell of width 0.5 beyond
    (:func:`~dolfinx_sfvem.meshing.gmsh3d.size_field`); with ``h_core`` also size ``h_core`` within
    ``core_radius`` of that point (the squeezed medium layer, the block's top and the sphere's tip
    under the contact zone), growing to ``h_contact`` over a shell of width ``core_radius``. The
    sphere's surface is followed by flat
    triangles whose vertices lie on it.

    Named points: ``sphere_tip`` (0, 0, 1 + gap), ``block_top`` (0, 0, 1). Named surfaces:
    ``bottom`` z = 0 (clamped), ``symmetry_x`` x = 0, ``symmetry_y`` y = 0 (the planes of the
    symmetry conditions u_x = 0 and u_y = 0), ``sphere_top`` the sphere's flat top (where u_z is
    prescribed), ``block_top`` z = 1 (the block's contact surface), ``sphere`` its curved surface.

    ``keep_gmsh``: also write the mesh to ``<keep_gmsh>.msh``.
    """
    _check_lengths(h_contact=h_contact, h_far=h_far, gap=gap, fine_radius=fine_radius, core_radius=core_radius)
    core = _hertz_core(h_contact, h_core, core_radius)

    def build(gmsh) -> dict[int, list[int]]:
        regions = _hertz_bodies(gmsh, gap, block=True)
        size_field(gmsh, h_contact, h_far, (0.0, 0.0, HERTZ3D_H + gap / 2), fine_radius, HERTZ3D_GROWTH, core)
        return regions

    return _hertz_benchmark(gmsh_tetrahedra(build, HERTZ3D_REGIONS, keep_gmsh), gap)


def hertz3d_octree(h_contact: float = 0.0625, h_far: float = 0.25, gap: float = 0.1, *, fine_radius: float = 0.8,
                   h_core: float | None = None, core_radius: float = 0.3) -> Benchmark3D:
    """The quarter Hertz model of :func:`hertz3d` with an octree block: the block's cubes refined
    toward the contact, the medium and the sphere gmsh tetrahedra conforming to the octree's top
    (:func:`~dolfinx_sfvem.meshing.octree_tetrahedra.octree_under_tetrahedra`), all as a
    :class:`~dolfinx_sfvem.mesh.polyhedron_mesh.PolyhedronMesh` for the SFVEM (``method="vem"``).

    The block starts from 2 x 2 x 1 unit cubes; a cube is split (with 2:1 balance across faces
    and edges) while its edge exceeds the size :func:`hertz3d`'s size field asks at the cube's
    point nearest the field's centre (0, 0, 1 + gap / 2). The cubes end at the largest size
    2**-k within that size: with ``h_contact``, ``h_far`` and ``h_core`` powers of 1/2 the cubes
    near the contact have size ``h_contact`` (``h_core``), the far ones ``h_far``, like the
    tetrahedra above them (gmsh gets the field as given). A coarse cube next to finer ones is one
    polyhedron with hanging vertices; the top layer's cubes have the gmsh triangles inside their
    top squares as faces, and the gmsh nodes on their top edges as further vertices.

    Parameters, regions, named points and surfaces: as :func:`hertz3d`.
    """
    _check_lengths(h_contact=h_contact, h_far=h_far, gap=gap, fine_radius=fine_radius, core_radius=core_radius)
    core = _hertz_core(h_contact, h_core, core_radius)
    L, H = HERTZ3D_L, HERTZ3D_H
    centre = np.array([0.0, 0.0, H + gap / 2])

    def size(lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
        nearest = np.clip(centre[:, None], lower, upper)
        return graded_size(np.linalg.norm(nearest - centre[:, None], axis=0), h_contact, h_far, fine_radius,
                           HERTZ3D_GROWTH, core)

    def build(gmsh) -> dict[int, list[int]]:
        regions = _hertz_bodies(gmsh, gap, block=False)
        size_field(gmsh, h_contact, h_far, tuple(centre), fine_radius, HERTZ3D_GROWTH, core)
        return regions

    octree = octree_box((0.0, 0.0, 0.0), (L, L, H), (2, 2, 1)).refine_to(size)
    return _hertz_benchmark(octree_under_tetrahedra(octree, build, HERTZ3D_REGIONS, SOLID), gap)


#: the Hertz model's regions
HERTZ3D_REGIONS = {"block": SOLID, "medium": MEDIUM, "sphere": SPHERE}
#: width of the shell over which the Hertz meshes grow from h_contact to h_far
HERTZ3D_GROWTH = 0.5


def _hertz_core(h_contact: float, h_core: float | None, core_radius: float) -> tuple[float, float, float] | None:
    """The ``core`` of :func:`~dolfinx_sfvem.meshing.gmsh3d.size_field` for h_core (checked)."""
    if h_core is None:
        return None
    _check_lengths(h_core=h_core)
    if h_core >= h_contact:
        raise ValueError(f"h_core ({h_core}) must be smaller than h_contact ({h_contact})")
    return h_core, core_radius, core_radius


def _hertz_bodies(gmsh, gap: float, block: bool) -> dict[int, list[int]]:
    """The Hertz model's volumes in the OpenCASCADE kernel (synchronised): the block (if ``block``),
    the medium's box around the sphere, the sphere; {tag: volumes}."""
    L, H, R = HERTZ3D_L, HERTZ3D_H, HERTZ3D_R
    occ = gmsh.model.occ
    objects = [(3, occ.addBox(0.0, 0.0, 0.0, L, L, H))] if block else []
    objects.append((3, occ.addBox(0.0, 0.0, H, L, L, gap + R)))
    sphere = occ.addSphere(0.0, 0.0, H + gap + R, R, angle1=-math.pi / 2, angle2=0.0, angle3=math.pi / 2)
    _, children = occ.fragment(objects, [(3, sphere)])
    occ.synchronize()
    sphere_parts = [v for _, v in children[-1]]
    regions = {SOLID: [v for _, v in children[0]]} if block else {}
    regions.update({SPHERE: sphere_parts, MEDIUM: [v for _, v in children[-2] if v not in sphere_parts]})
    return regions


def _hertz_benchmark(mesh: CellMesh | PolyhedronMesh, gap: float) -> Benchmark3D:
    """The Hertz model's mesh with its regions, named points and surfaces."""
    H, R = HERTZ3D_H, HERTZ3D_R
    top = H + gap + R
    return Benchmark3D(mesh, dict(HERTZ3D_REGIONS), {"sphere_tip": (0.0, 0.0, H + gap), "block_top": (0.0, 0.0, H)},
                       {"bottom": Plane((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
                        "symmetry_x": Plane((0.0, 0.0, 0.0), (1.0, 0.0, 0.0)),
                        "symmetry_y": Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
                        "sphere_top": Plane((0.0, 0.0, top), (0.0, 0.0, 1.0), R),
                        "block_top": Plane((0.0, 0.0, H), (0.0, 0.0, 1.0)),
                        "sphere": SphereSurface((0.0, 0.0, top), R)})


# --------------------------------------------------------------------------- the thick sphere
def thick_sphere(a: float = 1.0, b: float = 2.0, h: float = 0.25, *, filled: bool = False,
                 keep_gmsh: str | os.PathLike | None = None, order: int = 1) -> Benchmark3D:
    """1/8 of a thick spherical shell a < R < b (x, y, z >= 0) for internal, dead, follower or
    cavity pressure; exact answers :func:`dolfinx_sfvem.exact.thick_sphere`.

    Mesh: gmsh tetrahedra of size at most ``h`` (the conditions u_x = 0 on x = 0, u_y = 0 on y = 0,
    u_z = 0 on z = 0 are the user's). With ``filled=True`` the hole R < a is a third-medium region
    :data:`MEDIUM` named ``"cavity"`` (for ``cavity_pressure``), meshed conformingly with the wall.

    The spheres are followed by flat triangles whose vertices lie on them (gmsh places the boundary
    nodes on the surfaces); the edge midpoints, where P2 has its nodes, lie inside a sphere of
    radius r by the sagitta l^2 / (8 r) of an edge of length l, so the volumes fall short of the
    exact ones by O(h^2) and so does every answer of the discrete problem. With ``order=2`` the
    tetrahedra are gmsh's second-order ones, their edge nodes on the spheres too (a mesh of
    degree-2 geometry, for the FEM: curved faces; the SFVEM takes its faces flat).

    Named points: ``inner_x`` (a, 0, 0), ``inner_y``, ``inner_z``, ``outer_x`` (b, 0, 0), ``outer_y``,
    ``outer_z``, and ``centre`` (0, 0, 0) when filled. Named surfaces: ``inner`` (R = a, the cavity
    surface), ``outer`` (R = b), ``symmetry_x`` (x = 0), ``symmetry_y``, ``symmetry_z``.

    ``keep_gmsh``: also write the mesh to ``<keep_gmsh>.msh``.
    """
    _check_lengths(a=a, b=b, h=h)
    if not b > a:
        raise ValueError(f"outer radius b = {b!r} must exceed inner radius a = {a!r}")

    def build(gmsh) -> dict[int, list[int]]:
        occ = gmsh.model.occ
        outer, inner = (occ.addSphere(0.0, 0.0, 0.0, r, angle1=0.0, angle2=math.pi / 2, angle3=math.pi / 2)
                        for r in (b, a))
        if filled:
            _, children = occ.fragment([(3, outer)], [(3, inner)])
            cavity = [v for _, v in children[1]]
            regions = {SOLID: [v for _, v in children[0] if v not in cavity], MEDIUM: cavity}
        else:
            wall, _ = occ.cut([(3, outer)], [(3, inner)])
            regions = {SOLID: [v for _, v in wall]}
        occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
        return regions

    regions = {"solid": SOLID, "cavity": MEDIUM} if filled else {"solid": SOLID}
    mesh = gmsh_tetrahedra(build, regions, keep_gmsh, order)
    points = {f"{name}_{axis}": tuple(r * float(i == k) for k in range(3))
              for name, r in (("inner", a), ("outer", b)) for i, axis in enumerate("xyz")}
    if filled:
        points["centre"] = (0.0, 0.0, 0.0)
    planes = {f"symmetry_{axis}": Plane((0.0, 0.0, 0.0), tuple(float(i == k) for k in range(3)))
              for i, axis in enumerate("xyz")}
    return Benchmark3D(mesh, regions, points, {"inner": SphereSurface((0.0, 0.0, 0.0), a),
                                               "outer": SphereSurface((0.0, 0.0, 0.0), b), **planes})


# --------------------------------------------------------------------------- a 3D PneuNet
@dataclasses.dataclass(frozen=True)
class PneuNet3D(PneuNet):
    """Proportions of a PneuNet bellow in 3D (mm): :class:`PneuNet`'s length-height section plus its
    width (y). ``width`` is the outer width of the body and base, ``side`` the thickness of the
    chambers' walls facing +-y (our choices: 15 mm and 2 mm, after the Soft Robotics Toolkit's
    PneuNet, whose chambers are about as wide as high)."""

    width: float = 15.0
    side: float = 2.0

    def check(self) -> None:
        super().check()
        if not 2 * self.side < self.width:
            raise ValueError(f"PneuNet3D: 2 x side {self.side!r} must be below the width {self.width!r}")


def pneunet3d(h: float = 2.0, n_chambers: int = 4, *, geometry: PneuNet3D = PneuNet3D(), half: bool = True,
              cell: GridCell = "hexahedron") -> Benchmark3D:
    """A 3D PneuNet bending actuator (after the Soft Robotics Toolkit, Mosadegh et al. 2014): the
    section of :func:`~dolfinx_sfvem.meshes.pneumatic_actuator` extruded across its width, the
    chambers closed by side walls.

    Geometry (:class:`PneuNet3D`, mm): x along the actuator (clamped end x = 0, free end x = L), z up,
    y across; the body spans -width/2 <= y <= width/2, or 0 <= y <= width/2 with ``half=True`` (the
    default; y = 0 is then a symmetry plane, u_y = 0 there, and each chamber is open only along it).
    Base layer z <= base (:data:`BASE_LAYER`, "base"); on it the elastomer (:data:`SOLID`,
    "elastomer"): a floor, and the chambers of :class:`PneuNet`'s section, each with its cavity
    abs(y) <= width/2 - side (tags :data:`FIRST_CHAMBER` + i, "chamber_1" ...: third medium for
    ``cavity_pressure``); the gaps between neighbouring chambers (:data:`MEDIUM`, "gaps"), over
    the full width and open at the top and the sides, through which the bulging walls touch.

    Mesh: a tensor-product grid of boxes of about ``h`` whose lines fall on every wall and on the
    chambers' mid-height (``axis_nodes``; a wall thinner than h is one cell), hexahedra or each split into 6 tetrahedra (``cell``).

    Named points: ``tip_bottom`` (L, 0, 0), ``tip_top`` (L, 0, base + height) (on y = 0),
    ``gap_i_left`` / ``gap_i_right`` (i = 1 ... n - 1), the mid-height points on y = 0 of the two
    walls facing each other across gap i. Named surfaces: ``clamp`` (x = 0), ``tip`` (x = L), and
    ``symmetry`` (y = 0) with ``half``.
    """
    _check_lengths(h=h)
    geometry.check()
    if not (isinstance(n_chambers, (int, np.integer)) and n_chambers >= 1):
        raise ValueError(f"n_chambers must be an integer >= 1, got {n_chambers!r}")
    g, n = geometry, int(n_chambers)
    L, half_width = g.actuator_length(n), g.width / 2
    cavities, gaps = [g.cavity(i) for i in range(n)], [g.gap(i) for i in range(n - 1)]
    x_breaks = sorted({v for i in range(n) for v in (*g.chamber_x(i), *g.cavity(i)[:2])})
    y_breaks = [0.0, half_width - g.side, half_width]
    if not half:
        y_breaks = [-half_width, -half_width + g.side] + y_breaks
    middle = 0.5 * (g.floor + g.top)
    xs, ys = axis_nodes(x_breaks, h), axis_nodes(y_breaks, h)
    zs = axis_nodes(sorted({0.0, g.base, g.floor, middle, g.top - g.wall, g.top}), h)

    def tag_of(cx: np.ndarray, cy: np.ndarray, cz: np.ndarray) -> np.ndarray:
        tags = np.where(cz < g.base, BASE_LAYER, SOLID)
        inside = np.abs(cy) < half_width - g.side
        for i, (x0, x1, z0, z1) in enumerate(cavities):
            tags[inside & (cx > x0) & (cx < x1) & (cz > z0) & (cz < z1)] = FIRST_CHAMBER + i
        for x0, x1, z0, z1 in gaps:
            tags[(cx > x0) & (cx < x1) & (cz > z0)] = MEDIUM
        return tags

    regions = {"elastomer": SOLID, "gaps": MEDIUM, "base": BASE_LAYER,
               **{f"chamber_{i + 1}": FIRST_CHAMBER + i for i in range(n)}}
    mesh = box_grid(xs, ys, zs, tag_of, regions, cell)
    points = {"tip_bottom": (L, 0.0, 0.0), "tip_top": (L, 0.0, g.top)}
    for i, (x0, x1, _, _) in enumerate(gaps):
        points.update({f"gap_{i + 1}_left": (x0, 0.0, middle), f"gap_{i + 1}_right": (x1, 0.0, middle)})
    surfaces = {"clamp": Plane((0.0, 0.0, 0.0), (1.0, 0.0, 0.0)), "tip": Plane((L, 0.0, 0.0), (1.0, 0.0, 0.0))}
    if half:
        surfaces["symmetry"] = Plane((0.0, 0.0, 0.0), (0.0, 1.0, 0.0))
    return Benchmark3D(mesh, regions, points, surfaces)
