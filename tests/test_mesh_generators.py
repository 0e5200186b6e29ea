"""Mesh generators: exact region areas, valid CCW polygons, straight interfaces, hanging
nodes exactly where densities change, named points, gmsh and .npz I/O."""
from __future__ import annotations

import numpy as np
import pytest

from dolfinx_sfvem import meshes
from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh
from dolfinx_sfvem.meshes import MEDIUM, SOLID


# --------------------------------------------------------------------------- helpers
def shoelace(mesh: PolygonMesh) -> np.ndarray:
    """Signed areas computed here, independently of PolygonMesh."""
    return np.array([0.5 * np.sum(xy[:, 0] * np.roll(xy[:, 1], -1) - np.roll(xy[:, 0], -1) * xy[:, 1])
                     for xy in map(mesh.polygon_coordinates, range(mesh.n_polygons))])


def region_areas(mesh: PolygonMesh) -> dict[int, float]:
    areas = shoelace(mesh)
    return {int(t): float(areas[mesh.tags == t].sum()) for t in np.unique(mesh.tags)}


def assert_valid(mesh: PolygonMesh, expected_areas: dict[int, float]) -> None:
    """Every polygon CCW with positive area; region areas exact; no unused points."""
    assert (shoelace(mesh) > 0).all()
    assert region_areas(mesh) == pytest.approx(expected_areas, rel=1e-12, abs=1e-14)
    assert np.array_equal(np.unique(mesh.vertices), np.arange(mesh.n_points))


def vertices_of(mesh: PolygonMesh, tag: int) -> np.ndarray:
    return np.unique(np.concatenate([mesh.polygon(i) for i in np.flatnonzero(mesh.tags == tag)]))


def in_boxes(xy: np.ndarray, boxes, tol: float = 1e-12) -> np.ndarray:
    """Points inside the union of closed boxes (x0, x1, y0, y1)."""
    return np.any([(xy[:, 0] >= x0 - tol) & (xy[:, 0] <= x1 + tol) & (xy[:, 1] >= y0 - tol)
                   & (xy[:, 1] <= y1 + tol) for x0, x1, y0, y1 in boxes], axis=0)


def assert_polygons_in(mesh: PolygonMesh, tag: int, boxes) -> None:
    """All vertices of the tag's polygons in its region (with exact areas: no straddling)."""
    assert in_boxes(mesh.points[vertices_of(mesh, tag)], boxes).all()


def corners(xy: np.ndarray) -> np.ndarray:
    """Polygon vertices (N, 2) without the ones at straight angles."""
    d_in, d_out = xy - np.roll(xy, 1, axis=0), np.roll(xy, -1, axis=0) - xy
    cross = d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0]
    return xy[np.abs(cross) > 1e-12]


def interface_points(mesh: PolygonMesh, a: int, b: int) -> np.ndarray:
    return np.intersect1d(vertices_of(mesh, a), vertices_of(mesh, b))


# --------------------------------------------------------------------------- dual polygons
def grid_triangles(n: int) -> tuple[np.ndarray, np.ndarray]:
    """(n+1)^2 points on [0, n]^2, two triangles per unit square (diagonal ll -> ur)."""
    pts = np.array([[x, y] for y in range(n + 1) for x in range(n + 1)], dtype=float)
    tris = [[a, a + 1, a + n + 2] for a in range((n + 1) * n) if a % (n + 1) < n]
    tris += [[a, a + n + 2, a + n + 1] for a in range((n + 1) * n) if a % (n + 1) < n]
    return pts, np.array(tris)


