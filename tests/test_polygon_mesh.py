"""PolygonMesh: validation, orientation, hanging nodes, sub-triangulation, partition, DOLFINx mesh."""
import re

import numpy as np
import pytest
from matplotlib.path import Path
from mpi4py import MPI

import dolfinx.fem
import ufl
from dolfinx_sfvem import _compat
from dolfinx_sfvem.polygon_mesh import PolygonMesh
from dolfinx_sfvem.polygon import RTOL, sub_triangulate


# --------------------------------------------------------------------------- helpers
def shoelace(xy):
    x, y = np.asarray(xy, dtype=float).T
    return 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)


def square_grid(nx, ny, h=1.0, x0=0.0, y0=0.0):
    """Points and CCW vertex lists of an nx x ny grid of squares of side h."""
    x, y = np.meshgrid(x0 + h * np.arange(nx + 1), y0 + h * np.arange(ny + 1))
    points = np.column_stack([x.ravel(), y.ravel()])
    idx = np.arange((nx + 1) * (ny + 1)).reshape(ny + 1, nx + 1)
    polygons = [[idx[j, i], idx[j, i + 1], idx[j + 1, i + 1], idx[j + 1, i]] for j in range(ny) for i in range(nx)]
    return points, polygons


def assert_valid_triangulation(xy, triangles, interior, extra):
    """``triangles`` (into vstack(xy, extra)) form a CCW triangulation of the CCW polygon ``xy``
    in which every polygon edge is an edge of exactly one triangle, and the interior DOF point
    (midpoint of nodes interior[0], interior[1]) lies strictly inside the polygon."""
    n = len(xy)
    nodes = np.vstack([xy, extra])
    areas = np.array([shoelace(nodes[t]) for t in triangles])
    scale = np.ptp(xy, axis=0).max()
    assert np.all(areas > 1e-12 * scale**2)
    assert np.isclose(areas.sum(), shoelace(xy), rtol=1e-12)
    directed = [(t[k], t[(k + 1) % 3]) for t in triangles for k in range(3)]
    assert len(set(directed)) == len(directed)
    boundary = {(i, (i + 1) % n) for i in range(n)}
    assert boundary <= set(directed)  # each polygon edge once (directed edges are unique) ...
    assert not any((b, a) in directed for a, b in boundary)  # ... and never reversed
    for a, b in set(directed) - boundary:  # every other edge is interior: shared by two triangles
        assert (b, a) in directed
    assert len(extra) == (1 if interior[0] == interior[1] else 0)
    dof_point = 0.5 * (nodes[interior[0]] + nodes[interior[1]])
    assert Path(xy).contains_point(dof_point)
    assert min(distance_to_segment(dof_point, xy[a], xy[b]) for a, b in boundary) > 1e-9 * scale


def assert_deepest_diagonal(xy, triangles, interior):
    """The interior DOF of an ear-clipped polygon sits on the diagonal whose midpoint is deepest inside."""
    n = len(xy)
    diagonals = {tuple(sorted((t[k], t[(k + 1) % 3]))) for t in triangles for k in range(3)}
    diagonals -= {tuple(sorted((i, (i + 1) % n))) for i in range(n)}
    depth = {d: min(distance_to_segment(0.5 * (xy[d[0]] + xy[d[1]]), xy[i], xy[(i + 1) % n]) for i in range(n))
             for d in diagonals}
    assert len(diagonals) == n - 3
    assert np.isclose(depth[tuple(sorted(interior))], max(depth.values()))


