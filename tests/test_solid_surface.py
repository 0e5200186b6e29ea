"""The 3D contact checks (dolfinx_sfvem/physics/solid_surface.py) on configurations whose answer is exact:
two cubes across a gap and pushed into each other, a C whose arms are brought together, a curved
quadratic face, two ridges crossing between their nodes; and the size it handles."""
import math
import time

import numpy as np
import pytest

from dolfinx_sfvem.physics.contact import SolidBoundary
from dolfinx_sfvem.physics.contact_checks import solid_boundary
from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh
from dolfinx_sfvem.mesh.csr import edge_key
from dolfinx_sfvem.physics.solid_surface import SolidSurface

CELLS = ["hexahedron", "tetrahedron"]


def surface(mesh, solid_tags=(1,), **kwargs) -> SolidSurface:
    n = mesh.points.shape[0]
    return SolidSurface(mesh, solid_tags, lambda a, b: n + edge_key(a, b, n), **kwargs)


def two_cubes(box_grid, cell, gap=0.3):
    """Unit cubes [0, 1]³ and [1 + gap, 2 + gap] x [0, 1]² (tag 1), medium between them (tag 2)."""
    xs = [0, 0.5, 1, 1 + gap, 1.5 + gap, 2 + gap]
    return box_grid(xs, [0, 0.5, 1], [0, 0.5, 1], lambda c: 2 if 1 < c[0] < 1 + gap else 1, cell)


@pytest.mark.parametrize("cell", CELLS)
def test_two_cubes_gap_and_overlap(box_grid, cell):
    mesh = two_cubes(box_grid, cell)
    s = surface(mesh)
    assert s.n_bodies == 2
    faces_per_quad = 8 if cell == "hexahedron" else 8        # 1 quad -> 8, or 2 triangles -> 2 x 4
    assert s.triangles.shape[0] == 2 * 6 * 4 * faces_per_quad
    gap = s.gap(np.zeros_like(s.X))
    assert gap.value == pytest.approx(0.3, abs=1e-12)
    assert {gap.body, gap.partner_body} == {0, 1} and not gap.overlapping
    assert gap.x[0] in (pytest.approx(1.0), pytest.approx(1.3))
    # a rigid motion: the same gap
    R = np.array([[0.6, -0.8, 0.0], [0.8, 0.6, 0.0], [0.0, 0.0, 1.0]])
    assert s.gap(s.X @ R.T + [0.1, 2.0, -1.0] - s.X).value == pytest.approx(0.3, abs=1e-12)
    # the right cube moved by -0.25 and by -0.4 in x: gap 0.05; then 0.1 deep inside each other
    right = s.X[:, 0] > 1.2
    for shift, expected in ((-0.25, 0.05), (-0.4, -0.1)):
        u = np.zeros_like(s.X)
        u[right, 0] = shift
        gap = s.gap(u)
        assert gap.value == pytest.approx(expected, abs=1e-12)
        assert gap.overlapping == (expected < 0)
    # depth 0.1 in tolerances 0.02 x the longest surface edge: 0.5, or the diagonal of the tetrahedra's faces
    h = 0.5 if cell == "hexahedron" else 0.5 * math.sqrt(2.0)
    assert gap.overlap == pytest.approx(0.1 / (0.02 * h), rel=1e-9)


def test_factory(box_grid, square_grid):
    mesh = two_cubes(box_grid, "hexahedron")
    n = mesh.points.shape[0]
    assert isinstance(solid_boundary(mesh, (1,), lambda a, b: n + edge_key(a, b, n)), SolidSurface)
    points, polygons = square_grid(2, 1)
    mesh2d = PolygonMesh(points, polygons)
    assert isinstance(solid_boundary(mesh2d, (0,), lambda a, b: 6 + edge_key(a, b, 6)), SolidBoundary)


