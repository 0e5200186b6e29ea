"""gmsh models as users bring them: ``meshes.read_gmsh`` of a ``.msh`` file and of the open model,
2D and 3D, physical groups as regions and named boundaries, and boundary conditions and loads
given by those names, against the exact homogeneous uniaxial stretch."""
import numpy as np
import pytest

import dolfinx_sfvem as sf
from dolfinx_sfvem import meshes
from dolfinx_sfvem.mesh.cell_mesh import CellMesh, facet_normals
from dolfinx_sfvem.mesh.polygon_mesh import PolygonMesh

K, MU, STRETCH = 5 / 3, 5 / 14, 0.1
SOLID, MEDIUM = 1, 2
EPS = 1e-6


def in_box(gmsh, dim, lo, hi):
    """Tags of the ``dim``-entities of the current model inside the box [lo, hi] (widened by EPS)."""
    return [tag for _, tag in gmsh.model.getEntitiesInBoundingBox(*(np.asarray(lo) - EPS), *(np.asarray(hi) + EPS),
                                                                   dim)]


def column(gmsh, hexahedra: bool, groups: bool = True) -> None:
    """The column [0, 1] x [0, 1] x [0, 2] as two volumes, "solid" below z = 1 and "medium" above,
    meshed (2 x 2 x 4 hexahedra, or tetrahedra of size 0.5), with the surfaces "bottom" (z = 0),
    "top" (z = 2), "x0" (x = 0) and "y0" (y = 0); with ``groups=False`` the medium has no group."""
    occ = gmsh.model.occ
    occ.fragment([(3, occ.addBox(0, 0, 0, 1, 1, 1))], [(3, occ.addBox(0, 0, 1, 1, 1, 1))])
    occ.synchronize()
    if hexahedra:
        for _, curve in gmsh.model.getEntities(1):
            gmsh.model.mesh.setTransfiniteCurve(curve, 3)
        for _, surface in gmsh.model.getEntities(2):
            gmsh.model.mesh.setTransfiniteSurface(surface)
            gmsh.model.mesh.setRecombine(2, surface)
        for _, volume in gmsh.model.getEntities(3):
            gmsh.model.mesh.setTransfiniteVolume(volume)
    else:
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.5)
    gmsh.model.setPhysicalName(3, gmsh.model.addPhysicalGroup(3, in_box(gmsh, 3, [0, 0, 0], [1, 1, 1]), SOLID), "solid")
    if groups:
        gmsh.model.setPhysicalName(3, gmsh.model.addPhysicalGroup(3, in_box(gmsh, 3, [0, 0, 1], [1, 1, 2]), MEDIUM),
                                   "medium")
    for name, lo, hi in (("bottom", [0, 0, 0], [1, 1, 0]), ("top", [0, 0, 2], [1, 1, 2]),
                         ("x0", [0, 0, 0], [0, 1, 2]), ("y0", [0, 0, 0], [1, 0, 2])):
        gmsh.model.setPhysicalName(2, gmsh.model.addPhysicalGroup(2, in_box(gmsh, 2, lo, hi)), name)
    gmsh.model.mesh.generate(3)


def read_both(tmp_path, hexahedra: bool) -> tuple[CellMesh, CellMesh]:
    """The column read from its .msh file (in a session of its own) and from the open model."""
    with meshes.gmsh_session() as gmsh:
        column(gmsh, hexahedra)
        gmsh.write(str(tmp_path / "column.msh"))
        from_model = meshes.read_gmsh(None)
    return meshes.read_gmsh(tmp_path / "column.msh"), from_model