def assert_valid_mesh(mesh):
    """Every polygon CCW with positive area and a valid sub-triangulation in mesh numbering."""
    assert mesh.offsets[0] == 0 and mesh.offsets[-1] == mesh.vertices.size
    assert mesh.triangle_offsets[-1] == mesh.triangles.shape[0]
    nodes = mesh.nodes
    for i in range(mesh.n_polygons):
        verts = mesh.polygon(i)
        assert len(set(verts.tolist())) == verts.size >= 3
        xy = mesh.points[verts]
        assert shoelace(xy) > 0
        local = {v: k for k, v in enumerate(verts.tolist())}
        tri = mesh.triangles[mesh.triangle_offsets[i]:mesh.triangle_offsets[i + 1]]
        fan = sorted(set(tri.ravel().tolist()) - set(local))
        assert len(fan) <= 1 and all(f >= mesh.n_points for f in fan)
        local.update({f: verts.size for f in fan})
        extra = nodes[fan]
        assert_valid_triangulation(xy, np.vectorize(local.get)(tri),
                                   [local[v] for v in mesh.interior_node[i]], extra)


def hanging_mesh(k, listed):
    """k + 1 squares of side s = 1/(k+1) on [0, 1] x [0, s] below the unit square [0, 1] x [s, 1+s],
    whose bottom side holds the k inner points of the fine row's top side; they are listed in its
    vertex list if ``listed``. Returns points, polygons (the big square last), the k points."""
    s = 1.0 / (k + 1)
    fine_points, fine = square_grid(k + 1, 1, h=s)
    n = len(fine_points)
    points = np.vstack([fine_points, [[1.0, 1.0 + s], [0.0, 1.0 + s]]])
    top = list(range(k + 2, n))  # (0, s), ..., (1, s) left to right
    big = [top[0]] + (top[1:-1] if listed else []) + [top[-1], n, n + 1]
    return points, fine + [big], top[1:-1]


def glue(*blocks):
    """Concatenate (points, polygons) blocks and merge coincident points."""
    points = np.vstack([b[0] for b in blocks])
    offsets = np.cumsum([0] + [len(b[0]) for b in blocks])
    merged, inverse = np.unique(points.round(12), axis=0, return_inverse=True)
    return merged, [[int(inverse[v + o]) for v in p] for (_, polygons), o in zip(blocks, offsets) for p in polygons]


def distance_to_segment(p, a, b):
    t = np.clip(np.dot(p - a, b - a) / np.dot(b - a, b - a), 0.0, 1.0)
    return np.hypot(*(p - a - t * (b - a)))


# --------------------------------------------------------------------------- rejections
def two_by_two():
    return square_grid(2, 2)  # points 0..8, polygons 0..3


def _case_too_short():
    points, polygons = two_by_two()
    return points, polygons + [[0, 1]], 4, "at least 3"


def _case_repeated():
    points, polygons = two_by_two()
    polygons[2] = [3, 4, 7, 4]
    return points, polygons, 2, "repeated"


def _case_out_of_range():
    points, polygons = two_by_two()
    polygons[3] = [4, 5, 99, 7]
    return points, polygons, 3, "out of range"


def _case_negative_index():
    points, polygons = two_by_two()
    polygons[1] = [1, -2, 5, 4]
    return points, polygons, 1, "out of range"


def _case_float_indices():
    points, polygons = two_by_two()
    polygons[1] = [1.0, 2.5, 5.0, 4.0]
    return points, polygons, 1, "integers"


def _case_zero_area():
    points, polygons = two_by_two()
    points = np.vstack([points, [[3.0, 0.0], [4.0, 0.0], [5.0, 0.0]]])
    return points, polygons + [[9, 10, 11]], 4, "zero area"


def _case_bow_tie():
    points, polygons = two_by_two()
    points = np.vstack([points, [[3.0, 0.0], [5.0, 2.0], [5.0, 0.0], [3.0, 1.0]]])
    return points, polygons + [[9, 10, 11, 12]], 4, "self-intersection"


def _case_vertex_on_own_edge():
    points, polygons = two_by_two()
    points = np.vstack([points, [[3.0, 0.0], [5.0, 0.0], [5.0, 2.0], [4.0, 0.0]]])
    return points, polygons + [[9, 10, 11, 12]], 4, "self-intersection"


def _case_thin_triangle():
    points, polygons = two_by_two()
    # bounding box [0, 4] x [0, 2]: tol = RTOL * sqrt(20); a triangle of base 1 and height 2.5 tol
    # has area > tol * diameter but its centroid lies within tol of its base
    tol = RTOL * np.sqrt(20.0)
    points = np.vstack([points, [[3.0, 0.0], [4.0, 0.0], [3.5, 2.5 * tol]]])
    return points, polygons + [[9, 10, 11]], 4, "cannot be sub-triangulated"


