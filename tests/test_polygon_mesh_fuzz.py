"""Fuzzing PolygonMesh: random corruptions of valid meshes are either accepted as valid meshes or
rejected with ValueError, never another exception; random polygons triangulate validly. The mesh
builders and checks are conftest.py's fixtures."""
import numpy as np
import pytest
from matplotlib.path import Path

from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh
from dolfinx_sfvem.mesh.polygon import sub_triangulate

N_CASES = 200


def base_meshes(square_grid, hanging_mesh, glue, nonconvex):
    """Valid meshes (points, polygons) to corrupt."""
    points, squares = square_grid(4, 3)
    triangles = [t for a, b, c, d in squares for t in ([a, b, c], [a, c, d])]
    return [
        square_grid(3, 3),
        (points, triangles),
        hanging_mesh(2, listed=False)[:2],
        hanging_mesh(3, listed=True)[:2],
        glue((nonconvex.COMB, [list(range(12))]), (nonconvex.SPIRAL + [0.0, -4.0], [list(range(10))]),
             (nonconvex.STAR_L * 0.5 + [4.0, 3.0], [list(range(6))])),
    ]


# --------------------------------------------------------------------------- corruptions
# each takes (rng, points (n, 2) float array, polygons list of lists, tags list) and returns the three

def swap_indices(rng, points, polygons, tags):
    p = polygons[rng.integers(len(polygons))]
    i, j = rng.choice(len(p), 2, replace=False)
    p[i], p[j] = p[j], p[i]
    return points, polygons, tags


def duplicate_index(rng, points, polygons, tags):
    p = polygons[rng.integers(len(polygons))]
    i, j = rng.choice(len(p), 2, replace=False)
    p[i] = p[j]
    return points, polygons, tags


def out_of_range_index(rng, points, polygons, tags):
    p = polygons[rng.integers(len(polygons))]
    p[rng.integers(len(p))] = int(rng.choice([-1, -7, len(points), len(points) + 5, 2**40]))
    return points, polygons, tags


def collapse_points(rng, points, polygons, tags):
    a, b = rng.choice(len(points), 2, replace=False)
    points[a] = points[b] + rng.choice([0.0, 1e-13, 1e-3]) * rng.normal(size=2)
    return points, polygons, tags


def move_point(rng, points, polygons, tags):
    points[rng.integers(len(points))] += rng.normal(scale=rng.choice([0.05, 0.3, 1.0]), size=2)
    return points, polygons, tags


def reverse_polygon(rng, points, polygons, tags):
    i = rng.integers(len(polygons))
    polygons[i] = polygons[i][::-1]
    return points, polygons, tags


def rotate_polygon(rng, points, polygons, tags):
    i = rng.integers(len(polygons))
    polygons[i] = list(np.roll(polygons[i], rng.integers(1, len(polygons[i]))))
    return points, polygons, tags


def add_bow_tie(rng, points, polygons, tags):
    corners = [(0.0, 0.0), (1.0, 1.0), (1.0, 0.0), (0.0, rng.uniform(0.5, 2.0))]
    new = points.mean(axis=0) + rng.normal(scale=2.0, size=2) + rng.uniform(0.2, 2.0) * np.array(corners)
    n = len(points)
    return np.vstack([points, new]), polygons + [[n, n + 1, n + 2, n + 3]], tags + [0]


def add_overlapping_copy(rng, points, polygons, tags):
    p = polygons[rng.integers(len(polygons))]
    shift = rng.choice([0.0, 0.5, 1.0]) * rng.normal(size=2)
    n = len(points)
    return np.vstack([points, points[p] + shift]), polygons + [list(range(n, n + len(p)))], tags + [1]


def add_polygon_of_existing_points(rng, points, polygons, tags):
    return points, polygons + [list(rng.choice(len(points), rng.integers(3, 6), replace=False))], tags + [2]


