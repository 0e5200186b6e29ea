"""PolygonMesh: validation, orientation, hanging nodes, sub-triangulation, partition, DOLFINx mesh.

The mesh builders (square_grid, hanging_mesh, glue), the checks of a valid triangulation and mesh
and the nonconvex test polygons are conftest.py's fixtures (test_polygon_mesh_fuzz uses them too).
"""
import re

import numpy as np
import pytest
from matplotlib.path import Path
from mpi4py import MPI

import dolfinx.fem
import ufl
from dolfinx_sfvem import _compat
from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh
from dolfinx_sfvem.mesh.polygon import RTOL, sub_triangulate


# --------------------------------------------------------------------------- rejections
@pytest.fixture
def two_by_two(square_grid):
    """A maker of the 2 x 2 grid of unit squares (points 0..8, polygons 0..3) for the rejection cases."""
    return lambda: square_grid(2, 2)


def _case_too_short(two_by_two):
    points, polygons = two_by_two()
    return points, polygons + [[0, 1]], 4, "at least 3"


def _case_repeated(two_by_two):
    points, polygons = two_by_two()
    polygons[2] = [3, 4, 7, 4]
    return points, polygons, 2, "repeated"


def _case_out_of_range(two_by_two):
    points, polygons = two_by_two()
    polygons[3] = [4, 5, 99, 7]
    return points, polygons, 3, "out of range"


def _case_negative_index(two_by_two):
    points, polygons = two_by_two()
    polygons[1] = [1, -2, 5, 4]
    return points, polygons, 1, "out of range"


def _case_float_indices(two_by_two):
    points, polygons = two_by_two()
    polygons[1] = [1.0, 2.5, 5.0, 4.0]
    return points, polygons, 1, "integers"


def _case_zero_area(two_by_two):
    points, polygons = two_by_two()
    points = np.vstack([points, [[3.0, 0.0], [4.0, 0.0], [5.0, 0.0]]])
    return points, polygons + [[9, 10, 11]], 4, "zero area"


def _case_bow_tie(two_by_two):
    points, polygons = two_by_two()
    points = np.vstack([points, [[3.0, 0.0], [5.0, 2.0], [5.0, 0.0], [3.0, 1.0]]])
    return points, polygons + [[9, 10, 11, 12]], 4, "self-intersection"


def _case_vertex_on_own_edge(two_by_two):
    points, polygons = two_by_two()
    points = np.vstack([points, [[3.0, 0.0], [5.0, 0.0], [5.0, 2.0], [4.0, 0.0]]])
    return points, polygons + [[9, 10, 11, 12]], 4, "self-intersection"


def _case_thin_triangle(two_by_two):
    points, polygons = two_by_two()
    # bounding box [0, 4] x [0, 2]: tol = RTOL * sqrt(20); a triangle of base 1 and height 2.5 tol
    # has area > tol * diameter but its centroid lies within tol of its base
    tol = RTOL * np.sqrt(20.0)
    points = np.vstack([points, [[3.0, 0.0], [4.0, 0.0], [3.5, 2.5 * tol]]])
    return points, polygons + [[9, 10, 11]], 4, "cannot be sub-triangulated"


def _case_crack(two_by_two):
    points, polygons = two_by_two()
    points = np.vstack([points, points[[4, 7]]])  # copies of (1,1), (1,2): points 9, 10
    polygons[3] = [9, 5, 8, 10]
    return points, polygons, 3, "same location"


def _case_crossing(two_by_two):
    points, polygons = two_by_two()
    points = np.vstack([points, [[1.5, 1.5], [2.5, 1.5], [2.5, 2.5], [1.5, 2.5]]])
    return points, polygons + [[9, 10, 11, 12]], 4, "crosses or touches"


def _case_nested(two_by_two):
    points, polygons = two_by_two()
    points = np.vstack([points, [[0.25, 0.25], [0.75, 0.25], [0.75, 0.75], [0.25, 0.75]]])
    return points, polygons + [[9, 10, 11, 12]], 4, "inside polygon 0"


def _case_nested_first(two_by_two):
    points, polygons = two_by_two()
    points = np.vstack([points, [[0.25, 0.25], [0.75, 0.25], [0.75, 0.75], [0.25, 0.75]]])
    return points, [[9, 10, 11, 12]] + polygons, 1, "contains the midpoint"


def _case_diagonal_triangle(two_by_two):
    angles = np.pi / 3 * np.arange(6)
    points = np.column_stack([np.cos(angles), np.sin(angles)])
    return points, [list(range(6)), [0, 2, 4]], 1, "midpoint .* inside polygon 0"


def _case_same_direction(two_by_two):
    points, polygons = two_by_two()
    return points, polygons + [[4, 5, 8, 7]], 4, "same direction"


def _case_same_direction_partial(two_by_two):
    points, polygons = two_by_two()  # triangle on the lower half of square 0, sharing two of its edges
    return points, polygons + [[0, 1, 4]], 4, "same direction"


