"""Pi^nabla_2 and Pi^0_l nabla on polyhedra (dolfinx_sfvem.discretizations.projection3d; docs/method.md §8).

References from outside the code under test: quadratic fields and their gradients evaluated
directly, the 2D Pi^nabla_2 (Simpson on the edges) against the face projection built from the
gradient moments, LAPACK singular values against the inertia count, and the invariance of the
rank under rigid motions and scaling. The test polyhedra are conftest.py's ``polyhedra``.
"""
import numpy as np
import pytest

from dolfinx_sfvem.discretizations.cell_projection import RANK_TOL, null_space_dimensions
from dolfinx_sfvem.discretizations.monomials3d import exponents3
from dolfinx_sfvem.discretizations.projection import pi_nabla_2, polygon_geometry
from dolfinx_sfvem.discretizations.projection3d import (
    build_projections_3d, face_h1_projection, interpolation_dofs, polyhedron_projections)


class Quadratic3D:
    """q(x) = sum_a c_a x^alpha_a over the 10 monomials of degree <= 2 (unscaled), with its gradient."""

    def __init__(self, c):
        self.c = np.asarray(c)
        self.alpha = exponents3(2)

    def __call__(self, x):
        return np.prod(x[:, None, :] ** self.alpha, axis=2) @ self.c

    def gradient(self, x):
        g = np.zeros((len(x), 3))
        for c_a, a in zip(self.c, self.alpha):
            for d in range(3):
                if a[d]:
                    lowered = a.copy()
                    lowered[d] -= 1
                    g[:, d] += c_a * a[d] * np.prod(x ** lowered, axis=1)
        return g


def scaled(x, P, degree):
    """The scaled monomials of degree <= ``degree`` of the polyhedron at the points x (n, 3)."""
    return np.prod(((x[:, None, :] - P.centroid) / P.diameter) ** exponents3(degree), axis=2)


def sample_points(points, n, rng):
    """Points near the polyhedron (the projections are polynomials: any point tests them)."""
    return points.min(axis=0) + rng.random((n, 3)) * np.ptp(points, axis=0)


@pytest.mark.parametrize("name", ["square", "hanging"])
def test_face_projection_of_degree_2_is_the_2d_pi_nabla(name):
    """Pi^nabla_{2,f} from the gradient moments (Gauss on the sides) equals the 2D Pi^nabla_2 (Simpson)."""
    xy = {"square": np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]]),
          "hanging": np.array([[0.0, 0], [0.5, 0], [1, 0], [1, 0.5], [1, 1], [0, 1]])}[name]
    area, x_f, h_f = polygon_geometry(xy)
    Pi_2 = pi_nabla_2(xy, x_f, h_f, area)
    Pi, nullity = face_h1_projection(xy, x_f, h_f, area, Pi_2, 2, RANK_TOL)
    np.testing.assert_allclose(Pi, Pi_2, atol=1e-13)
    assert nullity > 1  # 6 coefficients cannot see 2N + 1 DOFs
    nullities = [face_h1_projection(xy, x_f, h_f, area, Pi_2, k, RANK_TOL)[1] for k in range(2, 9)]
    assert nullities == sorted(nullities, reverse=True) and nullities[-1] == 1
    # dim P_k - 1 >= 2N non-constant gradients are needed to see the 2N + 1 DOFs
    k_f = 2 + nullities.index(1)
    assert (k_f + 1) * (k_f + 2) // 2 - 1 >= 2 * len(xy)