def _case_crack():
    points, polygons = two_by_two()
    points = np.vstack([points, points[[4, 7]]])  # copies of (1,1), (1,2): points 9, 10
    polygons[3] = [9, 5, 8, 10]
    return points, polygons, 3, "same location"


def _case_crossing():
    points, polygons = two_by_two()
    points = np.vstack([points, [[1.5, 1.5], [2.5, 1.5], [2.5, 2.5], [1.5, 2.5]]])
    return points, polygons + [[9, 10, 11, 12]], 4, "crosses or touches"


def _case_nested():
    points, polygons = two_by_two()
    points = np.vstack([points, [[0.25, 0.25], [0.75, 0.25], [0.75, 0.75], [0.25, 0.75]]])
    return points, polygons + [[9, 10, 11, 12]], 4, "inside polygon 0"


def _case_nested_first():
    points, polygons = two_by_two()
    points = np.vstack([points, [[0.25, 0.25], [0.75, 0.25], [0.75, 0.75], [0.25, 0.75]]])
    return points, [[9, 10, 11, 12]] + polygons, 1, "contains the midpoint"


def _case_diagonal_triangle():
    angles = np.pi / 3 * np.arange(6)
    points = np.column_stack([np.cos(angles), np.sin(angles)])
    return points, [list(range(6)), [0, 2, 4]], 1, "midpoint .* inside polygon 0"


def _case_same_direction():
    points, polygons = two_by_two()
    return points, polygons + [[4, 5, 8, 7]], 4, "same direction"


def _case_same_direction_partial():
    points, polygons = two_by_two()  # triangle on the lower half of square 0, sharing two of its edges
    return points, polygons + [[0, 1, 4]], 4, "same direction"


REJECTIONS = {f.__name__[6:]: f for f in [
    _case_too_short, _case_repeated, _case_out_of_range, _case_negative_index, _case_float_indices,
    _case_zero_area, _case_bow_tie, _case_vertex_on_own_edge, _case_thin_triangle, _case_crack,
    _case_crossing, _case_nested, _case_nested_first, _case_diagonal_triangle, _case_same_direction,
    _case_same_direction_partial]}


@pytest.mark.parametrize("case", REJECTIONS)
def test_rejection_names_polygon(case):
    points, polygons, bad, reason = REJECTIONS[case]()
    with pytest.raises(ValueError, match=f"^polygon {bad}: .*{reason}") as info:
        PolygonMesh(points, polygons)
    assert not re.search(rf"polygon (?!{bad}\b)\d+:", str(info.value))


@pytest.mark.parametrize("case", sorted(set(REJECTIONS) - {"crack", "repeated", "out_of_range", "negative_index",
                                                          "float_indices"}))
def test_rejection_cases_are_valid_without_the_culprit(case):
    """The added polygon is the only problem of each case that adds one (it is the first one,
    polygon 0, in 'nested_first'; the named polygon otherwise)."""
    points, polygons, bad, _ = REJECTIONS[case]()
    culprit = 0 if case == "nested_first" else bad
    assert_valid_mesh(PolygonMesh(points, [p for i, p in enumerate(polygons) if i != culprit]))


def test_t_junction_rejected_without_insertion():
    points, polygons, _ = hanging_mesh(2, listed=False)
    with pytest.raises(ValueError, match=r"^polygon 3: vertex \d+ .*T-junction"):
        PolygonMesh(points, polygons, insert_hanging_nodes=False)


def test_half_listed_t_junction_rejected_without_insertion():
    points, polygons, hanging = hanging_mesh(2, listed=True)
    polygons[3] = [v for v in polygons[3] if v != hanging[1]]
    with pytest.raises(ValueError, match=rf"^polygon 3: vertex {hanging[1]} .*T-junction"):
        PolygonMesh(points, polygons, insert_hanging_nodes=False)