def drop_polygon(rng, points, polygons, tags):
    i = rng.integers(len(polygons))
    return points, polygons[:i] + polygons[i + 1:], tags[:i] + tags[i + 1:]


def split_edge(rng, points, polygons, tags):
    """A new point on an edge of one polygon, listed only there (or also slightly off the edge)."""
    p = polygons[rng.integers(len(polygons))]
    k = rng.integers(len(p))
    t = rng.uniform(0.1, 0.9)
    new = (1 - t) * points[p[k]] + t * points[p[(k + 1) % len(p)]] + rng.choice([0.0, 0.0, 1e-3]) * rng.normal(size=2)
    p.insert(k + 1, len(points))
    return np.vstack([points, new]), polygons, tags


def non_finite_point(rng, points, polygons, tags):
    points[rng.integers(len(points)), rng.integers(2)] = rng.choice([np.nan, np.inf, -np.inf])
    return points, polygons, tags


def shorten_polygon(rng, points, polygons, tags):
    i = rng.integers(len(polygons))
    polygons[i] = polygons[i][:rng.integers(0, 3)]
    return points, polygons, tags


GARBAGE = [None, "abc", 3.5, {}, [[0, 1], [2, 3]], [0.5, 1.0, 2.0], [True, False, True], [0, None, 1],
           np.array([0.0, 1.0, 2.0]), [[]], object(), [0, "1", 2]]


def garbage_polygon(rng, points, polygons, tags):
    polygons[rng.integers(len(polygons))] = GARBAGE[rng.integers(len(GARBAGE))]
    return points, polygons, tags


def garbage_points(rng, points, polygons, tags):
    choices = [points[:, :1], np.hstack([points, points[:, :1]]), points.ravel(), "points", None,
               points.astype(str), [[0.0, 1.0], [2.0]], points[:2]]
    return choices[rng.integers(len(choices))], polygons, tags


def garbage_tags(rng, points, polygons, tags):
    choices = [tags[:-1], [0.5] * len(tags), ["a"] * len(tags), [[t] for t in tags], 7, [2**40] * len(tags)]
    return points, polygons, choices[rng.integers(len(choices))]


def garbage_polygon_list(rng, points, polygons, tags):
    return points, [None, 5, "polygons", [], {1: 2}][rng.integers(5)], tags


CORRUPTIONS = [swap_indices, duplicate_index, collapse_points, move_point, reverse_polygon,
               rotate_polygon, add_bow_tie, add_overlapping_copy, add_polygon_of_existing_points, drop_polygon,
               split_edge, non_finite_point, shorten_polygon]
# these break what the others assume (valid indices and types): at most one, applied last
FINAL_CORRUPTIONS = [out_of_range_index, garbage_polygon, garbage_points, garbage_tags, garbage_polygon_list]


def assert_no_overlap(mesh):
    """No sub-triangle centroid lies inside another polygon (an independent conformity check)."""
    nodes = mesh.nodes
    centres = nodes[mesh.triangles].mean(axis=1)
    owner = mesh.triangle_polygon
    for i in range(mesh.n_polygons):
        inside = Path(mesh.polygon_coordinates(i)).contains_points(centres)
        np.testing.assert_array_equal(inside, owner == i)


