"""Octree meshes: refinement, 2:1 balance and the polyhedra of coarse cubes next to finer ones,
against hand counts and a brute-force reference (all pairs of leaves compared geometrically)."""
import numpy as np
import pytest

from dolfinx_sfvem.meshes import octree_box



def in_corner(x):
    """Marker of the cube at the origin of [0, 2]^3 (centres x (3, n))."""
    return (x[0] < 1) & (x[1] < 1) & (x[2] < 1)


def boxes(octree):
    """Lower and upper corners (m, 3) of the leaves."""
    return octree.lower + octree.ijk * octree.sizes, octree.lower + (octree.ijk + 1) * octree.sizes


def contact_dimension(lo, hi):
    """(m, m) dimension of the contact of every pair of boxes: 2 across a face, 1 along an edge,
    0 at a vertex, -1 apart or overlapping (the diagonal)."""
    overlap = np.minimum(hi[:, None], hi[None]) - np.maximum(lo[:, None], lo[None])        # (m, m, 3)
    touching = np.all(overlap > -1e-12, axis=2) & np.any(np.abs(overlap) < 1e-12, axis=2)
    return np.where(touching, (overlap > 1e-12).sum(axis=2), -1)


def reference_balance(levels_ijk, most):
    """The minimal 2:1 refinement of a set of leaves (level, i, j, k) on a grid of unit boxes,
    by brute force: split the coarser of any two leaves with a contact of dimension >= 3 - most
    whose levels differ by more than one, until none is left."""
    leaves = sorted(levels_ijk)
    while True:
        level = np.array([l for l, *_ in leaves])
        ijk = np.array([x for _, *x in leaves])
        lo, hi = ijk / 2.0 ** level[:, None], (ijk + 1) / 2.0 ** level[:, None]
        contact = contact_dimension(lo, hi) >= 3 - most
        bad = contact & (level[:, None] - level[None] >= 2)
        coarse = set(np.flatnonzero(bad.any(axis=0)).tolist())
        if not coarse:
            return set(leaves)
        leaves = [leaf for k, leaf in enumerate(leaves) if k not in coarse] + [
            (leaves[k][0] + 1, *(2 * np.array(leaves[k][1:]) + [i, j, l]))
            for k in coarse for i in (0, 1) for j in (0, 1) for l in (0, 1)]


def leaf_set(octree):
    return {(int(l), *map(int, x)) for l, x in zip(octree.level, octree.ijk)}


@pytest.mark.parametrize("levels, n_cells", [(1, 7 + 8), (2, 64 + 6 * 8 + 1), (3, None)])
def test_corner_refinement_is_balanced_across_faces_and_edges(levels, n_cells):
    octree = octree_box([0, 0, 0], [2, 2, 2], 2).refine(in_corner, levels)
    # the corner cube split levels times (8**levels leaves), its face and edge neighbours as balance needs
    corner = {(levels, i, j, k) for i in range(2 ** levels) for j in range(2 ** levels) for k in range(2 ** levels)}
    others = {(0, i, j, k) for i in (0, 1) for j in (0, 1) for k in (0, 1)} - {(0, 0, 0, 0)}
    assert leaf_set(octree) == reference_balance(corner | others, most=2)
    if n_cells is not None:
        assert octree.n_cells == n_cells
    lo, hi = boxes(octree)
    contact = contact_dimension(lo, hi)
    jump = np.abs(octree.level[:, None] - octree.level[None])
    assert jump[contact >= 1].max() == 1                 # across faces and edges at most one level
    assert np.all((octree.parent == 0) == np.all(hi <= 1.0 + 1e-12, axis=1))


def test_balance_across_faces_only_allows_jumps_of_two_along_edges():
    octree = octree_box([0, 0, 0], [2, 2, 2], 2).refine(in_corner, 2, balance="faces")
    corner = {(2, i, j, k) for i in range(4) for j in range(4) for k in range(4)}
    others = {(0, i, j, k) for i in (0, 1) for j in (0, 1) for k in (0, 1)} - {(0, 0, 0, 0)}
    assert leaf_set(octree) == reference_balance(corner | others, most=1)
    contact = contact_dimension(*boxes(octree))
    jump = np.abs(octree.level[:, None] - octree.level[None])
    assert jump[contact == 2].max() == 1 and jump[contact == 1].max() == 2


