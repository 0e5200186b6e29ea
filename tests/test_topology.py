"""Topology of a PolygonMesh (sides, succession, edges, boundary) and the SFVEM node count and keys.

References are built from the vertex lists by plain Python loops, counted by hand, or follow from
geometry (boundary edges lie on the outer boundary) and Euler's formula V - E + F = 1 - holes.
"""
import numpy as np
import pytest
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem.discretizations.node_keys import sfvem_unknowns
from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh
from dolfinx_sfvem.mesh.csr import next_entries, previous_entries

# unit square 0-1-2-3 left of two rectangles [1, 2] x [0, 0.5] and [1, 2] x [0.5, 1]: point 4 =
# (1, 0.5) is a hanging node of the square (inserted into its vertex list); point 8 is unused
POINTS = [[0, 0], [1, 0], [1, 1], [0, 1], [1, 0.5], [2, 0], [2, 0.5], [2, 1], [5, 5]]
POLYGONS = [[0, 1, 2, 3], [1, 5, 6, 4], [4, 6, 7, 2]]


def hanging_mesh() -> PolygonMesh:
    return PolygonMesh(np.array(POINTS, dtype=float), POLYGONS)


def python_sides(mesh):
    """(start, end, polygon) of every side, polygon by polygon, by index arithmetic."""
    out = []
    for p in range(mesh.n_polygons):
        verts = mesh.polygon(p).tolist()
        out += [(verts[k], verts[(k + 1) % len(verts)], p) for k in range(len(verts))]
    return out


def test_sides_and_succession_with_a_hanging_node():
    mesh = hanging_mesh()
    assert mesh.polygon(0).tolist() == [0, 1, 4, 2, 3] and mesh.hanging_nodes.tolist() == [4]
    start, end, polygon = (np.array(c) for c in zip(*python_sides(mesh)))
    sides = mesh.sides
    np.testing.assert_array_equal(sides.start, start)
    np.testing.assert_array_equal(sides.end, end)
    np.testing.assert_array_equal(sides.polygon, polygon)
    np.testing.assert_array_equal(mesh.vertices[mesh.next_entry], end)
    np.testing.assert_array_equal(mesh.vertices[mesh.previous_entry][mesh.next_entry], start)
    polygons_of = {}
    for a, b, p in python_sides(mesh):
        polygons_of.setdefault(frozenset((a, b)), []).append(p)
    across = [next((q for q in polygons_of[frozenset((a, b))] if q != p), -1) for a, b, p in python_sides(mesh)]
    np.testing.assert_array_equal(sides.neighbour, across)
    assert sides.neighbour.tolist()[:5] == [-1, 1, 2, -1, -1]     # the square: rectangle 1 and 2 across 1-4, 4-2
    np.testing.assert_array_equal(sides.edge, mesh.edge_index(start, end))


def test_succession_of_a_csr_array():
    offsets = np.array([0, 3, 7])                                # a triangle and a quadrilateral
    np.testing.assert_array_equal(next_entries(offsets), [1, 2, 0, 4, 5, 6, 3])
    np.testing.assert_array_equal(previous_entries(offsets), [2, 0, 1, 6, 3, 4, 5])


def test_edges_of_a_mesh_with_a_hanging_node():
    mesh = hanging_mesh()
    edges = sorted({(min(a, b), max(a, b)) for a, b, _ in python_sides(mesh)})
    assert mesh.n_edges == len(edges) == 10                      # 5 square sides (one split), 3 + 3 - 1 more
    np.testing.assert_array_equal(mesh.edge_points, edges)
    a, b = np.array(edges).T
    np.testing.assert_array_equal(mesh.edge_index(a, b), np.arange(10))
    np.testing.assert_array_equal(mesh.edge_index(b, a), np.arange(10))
    expected = np.full((10, 2), -1)
    for s, e, p in python_sides(mesh):
        expected[edges.index((min(s, e), max(s, e))), int(s > e)] = p
    np.testing.assert_array_equal(mesh.edge_polygons, expected)
    inner = [edges.index(e) for e in [(1, 4), (2, 4), (4, 6)]]     # the only edges with two polygons
    np.testing.assert_array_equal(mesh.boundary_edges, np.setdiff1d(np.arange(10), inner))
    np.testing.assert_array_equal(mesh.used_points, np.arange(8))


def test_edge_index_names_a_pair_that_is_not_an_edge():
    with pytest.raises(ValueError, match=r"points \(0, 2\) are not the end points of a polygon edge"):
        hanging_mesh().edge_index([0, 0], [1, 2])                # (0, 2): a diagonal of the square


@pytest.mark.parametrize("hole", [False, True])
def test_boundary_edges_lie_on_the_boundary(hole):
    """Quads with hanging nodes (and a hole cut out): the boundary edges are exactly the edges
    whose midpoints lie on the outer rectangle or the hole's boundary; E = V + F - 1 + holes."""
    mesh = sf.meshes.quads_with_hanging_nodes(2.0, 1.0, 8, refine=(0.5, 1.25, 0.25, 0.5))
    box = (0.75, 1.5, 0.5, 0.75)                                  # a hole on cells of the coarse part
    if hole:
        c = mesh.centroids
        keep = ~((c[:, 0] > box[0]) & (c[:, 0] < box[1]) & (c[:, 1] > box[2]) & (c[:, 1] < box[3]))
        mesh = PolygonMesh(mesh.points, [mesh.polygon(i) for i in np.flatnonzero(keep)])
    assert mesh.hanging_nodes.size > 0
    assert mesh.n_edges == mesh.used_points.size + mesh.n_polygons - 1 + int(hole)
    mid = mesh.points[mesh.edge_points].mean(axis=1)
    x, y = mid.T
    on = np.isclose(x, 0) | np.isclose(x, 2) | np.isclose(y, 0) | np.isclose(y, 1)
    if hole:
        on |= (((np.isclose(x, box[0]) | np.isclose(x, box[1])) & (y >= box[2]) & (y <= box[3]))
               | ((np.isclose(y, box[2]) | np.isclose(y, box[3])) & (x >= box[0]) & (x <= box[1])))
    np.testing.assert_array_equal(mesh.boundary_edges, np.flatnonzero(on))
    assert (mesh.sides.neighbour < 0).sum() == mesh.boundary_edges.size


@pytest.mark.mpi
@pytest.mark.parametrize("mesh", [hanging_mesh(),
                                  sf.meshes.quads_with_hanging_nodes(2.0, 1.0, 4, refine=(0.5, 1.5, 0.25, 0.75))])
def test_sfvem_unknowns_and_node_keys_of_the_space(mesh):
    """2 x (vertices + edges + polygons), hanging nodes as vertices and unused points not counted
    (hand count for the first mesh: 8 + 10 + 3); the space's node keys over all ranks are the
    used points, n_points + every edge and n_points + n_edges + every polygon."""
    space = sf.VEMSpace(mesh, MPI.COMM_WORLD, verbose=False)
    assert sfvem_unknowns(mesh) == space.num_dofs_global
    if mesh.n_points == len(POINTS):
        assert sfvem_unknowns(mesh) == 2 * (8 + 10 + 3)
    keys = np.sort(np.concatenate(MPI.COMM_WORLD.allgather(space.node_key[:space.n_owned_nodes])))
    n = mesh.n_points
    np.testing.assert_array_equal(keys, np.concatenate([mesh.used_points, n + np.arange(mesh.n_edges),
                                                        n + mesh.n_edges + np.arange(mesh.n_polygons)]))