@pytest.mark.parametrize("points, message", [
    (np.zeros((4, 3)), r"shape \(n, 2\)"),
    (np.zeros(8), r"shape \(n, 2\)"),
    ([[0.0, 0.0], [1.0, "a"]], "array of floats"),
    (np.array([[0.0, 0.0], [1.0, 0.0], [np.nan, 1.0]]), "point 2 is not finite"),
    (np.array([[0.0, 0.0], [np.inf, 0.0], [0.0, 1.0]]), "point 1 is not finite"),
])
def test_bad_points(points, message):
    with pytest.raises(ValueError, match=message):
        PolygonMesh(points, [[0, 1, 2]])


@pytest.mark.parametrize("polygons, message", [
    (5, "sequence of vertex-index sequences"),
    ("abc", "sequence of vertex-index sequences"),
    ([], "no polygons"),
    ([[0, 1, 2], [[0, 1], [2, 3]]], "polygon 1: .*flat"),
    ([[0, 1, 2], [0, 1, None]], "polygon 1: .*integers"),
    ([[0, 1, 2], [True, False, True]], "polygon 1: .*integers"),
])
def test_bad_polygons(polygons, message):
    with pytest.raises(ValueError, match=message):
        PolygonMesh([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]], polygons)


@pytest.mark.parametrize("tags, message", [
    ([0, 1], r"one entry per polygon"),
    ([[0, 1, 2, 3]], r"one entry per polygon"),
    ([0, 1, 2.5, 3], "integers"),
    (["a", "b", "c", "d"], "integers"),
    ([0, 1, 2**40, 3], "polygon 2: tag"),
])
def test_bad_tags(tags, message):
    points, polygons = two_by_two()
    with pytest.raises(ValueError, match=message):
        PolygonMesh(points, polygons, tags)


# --------------------------------------------------------------------------- acceptance
def test_clockwise_polygons_are_reoriented():
    points, polygons = square_grid(3, 2)
    reversed_ = np.array([p[::-1] if i % 2 else p for i, p in enumerate(polygons)])
    given = reversed_.copy()
    mesh = PolygonMesh(points, reversed_, tags=np.arange(6) % 3)
    np.testing.assert_array_equal(reversed_, given)  # the input is not modified
    for i, p in enumerate(polygons):
        v = mesh.polygon(i).tolist()
        k = v.index(p[0])
        assert v[k:] + v[:k] == list(p)  # the same CCW cycle
        assert v[0] == reversed_[i][0]  # first vertex kept
    np.testing.assert_allclose(mesh.areas, 1.0)
    np.testing.assert_array_equal(mesh.tags, [0, 1, 2, 0, 1, 2])
    assert mesh.tags.dtype == np.int32
    assert_valid_mesh(mesh)


def test_attributes_of_a_valid_mesh():
    points, polygons = square_grid(3, 2)
    mesh = PolygonMesh(points, polygons)
    assert (mesh.n_points, mesh.n_polygons) == (12, 6)
    assert mesh.points.dtype == np.float64 and mesh.vertices.dtype == mesh.offsets.dtype == np.int64
    np.testing.assert_array_equal(mesh.offsets, 4 * np.arange(7))
    np.testing.assert_array_equal(mesh.polygon(4), polygons[4])
    np.testing.assert_array_equal(mesh.polygon_coordinates(4), [[1, 1], [2, 1], [2, 2], [1, 2]])
    # convex squares: fans from the centres, interior DOF at the fan centre
    np.testing.assert_allclose(mesh.extra_points, [[i + 0.5, j + 0.5] for j in range(2) for i in range(3)])
    np.testing.assert_array_equal(mesh.interior_node, np.repeat(12 + np.arange(6), 2).reshape(6, 2))
    assert mesh.triangles.shape == (24, 3) and mesh.nodes.shape == (18, 2)
    np.testing.assert_array_equal(mesh.triangle_offsets, 4 * np.arange(7))
    assert mesh.hanging_nodes.size == 0 and mesh.n_inserted_hanging_nodes == 0
    assert_valid_mesh(mesh)


