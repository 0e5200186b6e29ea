"""Energy quadrature on polygons (docs/method.md §4): the small rules are exact for degree 2l.

References are independent of the rules under test: the Gauss rules on the sub-triangles
(exact for the same degree, basix), and the linear-elastic tangent, whose integrand is a
polynomial of degree 2l, so that every exact rule must give the same matrix.
"""
import numpy as np
import pytest
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem import meshes
from dolfinx_sfvem.discretizations import quadrature
from dolfinx_sfvem.mesh.polygon import ear_clipping, point_location

COMM = MPI.COMM_SELF

#: non-convex, convex, with collinear (hanging) vertices
POLYGONS = {
    "hexagon": [[0, 0], [1, 0], [1.3, 0.8], [0.6, 1.4], [-0.2, 1.0], [-0.3, 0.4]],
    "U": [[0, 0], [3, 0], [3, 2], [2, 2], [2, 1], [1, 1], [1, 2], [0, 2]],
    "pentagon_with_hanging_node": [[0, 0], [1, 0], [2, 0], [2, 1], [1, 1.5], [0, 1]],
    "sheared_square_with_hanging_nodes": [[0, 0], [0.5, 0], [1, 0], [1.4, 0.5], [1.8, 1], [0.8, 1], [0.4, 0.5]],
}


def sub_triangle_rule(xy: np.ndarray, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """The reference rule: Gauss points of an ear-clipping triangulation of ``xy``."""
    ok, triangles, _ = ear_clipping(xy, 1e-12)
    assert ok
    _, x, w = quadrature.polygon_quadrature(xy, triangles, np.array([0, len(triangles)]), np.array([0]),
                                            np.array([degree]))
    return x, w


def moments(x: np.ndarray, w: np.ndarray, degree: int) -> np.ndarray:
    return quadrature.scaled_monomials(x, np.array([0.3, 0.4]), 1.7, degree) @ w


@pytest.mark.parametrize("name", POLYGONS)
@pytest.mark.parametrize("degree", [6, 8, 12])
def test_compressed_rule_is_exact_positive_inside_and_small(name, degree):
    xy = np.array(POLYGONS[name], dtype=float)
    x, w = sub_triangle_rule(xy, degree)
    xc, wc = quadrature.compress_rule(x, w, degree)
    np.testing.assert_allclose(moments(xc, wc, degree), moments(x, w, degree), rtol=1e-11, atol=1e-12)
    assert np.all(wc > 0)
    assert wc.size <= (degree + 1) * (degree + 2) // 2 < w.size
    assert all(point_location(p, xy, 1e-12) >= 0 for p in xc)      # inside or on the boundary


def test_compressed_rule_is_not_exact_one_degree_higher():
    """The compression uses its freedom: the rule is not simply the old one."""
    xy = np.array(POLYGONS["hexagon"])
    x, w = sub_triangle_rule(xy, 6)
    xc, wc = quadrature.compress_rule(x, w, 6)
    assert np.abs(moments(xc, wc, 8) - moments(x, w, 8)).max() > 1e-8


@pytest.mark.parametrize("name,is_parallelogram", [("hexagon", False), ("U", False),
                                                   ("pentagon_with_hanging_node", False),
                                                   ("sheared_square_with_hanging_nodes", True)])
def test_parallelogram_detection(name, is_parallelogram):
    corners = quadrature.parallelogram_corners(np.array(POLYGONS[name], dtype=float))
    assert (corners is not None) == is_parallelogram
    if is_parallelogram:
        np.testing.assert_allclose(corners, [[0, 0], [1, 0], [1.8, 1], [0.8, 1]])


@pytest.mark.parametrize("degree", [4, 6, 7, 8, 9])
def test_parallelogram_rule_is_exact(degree):
    xy = np.array(POLYGONS["sheared_square_with_hanging_nodes"])
    x, w = quadrature.parallelogram_rule(quadrature.parallelogram_corners(xy), degree)
    assert w.size == (degree // 2 + 1) ** 2 and np.all(w > 0)
    assert all(point_location(p, xy, 0.0) == 1 for p in x)              # strictly inside
    reference = sub_triangle_rule(xy, degree)
    np.testing.assert_allclose(moments(x, w, degree), moments(*reference, degree), rtol=1e-12, atol=1e-13)


@pytest.mark.parametrize("mesh", ["voronoi", "hanging"])
def test_linear_elastic_tangent_is_the_same_with_every_exact_rule(mesh):
    """At u = 0 the tangent is the linear-elastic stiffness: a degree-2l polynomial integrand."""
    polygons = (meshes.polygon_rectangle(1.0, 0.5, 0.15, tag=meshes.SOLID) if mesh == "voronoi"
                else meshes.quads_with_hanging_nodes(1.0, 1.0, 4, refine=(0.25, 0.75, 0.25, 0.75), tag=meshes.SOLID))
    energy = {meshes.SOLID: sf.Hyperelastic(K=5 / 3, mu=5 / 14)}
    K = {}
    for rule in ("compressed", "subtriangles"):
        disc = sf.SFVEMDiscretization(polygons, energy, COMM, quadrature=rule, verbose=False)
        x = disc.create_vector()
        x.set(0.0)
        A = disc.create_matrix()
        disc.jacobian(x, A)
        K[rule] = (A.convert("dense").getDenseArray().copy(), disc.space.x_q.shape[0])
    (Kc, nc), (Ks, ns) = K["compressed"], K["subtriangles"]
    assert nc < 0.75 * ns
    np.testing.assert_allclose(Kc, Ks, atol=1e-12 * np.abs(Ks).max())


def test_compressed_rules_in_every_region():
    """NNLS compression off parallelograms in the solids and in the third medium alike
    (module docstring): the medium's energy has gradient terms, its rule is the same."""
    polygons = meshes.polygon_rectangle(1.0, 0.5, 0.15, tag=meshes.SOLID)
    count = {}
    for name, energy in (("solid", sf.Hyperelastic(K=1.0, mu=1.0)),
                         ("medium", sf.ThirdMedium(mu=1.0, gamma=1e-3, alpha_r=1.0, regularization="huhu"))):
        for rule in ("compressed", "subtriangles"):
            disc = sf.SFVEMDiscretization(polygons, {meshes.SOLID: energy}, COMM, quadrature=rule, verbose=False)
            count[name, rule] = disc.space.x_q.shape[0]
    assert count["medium", "compressed"] == count["solid", "compressed"]
    assert count["medium", "subtriangles"] == count["solid", "subtriangles"]
    assert count["solid", "compressed"] < 0.75 * count["solid", "subtriangles"]


def test_unknown_quadrature_is_rejected():
    with pytest.raises(ValueError, match="unknown quadrature 'gauss'"):
        sf.SFVEMDiscretization(meshes.quad_rectangle(1.0, 1.0, 2, 2, tag=meshes.SOLID),
                               {meshes.SOLID: sf.Hyperelastic(K=1.0, mu=1.0)}, COMM, quadrature="gauss")