@pytest.mark.parametrize("cell", CELLS)
def test_c_shape_self_contact(box_grid, cell):
    """A C in the x-z plane (wall x < 0.1, beams z < 0.1 and z > 0.5, medium between), extruded in y:
    one body whose beams face each other across 0.4; the wall and the beams' own faces never count
    (the mesh is fine enough that the beams are more than two surface edges apart)."""
    xs, zs = np.linspace(0.0, 1.0, 11), np.linspace(0.0, 0.6, 7)      # h = 0.1: 2 sqrt(2) h < 0.4
    mesh = box_grid(xs, [0, 0.1, 0.2], zs, lambda c: 2 if c[0] > 0.1 and 0.1 < c[2] < 0.5 else 1, cell)
    s = surface(mesh)
    assert s.n_bodies == 1
    gap = s.gap(np.zeros_like(s.X))
    assert gap.value == pytest.approx(0.4, abs=1e-12)
    assert gap.body == gap.partner_body == 0
    # the upper beam sheared down about the wall: its tip comes to 0.05 above the lower beam's tip;
    # sheared further and shortened to 0.9, its tip lies 0.05 deep inside the lower beam (0.1 thick)
    upper = s.X[:, 2] >= 0.5 - 1e-12
    for drop, shorten, expected in ((0.35, 0.0, 0.05), (0.45, 0.1, -0.05)):
        u = np.zeros_like(s.X)
        arm = np.maximum(s.X[upper, 0] - 0.1, 0.0) / 0.9
        u[upper, 2], u[upper, 0] = -drop * arm, -shorten * arm
        gap = s.gap(u)
        assert gap.value == pytest.approx(expected, abs=1e-12)
        assert gap.x[0] == pytest.approx(1.0 - shorten) and gap.overlapping == (expected < 0)


@pytest.mark.parametrize("cell", CELLS)
def test_curved_quadratic_face(box_grid, cell):
    """The right cube's face x = 1.3 bulged towards the left cube by moving its edge-midpoint (and face
    centre) nodes by -delta: the gap is measured to the flat sub-triangles through the moved nodes,
    0.3 - delta, within delta / 3 of the distance to the quadratic face itself."""
    mesh = two_cubes(box_grid, cell)
    s = surface(mesh)
    n = mesh.points.shape[0]
    delta = 0.06
    midpoint = (s.node_keys >= n) & (np.abs(s.X[:, 0] - 1.3) < 1e-12)
    interior = (s.X[:, 1] > 1e-12) & (s.X[:, 1] < 1 - 1e-12) & (s.X[:, 2] > 1e-12) & (s.X[:, 2] < 1 - 1e-12)
    u = np.zeros_like(s.X)
    u[midpoint & interior, 0] = -delta
    gap = s.gap(u)
    assert gap.value == pytest.approx(0.3 - delta, abs=1e-12)
    # a P2 triangle with its three midpoints moved bulges by 4/3 delta at its centre; a Q2 face by delta
    assert 0.3 - 4 / 3 * delta - 1e-12 <= gap.value <= 0.3 - delta + 1e-12


def test_ridges_crossing_between_nodes(box_grid):
    """Two single-hexahedron cubes turned 45° so that a ridge of each points at the other, crossing by
    depth d at a point a quarter along both ridges: no node lies inside the other cube, the samples on
    the crossing sub-triangles find it (depth d / sqrt(2) on the quarter-point sample)."""
    unit = box_grid([0, 1], [0, 1], [0, 1])
    c, r2 = math.cos(math.pi / 4), math.sqrt(2.0)
    # cube A: ridge along y on top at height r2/2, x = 0; cube B: ridge along x at the bottom
    rot_y = np.array([[c, 0, -c], [0, 1, 0], [c, 0, c]])      # (1, 0, 1)/sqrt2 ... edge (1, y, 1) on top
    A = (unit.points - [0.5, 0, 0.5]) @ rot_y.T
    rot_x = np.array([[1, 0, 0], [0, c, -c], [0, c, c]])
    B = (unit.points - [0, 0.5, 0.5]) @ rot_x.T
    top_A, bottom_B = A[:, 2].max(), B[:, 2].min()
    d = 0.05                                                  # d / sqrt(2) > 0.02 (the tolerance) x 1 (h)
    B += [-0.25, 0.25, top_A - bottom_B - d]                  # B's ridge crosses A's at (0, 0.25) quarter points
    mesh = type(unit)(np.concatenate([A, B]), np.concatenate([unit.cells, unit.cells + 8]), np.array([1, 1]),
                      "hexahedron")
    s = surface(mesh)
    assert s.n_bodies == 2
    gap = s.gap(np.zeros_like(s.X))
    assert gap.value == pytest.approx(-d / r2, rel=1e-9)
    assert gap.overlapping and gap.x[1] == pytest.approx(0.25, abs=1e-9)
    B[:, 2] += 2 * d                           # apart by d: nothing crosses; the nodes are farther than d
    apart = surface(type(unit)(np.concatenate([A, B]), mesh.cells, mesh.tags, "hexahedron")).gap(np.zeros((s.n_nodes, 3)))
    assert apart.value > d and apart.overlap == 0.0