def test_unused_points_are_allowed():
    points, polygons = square_grid(2, 1)
    points = np.vstack([points, [[7.0, 7.0], [1.0, 1.0]]])  # unused, one even at a used location
    assert_valid_mesh(PolygonMesh(points, polygons))


@pytest.mark.parametrize("k", [1, 2, 3])
def test_hanging_nodes_listed(k):
    points, polygons, hanging = hanging_mesh(k, listed=True)
    mesh = PolygonMesh(points, polygons)
    assert mesh.polygon(k + 1).size == 4 + k
    np.testing.assert_array_equal(mesh.hanging_nodes, hanging)
    assert mesh.n_inserted_hanging_nodes == 0
    np.testing.assert_allclose(mesh.areas, [1.0 / (k + 1) ** 2] * (k + 1) + [1.0])
    assert_valid_mesh(mesh)
    assert f"hanging nodes: {k} (0 inserted" in mesh.summary()


@pytest.mark.parametrize("k", [1, 2, 3])
def test_hanging_nodes_inserted_equal_listed(k):
    listed = PolygonMesh(*hanging_mesh(k, listed=True)[:2])
    points, polygons, hanging = hanging_mesh(k, listed=False)
    assert len(polygons[k + 1]) == 4
    inserted = PolygonMesh(points, polygons)
    assert inserted.n_inserted_hanging_nodes == k
    np.testing.assert_array_equal(inserted.offsets, listed.offsets)
    np.testing.assert_array_equal(inserted.vertices, listed.vertices)
    np.testing.assert_array_equal(inserted.hanging_nodes, hanging)
    np.testing.assert_array_equal(inserted.triangles, listed.triangles)
    assert f"({k} inserted at T-junctions)" in inserted.summary()


def test_t_junctions_on_several_edges_of_both_orientations():
    """Unit squares on [0,2]^2, half-size squares on [2,3]x[0,2] (right) and [0,3]x[2,2.5] (above):
    the coarse squares get hanging nodes on their right and top sides, the fine ones none."""
    points, polygons = glue(square_grid(2, 2), square_grid(2, 4, h=0.5, x0=2.0),
                            square_grid(6, 1, h=0.5, y0=2.0))
    mesh = PolygonMesh(points, polygons)
    assert mesh.n_inserted_hanging_nodes == 4  # (2, 0.5), (2, 1.5) on right sides, (0.5, 2), (1.5, 2) on top
    assert [mesh.polygon(i).size for i in range(mesh.n_polygons)] == [4, 5, 5, 6] + [4] * 14
    np.testing.assert_array_equal(mesh.points[mesh.hanging_nodes], [[0.5, 2.0], [1.5, 2.0], [2.0, 0.5], [2.0, 1.5]])
    assert_valid_mesh(mesh)
    np.testing.assert_allclose(mesh.areas.sum(), 4.0 + 2.0 + 1.5)


def test_summary():
    points, polygons, _ = hanging_mesh(1, listed=True)
    mesh = PolygonMesh(points, polygons, tags=[1, 1, 7])
    text = mesh.summary()
    assert "3 polygons" in text and "4: 2, 5: 1" in text and "1: 2 polygons, 7: 1 polygons" in text


# --------------------------------------------------------------------------- triangulation
STAR_L = np.array([(0, 0), (2, 0), (2, .2), (.2, .2), (.2, 2), (0, 2)], dtype=float)  # kernel [0,.2]^2
COMB = np.array([(0, 0), (5, 0), (5, 3), (4, 3), (4, 1), (3, 1), (3, 3), (2, 3), (2, 1), (1, 1), (1, 3), (0, 3)],
                dtype=float)  # empty kernel
SPIRAL = np.array([(0, 0), (4, 0), (4, 4), (1, 4), (1, 2), (2, 2), (2, 3), (3, 3), (3, 1), (0, 1)], dtype=float)