def test_dual_of_two_region_grid_keeps_interface_straight():
    pts, tris = grid_triangles(4)
    tags = np.where(pts[tris].mean(axis=1)[:, 0] < 1.0, SOLID, MEDIUM)     # interface x = 1
    tris[::2] = tris[::2, ::-1]                                              # mixed orientations
    mesh = meshes.dual_polygons(pts, tris, tags).to_mesh()
    assert_valid(mesh, {SOLID: 4.0, MEDIUM: 12.0})
    # one polygon per (vertex, region): 25 vertices, 5 of them on the interface
    assert mesh.n_polygons == 30
    assert_polygons_in(mesh, SOLID, [(0, 1, 0, 4)])
    assert_polygons_in(mesh, MEDIUM, [(1, 4, 0, 4)])
    on_interface = mesh.points[interface_points(mesh, SOLID, MEDIUM)]
    assert np.allclose(on_interface[:, 0], 1.0) and len(on_interface) == 9  # 5 vertices + 4 midpoints
    assert meshes.t_junctions(mesh).size == 0


def test_dual_of_nonconvex_domain_keeps_reentrant_corner():
    pts, tris = grid_triangles(2)
    centres = pts[tris].mean(axis=1)
    tris = tris[~((centres[:, 0] > 1) & (centres[:, 1] > 1))]               # L-shape, corner at (1, 1)
    ps = meshes.dual_polygons(pts, tris)
    mesh = ps.to_mesh()
    assert_valid(mesh, {0: 3.0})
    corner = int(np.flatnonzero(np.all(mesh.points == [1.0, 1.0], axis=1))[0])
    (owner,) = [i for i in range(mesh.n_polygons) if corner in mesh.polygon(i)]
    xy = mesh.polygon_coordinates(owner)
    k = int(np.flatnonzero(mesh.polygon(owner) == corner)[0])
    d_in, d_out = xy[k] - xy[k - 1], xy[(k + 1) % len(xy)] - xy[k]
    assert d_in[0] * d_out[1] - d_in[1] * d_out[0] < 0                      # reflex angle kept
    assert {tuple(p) for p in mesh.points[mesh.hanging_nodes]} >= {(0.0, 1.0), (1.0, 0.0)}


def test_dual_splits_a_region_touching_a_vertex_twice():
    pts, tris = grid_triangles(2)
    centres = pts[tris].mean(axis=1)
    checkerboard = np.where((centres[:, 0] < 1) == (centres[:, 1] < 1), SOLID, MEDIUM)
    mesh = meshes.dual_polygons(pts, tris, checkerboard).to_mesh()
    assert_valid(mesh, {SOLID: 2.0, MEDIUM: 2.0})
    centre = int(np.flatnonzero(np.all(mesh.points == [1.0, 1.0], axis=1))[0])
    owners = [i for i in range(mesh.n_polygons) if centre in mesh.polygon(i)]
    assert len(owners) == 4 and sorted(mesh.tags[owners]) == [SOLID, SOLID, MEDIUM, MEDIUM]


def test_dual_rejects_degenerate_triangle():
    pts = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [0.0, 1.0]])
    with pytest.raises(ValueError, match=r"triangles \[0\]"):
        meshes.dual_polygons(pts, np.array([[0, 1, 2], [0, 1, 3]]))


# --------------------------------------------------------------------------- rectangles, gluing
def test_quad_rectangle():
    mesh = meshes.quad_rectangle(2.0, 1.0, 4, 3, origin=(1.0, -1.0), tag=7)
    assert (mesh.n_polygons, mesh.n_points) == (12, 20)
    assert_valid(mesh, {7: 2.0})
    assert np.allclose(mesh.points.min(axis=0), [1.0, -1.0]) and np.allclose(mesh.points.max(axis=0), [3.0, 0.0])
    assert meshes.t_junctions(mesh).size == 0 and mesh.hanging_nodes.size == 0


def test_polygon_rectangle_is_voronoi_like():
    mesh = meshes.polygon_rectangle(1.0, 0.5, 0.1, origin=(2.0, 0.0), tag=3)
    assert_valid(mesh, {3: 0.5})
    sizes = np.diff(mesh.offsets)
    assert sizes.min() >= 4 and np.mean((sizes >= 5) & (sizes <= 8)) > 0.9
    for xy in ([2, 0], [3, 0], [3, 0.5], [2, 0.5]):
        assert np.min(np.linalg.norm(mesh.points - xy, axis=1)) == 0.0
    assert meshes.t_junctions(mesh).size == 0


