"""Local refinement with hanging nodes and state transfer (docs/refinement-local.md).

References come from outside the code under test: areas and moments by Green's formulas, quadratic
fields evaluated directly, eigenvalues by LAPACK, the location of points by a geometric search, and
the same problem solved on the refined mesh from the start. The patch test, the reference moments
and the two blocks across a medium are conftest.py's fixtures.
"""
import numpy as np
import pytest
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem.discretizations.projection import build_projections
from dolfinx_sfvem.discretizations.state_transfer import transfer_state

SOLID, MEDIUM = sf.meshes.SOLID, sf.meshes.MEDIUM
K, MU = 5 / 3, 5 / 14
YOUNG, POISSON = 7.0, 0.3          # of the linear-elastic element whose zero-energy modes are counted

U_SHAPE = [[0, 0], [3, 0], [3, 3], [2, 3], [2, 1], [1, 1], [1, 3], [0, 3]]        # no visibility-region point: ear triangles
STAR = [[0, 0], [2, 0], [2, 2], [1.2, 0.9], [0, 2]]                                  # centroid outside the visibility region
KINDS = {
    "triangle": [[0, 0], [1, 0], [0.3, 0.8]],
    "quadrilateral": [[0, 0], [1, 0], [1.2, 1], [0, 0.7]],
    "convex hexagon": [[np.cos(a), np.sin(a)] for a in np.arange(6) * np.pi / 3],
    "non-convex, star-shaped": STAR,
    "non-convex, not star-shaped": U_SHAPE,
    "square with hanging nodes": [[0, 0], [0.5, 0], [1, 0], [1, 0.25], [1, 1], [0, 1], [0, 0.5]],
}


def single(xy) -> sf.PolygonMesh:
    xy = np.asarray(xy, dtype=float)
    return sf.PolygonMesh(xy, [np.arange(len(xy))])


# --------------------------------------------------------------------------- quadratic fields
COEFFICIENTS = np.array([[0.2, 0.3, -0.2, 0.5, -0.7, 0.2],
                         [-0.4, 0.1, 0.25, -0.3, 0.1, 0.9]])       # u_i = c_i . [1, x, y, x^2, xy, y^2]


def u_quadratic(x: np.ndarray) -> np.ndarray:
    """(2, n) at x (2, n)."""
    X, Y = x
    return COEFFICIENTS @ np.array([np.ones_like(X), X, Y, X * X, X * Y, Y * Y])