def test_star_shaped_polygon_fans_from_kernel_centroid():
    extra, triangles, interior = sub_triangulate(STAR_L)
    np.testing.assert_allclose(extra, [[0.1, 0.1]])  # the centroid (0.55, 0.55) sees only part of it
    assert triangles.shape == (6, 3) and list(interior) == [6, 6]
    assert_valid_triangulation(STAR_L, triangles, interior, extra)


def test_hanging_vertices_on_a_nonconvex_star_polygon():
    # the L with extra collinear vertices on its long outer sides and on a reflex side
    xy = np.array([(0, 0), (1, 0), (2, 0), (2, .2), (1, .2), (.2, .2), (.2, 1), (.2, 2), (0, 2), (0, 1)], float)
    extra, triangles, interior = sub_triangulate(xy)
    assert extra.shape == (1, 2)
    assert_valid_triangulation(xy, triangles, interior, extra)


@pytest.mark.parametrize("xy", [COMB, SPIRAL, COMB[::-1] * [-1, 1]], ids=["comb", "spiral", "mirrored-comb"])
def test_non_star_polygon_is_ear_clipped(xy):
    extra, triangles, interior = sub_triangulate(xy)
    assert extra.shape == (0, 2) and triangles.shape == (len(xy) - 2, 3)
    assert interior[0] != interior[1]
    assert_valid_triangulation(xy, triangles, interior, extra)
    assert_deepest_diagonal(xy, triangles, interior)


def test_convex_polygon_fans_from_centroid():
    angles = np.linspace(0, 2 * np.pi, 9)[:-1]
    xy = np.column_stack([2 + np.cos(angles), 3 + 0.5 * np.sin(angles)])
    extra, triangles, interior = sub_triangulate(xy)
    np.testing.assert_allclose(extra, [[2.0, 3.0]], atol=1e-14)
    assert_valid_triangulation(xy, triangles, interior, extra)


@pytest.mark.parametrize("xy", [[(0, 0), (1, 0), (2, 0)], [(0, 0), (0, 1), (1, 0)], [(0, 0), (1, 0)]],
                         ids=["collinear", "clockwise", "two points"])
def test_sub_triangulate_rejects_degenerate_input(xy):
    with pytest.raises(ValueError):
        sub_triangulate(xy)


def test_mesh_of_nonconvex_polygons():
    """The comb with the spiral glued below (its top side puts two T-junctions into the comb's
    bottom side) and a small L on its right tooth: ear clipping and a kernel fan in mesh numbering."""
    points, polygons = glue((COMB, [list(range(12))]), (SPIRAL + [0.0, -4.0], [list(range(10))]),
                            (STAR_L * 0.5 + [4.0, 3.0], [list(range(6))]))
    mesh = PolygonMesh(points, polygons, tags=[0, 1, 2])
    assert mesh.n_inserted_hanging_nodes == 2 and mesh.polygon(0).size == 14
    assert_valid_mesh(mesh)
    assert mesh.extra_points.shape == (1, 2) and mesh.triangles.shape == (12 + 8 + 6, 3)
    np.testing.assert_allclose(mesh.areas, [shoelace(COMB), shoelace(SPIRAL), shoelace(STAR_L) / 4])


# --------------------------------------------------------------------------- partition
@pytest.mark.parametrize("n_parts", [1, 2, 3, 5, 7, 16])
def test_partition_is_balanced_and_deterministic(n_parts):
    points, polygons = square_grid(13, 7)
    mesh = PolygonMesh(points, polygons)
    parts = mesh.partition(n_parts)
    assert parts.dtype == np.int32 and parts.shape == (91,)
    counts = np.bincount(parts, minlength=n_parts)
    assert counts.size == n_parts and counts.max() - counts.min() <= 1
    np.testing.assert_array_equal(parts, mesh.partition(n_parts))


def test_partition_cuts_across_the_longer_extent():
    points, polygons = square_grid(10, 3)
    parts = PolygonMesh(points, polygons).partition(2)
    centres = points[np.array(polygons)].mean(axis=1)
    assert centres[parts == 0, 0].max() < centres[parts == 1, 0].min()