def test_glue_merges_points_and_creates_hanging_nodes():
    coarse = meshes.quad_rectangle(1.0, 1.0, 2, 2, tag=SOLID)
    fine = meshes.quad_rectangle(1.0, 1.0, 4, 4, origin=(1.0, 0.0), tag=MEDIUM)
    mesh = meshes.glue(coarse, fine)
    assert mesh.n_points == 9 + 25 - 3
    assert_valid(mesh, {SOLID: 1.0, MEDIUM: 1.0})
    assert np.allclose(mesh.points[meshes.t_junctions(mesh)], [[1.0, 0.25], [1.0, 0.75]])
    assert mesh.n_inserted_hanging_nodes == 2


def test_quads_with_hanging_nodes_only_on_refined_box():
    mesh = meshes.quads_with_hanging_nodes(2.0, 1.0, 8, refine=(0.5, 1.25, 0.25, 0.5))
    assert_valid(mesh, {0: 2.0})
    assert mesh.n_polygons == 64 - 3 * 2 + 4 * 3 * 2
    hanging = mesh.points[meshes.t_junctions(mesh)]
    on_box = (np.isclose(hanging[:, 0], 0.5) | np.isclose(hanging[:, 0], 1.25)
              | np.isclose(hanging[:, 1], 0.25) | np.isclose(hanging[:, 1], 0.5))
    assert len(hanging) == 2 * (3 + 2) and on_box.all()
    with pytest.raises(ValueError, match="coarse grid"):
        meshes.quads_with_hanging_nodes(2.0, 1.0, 8, refine=(0.3, 1.25, 0.25, 0.5))


# --------------------------------------------------------------------------- benchmarks
CBOX_SOLID = [(0, 0.1, 0, 0.5), (0, 1, 0, 0.1), (0, 1, 0.4, 0.5)]
BOX_SOLID = [(0, 2, 0, 0.1), (0, 2, 0.4, 0.5), (0, 0.1, 0, 0.5), (1.9, 2, 0, 0.5)]


@pytest.fixture(scope="module")
def cboxes():
    return {r: meshes.cbox(h_solid=0.05, medium_refinement=r) for r in (1, 2)}


@pytest.fixture(scope="module")
def boxes():
    return {m: meshes.box(mesh=m, h_solid=0.1) for m in (1, 2, 3)}


def assert_hanging_only_on_interface(mesh: PolygonMesh) -> None:
    hanging = meshes.t_junctions(mesh)
    assert hanging.size > 0
    assert np.isin(hanging, interface_points(mesh, SOLID, MEDIUM)).all()


def assert_same_solid(a: PolygonMesh, b: PolygonMesh) -> None:
    """Solid polygons equal up to hanging nodes inserted on their straight sides."""
    sa, sb = np.flatnonzero(a.tags == SOLID), np.flatnonzero(b.tags == SOLID)
    assert len(sa) == len(sb)
    assert np.allclose(a.areas[sa], b.areas[sb], rtol=1e-13)
    for i, j in zip(sa, sb):
        assert np.array_equal(corners(a.polygon_coordinates(i)), corners(b.polygon_coordinates(j)))


@pytest.mark.parametrize("r", [1, 2])
def test_cbox(cboxes, r):
    bench = cboxes[r]
    mesh = bench.mesh
    assert_valid(mesh, {SOLID: 0.23, MEDIUM: 0.9 * 0.3 + 0.1 * 0.5})
    assert_polygons_in(mesh, SOLID, CBOX_SOLID)
    assert_polygons_in(mesh, MEDIUM, [(0.1, 1.0, 0.1, 0.4), (1.0, 1.1, 0.0, 0.5)])
    assert_hanging_only_on_interface(mesh)
    for name, xy in bench.points.items():
        assert np.array_equal(mesh.points[bench.vertex(name)], xy)
    fixed = mesh.points[bench.vertices_on("fixed")]
    assert np.all(fixed[:, 0] == 0.0) and len(fixed) == 2 * 10 + 1         # vertices + dual midpoints
    medium_cells = np.diff(mesh.offsets)[mesh.tags == MEDIUM]
    assert len(medium_cells) == r * r * (18 * 6 + 2 * 10)


