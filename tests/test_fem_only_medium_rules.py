"""The medium's FEM-only quadratures, ``ThirdMedium(..., quadrature="lobatto")`` (issue 42 item 1)
and ``quadrature="reduced"``.

- The option is validated and named in messages; the default is "gauss", for the solids too.
- Each rule is refused by the discretizations without it, the SFVEM in 2D and 3D and the FEM's
  cells of the other element (Gauss-Lobatto: P2 triangles and tetrahedra; reduced: Q2
  quadrilaterals and hexahedra), each message naming where the rule is available.

What the rules compute: test_lobatto_medium (Q2 cells), test_reduced_medium (P2 simplices).
"""
import numpy as np
import pytest
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem.discretizations.fem import LagrangeDiscretization
from dolfinx_sfvem.discretizations.vem import SFVEMDiscretization
from dolfinx_sfvem.discretizations.vem3d import PolyhedralDiscretization
from dolfinx_sfvem.mesh.cell_mesh import CellMesh

#: rule -> the FEM's cells without it (2D, 3D) and their element, the rule those cells have
#: instead, and where the rule is available in the SFVEM's message and in the FEM's
FEM_ONLY = {
    "lobatto": dict(cells=("triangle", "tetrahedron"), element="P2", instead="reduced",
                    sfvem="method='fem' on Q2 cells", fem="Q2 quadrilaterals and hexahedra"),
    "reduced": dict(cells=("quadrilateral", "hexahedron"), element="Q2", instead="lobatto",
                    sfvem="method='fem' on P2 triangles and tetrahedra", fem="P2 triangles and tetrahedra"),
}


def sfvem_2d(energy, tiny3d):
    mesh = sf.meshes.quad_rectangle(1.0, 1.0, 2, 2, tag=1)
    return SFVEMDiscretization(mesh, {1: energy}, MPI.COMM_WORLD, verbose=False)


def sfvem_3d(energy, tiny3d):
    cubes = sf.meshes.octree_box([0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [1, 1, 1]).polyhedra()
    cubes.tags[:] = 1
    return PolyhedralDiscretization(cubes, {1: energy}, MPI.COMM_WORLD, verbose=False)


def fem_2d(mesh: sf.PolygonMesh):
    return lambda energy, tiny3d: LagrangeDiscretization.from_polygon_mesh(
        mesh, {1: energy}, MPI.COMM_WORLD, fem_mesh=mesh, verbose=False)


def fem_3d(cell: str, cells):
    return lambda energy, tiny3d: LagrangeDiscretization.from_cell_mesh(
        CellMesh(tiny3d.CUBE, cells, np.ones(len(cells)), cell), {1: energy}, MPI.COMM_WORLD, verbose=False)


#: where -> ``(energy, tiny3d) -> a discretization`` of one region with ``energy``
DISCRETIZATIONS = {
    "the SFVEM in 2D": sfvem_2d,
    "the SFVEM in 3D": sfvem_3d,
    "triangle": fem_2d(sf.PolygonMesh([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]], [1])),
    "quadrilateral": fem_2d(sf.meshes.quad_rectangle(1.0, 1.0, 1, 1, tag=1)),
    "tetrahedron": fem_3d("tetrahedron", [[0, 1, 2, 4]]),                  # the cube's corner at the origin
    "hexahedron": fem_3d("hexahedron", [np.arange(8)]),
}


def test_option_is_validated_and_named(medium_by_hand):
    MU, K = medium_by_hand.MU, medium_by_hand.K
    with pytest.raises(ValueError, match=r"quadrature 'simpson'.*'gauss', 'lobatto', 'reduced'"):
        sf.ThirdMedium(mu=MU, gamma=1e-5, alpha_r=1.0, quadrature="simpson")
    assert sf.ThirdMedium(mu=MU, gamma=1e-5, alpha_r=1.0).quadrature == "gauss"
    assert sf.Hyperelastic(K=K, mu=MU).quadrature == "gauss"
    for rule in FEM_ONLY:
        assert rule in repr(medium_by_hand.medium(rule))


@pytest.mark.parametrize("rule, where", [(rule, where) for rule, expected in FEM_ONLY.items()
                                         for where in ("the SFVEM in 2D", "the SFVEM in 3D", *expected["cells"])])
def test_discretizations_without_the_rule_refuse_it(rule, where, medium_by_hand, tiny3d):
    expected = FEM_ONLY[rule]
    if where.startswith("the SFVEM"):
        message = rf"quadrature='{rule}' is not available with the SFVEM \(method='vem'\).*{expected['sfvem']}"
    else:
        message = (rf"quadrature='{rule}' is not available on {expected['element']} {where}s: .* is that of "
                   rf"{expected['fem']}; available: \['gauss', '{expected['instead']}'\]")
    with pytest.raises(ValueError, match=message):
        DISCRETIZATIONS[where](medium_by_hand.medium(rule), tiny3d)