@pytest.mark.parametrize("balance", ["edges", "faces", None])
def test_polyhedra_carry_every_leaf_corner_on_their_boundary(balance):
    """Each cell's vertices are exactly the leaf corners on its closed cube; its faces tile the cube's
    surface; each geometric face is one face of two cells; the volumes fill the box."""
    octree = octree_box([0, 0, 0], [2, 2, 2], 2).refine(in_corner, 2, balance=balance)
    mesh = octree.polyhedra()
    assert mesh.n_cells == octree.n_cells
    lo, hi = boxes(octree)
    assert mesh.volumes == pytest.approx(np.prod(hi - lo, axis=1), rel=1e-13)
    assert mesh.volumes.sum() == pytest.approx(8.0, rel=1e-14)
    corners = np.unique(np.concatenate([lo, hi, np.column_stack([hi[:, 0], lo[:, 1:]]),
                                        np.column_stack([lo[:, 0], hi[:, 1], lo[:, 2]]),
                                        np.column_stack([lo[:, :2], hi[:, 2]]),
                                        np.column_stack([hi[:, :2], lo[:, 2]]),
                                        np.column_stack([hi[:, 0], lo[:, 1], hi[:, 2]]),
                                        np.column_stack([lo[:, 0], hi[:, 1:]])]), axis=0)
    for c in range(mesh.n_cells):
        points, faces = mesh.polyhedron(c)
        inside = np.all((corners >= lo[c] - 1e-12) & (corners <= hi[c] + 1e-12), axis=1)
        assert {tuple(x) for x in np.round(points, 12)} == {tuple(x) for x in np.round(corners[inside], 12)}
        area = sum(np.linalg.norm(np.cross(points[f[1:-1]] - points[f[0]], points[f[2:]] - points[f[0]]).sum(axis=0))
                   / 2 for f in faces)
        size = hi[c] - lo[c]
        assert area == pytest.approx(2 * (size[0] * size[1] + size[1] * size[2] + size[0] * size[2]), rel=1e-13)
    count = np.bincount(mesh.cell_faces, minlength=mesh.n_faces)
    boundary = np.isclose(np.abs(mesh.face_centroids - 1.0), 1.0).any(axis=1)     # on x, y or z = 0 or 2
    assert np.all(count == np.where(boundary, 1, 2))
    signs = np.bincount(mesh.cell_faces, weights=mesh.cell_face_signs, minlength=mesh.n_faces)
    assert np.all(signs[~boundary] == 0)


def test_hand_count_of_the_coarse_neighbours():
    """Corner cube of [0, 2]^3 split once: its 3 face neighbours have the shared face in 4 squares
    and a hanging vertex on each of the 4 faces around it (9 faces, 8 + 4 + 1 = 13 vertices), its 3
    edge neighbours a hanging vertex on 2 faces (6 faces, 9 vertices), the far corner nothing.
    Split twice: the far corner touches 3 cubes split once: 3 faces in 4 squares, 3 hexagons on
    the boundary (15 faces) and 8 + 9 + 3 = 20 vertices."""
    octree = octree_box([0, 0, 0], [2, 2, 2], 2)
    once = octree.refine(in_corner)
    mesh = once.polyhedra()
    kind = lambda ijk: int((np.asarray(ijk) > 0).sum())        # noqa: E731  1 face, 2 edge, 3 vertex neighbour
    for c in np.flatnonzero(once.level == 0):
        points, faces = mesh.polyhedron(c)
        sizes = sorted(len(f) for f in faces)
        expected = {1: (13, [4] * 5 + [5] * 4), 2: (9, [4] * 4 + [5] * 2), 3: (8, [4] * 6)}[kind(once.ijk[c])]
        assert (points.shape[0], sizes) == (expected[0], expected[1])
    twice = octree.refine(in_corner, 2)
    mesh = twice.polyhedra()
    far = int(np.flatnonzero(twice.level == 0)[0])
    points, faces = mesh.polyhedron(far)
    assert twice.ijk[far].tolist() == [1, 1, 1]
    assert points.shape[0] == 20 and sorted(len(f) for f in faces) == [4] * 12 + [6] * 3


