"""Polyhedron geometry and quadrature (dolfinx_sfvem.mesh.polyhedron; docs/method.md §8).

References from outside the code under test: closed-form monomial integrals over the unit cube
and a tetrahedron, scipy's convex hull volumes, the divergence-theorem integrals against the
sub-tetrahedral rule (two independent constructions), and counts of the octree cells' entities.
"""
from math import factorial

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from dolfinx_sfvem.discretizations.monomials3d import (
    evaluate_monomials3, exponents3, monomial_index3, monomial_matrix3, n_monomials3)
from dolfinx_sfvem.mesh.polyhedron import (
    energy_quadrature, face_quadrature, polyhedron_edges, polyhedron_geometry, polyhedron_monomial_integrals,
    polyhedron_quadrature, validate_polyhedron)


def test_monomials3_order_and_derivatives():
    alpha = exponents3(3)
    assert n_monomials3(3) == 20 and alpha.shape == (20, 3)
    assert alpha[:10].tolist() == [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [2, 0, 0], [1, 1, 0], [1, 0, 1],
                                   [0, 2, 0], [0, 1, 1], [0, 0, 2]]
    assert [monomial_index3(*a) for a in alpha] == list(range(20))
    x, x_E, h = np.array([0.9, 0.4, -0.3]), np.array([0.1, 0.2, 0.3]), 0.8
    m, dm = np.empty(20), np.empty((3, 20))
    evaluate_monomials3(x, x_E, h, 3, m, dm)
    xi = (x - x_E) / h
    np.testing.assert_allclose(m, np.prod(xi ** alpha, axis=1), rtol=1e-14)
    step = 1e-6
    for c in range(3):
        e = np.zeros(3)
        e[c] = step
        plus, minus = (np.prod(((x + s * e - x_E) / h) ** alpha, axis=1) for s in (1, -1))
        np.testing.assert_allclose(dm[c], (plus - minus) / (2 * step), rtol=1e-7, atol=1e-9)


def test_edges_of_the_octree_cells(polyhedra):
    assert polyhedron_edges(polyhedra["cube"][1]).shape == (12, 2)
    # one split face: 4 split cube edges (+4), 4 inner edges of the split face
    edges = polyhedron_edges(polyhedra["cube, 1 refined neighbour"][1])
    assert edges.shape == (20, 2) and np.all(edges[:, 0] < edges[:, 1])
    assert edges.tolist() == sorted(edges.tolist())
    assert polyhedron_edges(polyhedra["cube, 6 refined neighbours"][1]).shape == (48, 2)


def test_geometry_of_the_unit_cube_and_a_hull(polyhedra):
    g = polyhedron_geometry(*polyhedra["cube"])
    assert g.volume == pytest.approx(1.0, rel=1e-14) and g.diameter == pytest.approx(np.sqrt(3))
    np.testing.assert_allclose(g.centroid, 0.5, rtol=1e-14)
    np.testing.assert_allclose(g.face_areas, 1.0, rtol=1e-14)
    # outward normals: from the centroid to the face centroid, and the frames right-handed
    np.testing.assert_allclose(g.face_normals, 2 * (g.face_centroids - g.centroid), atol=1e-14)
    frames = np.concatenate([g.face_bases, g.face_normals[:, None]], axis=1)
    np.testing.assert_allclose(np.linalg.det(frames), 1.0, rtol=1e-14)
    points, faces = polyhedra["random convex hull"]
    hull = ConvexHull(points)
    g = polyhedron_geometry(points, faces)
    assert g.volume == pytest.approx(hull.volume, rel=1e-13)
    assert g.face_areas.sum() == pytest.approx(hull.area, rel=1e-13)
    # the truncated octahedron with edge a = sqrt(2): volume 8 sqrt(2) a^3, area (6 + 12 sqrt(3)) a^2
    g = polyhedron_geometry(*polyhedra["truncated octahedron (BCC Voronoi cell)"])
    assert g.volume == pytest.approx(32.0, rel=1e-14)
    assert g.face_areas.sum() == pytest.approx(2 * (6 + 12 * np.sqrt(3)), rel=1e-14)
    np.testing.assert_allclose(g.centroid, 0.0, atol=1e-14)


@pytest.mark.parametrize("degree", [1, 4, 7])
def test_quadrature_exact_on_cube_and_tetrahedron(degree, polyhedra):
    """Closed forms: int_[0,1]^3 x^p y^q z^r = 1/((p+1)(q+1)(r+1)); over the unit simplex p! q! r! / (d + 3)!"""
    alpha = exponents3(degree)
    x, w = polyhedron_quadrature(*polyhedra["cube"], degree)
    expected = 1.0 / np.prod(alpha + 1, axis=1)
    np.testing.assert_allclose(np.prod(x[:, None] ** alpha, axis=2).T @ w, expected, rtol=1e-13)
    simplex = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    faces = [np.array(f) for f in ([0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2])]
    x, w = polyhedron_quadrature(simplex, faces, degree)
    expected = [factorial(p) * factorial(q) * factorial(r) / factorial(p + q + r + 3) for p, q, r in alpha]
    np.testing.assert_allclose(np.prod(x[:, None] ** alpha, axis=2).T @ w, expected, rtol=1e-13)
    # the divergence-theorem integrals agree with the closed form too (centre 0, scale 1)
    np.testing.assert_allclose(polyhedron_monomial_integrals(simplex, faces, np.zeros(3), 1.0, degree), expected,
                               rtol=1e-13)