REJECTIONS = {f.__name__[6:]: f for f in [
    _case_too_short, _case_repeated, _case_out_of_range, _case_negative_index, _case_float_indices,
    _case_zero_area, _case_bow_tie, _case_vertex_on_own_edge, _case_thin_triangle, _case_crack,
    _case_crossing, _case_nested, _case_nested_first, _case_diagonal_triangle, _case_same_direction,
    _case_same_direction_partial]}


@pytest.mark.parametrize("case", REJECTIONS)
def test_rejection_names_polygon(case, two_by_two):
    points, polygons, bad, reason = REJECTIONS[case](two_by_two)
    with pytest.raises(ValueError, match=f"^polygon {bad}: .*{reason}") as info:
        PolygonMesh(points, polygons)
    assert not re.search(rf"polygon (?!{bad}\b)\d+:", str(info.value))


@pytest.mark.parametrize("case", sorted(set(REJECTIONS) - {"crack", "repeated", "out_of_range", "negative_index",
                                                          "float_indices"}))
def test_rejection_cases_are_valid_without_the_culprit(case, assert_valid_mesh, two_by_two):
    """The added polygon is the only problem of each case that adds one (it is the first one,
    polygon 0, in 'nested_first'; the named polygon otherwise)."""
    points, polygons, bad, _ = REJECTIONS[case](two_by_two)
    culprit = 0 if case == "nested_first" else bad
    assert_valid_mesh(PolygonMesh(points, [p for i, p in enumerate(polygons) if i != culprit]))


def test_t_junction_rejected_without_insertion(hanging_mesh):
    points, polygons, _ = hanging_mesh(2, listed=False)
    with pytest.raises(ValueError, match=r"^polygon 3: vertex \d+ .*T-junction"):
        PolygonMesh(points, polygons, insert_hanging_nodes=False)


def test_half_listed_t_junction_rejected_without_insertion(hanging_mesh):
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
def test_bad_tags(tags, message, two_by_two):
    points, polygons = two_by_two()
    with pytest.raises(ValueError, match=message):
        PolygonMesh(points, polygons, tags)


# --------------------------------------------------------------------------- acceptance
def test_clockwise_polygons_are_reoriented(square_grid, assert_valid_mesh):
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


def test_attributes_of_a_valid_mesh(square_grid, assert_valid_mesh):
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


def test_unused_points_are_allowed(square_grid, assert_valid_mesh):
    points, polygons = square_grid(2, 1)
    points = np.vstack([points, [[7.0, 7.0], [1.0, 1.0]]])  # unused, one even at a used location
    assert_valid_mesh(PolygonMesh(points, polygons))


@pytest.mark.parametrize("k", [1, 2, 3])
def test_hanging_nodes_listed(k, assert_valid_mesh, hanging_mesh):
    points, polygons, hanging = hanging_mesh(k, listed=True)
    mesh = PolygonMesh(points, polygons)
    assert mesh.polygon(k + 1).size == 4 + k
    np.testing.assert_array_equal(mesh.hanging_nodes, hanging)
    assert mesh.n_inserted_hanging_nodes == 0
    np.testing.assert_allclose(mesh.areas, [1.0 / (k + 1) ** 2] * (k + 1) + [1.0])
    assert_valid_mesh(mesh)
    assert f"hanging nodes: {k} (0 inserted" in mesh.summary()


@pytest.mark.parametrize("k", [1, 2, 3])
def test_hanging_nodes_inserted_equal_listed(k, hanging_mesh):
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


def test_t_junctions_on_several_edges_of_both_orientations(square_grid, assert_valid_mesh, glue):
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


def test_summary(hanging_mesh):
    points, polygons, _ = hanging_mesh(1, listed=True)
    mesh = PolygonMesh(points, polygons, tags=[1, 1, 7])
    text = mesh.summary()
    assert "3 polygons" in text and "4: 2, 5: 1" in text and "1: 2 polygons, 7: 1 polygons" in text


# --------------------------------------------------------------------------- triangulation
def test_star_shaped_polygon_fans_from_kernel_centroid(assert_valid_triangulation, nonconvex):
    extra, triangles, interior = sub_triangulate(nonconvex.STAR_L)
    np.testing.assert_allclose(extra, [[0.1, 0.1]])  # the centroid (0.55, 0.55) sees only part of it
    assert triangles.shape == (6, 3) and list(interior) == [6, 6]
    assert_valid_triangulation(nonconvex.STAR_L, triangles, interior, extra)


def test_hanging_vertices_on_a_nonconvex_star_polygon(assert_valid_triangulation):
    # the L with extra collinear vertices on its long outer sides and on a reflex side
    xy = np.array([(0, 0), (1, 0), (2, 0), (2, .2), (1, .2), (.2, .2), (.2, 1), (.2, 2), (0, 2), (0, 1)], float)
    extra, triangles, interior = sub_triangulate(xy)
    assert extra.shape == (1, 2)
    assert_valid_triangulation(xy, triangles, interior, extra)