def test_corrupted_meshes_are_rejected_or_valid(square_grid, assert_valid_mesh, hanging_mesh, glue, nonconvex):
    rng = np.random.default_rng(20240531)
    bases = base_meshes(square_grid, hanging_mesh, glue, nonconvex)
    outcome = {"accepted": 0, "rejected": 0}
    for case in range(N_CASES):
        points, polygons = bases[case % len(bases)]
        points, polygons = np.array(points, dtype=float), [list(map(int, p)) for p in polygons]
        tags = list(rng.integers(0, 3, size=len(polygons)))
        for corrupt in rng.choice(CORRUPTIONS, size=rng.integers(1, 4)):
            if len(polygons) > 1 and min(map(len, polygons)) >= 2:  # what the corruptions need
                points, polygons, tags = corrupt(rng, points, polygons, tags)
        if rng.uniform() < 0.25:
            points, polygons, tags = FINAL_CORRUPTIONS[rng.integers(len(FINAL_CORRUPTIONS))](
                rng, points, polygons, tags)
        try:
            mesh = PolygonMesh(points, polygons, tags, insert_hanging_nodes=rng.uniform() < 0.7)
        except ValueError:
            outcome["rejected"] += 1
            continue
        outcome["accepted"] += 1
        assert_valid_mesh(mesh)
        assert_no_overlap(mesh)
        np.testing.assert_array_equal(mesh.points, points)
    # both outcomes are exercised
    assert outcome["accepted"] >= N_CASES // 10 and outcome["rejected"] >= N_CASES // 2, outcome


def random_star_polygon(rng):
    """A polygon with the origin strictly inside its kernel (all angular gaps < pi), often very
    non-convex, some vertices collinear (hanging) on its sides."""
    n = rng.integers(3, 16)
    angles = np.sort(rng.uniform(0, 2 * np.pi, n))
    while np.diff(np.append(angles, angles[0] + 2 * np.pi)).max() > 0.9 * np.pi:
        angles = np.sort(rng.uniform(0, 2 * np.pi, n))
    radii = rng.uniform(0.05, 1.0, n)
    xy = np.column_stack([radii * np.cos(angles), radii * np.sin(angles)])
    for k in np.sort(rng.choice(n, rng.integers(0, 3), replace=False))[::-1]:
        t = rng.uniform(0.2, 0.8)
        xy = np.insert(xy, k + 1, (1 - t) * xy[k] + t * xy[(k + 1) % len(xy)], axis=0)
    return xy


def random_comb(rng):
    """A comb: teeth of random widths and heights on a base strip, some with hanging vertices;
    usually not star-shaped."""
    n_teeth = rng.integers(2, 6)
    edges = np.sort(rng.uniform(0, 10, 2 * n_teeth))
    top = [(10.0, 0.0), (10.0, 1.0)]
    for k in range(n_teeth - 1, -1, -1):
        x0, x1, h = edges[2 * k], edges[2 * k + 1], rng.uniform(1.5, 6.0)
        top += [(x1, 1.0), (x1, 1.0 + h), (0.5 * (x0 + x1), 1.0 + h), (x0, 1.0 + h), (x0, 1.0)]
    return np.array([(0.0, 0.0), (5.0, 0.0)] + top + [(0.0, 1.0)])


def random_affine(rng, xy):
    a = np.eye(2) + 0.3 * rng.normal(size=(2, 2))
    if np.linalg.det(a) < 0:
        a[:, 0] *= -1
    return xy @ a.T + rng.choice([0.0, 1e4]) * rng.normal(size=2)


@pytest.mark.parametrize("seed", range(5))
def test_random_star_polygons_get_a_valid_fan(seed, assert_valid_triangulation):
    rng = np.random.default_rng(seed)
    for _ in range(40):
        xy = random_affine(rng, random_star_polygon(rng))
        extra, triangles, interior = sub_triangulate(xy)
        assert extra.shape == (1, 2)
        assert_valid_triangulation(xy, triangles, interior, extra)


@pytest.mark.parametrize("seed", range(5))
def test_random_combs_triangulate_validly(seed, assert_valid_triangulation, assert_deepest_diagonal):
    rng = np.random.default_rng(100 + seed)
    n_ears = 0
    for _ in range(20):
        xy = random_affine(rng, random_comb(rng))
        extra, triangles, interior = sub_triangulate(xy)
        assert_valid_triangulation(xy, triangles, interior, extra)
        if extra.shape[0] == 0:
            assert_deepest_diagonal(xy, triangles, interior)
            n_ears += 1
    assert n_ears >= 5  # most combs have an empty kernel