@pytest.mark.parametrize("hexahedra", [True, False])
def test_read_gmsh_3d_regions_and_named_surfaces(tmp_path, hexahedra):
    from_file, from_model = read_both(tmp_path, hexahedra)
    for mesh in (from_file, from_model):
        assert isinstance(mesh, CellMesh)
        assert mesh.cell_type == ("hexahedron" if hexahedra else "tetrahedron")
        assert mesh.region_names == {"solid": SOLID, "medium": MEDIUM}
        assert set(mesh.tags.tolist()) == {SOLID, MEDIUM}
        assert np.isclose(mesh.volumes[mesh.tags == SOLID].sum(), 1.0) and np.isclose(mesh.volumes.sum(), 2.0)
        centre_z = mesh.points[mesh.cells].mean(axis=1)[:, 2]
        assert np.all((centre_z < 1.0) == (mesh.tags == SOLID))
        assert sorted(mesh.boundary_names) == ["bottom", "top", "x0", "y0"]
        for name, axis, value, area in (("bottom", 2, 0.0, 1.0), ("top", 2, 2.0, 1.0), ("x0", 0, 0.0, 2.0),
                                        ("y0", 1, 0.0, 2.0)):
            faces = mesh.boundary_names[name]
            assert faces.shape[1] == (4 if hexahedra else 3)
            assert np.allclose(mesh.points[faces][..., axis], value)
            normals = facet_normals(mesh.points, faces)
            assert np.isclose(np.abs(normals[:, axis]).sum(), area)      # the whole surface, each face once
    if hexahedra:
        assert from_file.n_cells == 16 and from_file.boundary_names["top"].shape == (4, 4)
    assert from_file.n_cells == from_model.n_cells and from_file.n_points == from_model.n_points


def test_read_gmsh_errors(tmp_path):
    with meshes.gmsh_session() as gmsh:
        column(gmsh, hexahedra=False, groups=False)
        with pytest.raises(ValueError, match="volume .* belongs to none of the model's 3D physical groups"):
            meshes.read_gmsh(None)
        assert meshes.read_gmsh(None, {"solid": SOLID}).n_cells > 0      # a selection takes what it names
    with meshes.gmsh_session() as gmsh:
        occ = gmsh.model.occ
        occ.addBox(0, 0, 0, 1, 1, 1)
        occ.addBox(3, 0, 0, 1, 1, 1)
        occ.synchronize()
        for curve in in_box(gmsh, 1, [0, 0, 0], [1, 1, 1]):
            gmsh.model.mesh.setTransfiniteCurve(curve, 2)
        for surface in in_box(gmsh, 2, [0, 0, 0], [1, 1, 1]):
            gmsh.model.mesh.setTransfiniteSurface(surface)
            gmsh.model.mesh.setRecombine(2, surface)
        gmsh.model.mesh.setTransfiniteVolume(in_box(gmsh, 3, [0, 0, 0], [1, 1, 1])[0])
        gmsh.model.mesh.generate(3)
        with pytest.raises(ValueError, match="mixes tetrahedra and hexahedra"):
            meshes.read_gmsh(None)


def column_problem(mesh, method="fem"):
    problem = sf.ContactProblem(mesh, {"solid": sf.Hyperelastic(K=K, mu=MU), "medium": sf.Hyperelastic(K=K, mu=MU)},
                                method=method, verbose=False)
    problem.fix("x0", components="x", name="x0")
    problem.fix("y0", components="y", name="y0")
    problem.fix("bottom", components="z", name="bottom")
    return problem


@pytest.mark.parametrize("hexahedra, method, load", [(True, "fem", "prescribe"), (False, "fem", "traction"),
                                                     (True, "vem", "traction")])
def test_named_surfaces_carry_the_uniaxial_stretch(tmp_path, by_hand, hexahedra, method, load):
    """Symmetry planes and the clamp given by surface name, the pull on "top" by name (a prescribed
    displacement, or the traction P_zz): the homogeneous stretch exactly (Q2, P2, the SFVEM)."""
    mesh = read_both(tmp_path, hexahedra)[0]
    s, P33 = by_hand.uniaxial(K, MU, STRETCH)
    problem = column_problem(mesh, method)
    if load == "prescribe":
        problem.prescribe("top", uz=2.0 * STRETCH, name="pull")
    else:
        problem.traction("top", (0.0, 0.0, P33), name="pull")
    assert problem.solve(steps=2).converged
    corner = problem.displacement_at([[1.0, 1.0, 2.0], [0.5, 0.25, 1.0]])
    assert corner == pytest.approx(np.array([[s - 1, s - 1, 2 * STRETCH], [0.5 * (s - 1), 0.25 * (s - 1), STRETCH]]),
                                   abs=1e-10)
    reactions = problem.reactions()
    assert reactions["bottom"] == pytest.approx([0.0, 0.0, -P33], abs=1e-10)
    if load == "prescribe":
        assert reactions["pull"] == pytest.approx([0.0, 0.0, P33], abs=1e-10)