@pytest.mark.parametrize("h,column", [(0.1, 0.1), (0.025, 0.1), (0.025, 0.025), (0.05, 0.2)])
def test_cbox_column_is_geometry_not_mesh(h, column):
    """The medium column right of the beams is ``column`` wide whatever the mesh size."""
    for bench in (meshes.cbox(h_solid=h, column=column), meshes.cbox_grid(h_solid=h, column=column)):
        mesh = bench.mesh
        assert_valid(mesh, {SOLID: 0.23, MEDIUM: 0.9 * 0.3 + column * 0.5})
        assert np.isclose(mesh.points[:, 0].max(), 1.0 + column, rtol=0, atol=1e-12)


def test_cbox_column_must_be_positive():
    with pytest.raises(ValueError, match="column"):
        meshes.cbox(h_solid=0.1, column=0.0)


def test_cbox_refinement_keeps_solid(cboxes):
    assert_same_solid(cboxes[1].mesh, cboxes[2].mesh)
    assert cboxes[2].mesh.n_polygons > cboxes[1].mesh.n_polygons


@pytest.mark.parametrize("r", [1, 2])
def test_cbox_grid_is_the_medium_grid_through_the_solid(cboxes, r):
    """The FEM's quadrilateral C-box: the same regions as cbox(), rectangles only, and the
    medium cells are exactly cbox()'s medium quads."""
    grid = meshes.cbox_grid(h_solid=0.05, medium_refinement=r)
    mesh = grid.mesh
    assert_valid(mesh, {SOLID: 0.23, MEDIUM: 0.9 * 0.3 + 0.1 * 0.5})
    assert_polygons_in(mesh, SOLID, CBOX_SOLID)
    assert np.all(np.diff(mesh.offsets) == 4) and meshes.t_junctions(mesh).size == 0
    x = mesh.points[mesh.vertices.reshape(-1, 4)]
    assert np.allclose(x[:, 0] + x[:, 2], x[:, 1] + x[:, 3], rtol=0, atol=1e-14)         # parallelograms
    h = 0.05 / r
    assert np.allclose(np.abs(x[:, 2] - x[:, 0]), h, rtol=1e-9)
    ours, theirs = (m.centroids[m.tags == MEDIUM] for m in (mesh, cboxes[r].mesh))
    distance = np.linalg.norm(ours[:, None, :] - theirs[None, :, :], axis=2)
    assert ours.shape == theirs.shape and np.all(distance.min(axis=1) < 1e-12)
    assert grid.points == cboxes[r].points and grid.segments == cboxes[r].segments
    for name in grid.points:
        grid.vertex(name)


@pytest.mark.parametrize("m", [1, 2, 3])
def test_box(boxes, m):
    bench = boxes[m]
    mesh = bench.mesh
    assert_valid(mesh, {SOLID: 1.0 - 1.8 * 0.3, MEDIUM: 1.8 * 0.3})
    assert_polygons_in(mesh, SOLID, BOX_SOLID)
    assert_polygons_in(mesh, MEDIUM, [(0.1, 1.9, 0.1, 0.4)])
    assert_hanging_only_on_interface(mesh)
    assert np.count_nonzero(mesh.tags == MEDIUM) == m * m * 18 * 3
    for name in ("fixed", "roller", "load", "gap_top", "gap_bottom"):
        assert np.array_equal(mesh.points[bench.vertex(name)], bench.points[name])
    assert_same_solid(boxes[1].mesh, mesh)


def assert_named_vertices(bench: meshes.Benchmark, atol: float = 1e-12) -> None:
    for name, xy in bench.points.items():
        assert np.allclose(bench.mesh.points[bench.vertex(name)], xy, rtol=0, atol=atol)
    for name, (a, b) in bench.segments.items():
        on = bench.mesh.points[bench.vertices_on(name)]
        assert len(on) >= 3
        assert {tuple(a), tuple(b)} <= {tuple(p) for p in np.round(on, 12)}