def test_refine_selections_and_errors():
    octree = octree_box([0, 0, 0], [1, 2, 3], [1, 2, 3])
    assert octree.n_cells == 6 and np.allclose(octree.sizes, 1.0)
    assert octree.refine([0]).n_cells == octree.refine(np.arange(6) == 0).n_cells == 13
    with pytest.raises(ValueError, match="selection is empty"):
        octree.refine(lambda x: x[0] > 5)
    with pytest.raises(ValueError, match="levels must be an integer >= 1"):
        octree.refine([0], 0)
    with pytest.raises(ValueError, match="balance must be one of"):
        octree.refine([0], balance="corners")
    with pytest.raises(ValueError, match="upper > lower"):
        octree_box([0, 0, 0], [1, 0, 1], 2)


def test_tags_of_the_polyhedra():
    mesh = octree_box([0, 0, 0], [2, 1, 1], [2, 1, 1]).refine([0]).polyhedra(
        lambda x: np.where(x[0] < 1, 1, 2), {"fine": 1})
    assert np.bincount(mesh.tags).tolist() == [0, 8, 1] and mesh.region_names == {"fine": 1}


@pytest.mark.parametrize("seed", [1, 3, 5])
def test_random_refinements_of_a_box_are_the_minimal_balanced_ones(seed):
    """Random leaves of a 3 x 2 x 1 grid on a non-cubic box refined three times in a row, 1 or 2
    levels each: the leaves are the brute-force minimal balance of the unbalanced refinement, and
    their polyhedra fill the box."""
    rng = np.random.default_rng(seed)
    octree = octree_box([-1.0, 0.0, 0.0], [2.0, 1.0, 0.5], [3, 2, 1])
    for _ in range(3):
        marked = rng.random(octree.n_cells) < 0.1
        marked[rng.integers(octree.n_cells)] = True
        levels = 1 + int(rng.integers(2))
        refined = octree.refine(marked, levels)
        assert leaf_set(refined) == reference_balance(leaf_set(octree.refine(marked, levels, balance=None)), most=2)
        octree = refined
    lo, hi = boxes(octree)
    mesh = octree.polyhedra()
    assert mesh.volumes.sum() == pytest.approx(1.5, rel=1e-13)
    assert mesh.volumes == pytest.approx(np.prod(hi - lo, axis=1), rel=1e-12)


def test_refine_to_a_size():
    """A uniform size gives the uniform octree of that size; a size small only near a corner gives
    cubes of that size at the corner, the coarse ones far away, and a 2:1 balanced mesh."""
    box = octree_box([0.0, 0.0, 0.0], [1.0, 1.0, 1.0], 1)
    uniform = box.refine_to(lambda lower, upper: np.full(lower.shape[1], 0.3))
    assert uniform.n_cells == 64 and np.all(uniform.sizes == 0.25)
    assert box.refine_to(lambda lower, upper: np.ones(lower.shape[1])) is box

    def corner(lower, upper):
        return np.where(np.linalg.norm(lower, axis=0) < 1e-12, 0.125, 0.5)

    mesh = box.refine_to(corner)
    at_corner = np.all(mesh.centres - 0.5 * mesh.sizes == 0.0, axis=1)
    assert np.all(mesh.sizes[at_corner] == 0.125) and mesh.sizes.max() == 0.5
    assert mesh.unbalanced("edges").size == 0
    assert np.all(mesh.parent == 0)
    with pytest.raises(ValueError, match="positive sizes"):
        box.refine_to(lambda lower, upper: np.zeros(lower.shape[1]))