def test_quadratics_are_reproduced(polyhedron):
    """Pi^nabla_2 q = q and Pi^0_l grad q = grad q for a quadratic q, on every test polyhedron."""
    points, faces = polyhedron
    rng = np.random.default_rng(7)
    q = Quadratic3D(rng.standard_normal(10))
    P = polyhedron_projections(points, faces)
    dofs = interpolation_dofs(points, faces, q, 2)
    x = sample_points(points, 20, rng)
    scale = np.abs(q(x)).max()
    np.testing.assert_allclose(scaled(x, P, 2) @ (P.Pi_nabla @ dofs), q(x), rtol=0, atol=1e-13 * scale)
    gradient = np.stack([scaled(x, P, P.l) @ (P.Pi_m[c] @ dofs) for c in range(3)], axis=1)
    # scaled monomials of degree l lose about a digit per degree (measured: 3e-12 at l = 5, 6e-10 at l = 9)
    np.testing.assert_allclose(gradient, q.gradient(x), rtol=0, atol=10.0 ** (max(P.l, 7) - 17) * scale / P.diameter)


def test_automatic_l_is_the_smallest_sufficient(polyhedron):
    """At the chosen l the null spaces are the constants and the rigid motions (LAPACK SVD), and
    l - 1 is refused as rank-deficient."""
    points, faces = polyhedron
    P = polyhedron_projections(points, faces)
    Q = P.Q
    assert null_space_dimensions(Q, RANK_TOL) == (1, 6)
    sigma = np.linalg.svd(np.concatenate(list(Q), axis=0), compute_uv=False)
    assert np.sum(sigma <= RANK_TOL * sigma[0]) == 1  # the gradient operator: constants only
    if P.l > 2:
        with pytest.raises(ValueError, match=f"l={P.l - 1} is rank-deficient"):
            polyhedron_projections(points, faces, l=P.l - 1)


def rotation(angles):
    a, b, c = angles
    Rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    Rz = np.array([[np.cos(c), -np.sin(c), 0], [np.sin(c), np.cos(c), 0], [0, 0, 1]])
    Ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    return Rz @ Ry @ Rx


@pytest.mark.parametrize("name", ["cube, 1 refined neighbour", "L prism (non-convex)", "random convex hull"])
def test_rigid_motion_and_scaling_invariance(name, polyhedra):
    """A moved, turned and scaled polyhedron gets the same l, and the singular values of its
    projected gradient scale with s^{1/2} (grad v ~ 1/s, volume ~ s^3)."""
    points, faces = polyhedra[name]
    s = 3e-3
    moved = s * points @ rotation([0.3, -1.1, 2.0]).T + np.array([10.0, -5.0, 2.0])
    P, R = polyhedron_projections(points, faces), polyhedron_projections(moved, faces)
    assert R.l == P.l
    sv = [np.linalg.svd(np.concatenate(list(X.Q), axis=0), compute_uv=False) for X in (P, R)]
    np.testing.assert_allclose(sv[1] / np.sqrt(s), sv[0], rtol=1e-8, atol=1e-8 * sv[0][0])
    np.testing.assert_allclose(R.volume, s ** 3 * P.volume, rtol=1e-12)


def test_face_degrees_of_the_octree_cell(polyhedra):
    """Quadrilateral faces need k_f = 4 (Q2-like traces), faces with hanging vertices more."""
    P = polyhedron_projections(*polyhedra["cube, 1 refined neighbour"])
    points, faces = polyhedra["cube, 1 refined neighbour"]
    sizes = np.array([len(f) for f in faces])
    assert np.all(P.face_degrees[sizes == 4] == 4)
    assert np.all(P.face_degrees[sizes > 4] >= 4)
    assert P.n_dofs == 13 + 20 + 9 + 1


def test_bad_input(polyhedra):
    points, faces = polyhedra["cube"]
    with pytest.raises(ValueError, match="oriented inward"):
        polyhedron_projections(points, [faces[0][::-1]] + faces[1:])
    with pytest.raises(ValueError, match="open polyhedron"):
        polyhedron_projections(points, faces[1:])
    with pytest.raises(ValueError, match="l must be an integer"):
        polyhedron_projections(points, faces, l=0)
    with pytest.raises(ValueError, match="l=3 is rank-deficient"):
        polyhedron_projections(points, faces, l=3)
    with pytest.raises(ValueError, match="no l <= l_max=4 is sufficient"):
        polyhedron_projections(points, faces, l_max=4)