def test_punch():
    bench = meshes.punch(h=0.1)
    mesh, top = bench.mesh, 3.0
    areas = region_areas(mesh)
    assert_valid(mesh, {SOLID: 2.0, MEDIUM: areas[MEDIUM], 3: areas[3]})
    assert areas[MEDIUM] + areas[3] == pytest.approx(2.0 * (top - 1.0), rel=1e-12)
    assert areas[3] == pytest.approx(np.pi / 4, rel=5e-3)
    assert np.linalg.norm(mesh.points[vertices_of(mesh, 3)] - [0.0, top], axis=1).max() <= 1.0 + 1e-12
    assert_polygons_in(mesh, SOLID, [(0, 2, 0, 1)])
    assert meshes.t_junctions(mesh).size == 0
    assert_named_vertices(bench)


def test_multi_object():
    bench = meshes.multi_object(h=0.06)
    mesh = bench.mesh
    areas = region_areas(mesh)
    assert_valid(mesh, {SOLID: 1.6, MEDIUM: areas[MEDIUM], 3: areas[3]})
    assert areas[MEDIUM] + areas[3] == pytest.approx(8 * 0.3, rel=1e-12)
    assert 0.98 * 7 * np.pi * 0.2 ** 2 / 2 < areas[3] < 7 * np.pi * 0.2 ** 2 / 2          # inscribed chords
    assert_polygons_in(mesh, SOLID, [(0, 8, 0, 0.2)])
    assert_polygons_in(mesh, 3, [(x - 0.2, x + 0.2, 0.3, 0.5) for x in range(1, 8)])
    assert meshes.t_junctions(mesh).size == 0
    assert_named_vertices(bench)


def test_pneumatic_actuator():
    """Two chambers of the default PneuNet: region areas from the proportions (body = chambers and
    floor minus cavities), every polygon inside its box, the named corners and sidewall points."""
    g = meshes.PneuNet()
    bench = meshes.pneumatic_actuator(h=1.0, n_chambers=2)
    mesh, L = bench.mesh, 2 * g.length + g.spacing
    cavity = (g.length - 2 * g.sidewall) * (g.height - 2 * g.wall)
    body = 2 * g.length * g.height + g.spacing * g.wall - 2 * cavity
    chambers = {meshes.FIRST_CHAMBER: cavity, meshes.FIRST_CHAMBER + 1: cavity}
    assert_valid(mesh, {SOLID: body, MEDIUM: g.spacing * (g.height - g.wall), meshes.BASE_LAYER: L * g.base,
                        **chambers})
    assert bench.regions == {"elastomer": SOLID, "gaps": MEDIUM, "base": meshes.BASE_LAYER,
                             "chamber_1": meshes.FIRST_CHAMBER, "chamber_2": meshes.FIRST_CHAMBER + 1}
    floor, top = g.base + g.wall, g.base + g.height
    assert_polygons_in(mesh, meshes.FIRST_CHAMBER, [(g.sidewall, g.length - g.sidewall, floor, top - g.wall)])
    assert_polygons_in(mesh, MEDIUM, [(g.length, g.length + g.spacing, floor, top)])
    assert_polygons_in(mesh, meshes.BASE_LAYER, [(0, L, 0, g.base)])
    assert bench.points["tip_top"] == (L, top) and bench.points["gap_1_right"] == (g.length + g.spacing, 9.5)
    assert_named_vertices(bench, atol=1e-10)        # the sidewall points: vertices of gmsh's edge nodes


@pytest.mark.parametrize("arguments, message", [
    ({"h": 0.0}, "h must be"), ({"n_chambers": 0}, "n_chambers"), ({"n_chambers": 2.5}, "n_chambers"),
    ({"medium_refinement": 0}, "medium_refinement"),
    ({"geometry": meshes.PneuNet(spacing=-1.0)}, "spacing must be"),
    ({"geometry": meshes.PneuNet(sidewall=4.0)}, "no cavity: 2 x sidewall 4.0")])
def test_pneumatic_actuator_rejects_bad_input(arguments, message):
    with pytest.raises(ValueError, match=message):
        meshes.pneumatic_actuator(**arguments)