def exact_state(mesh: sf.PolygonMesh, polygon_moments) -> np.ndarray:
    """The quadratic's SFVEM DOFs by node key (point, then sorted unordered edge, then polygon)."""
    n = mesh.n_points
    nxt = np.arange(1, mesh.vertices.size + 1)
    nxt[mesh.offsets[1:] - 1] = mesh.offsets[:-1]
    a, b = mesh.vertices, mesh.vertices[nxt]
    keys = np.unique(np.minimum(a, b) * n + np.maximum(a, b))
    midpoints = 0.5 * (mesh.points[keys // n] + mesh.points[keys % n])
    means = np.array([COEFFICIENTS @ polygon_moments(mesh.polygon_coordinates(i)) / mesh.areas[i]
                      for i in range(mesh.n_polygons)])
    return np.vstack([u_quadratic(mesh.points.T).T, u_quadratic(midpoints.T).T, means])


# --------------------------------------------------------------------------- the refined polygons
@pytest.fixture
def check_refined(build_one, check_patch, zero_eigenvalues):
    """``check_refined(r)`` of a refinement ``r``: areas add up, every child lies in its parent, tags
    follow the parents, and every new polygon passes the patch test and has exactly the 3 rigid
    motions as zero-energy modes."""
    def check(r) -> None:
        coarse, fine = r.coarse, r.mesh
        np.testing.assert_allclose(np.bincount(r.parent, fine.areas, coarse.n_polygons), coarse.areas, rtol=1e-12)
        inside = fine.nodes[fine.triangles[fine.triangle_offsets[:-1]]].mean(axis=1)     # a point in each child
        np.testing.assert_array_equal(coarse.locate(inside), r.parent)
        np.testing.assert_array_equal(fine.tags, coarse.tags[r.parent])
        np.testing.assert_array_equal(fine.points[:coarse.n_points], coarse.points)
        for i in range(fine.n_polygons):
            xy = fine.polygon_coordinates(i)
            check_patch(xy, build_one(xy), rtol=1e-9, seed=i)
            K_E, _ = sf.linear_elastic_stiffness(xy, YOUNG, POISSON)
            assert zero_eigenvalues(K_E) == 3, f"polygon {i}"

    return check


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("levels", [1, 2])
def test_every_polygon_kind(kind, levels, check_refined):
    """One polygon becomes one quadrilateral per convex vertex and two triangles per reflex one (a
    polygon without a visibility-region point: three quadrilaterals per ear triangle); at the next level
    quadrilaterals make four, triangles three."""
    r = single(KINDS[kind]).refine([0], levels=levels)
    quads, triangles = {"non-convex, star-shaped": (4, 2), "non-convex, not star-shaped": (3 * 6, 0)}.get(
        kind, (len(KINDS[kind]), 0))
    assert r.mesh.n_polygons == (quads + triangles if levels == 1 else 4 * quads + 3 * triangles)
    check_refined(r)


def test_neighbours_gain_hanging_nodes_and_refinement_repeats(check_refined):
    """Refining one quad of a 3 x 1 strip puts one hanging node on each neighbour's shared side;
    refining its children next to the neighbour again puts two more there."""
    coarse = sf.meshes.quad_rectangle(3.0, 1.0, 3, 1)
    once = coarse.refine([1])
    assert once.mesh.n_polygons == 2 + 4 and once.mesh.hanging_nodes.size == 2
    assert sorted(np.diff(once.mesh.offsets)) == [4, 4, 4, 4, 5, 5]
    twice = once.mesh.refine(lambda x: (x[0] > 1.0) & (x[0] < 1.5))
    right_of_left_quad = twice.mesh.polygon_coordinates(0)
    on_shared_side = np.isclose(right_of_left_quad[:, 0], 1.0)
    np.testing.assert_allclose(np.sort(right_of_left_quad[on_shared_side, 1]), [0, 0.25, 0.5, 0.75, 1.0])
    check_refined(twice)
    assert sf.PolygonMesh(twice.mesh.points, np.split(twice.mesh.vertices, twice.mesh.offsets[1:-1]),
                          twice.mesh.tags).n_inserted_hanging_nodes == 0


def test_levels_refine_the_children():
    coarse = sf.meshes.quad_rectangle(2.0, 1.0, 2, 1)
    r = coarse.refine([0], levels=2)
    assert r.levels == 2 and r.mesh.n_polygons == 1 + 4 ** 2
    assert np.count_nonzero(r.parent == 0) == 4 ** 2
    stepwise = coarse.refine([0]).mesh.refine(lambda x: x[0] < 1).mesh
    np.testing.assert_array_equal(stepwise.points, r.mesh.points)
    np.testing.assert_array_equal(stepwise.vertices, r.mesh.vertices)


@pytest.mark.parametrize("max_l", [6, 10])
def test_neighbours_needing_a_high_order_are_split_too(max_l):
    """Three levels on the middle quad of a strip would put 7 hanging nodes on each neighbour's
    side (no l <= 10 passes the rank check there): the neighbours are split as well, and every
    polygon then has a projection order l <= max_l."""
    coarse = sf.meshes.quad_rectangle(3.0, 1.0, 3, 1)
    r = coarse.refine([1], levels=3, max_l=max_l)
    assert r.selected.all()
    assert build_projections(r.mesh.points, r.mesh.offsets, r.mesh.vertices).l.max() <= max_l
    gentle = coarse.refine([1], levels=2, max_l=max_l)            # 3 hanging nodes per side: l = 6
    assert gentle.selected.tolist() == [False, True, False]
    assert build_projections(gentle.mesh.points, gentle.mesh.offsets, gentle.mesh.vertices).l.max() == 6


def test_regions_and_generators():
    """A gmsh-generated C-box: refining the medium keeps every region's area and the region names;
    the selection by tag, by name and by marker combine by 'and'."""
    box = sf.meshes.cbox(h_solid=0.1).mesh
    by_tag = box.refine(tags=[MEDIUM])
    by_name = box.refine(tags=["medium"])
    assert by_tag.mesh.n_polygons == by_name.mesh.n_polygons
    assert by_tag.selected.sum() == np.count_nonzero(box.tags == MEDIUM)
    assert by_tag.mesh.region_names == box.region_names
    for tag in (SOLID, MEDIUM):
        assert by_tag.mesh.areas[by_tag.mesh.tags == tag].sum() == pytest.approx(box.areas[box.tags == tag].sum(),
                                                                                 rel=1e-12)
    near = box.refine(lambda x: x[0] > 0.5, tags=[MEDIUM])
    assert np.array_equal(near.selected, (box.tags == MEDIUM) & (box.centroids[:, 0] > 0.5))
    assert np.count_nonzero(near.mesh.tags == SOLID) == np.count_nonzero(box.tags == SOLID)   # only gain nodes


def test_polygon_mesh_from_scratch_with_a_non_star_polygon_and_a_neighbour(check_refined):
    mesh = sf.PolygonMesh(np.array(U_SHAPE + [[4, 0], [4, 3]], dtype=float), [range(8), [1, 8, 9, 2]], [5, 7])
    r = mesh.refine([0], levels=2)
    check_refined(r)
    assert r.mesh.hanging_nodes.size == 3            # on the shared side x = 3: at y = 0.75, 1.5, 2.25
    assert set(np.unique(r.mesh.tags)) == {5, 7}


@pytest.mark.parametrize("where, levels, tags, message", [
    (lambda x: x[0] > 10, 1, None, "selection is empty"),
    ([0], 0, None, "levels must be an integer >= 1"),
    ([0], 1.5, None, "levels must be an integer >= 1"),
    (lambda x: x[0][:2] > 0, 1, None, r"marker must return a bool array of shape \(3,\)"),
    (np.array([True, False]), 1, None, r"mask must have shape \(3,\)"),
    ([3], 1, None, r"polygon index 3 out of range \[0, 3\)"),
    ([-1], 1, None, "out of range"),
    (None, 1, [9], "no polygon has region tag 9"),
    (None, 1, ["rubber"], "'rubber' is not a region name"),
    (None, 1, None, "give a centroid marker"),
    (np.array([0.5]), 1, None, "must be a centroid marker, a boolean mask or polygon indices"),
])
def test_bad_input(where, levels, tags, message):
    mesh = sf.meshes.quad_rectangle(3.0, 1.0, 3, 1)
    with pytest.raises(ValueError, match=message):
        mesh.refine(where, levels, tags=tags)
    with pytest.raises(ValueError, match=r"max_l must be an integer in \[3, 10\]"):
        mesh.refine([0], max_l=2)


# --------------------------------------------------------------------------- state transfer
@pytest.mark.parametrize("mesh, where, levels", [
    (sf.PolygonMesh(np.array(U_SHAPE + [[4, 0], [4, 3]], dtype=float), [range(8), [1, 8, 9, 2]]), [0], 2),
    (sf.PolygonMesh(np.array(U_SHAPE + [[4, 0], [4, 3]], dtype=float), [range(8), [1, 8, 9, 2]]), [1], 2),
    (single(STAR), [0], 1),
    (sf.meshes.quad_rectangle(3.0, 1.0, 3, 1), [1], 3),
])
def test_transfer_reproduces_quadratics(mesh, where, levels, polygon_moments):
    """Vertex values, midpoint values and polygon means of a quadratic field on the refined mesh,
    from those on the coarse mesh."""
    r = mesh.refine(where, levels)
    expected = exact_state(r.mesh, polygon_moments)
    np.testing.assert_allclose(transfer_state(r, exact_state(mesh, polygon_moments)), expected, rtol=0,
                               atol=1e-12 * np.abs(expected).max())


@pytest.mark.mpi
def test_problem_refine_transfers_a_quadratic_state(two_blocks):
    """Through the distributed discretization: a quadratic set on the coarse problem, refined,
    equals the quadratic set on the refined mesh directly (every node, on any number of ranks)."""
    comm = MPI.COMM_WORLD
    materials = two_blocks.materials()
    ux, uy = (lambda x: u_quadratic(x)[0]), (lambda x: u_quadratic(x)[1])
    problem = sf.ContactProblem(two_blocks.mesh(), materials, verbose=False)
    problem.set_displacement(ux, uy)
    r = problem.refine(lambda x: x[1] > 0.7, tags=[two_blocks.SOLID, two_blocks.MEDIUM], levels=2)
    assert problem.mesh is r.mesh
    direct = sf.ContactProblem(r.mesh, materials, verbose=False)
    direct.set_displacement(ux, uy)
    keys, values = (np.concatenate(v) for v in zip(*comm.allgather(problem.disc.get_state(problem.x))))
    keys_d, values_d = (np.concatenate(v) for v in zip(*comm.allgather(direct.disc.get_state(direct.x))))
    np.testing.assert_array_equal(np.sort(keys), np.sort(keys_d))
    np.testing.assert_allclose(values[np.argsort(keys)], values_d[np.argsort(keys_d)], rtol=0, atol=1e-12)


# --------------------------------------------------------------------------- load paths
def compressed_block(mesh: sf.PolygonMesh, uy: float = -0.06) -> sf.ContactProblem:
    problem = sf.ContactProblem(mesh, {SOLID: sf.Hyperelastic(K=K, mu=MU)}, verbose=False)
    problem.fix(lambda x: np.isclose(x[1], 0.0))
    problem.prescribe(lambda x: np.isclose(x[1], 1.0), ux=-uy / 3, uy=uy, name="top")
    return problem


def gathered_state(problem: sf.ContactProblem) -> np.ndarray:
    keys, values = (np.concatenate(v) for v in zip(*problem.comm.allgather(problem.disc.get_state(problem.x))))
    return values[np.argsort(keys)]


@pytest.mark.mpi
def test_continued_load_path_matches_the_refined_mesh_from_the_start():
    """A block compressed to half the load on a coarse mesh (``until``), refined in its upper
    half, then continued to the full load from the transferred state (``from_current_state``:
    a re-balancing step at the load reached, then the rest of the path) passes through the
    states of the refined mesh solved from the start."""
    coarse = sf.meshes.quad_rectangle(1.0, 1.0, 3, 3, tag=SOLID)
    upper = lambda x: x[1] > 0.5                                              # noqa: E731
    continued = compressed_block(coarse)
    half = continued.solve(steps=2, until=0.5)
    assert half.converged and continued.load == pytest.approx(0.5) and len(half.steps) == 1
    continued.refine(upper)
    after = continued.solve(steps=2, from_current_state=True)
    assert after.converged and [s["load"] for s in after.steps] == pytest.approx([0.5, 1.0])
    assert after.steps[0]["newton_iterations"] <= 3 and after.steps[0]["dofs"] > half.steps[0]["dofs"]

    reference = compressed_block(coarse.refine(upper).mesh)
    ref = reference.solve(steps=2)
    assert ref.converged
    u, u_ref = gathered_state(continued), gathered_state(reference)
    np.testing.assert_allclose(u, u_ref, rtol=0, atol=1e-8 * np.abs(u_ref).max())
    for step, step_ref in zip(after.steps, ref.steps):
        np.testing.assert_allclose(step["reaction"]["top"], step_ref["reaction"]["top"], rtol=1e-7)


def test_continuation_input_is_checked():
    problem = compressed_block(sf.meshes.quad_rectangle(1.0, 1.0, 2, 2, tag=SOLID))
    with pytest.raises(ValueError, match="until must be a load factor"):
        problem.solve(steps=2, until=1.5)
    assert problem.solve(steps=2, until=0.5).converged
    with pytest.raises(ValueError, match="lies below the load factor 0.5"):
        problem.solve(steps=2, until=0.25, from_current_state=True)
    problem.reset()
    assert problem.load == 0.0


@pytest.mark.mpi
def test_linear_patch_test_on_a_refined_mesh():
    """A homogeneous deformation prescribed on the boundary of a mesh with hanging nodes of
    several levels is reproduced exactly inside (the refined mesh is conforming)."""
    mesh = sf.meshes.quad_rectangle(1.0, 1.0, 3, 3, tag=SOLID).refine([4], levels=2).mesh
    problem = sf.ContactProblem(mesh, {SOLID: sf.Hyperelastic(K=K, mu=MU)}, verbose=False)
    F = np.array([[0.04, 0.02], [-0.01, -0.05]])                              # u = F x
    boundary = lambda x: np.isclose(x[0] * (1 - x[0]) * x[1] * (1 - x[1]), 0.0)   # noqa: E731
    problem.prescribe(boundary, ux=lambda x: F[0] @ x, uy=lambda x: F[1] @ x, name="edge")
    assert problem.solve(steps=1).converged
    points = np.random.default_rng(3).uniform(0.05, 0.95, (30, 2))
    np.testing.assert_allclose(problem.displacement_at(points), points @ F.T, rtol=0, atol=1e-9)


def test_refined_mesh_passes_the_contact_checks(two_blocks):
    """Two blocks across a medium layer, the layer and the blocks' facing rows refined: the gap
    seen through the hanging nodes is the true one, overlaps are flagged, and pressing the upper
    block down converges with the solids apart."""
    facing = lambda x: (x[1] > 0.7) & (x[1] < 1.5)                              # noqa: E731
    mesh = two_blocks.mesh().refine(facing).mesh
    problem = sf.ContactProblem(mesh, two_blocks.materials(), verbose=False)
    for drop, gap in [(0.1, 0.1), (0.3, -0.1)]:
        problem.set_displacement(uy=lambda x: np.where(x[1] > 1.1, -drop, 0.0))
        g = problem.contact_gap()
        assert g.value == pytest.approx(gap, abs=1e-12) and g.overlapping == (gap < 0)
    problem.reset()
    problem.fix(lambda x: np.isclose(x[1], 0.0))
    problem.prescribe(lambda x: np.isclose(x[1], 2.2), uy=-0.15, name="press")
    result = problem.solve(steps=3)
    assert result.converged and 0 < result.steps[-1]["gap"]["value"] < 0.2


def test_fem_is_refused_a_body_force_follows_the_refined_mesh():
    """The FEM cannot be refined; a body force is bound to the refined mesh again (loads are
    definitions, not vectors of one mesh): its resultant is the same before and after."""
    fem = sf.ContactProblem(sf.meshes.quad_rectangle(1.0, 1.0, 2, 2, tag=SOLID),
                            {SOLID: sf.Hyperelastic(K=K, mu=MU)}, method="fem", verbose=False)
    with pytest.raises(ValueError, match="only method='vem' can be refined"):
        fem.refine([0])
    vem = compressed_block(sf.meshes.quad_rectangle(1.0, 1.0, 2, 2, tag=SOLID))
    vem.body_force(lambda x: np.stack([np.zeros(x.shape[1]), -np.ones(x.shape[1])]))
    before = vem.equilibrium().loads[0].magnitude
    vem.refine([0])
    after = vem.equilibrium().loads[0]
    assert after.disc is vem.disc and before == pytest.approx(1.0) and after.magnitude == pytest.approx(1.0)