def uniform_traction_forces(s: SolidSurface, p: float) -> np.ndarray:
    """Consistent P2/Q2 nodal forces (n_nodes, 3) of the traction p e_x on the left cube's face x = 1."""
    f = np.zeros_like(s.X)
    for face, nodes in enumerate(s.face_nodes):
        if not s.face_faces_medium[face] or abs(s.X[nodes[0], 0] - 1.0) > 1e-12:
            continue
        k = 3 if nodes.size == 6 else 4
        area = 0.25 if k == 4 else 0.125
        weights = [0.0] * 3 + [1 / 3] * 3 if k == 3 else [1 / 36] * 4 + [1 / 9] * 4 + [4 / 9]
        f[nodes, 0] += p * area * np.array(weights)
    return f


@pytest.mark.parametrize("vertices_only", [False, True])
def test_pressure_uniform_compression(box_grid, vertices_only):
    """Nodal forces of a uniform traction p n on the solid-medium interface (the consistent P2/Q2 loads)
    give back the pressure p at every node of that face, and the pair's force p x area; also when
    the pressure is recovered at the vertices alone and interpolated at the other nodes."""
    for cell in CELLS:
        mesh = two_cubes(box_grid, cell)
        s = surface(mesh, pressure_keys=np.arange(mesh.points.shape[0]) if vertices_only else None)
        u = np.zeros_like(s.X)
        p = 2.5
        f = uniform_traction_forces(s, p)
        gap, pressure = s.gap_and_pressure(u, f, f)
        on = np.abs(s.X[:, 0] - 1.0) < 1e-12
        np.testing.assert_allclose(pressure.pressure[on], p, rtol=1e-12)
        assert np.all(pressure.pressure[~on] == 0.0)
        pair = next(q for q in pressure.pairs if q.body == pressure.body[np.argmax(on)])
        assert pair.force[0] == pytest.approx(-p, rel=1e-12) and pair.zone_length == pytest.approx(1.0)


@pytest.mark.parametrize("cell", CELLS)
def test_pressure_interpolated_off_the_recovered_nodes(box_grid, cell):
    """With ``pressure_keys`` the vertices but the centre (1, 0.5, 0.5) of the contact face, under
    uneven forces: the recovered vertices keep the pressure recovered at every node, the centre takes
    the mean of the recovered corners of its faces, every edge midpoint the mean of its ends and a
    quadrilateral's centre that of its corners."""
    mesh = two_cubes(box_grid, cell)
    centre = int(np.flatnonzero(np.all(np.isclose(mesh.points, [1.0, 0.5, 0.5]), axis=1))[0])
    keys = np.delete(np.arange(mesh.points.shape[0]), centre)
    everywhere, interpolated = surface(mesh), surface(mesh, pressure_keys=keys)
    rng = np.random.default_rng(7)
    f = uniform_traction_forces(everywhere, 1.0) * rng.uniform(0.5, 1.5, (everywhere.n_nodes, 1))
    u = np.zeros_like(everywhere.X)
    p0 = everywhere.gap_and_pressure(u, f, f)[1].pressure
    p1 = interpolated.gap_and_pressure(u, f, f)[1].pressure
    assert np.ptp(p0[np.isclose(everywhere.X[:, 0], 1.0)]) > 0.1          # uneven
    k = 4 if cell == "hexahedron" else 3
    on = everywhere.face_nodes[everywhere.face_faces_medium & np.all(np.isclose(everywhere.X[everywhere.face_nodes[:, :k], 0], 1.0), axis=1)]
    corners = on[:, :k]
    c = int(np.flatnonzero(everywhere.node_keys == centre)[0])
    vertex = np.unique(corners[corners != c])
    np.testing.assert_allclose(p1[vertex], p0[vertex], rtol=1e-14)
    around = corners[(corners == c).any(axis=1)]
    assert p1[c] == pytest.approx(p0[around[around != c]].mean(), rel=1e-14)
    for j in range(k):
        np.testing.assert_allclose(p1[on[:, k + j]], 0.5 * (p1[corners[:, j]] + p1[corners[:, (j + 1) % k]]), rtol=1e-14)
    if k == 4:
        np.testing.assert_allclose(p1[on[:, 8]], p1[corners].mean(axis=1), rtol=1e-14)