def test_named_point_must_be_vertex(boxes):
    assert_named_vertices(boxes[1])
    bench = meshes.Benchmark(boxes[1].mesh, {}, {"off": (0.3333, 0.2)}, {})
    with pytest.raises(ValueError, match="'off'"):
        bench.vertex("off")


# --------------------------------------------------------------------------- I/O
def write_msh(path, physical: bool, order: int = 1) -> PolygonMesh | None:
    """Two unit squares side by side, left triangles, right quads, written to ``path``;
    returns ``from_gmsh(None, ...)`` of the open model when ``physical``."""
    import gmsh

    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        left = gmsh.model.occ.addRectangle(0, 0, 0, 1, 1)
        right = gmsh.model.occ.addRectangle(1, 0, 0, 1, 1)
        _, (left_parts, right_parts) = gmsh.model.occ.fragment([(2, left)], [(2, right)])
        gmsh.model.occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.25)
        gmsh.model.mesh.setRecombine(2, right_parts[0][1])
        if physical:
            gmsh.model.setPhysicalName(2, gmsh.model.addPhysicalGroup(2, [left_parts[0][1]], 11), "solid")
            gmsh.model.setPhysicalName(2, gmsh.model.addPhysicalGroup(2, [right_parts[0][1]], 12), "medium")
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(order)
        gmsh.write(str(path))
        return meshes.from_gmsh(None, {"solid": SOLID, "medium": MEDIUM}) if physical else None
    finally:
        gmsh.finalize()


@pytest.mark.parametrize("order", [1, 2])
def test_from_gmsh_with_physical_groups(tmp_path, order):
    path = tmp_path / "two.msh"
    current = write_msh(path, physical=True, order=order)
    mesh = meshes.from_gmsh(path, {"solid": SOLID, "medium": MEDIUM})
    assert np.allclose(current.points, mesh.points, rtol=0, atol=1e-14)    # .msh text keeps ~16 digits
    assert np.array_equal(current.vertices, mesh.vertices)
    assert_valid(mesh, {SOLID: 1.0, MEDIUM: 1.0})
    sizes = np.diff(mesh.offsets)
    assert set(sizes[mesh.tags == SOLID]) == {3} and set(sizes[mesh.tags == MEDIUM]) == {4}
    by_number = meshes.from_gmsh(path)
    assert np.array_equal(np.unique(by_number.tags), [11, 12])
    assert np.array_equal(by_number.offsets, mesh.offsets)


def test_from_gmsh_missing_groups(tmp_path):
    path = tmp_path / "plain.msh"
    write_msh(path, physical=False)
    assert set(meshes.from_gmsh(path).tags) == {0}
    with pytest.raises(ValueError, match=r"\['medium', 'solid'\].*no 2D physical groups"):
        meshes.from_gmsh(path, {"solid": SOLID, "medium": MEDIUM})
    write_msh(path, physical=True)
    with pytest.raises(ValueError, match=r"\['punch'\]"):
        meshes.from_gmsh(path, {"solid": SOLID, "punch": 3})
    with pytest.raises(FileNotFoundError):
        meshes.from_gmsh(tmp_path / "none.msh")


def test_npz_round_trip_and_describe(tmp_path, boxes):
    mesh = boxes[3].mesh
    meshes.write_polygons(tmp_path / "box.npz", mesh)
    back = meshes.read_polygons(tmp_path / "box.npz")
    for name in ("points", "offsets", "vertices", "tags"):
        assert np.array_equal(getattr(back, name), getattr(mesh, name))
    np.savez(tmp_path / "other.npz", points=mesh.points)
    with pytest.raises(ValueError, match="not a"):
        meshes.read_polygons(tmp_path / "other.npz")
    text = meshes.describe(mesh)
    assert f"{mesh.n_polygons} polygons" in text
    assert f"{meshes.t_junctions(mesh).size} T-junctions" in text
    assert f"region {SOLID}: {np.count_nonzero(mesh.tags == SOLID)} polygons, area 0.46" in text