def test_flat_cell_is_refused(prism):
    """A square slab 1 x 1 x 0.001: its in-plane modes fall below RANK_TOL next to the through-thickness
    ones (sigma_7 / sigma_max ~ t^2), a clear error; at 1 x 1 x 0.1 it is an ordinary cell."""
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    assert polyhedron_projections(*prism(square, 0.1)).l == 5
    with pytest.raises(ValueError, match="no l <= l_max=10 is sufficient: [0-9]+ zero-strain modes"):
        polyhedron_projections(*prism(square, 1e-3))


def mesh_arrays(cells):
    """The PolyhedronMesh CSR arrays (POLY-INTERFACES.md) of polyhedra that share faces by position."""
    keys: dict = {}
    stored: dict = {}
    face_lists, cell_faces, signs, offsets = [], [], [], [0]
    for points, faces in cells:
        numbers = [keys.setdefault(tuple(np.round(p, 11)), len(keys)) for p in points]
        for face in faces:
            global_face = [numbers[i] for i in face]
            key = frozenset(global_face)
            if key not in stored:
                stored[key] = len(face_lists)
                face_lists.append(global_face)
                signs.append(1)
            else:  # the neighbour passes the face the other way round
                first = face_lists[stored[key]]
                k = first.index(global_face[0])
                assert global_face == [first[(k - i) % len(first)] for i in range(len(first))]
                signs.append(-1)
            cell_faces.append(stored[key])
        offsets.append(len(cell_faces))
    points = np.array(sorted(keys, key=keys.get))
    face_offsets = np.cumsum([0] + [len(f) for f in face_lists])
    return points, face_offsets, np.concatenate(face_lists), np.array(offsets), np.array(cell_faces), np.array(signs)


def test_bulk_build_equals_per_polyhedron_build(octree_polyhedra):
    """The mesh loop gives each cell what polyhedron_projections gives its (points, outward faces)."""
    cells = octree_polyhedra(2, lambda c: bool(np.all(c < 0.5)))
    points, face_offsets, face_vertices, cell_offsets, cell_faces, signs = mesh_arrays(cells)
    chosen = np.array([0, 3, 8, 14, 9])
    B = build_projections_3d(points, face_offsets, face_vertices, cell_offsets, cell_faces, signs, cells=chosen)
    assert sum(B.histogram().values()) == chosen.size
    for j, c in enumerate(chosen):
        vertices = B.vertices_of(j)
        assert np.all(np.diff(vertices) > 0)
        local = {v: i for i, v in enumerate(vertices)}
        faces = []
        for f, s in zip(cell_faces[cell_offsets[c]:cell_offsets[c + 1]], signs[cell_offsets[c]:cell_offsets[c + 1]]):
            face = [local[v] for v in face_vertices[face_offsets[f]:face_offsets[f + 1]]]
            faces.append(np.array(face if s > 0 else face[::-1]))
        P = polyhedron_projections(points[vertices], faces)
        assert B.l[j] == P.l and B.measure[j] == pytest.approx(P.volume)
        np.testing.assert_allclose(B.Pi_nabla_of(j), P.Pi_nabla, rtol=0, atol=1e-12 * np.abs(P.Pi_nabla).max())
        np.testing.assert_allclose(B.Pi_m_of(j), P.Pi_m, rtol=0, atol=1e-12 * np.abs(P.Pi_m).max())
        # the same polyhedron as given, in its own numbering: the same l and volume
        assert polyhedron_projections(*cells[c]).l == P.l
    again = build_projections_3d(points, face_offsets, face_vertices, cell_offsets, cell_faces, signs, cells=chosen,
                                 l=B.l)     # one l per cell, as in 2D
    np.testing.assert_array_equal(again.Pi_m, B.Pi_m)
    with pytest.raises(ValueError, match=r"cell 0: l=3 is rank-deficient \(\d+ zero-strain modes where the 6 rigid "
                                         r"motions are expected.*; the smallest sufficient l is \d+"):
        build_projections_3d(points, face_offsets, face_vertices, cell_offsets, cell_faces, signs, l=3)
