"""The SFVEM space on polyhedra hosted by the P2 space of the fan tetrahedra (polyhedral_space)."""
import functools

import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

import dolfinx_sfvem as sf
from dolfinx_sfvem import _compat
from dolfinx_sfvem.discretizations.elasticity import linear_elastic_stiffness_3d
from dolfinx_sfvem.meshes import extrude_polygons, octree_box, voronoi_box
from dolfinx_sfvem.discretizations.polyhedral_space import CELL, FACE, PolyhedralSpace, fan_mesh, n_unknowns
from dolfinx_sfvem.discretizations.space import MIDPOINT, VERTEX
from dolfinx_sfvem.mesh.polyhedron_mesh import PolyhedronMesh
from dolfinx_sfvem.mesh.polyhedron import polyhedron_edges, polyhedron_geometry, polyhedron_quadrature, face_quadrature

WORLD = MPI.COMM_WORLD
MESHES = ("grid", "octree", "prisms", "voronoi")


@functools.lru_cache(maxsize=None)
def polyhedral_mesh(name: str) -> PolyhedronMesh:
    """Small meshes of the unit box (prisms: 1 x 1 x 0.5), the same on every rank."""
    if name == "grid":
        return octree_box([0, 0, 0], [1, 1, 1], 2).polyhedra()
    if name == "octree":           # one refined corner: three coarse cubes with hanging vertices
        return octree_box([0, 0, 0], [1, 1, 1], 2).refine(lambda x: np.all(x < 0.5, axis=0)).polyhedra()
    if name == "prisms":           # pentagons with hanging nodes, two layers
        return extrude_polygons(sf.meshes.quads_with_hanging_nodes(1.0, 1.0, 2, refine=(0.0, 0.5, 0.0, 0.5)),
                                0.5, 2)
    seeds = np.random.default_rng(7).random((7, 3))
    return voronoi_box(seeds, [0, 0, 0], [1, 1, 1])


@functools.lru_cache(maxsize=None)
def space(name: str, parallel: bool = False) -> PolyhedralSpace:
    return PolyhedralSpace(polyhedral_mesh(name), WORLD if parallel else MPI.COMM_SELF, verbose=False)


def linear(x):
    A = np.array([[0.3, -1.2, 0.5], [2.0, 0.1, -0.7], [-0.4, 0.9, 1.1]])
    return A @ x + np.array([[0.2], [-0.5], [1.0]])


def quadratic(x):
    return np.stack([x[0] * x[1] + x[2] ** 2, x[0] ** 2 - 2 * x[1] * x[2], 1 + x[0] * x[2] + x[1] ** 2])


def local_values(vec) -> np.ndarray:
    with vec.localForm() as v:
        return v.array.reshape(-1, 3).copy()


# --------------------------------------------------------------------------- serial
@pytest.mark.parametrize("name", MESHES)
def test_unknowns_are_the_vertices_edges_faces_and_cells(name):
    mesh = polyhedral_mesh(name)
    S = space(name)
    n_v, n_e = np.unique(mesh.face_vertices).size, mesh.edges().shape[0]
    assert n_v - n_e + mesh.n_faces - mesh.n_cells == 1          # Euler characteristic of a ball
    assert S.num_dofs_global == n_unknowns(mesh) == 3 * (n_v + n_e + mesh.n_faces + mesh.n_cells)
    assert np.bincount(S.node_kind, minlength=4).tolist() == [n_v, n_e, mesh.n_faces, mesh.n_cells]
    assert np.unique(S.node_key).size == S.n_local_nodes          # one node per key


@pytest.mark.parametrize("name", MESHES)
def test_fan_mesh_is_conforming_and_fills_the_polyhedra(name):
    mesh = polyhedral_mesh(name)
    fan = fan_mesh(mesh)
    X = fan.nodes[fan.tetrahedra]
    volume = np.einsum("ij,ij->i", X[:, 1] - X[:, 0], np.cross(X[:, 2] - X[:, 0], X[:, 3] - X[:, 0])) / 6
    assert np.all(volume > 0)
    assert np.bincount(fan.tetrahedron_cell, weights=volume) == pytest.approx(mesh.volumes, rel=1e-12)
    facets = np.sort(fan.tetrahedra[:, [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]]].reshape(-1, 3), axis=1)
    unique, count = np.unique(facets, axis=0, return_counts=True)
    assert count.max() == 2                                           # every facet in one or two tetrahedra
    Y = fan.nodes[unique[count == 1]]
    outer = 0.5 * np.linalg.norm(np.cross(Y[:, 1] - Y[:, 0], Y[:, 2] - Y[:, 0]), axis=1).sum()
    assert outer == pytest.approx(np.linalg.norm(mesh.face_area_vectors[mesh.boundary_faces()], axis=1).sum(),
                                  rel=1e-12)