def test_partition_rejects_bad_counts():
    mesh = PolygonMesh(*square_grid(2, 2))
    for bad in (0, -1, 1.5):
        with pytest.raises(ValueError, match="n_parts"):
            mesh.partition(bad)


# --------------------------------------------------------------------------- DOLFINx
def _check_dolfinx_mesh(mesh, comm):
    dmesh, cell_polygon = mesh.to_dolfinx(comm)
    cell_map = dmesh.topology.index_map(2)
    n_local = cell_map.size_local
    assert cell_polygon.shape == (n_local + cell_map.num_ghosts,) and cell_polygon.dtype == np.int64
    # ghost cells (after the owned ones) belong to polygons owned by other ranks
    assert not np.any(mesh.partition(comm.size)[cell_polygon[n_local:]] == comm.rank)
    cell_polygon = cell_polygon[:n_local]
    # every local cell lies in the polygon it is mapped to, and on that polygon's rank
    x = dmesh.geometry.x[:, :2]
    cells = _compat.cell_geometry_nodes(dmesh)[:n_local]
    centres = x[cells].mean(axis=1)
    for c, p in zip(centres, cell_polygon):
        assert Path(mesh.polygon_coordinates(p)).contains_point(c)
    np.testing.assert_array_equal(mesh.partition(comm.size)[cell_polygon], comm.rank)
    # each polygon's sub-triangles are all there, on one rank
    count = comm.allreduce(np.bincount(cell_polygon, minlength=mesh.n_polygons))
    np.testing.assert_array_equal(count, np.diff(mesh.triangle_offsets))
    area = dolfinx.fem.assemble_scalar(dolfinx.fem.form(dolfinx.fem.Constant(dmesh, 1.0) * ufl.dx))
    return comm.allreduce(area), comm.allreduce(n_local)


def test_to_dolfinx_serial():
    points, polygons, _ = hanging_mesh(3, listed=False)
    n = len(points)
    points = np.vstack([points, [[9.0, 9.0]], COMB * 0.2 + [1.5, 0.0]])  # an unused point, a separate comb
    polygons = polygons + [list(range(n + 1, n + 13))]
    mesh = PolygonMesh(points, polygons)
    area, n_cells = _check_dolfinx_mesh(mesh, MPI.COMM_SELF)
    assert n_cells == mesh.triangles.shape[0] == 4 * 4 + 7 + 10
    assert np.isclose(area, 4 / 16 + 1.0 + 0.04 * shoelace(COMB))


@pytest.mark.mpi
def test_to_dolfinx_parallel():
    comm = MPI.COMM_WORLD
    points, polygons, _ = hanging_mesh(3, listed=False)
    # thirds on [1, 3] x [0, 1]: T-junctions both ways across x = 1
    points, polygons = glue((points, polygons), square_grid(6, 3, h=1.0 / 3, x0=1.0))
    mesh = PolygonMesh(points, polygons)
    assert mesh.n_inserted_hanging_nodes == 3 + 3 + 1  # fine row top, x = 1 into big square / into a third
    area, n_cells = _check_dolfinx_mesh(mesh, comm)
    assert n_cells == mesh.triangles.shape[0]
    assert np.isclose(area, 0.25 + 1.0 + 2.0)


@pytest.mark.parametrize("listed", [True, False])
def test_quadrature_triangulation_has_n_minus_2_positive_triangles_tiling_each_polygon(listed):
    points, polygons, _ = hanging_mesh(3, listed=listed)
    n = len(points)
    points = np.vstack([points, COMB * 0.2 + [1.5, 0.0]])
    mesh = PolygonMesh(points, polygons + [list(range(n, n + 12))])
    nodes, tri, off = mesh.nodes, mesh.quadrature_triangles, mesh.quadrature_triangle_offsets
    for p in range(mesh.n_polygons):
        t = tri[off[p]:off[p + 1]]
        assert t.shape[0] == mesh.polygon(p).size - 2
        areas = np.array([shoelace(nodes[k]) for k in t])
        assert np.all(areas > 0)
        assert np.isclose(areas.sum(), mesh.areas[p])