def test_sub_tetrahedral_rule_matches_divergence_theorem(polyhedron):
    """Two independent constructions of int_E m_a up to degree 8 on every test polyhedron."""
    points, faces = polyhedron
    g = polyhedron_geometry(points, faces)
    degree = 8
    x, w = polyhedron_quadrature(points, faces, degree)
    values = np.prod(((x[:, None] - g.centroid) / g.diameter) ** exponents3(degree), axis=2)
    reference = polyhedron_monomial_integrals(points, faces, g.centroid, g.diameter, degree)
    assert reference[0] == pytest.approx(g.volume, rel=1e-13)
    np.testing.assert_allclose(values.T @ w, reference, rtol=0, atol=5e-14 * g.volume)
    np.testing.assert_allclose(reference[1:4], 0.0, atol=1e-14 * g.volume)  # centroid


def test_face_quadrature_on_the_split_face(polyhedra):
    """Each face's rule integrates its area and centroid exactly: the split faces are quarters of
    the cube's faces, the others whole faces (hanging vertices on their sides); all are rectangles,
    whose centroid is the middle of their bounding box."""
    points, faces = polyhedra["cube, 3 refined neighbours"]
    x, w, face = face_quadrature(points, faces, 2)
    assert np.all(w > 0)
    np.testing.assert_allclose(np.bincount(face, w), [0.25 if len(f) == 4 else 1.0 for f in faces], rtol=1e-14)
    for f, vertices in enumerate(faces):
        box = points[vertices]
        np.testing.assert_allclose(w[face == f] @ x[face == f] / w[face == f].sum(),
                                   0.5 * (box.min(axis=0) + box.max(axis=0)), atol=1e-14)
    g = polyhedron_geometry(points, faces)
    np.testing.assert_allclose(g.face_areas, np.bincount(face, w), rtol=1e-14)


def _flip(faces, f):
    return [face[::-1] if k == f else face for k, face in enumerate(faces)]


@pytest.mark.parametrize("damage, message", [
    (lambda p, f: (p, _flip(f, 2)), "oriented inward"),
    (lambda p, f: (p, [face[::-1] for face in f]), "point inward"),
    (lambda p, f: (p, f[:-1]), "open polyhedron"),
    (lambda p, f: (p + np.where(np.arange(len(p))[:, None] == 0, [0, 0, 0.1], 0), f), "not planar"),
    (lambda p, f: (np.vstack([p, [5.0, 5, 5]]), f), "in no face"),
    (lambda p, f: (p, [np.array([0, 1, 1, 2])] + f[1:]), "repeated"),
    (lambda p, f: (p, [np.array([0, 1])] + f[1:]), "at least 3"),
    (lambda p, f: (p[:, :2], f), "shape"),
])
def test_bad_polyhedra_are_rejected(damage, message, polyhedra):
    points, faces = damage(*polyhedra["cube, 1 refined neighbour"])
    with pytest.raises(ValueError, match=message):
        validate_polyhedron(points, faces)
    with pytest.raises(ValueError, match=message):
        polyhedron_quadrature(points, faces, 2)


@pytest.mark.parametrize("name, rule, points_at_most", [
    ("cube", "auto", 6 ** 3), ("cube, 6 refined neighbours", "auto", 10 ** 3),
    ("triangle prism", "compressed", 286), ("L prism (non-convex)", "auto", None)])
def test_energy_quadrature_is_exact(polyhedra, name, rule, points_at_most):
    """Boxes (octree cells with hanging vertices too) get the tensor rule, "compressed" at most
    dim P_degree points, others the sub-tetrahedral rule: all exact for the monomials of the degree
    (against the divergence-theorem integrals)."""
    points, faces = polyhedra[name]
    degree = 18 if "refined" in name else 10
    x, w = energy_quadrature(points, faces, degree, rule)
    g = polyhedron_geometry(points, faces)
    exact = polyhedron_monomial_integrals(points, faces, g.centroid, g.diameter, degree)
    computed = monomial_matrix3(x, g.centroid, g.diameter, degree) @ w
    np.testing.assert_allclose(computed, exact, rtol=0, atol=1e-12 * g.volume)
    if points_at_most is None:
        assert w.size == polyhedron_quadrature(points, faces, degree)[1].size
    else:
        assert w.size <= points_at_most and w.min() > 0


def test_energy_quadrature_names_its_rules():
    with pytest.raises(ValueError, match="'tensor'"):
        energy_quadrature(np.eye(3), [], 2, "tensor")