@pytest.mark.parametrize("name", ["comb", "spiral", "mirrored-comb"])
def test_non_star_polygon_is_ear_clipped(name, assert_valid_triangulation, assert_deepest_diagonal, nonconvex):
    xy = {"comb": nonconvex.COMB, "spiral": nonconvex.SPIRAL, "mirrored-comb": nonconvex.COMB[::-1] * [-1, 1]}[name]
    extra, triangles, interior = sub_triangulate(xy)
    assert extra.shape == (0, 2) and triangles.shape == (len(xy) - 2, 3)
    assert interior[0] != interior[1]
    assert_valid_triangulation(xy, triangles, interior, extra)
    assert_deepest_diagonal(xy, triangles, interior)


def test_convex_polygon_fans_from_centroid(assert_valid_triangulation):
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


def test_mesh_of_nonconvex_polygons(shoelace, assert_valid_mesh, glue, nonconvex):
    """The comb with the spiral glued below (its top side puts two T-junctions into the comb's
    bottom side) and a small L on its right tooth: ear clipping and a kernel fan in mesh numbering."""
    points, polygons = glue((nonconvex.COMB, [list(range(12))]), (nonconvex.SPIRAL + [0.0, -4.0], [list(range(10))]),
                            (nonconvex.STAR_L * 0.5 + [4.0, 3.0], [list(range(6))]))
    mesh = PolygonMesh(points, polygons, tags=[0, 1, 2])
    assert mesh.n_inserted_hanging_nodes == 2 and mesh.polygon(0).size == 14
    assert_valid_mesh(mesh)
    assert mesh.extra_points.shape == (1, 2) and mesh.triangles.shape == (12 + 8 + 6, 3)
    np.testing.assert_allclose(mesh.areas, [shoelace(nonconvex.COMB), shoelace(nonconvex.SPIRAL),
                                            shoelace(nonconvex.STAR_L) / 4])


# --------------------------------------------------------------------------- partition
@pytest.mark.parametrize("n_parts", [1, 2, 3, 5, 7, 16])
def test_partition_is_balanced_and_deterministic(n_parts, square_grid):
    points, polygons = square_grid(13, 7)
    mesh = PolygonMesh(points, polygons)
    parts = mesh.partition(n_parts)
    assert parts.dtype == np.int32 and parts.shape == (91,)
    counts = np.bincount(parts, minlength=n_parts)
    assert counts.size == n_parts and counts.max() - counts.min() <= 1
    np.testing.assert_array_equal(parts, mesh.partition(n_parts))


def test_partition_cuts_across_the_longer_extent(square_grid):
    points, polygons = square_grid(10, 3)
    parts = PolygonMesh(points, polygons).partition(2)
    centres = points[np.array(polygons)].mean(axis=1)
    assert centres[parts == 0, 0].max() < centres[parts == 1, 0].min()


def test_partition_rejects_bad_counts(square_grid):
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


def test_to_dolfinx_serial(shoelace, hanging_mesh, nonconvex):
    points, polygons, _ = hanging_mesh(3, listed=False)
    n = len(points)
    points = np.vstack([points, [[9.0, 9.0]], nonconvex.COMB * 0.2 + [1.5, 0.0]])  # an unused point, a separate comb
    polygons = polygons + [list(range(n + 1, n + 13))]
    mesh = PolygonMesh(points, polygons)
    area, n_cells = _check_dolfinx_mesh(mesh, MPI.COMM_SELF)
    assert n_cells == mesh.triangles.shape[0] == 4 * 4 + 7 + 10
    assert np.isclose(area, 4 / 16 + 1.0 + 0.04 * shoelace(nonconvex.COMB))


@pytest.mark.mpi
def test_to_dolfinx_parallel(square_grid, hanging_mesh, glue):
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
def test_quadrature_triangulation_has_n_minus_2_positive_triangles_tiling_each_polygon(listed, shoelace, hanging_mesh,
                                                                                       nonconvex):
    points, polygons, _ = hanging_mesh(3, listed=listed)
    n = len(points)
    points = np.vstack([points, nonconvex.COMB * 0.2 + [1.5, 0.0]])
    mesh = PolygonMesh(points, polygons + [list(range(n, n + 12))])
    nodes, tri, off = mesh.nodes, mesh.quadrature_triangles, mesh.quadrature_triangle_offsets
    for p in range(mesh.n_polygons):
        t = tri[off[p]:off[p + 1]]
        assert t.shape[0] == mesh.polygon(p).size - 2
        areas = np.array([shoelace(nodes[k]) for k in t])
        assert np.all(areas > 0)
        assert np.isclose(areas.sum(), mesh.areas[p])