def test_size_50k_nodes(box_grid):
    """A cube of 32³ hexahedra with a slot cut in it (one body facing itself across the slot): about
    25k surface nodes; the gap of a state in seconds (printed, the numbers of docs/contact.md)."""
    n = 24
    xs = np.linspace(0, 1, n + 1)
    mesh = box_grid(xs, xs, xs, lambda c: 2 if c[0] > 0.25 and 0.375 < c[2] < 0.625 else 1)
    start = time.perf_counter()
    s = surface(mesh)
    built = time.perf_counter() - start
    start = time.perf_counter()
    gap = s.gap(np.zeros_like(s.X))
    took = time.perf_counter() - start
    print(f"{s.n_nodes} surface nodes, {s.triangles.shape[0]} sub-triangles: set-up {built:.2f} s, gap {took:.2f} s")
    assert gap.value == pytest.approx(0.25, abs=1e-12)


@pytest.mark.mpi
def test_gap_of_state_gathers_the_ranks_nodes(box_grid):
    """Each rank holds every other surface node (and nodes that are not on the surface): the gap of
    the gathered state is the serial one, on every rank."""
    from mpi4py import MPI
    comm = MPI.COMM_WORLD
    s = surface(two_cubes(box_grid, "hexahedron"))
    u = np.zeros_like(s.X)
    u[s.X[:, 0] > 1.2, 0] = -0.25
    keys = np.concatenate([s.node_keys, [10 ** 9 + comm.rank]])
    values = np.concatenate([u, [[9.0, 9.0, 9.0]]])
    mine = np.arange(keys.size) % comm.size == comm.rank
    gap = s.gap_of_state(comm, keys[mine], values[mine])
    assert gap.value == pytest.approx(0.05, abs=1e-12) and gap.value == s.gap(u).value


@pytest.mark.parametrize("cell", CELLS)
def test_facing_clusters_equal_every_pair(box_grid, cell):
    """The cluster search for facing surfaces of the own body (pruned by bounds) gives the distance of
    every node that the loop over all its node-triangle pairs gives, on a C bent out of shape."""
    from dolfinx_sfvem.physics.contact import FACING_COSINE
    from dolfinx_sfvem.physics.solid_surface import _facing_nearest
    mesh = box_grid(np.linspace(0, 1, 11), np.linspace(0, 0.4, 5), np.linspace(0, 0.6, 13),
                    lambda c: 2 if c[0] > 0.1 and 0.1 < c[2] < 0.5 else 1, cell)
    s = surface(mesh)
    X = s.X
    u = 0.04 * np.stack([np.sin(5 * X[:, 2] + X[:, 1]), np.cos(4 * X[:, 0]) * X[:, 2], -X[:, 0] * np.sin(3 * X[:, 1])],
                        axis=1)
    u[:, 2] -= 0.25 * X[:, 0] * (X[:, 2] > 0.3)
    x = X + u
    assert len(s._facing[0].node_groups) > 4                   # several clusters: the pruning is at work
    g, partner = np.full(s.n_nodes, np.inf), np.full(s.n_nodes, -1)
    s._facing[0].nearest(x, g, partner, np.ones(s.n_nodes, dtype=bool))
    g_all, partner_all = np.full(s.n_nodes, np.inf), np.full(s.n_nodes, -1)
    _facing_nearest(np.arange(s.n_nodes), np.arange(s.triangles.shape[0]), x, X, s.node_normal, s.triangles,
                    s.triangle_centre, s.triangle_normal, FACING_COSINE, 0, g_all, partner_all)
    assert np.isfinite(g_all).sum() > 0.2 * s.n_nodes           # the C's inner faces: a quarter of the nodes
    np.testing.assert_allclose(g, g_all, rtol=1e-12, atol=1e-14)