def test_unknown_boundary_names_are_named(tmp_path):
    problem = column_problem(read_both(tmp_path, hexahedra=True)[0])
    with pytest.raises(ValueError, match=r"'side' is not a named boundary of the mesh \(its boundaries: "
                                         r"\['bottom', 'top', 'x0', 'y0'\]\)"):
        problem.fix("side")
    with pytest.raises(ValueError, match=r"'side' is neither a region name .*'medium', 'solid'.* nor a boundary name "
                                         r".*'bottom', 'top'"):
        problem.pressure("side", 1.0)
    with pytest.raises(ValueError, match="boundaries or regions, not both"):
        problem.traction(["top", "solid"], (0.0, 0.0, 1.0))


# ----------------------------------------------------------------------------- 2D: named curves
def strip(gmsh) -> None:
    """The strip [0, 2] x [0, 1] as two surfaces, "solid" (x < 1) and "medium", triangles of size
    0.25, with the curves "left" (x = 0), "right" (x = 2) and "bottom" (y = 0, two curves)."""
    occ = gmsh.model.occ
    occ.fragment([(2, occ.addRectangle(0, 0, 0, 1, 1))], [(2, occ.addRectangle(1, 0, 0, 1, 1))])
    occ.synchronize()
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.25)
    for name, tag, lo, hi in (("solid", SOLID, [0, 0, 0], [1, 1, 0]), ("medium", MEDIUM, [1, 0, 0], [2, 1, 0])):
        gmsh.model.setPhysicalName(2, gmsh.model.addPhysicalGroup(2, in_box(gmsh, 2, lo, hi), tag), name)
    for name, lo, hi in (("left", [0, 0, 0], [0, 1, 0]), ("right", [2, 0, 0], [2, 1, 0]),
                         ("bottom", [0, 0, 0], [2, 0, 0])):
        gmsh.model.setPhysicalName(1, gmsh.model.addPhysicalGroup(1, in_box(gmsh, 1, lo, hi)), name)
    gmsh.model.mesh.generate(2)


@pytest.mark.parametrize("method", ["vem", "fem"])
def test_named_curves_in_2d_select_what_markers_select(tmp_path, method):
    """In 2D the named curves select the same unknowns as the equivalent marker functions (on the
    FEM's own triangulation, too) and give the same solution, for a prescribed displacement and a
    traction."""
    with meshes.gmsh_session() as gmsh:
        strip(gmsh)
        gmsh.write(str(tmp_path / "strip.msh"))
    mesh = meshes.read_gmsh(tmp_path / "strip.msh")
    assert isinstance(mesh, PolygonMesh) and mesh.region_names == {"solid": SOLID, "medium": MEDIUM}
    assert sorted(mesh.boundary_names) == ["bottom", "left", "right"]
    assert np.allclose(mesh.points[mesh.boundary_names["right"]][..., 0], 2.0)
    assert np.isclose(np.abs(np.diff(mesh.points[mesh.boundary_names["bottom"]][..., 0], axis=1)).sum(), 2.0)
    materials = {"solid": sf.Hyperelastic(K=K, mu=MU), "medium": sf.Hyperelastic(K=K, mu=MU)}
    markers = {"left": lambda x: np.isclose(x[0], 0.0), "right": lambda x: np.isclose(x[0], 2.0),
               "bottom": lambda x: np.isclose(x[1], 0.0)}
    results = []
    for by_name in (True, False):
        problem = sf.ContactProblem(mesh, materials, method=method, verbose=False)
        where = {name: name if by_name else marker for name, marker in markers.items()}
        problem.fix(where["left"], components="x", name="left")
        problem.fix(where["bottom"], components="y", name="bottom")
        problem.prescribe(where["right"], ux=0.1, name="pull")
        problem.traction(where["left"], (0.0, 0.05), name="shear")
        assert problem.solve(steps=1).converged
        constraints = problem.constraints()
        results.append((constraints.dofs, problem.reactions()["left"], problem.displacement_at([[2.0, 1.0]])))
    (dofs, reaction, u), (dofs_marker, reaction_marker, u_marker) = results
    assert np.array_equal(dofs, dofs_marker) and dofs.size > 0
    assert reaction == pytest.approx(reaction_marker, abs=1e-12)
    assert u == pytest.approx(u_marker, abs=1e-12) and u[0, 0] == pytest.approx(0.1, abs=1e-3)