@pytest.mark.parametrize("name", MESHES)
def test_node_coordinates_are_the_polyhedra_geometry(name):
    mesh, S = polyhedral_mesh(name), space(name)
    for k, c in enumerate(S.cells):
        points, faces = mesh.polyhedron(c)
        geometry = polyhedron_geometry(points, faces)
        edges = polyhedron_edges(faces)
        expected = np.concatenate([points, points[edges].mean(axis=1), geometry.face_centroids,
                                   geometry.centroid[None]])
        nodes = S.cell_dofs(k)
        assert S.x_nodes[nodes] == pytest.approx(expected, abs=1e-13)
        n_v, n_e, n_f = len(points), len(edges), len(faces)
        assert S.node_kind[nodes].tolist() == [VERTEX] * n_v + [MIDPOINT] * n_e + [FACE] * n_f + [CELL]


@pytest.mark.parametrize("name", MESHES)
def test_interpolant_holds_point_values_and_exact_means(name):
    mesh, S = polyhedral_mesh(name), space(name)
    u = local_values(S.interpolate(linear))
    point = S.node_kind <= MIDPOINT
    assert u[point] == pytest.approx(linear(S.x_nodes[point].T).T, abs=1e-13)
    assert u[~point] == pytest.approx(linear(S.x_nodes[~point].T).T, abs=1e-13)     # means at the centroids
    q = local_values(S.interpolate(quadratic, degree=2))
    for k, c in enumerate(S.cells):          # quadratic means against the element's own quadratures
        points, faces = mesh.polyhedron(c)
        nodes = S.cell_dofs(k)
        x_q, w_q = polyhedron_quadrature(points, faces, 2)
        assert q[nodes[-1]] == pytest.approx(quadratic(x_q.T) @ w_q / w_q.sum(), abs=1e-13)
        x_f, w_f, face_of = face_quadrature(points, faces, 2)
        means = np.stack([np.bincount(face_of, weights=w_f * v) for v in quadratic(x_f.T)], axis=1)
        means /= np.bincount(face_of, weights=w_f)[:, None]
        assert q[nodes[-1 - len(faces):-1]] == pytest.approx(means, abs=1e-13)


def test_a_cell_that_is_not_star_shaped_is_refused():
    u_shape = np.array([[0, 0], [3, 0], [3, 2], [2, 2], [2, 0.5], [1, 0.5], [1, 2], [0, 2]], dtype=float)
    mesh = extrude_polygons(sf.PolygonMesh(u_shape, [np.arange(8)]), 1.0, 1)   # no point sees the whole U
    with pytest.raises(ValueError, match="cell 0.* not star-shaped"):
        fan_mesh(mesh)


def test_fans_from_the_kernel_where_the_centroid_does_not_see_the_cell():
    thin_l = np.array([[0, 0], [4, 0], [4, 0.2], [0.2, 0.2], [0.2, 4], [0, 4]], dtype=float)
    mesh = extrude_polygons(sf.PolygonMesh(thin_l, [np.arange(6)]), 1.0, 2)    # centroid (1.07, 1.07) outside
    fan = fan_mesh(mesh)
    assert np.all(fan.nodes[-2:, :2] <= 0.2) and np.all(fan.nodes[-2:, :2] >= 0)   # the kernel: the corner
    X = fan.nodes[fan.tetrahedra]
    volume = np.einsum("ij,ij->i", X[:, 1] - X[:, 0], np.cross(X[:, 2] - X[:, 0], X[:, 3] - X[:, 0])) / 6
    assert np.all(volume > 0)
    assert np.bincount(fan.tetrahedron_cell, weights=volume) == pytest.approx(mesh.volumes, rel=1e-12)
    S = PolyhedralSpace(mesh, MPI.COMM_SELF, verbose=False)
    u = local_values(S.interpolate(quadratic, degree=2))
    for k, c in enumerate(S.cells):      # the means are those of the element's quadrature
        points, faces = mesh.polyhedron(c)
        x_q, w_q = polyhedron_quadrature(points, faces, 2)
        assert u[S.cell_dofs(k)[-1]] == pytest.approx(quadratic(x_q.T) @ w_q / w_q.sum(), abs=1e-12)


# --------------------------------------------------------------------------- patch test
def elastic_patch_solution(S: PolyhedralSpace, young: float = 3.0, poisson: float = 0.3) -> PETSc.Vec:
    """Linear elasticity with the boundary unknowns of :func:`linear`: the solution vector."""
    A = S.create_matrix()
    blocks = []
    for c in S.cells:
        K, _ = linear_elastic_stiffness_3d(*S.polyhedron_mesh.polyhedron(c), young, poisson)
        nd = K.shape[0] // 3
        node_major = (np.arange(3)[None, :] * nd + np.arange(nd)[:, None]).ravel()
        blocks.append(K[np.ix_(node_major, node_major)].ravel())
    _compat.mat_set_values_coo(A, np.concatenate(blocks + [np.zeros(3 * S.n_owned_nodes)]))
    A.assemble()
    exact = S.interpolate(linear)
    owned = S.boundary_nodes()
    owned = owned[owned < S.n_owned_nodes]
    rows = (3 * S.global_nodes[owned][:, None] + np.arange(3)).ravel().astype(PETSc.IntType)
    b = S.create_vector()
    b.set(0.0)
    A.zeroRowsColumns(rows, 1.0, exact, b)
    ksp = PETSc.KSP().create(S.comm)
    ksp.setOperators(A)
    ksp.setType("cg")
    ksp.getPC().setType("jacobi")
    ksp.setTolerances(rtol=1e-14, atol=1e-30, max_it=5000)
    x = S.create_vector()
    ksp.solve(b, x)
    assert ksp.getConvergedReason() > 0
    x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
    ksp.destroy()
    A.destroy()
    return x


@pytest.mark.parametrize("name", ["octree", "voronoi"])
def test_patch_test_recovers_a_linear_field(name):
    S = space(name)
    x = local_values(elastic_patch_solution(S))
    assert x == pytest.approx(linear(S.x_nodes.T).T, abs=1e-9)


# --------------------------------------------------------------------------- 1 rank vs 2 ranks
def by_key(S: PolyhedralSpace, values: np.ndarray) -> dict[int, np.ndarray]:
    """Owned node key -> value, gathered from every rank."""
    owned = slice(0, S.n_owned_nodes)
    pairs = S.comm.allgather((S.node_key[owned], values[owned]))
    keys = np.concatenate([k for k, _ in pairs])
    assert np.unique(keys).size == keys.size                     # every node owned by one rank
    return dict(zip(keys.tolist(), np.concatenate([v for _, v in pairs])))


@pytest.mark.mpi
@pytest.mark.parametrize("name", MESHES)
def test_parallel_space_has_the_serial_nodes_and_values(name):
    serial, parallel = space(name), space(name, parallel=True)
    polyhedra = np.concatenate(WORLD.allgather(parallel.cells))
    assert np.sort(polyhedra).tolist() == list(range(polyhedral_mesh(name).n_cells))   # each on one rank
    assert parallel.num_dofs_global == serial.num_dofs_global
    reference = by_key(serial, local_values(serial.interpolate(quadratic)))
    values = local_values(parallel.interpolate(quadratic))
    assert by_key(parallel, values).keys() == reference.keys()
    for key, value in zip(parallel.node_key.tolist(), values):  # owned and ghost nodes
        assert value == pytest.approx(reference[key], abs=1e-13)
    # a ghost's global index is its owner's: the same key behind every global node
    pairs = np.concatenate(WORLD.allgather(np.column_stack([parallel.global_nodes, parallel.node_key])))
    assert np.unique(pairs, axis=0).shape[0] == parallel.index_map.size_global


@pytest.mark.mpi
@pytest.mark.parametrize("name", ["octree", "voronoi"])
def test_parallel_patch_test_agrees_with_serial(name):
    serial, parallel = space(name), space(name, parallel=True)
    reference = by_key(serial, local_values(elastic_patch_solution(serial)))
    values = local_values(elastic_patch_solution(parallel))
    for key, value in zip(parallel.node_key.tolist(), values):
        assert value == pytest.approx(reference[key], abs=1e-9)
    assert values == pytest.approx(linear(parallel.x_nodes.T).T, abs=1e-9)


@pytest.mark.mpi
def test_located_nodes_are_those_of_the_face_on_every_partition():
    S = space("grid", parallel=True)
    located = S.locate_nodes(lambda x: np.isclose(x[0], 0.0))
    keys = set(np.concatenate(WORLD.allgather(S.node_key[located])).tolist())
    # the face x = 0 of the 2 x 2 x 2 grid: 9 vertices, 12 edges, 4 faces (no cell centre)
    kinds = np.concatenate(WORLD.allgather(S.node_kind[located].astype(np.int64)))
    all_keys = np.concatenate(WORLD.allgather(S.node_key[located]))
    assert np.bincount(kinds[np.unique(all_keys, return_index=True)[1]], minlength=4).tolist() == [9, 12, 4, 0]
    assert keys == set(space("grid").node_key[space("grid").locate_nodes(lambda x: np.isclose(x[0], 0.0))].tolist())
    everything = S.locate_nodes(tags=[0])
    assert everything.size == S.n_local_nodes


@pytest.mark.mpi
@pytest.mark.parametrize("name", ["grid", "prisms"])
def test_p2_function_of_a_quadratic_is_the_quadratic(name):
    S = space(name, parallel=True)
    x = S.interpolate(quadratic, degree=2)
    u = S.to_function(x)
    expected = quadratic(S.V.tabulate_dof_coordinates().T).T
    assert u.x.array.reshape(-1, 3) == pytest.approx(expected, abs=1e-10)
