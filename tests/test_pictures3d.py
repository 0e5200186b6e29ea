"""The 3D pictures (dolfinx_sfvem/output/pictures3d.py): two blocks across a medium layer, the upper one
pressed down and bulged, rendered offscreen; the PNGs exist, have the window's size, show something
and the pressure picture is in colour."""
import numpy as np
import pytest
from mpi4py import MPI

from dolfinx_sfvem.output.pictures3d import WINDOW_SIZE, offscreen_unavailable, write_pictures_3d
from dolfinx_sfvem.mesh.csr import edge_key, segment_owner
from dolfinx_sfvem.physics.solid_surface import SolidSurface

plt = pytest.importorskip("matplotlib.pyplot")
REASON = offscreen_unavailable()
pytestmark = pytest.mark.skipif(REASON is not None, reason=f"no offscreen rendering: {REASON}")


def two_blocks(box_grid, cell):
    """Blocks [0, 1]² x [0, 0.4] and [0, 1]² x [0.6, 1] (tags 1, 3), medium between (tag 2); the upper
    block moved down by 0.15 and bulged down by up to 0.04 in its middle."""
    grid = np.linspace(0, 1, 5)
    mesh = box_grid(grid, grid, [0, 0.2, 0.4, 0.5, 0.6, 0.8, 1.0],
                    lambda c: 1 if c[2] < 0.4 else (2 if c[2] < 0.6 else 3), cell)
    x, y, z = mesh.points.T
    bump = 0.04 * np.sin(np.pi * x) * np.sin(np.pi * y)
    u = np.zeros_like(mesh.points)
    u[:, 2] = np.where(z >= 0.6, -0.15 - bump * (1.0 - z) / 0.4, np.where(z > 0.4, -0.15 * (z - 0.4) / 0.2, 0.0))
    return mesh, u


@pytest.mark.parametrize("cell", ["hexahedron", "tetrahedron"])
def test_pictures(box_grid, tmp_path, cell):
    mesh, u = two_blocks(box_grid, cell)
    n = mesh.points.shape[0]
    surface = SolidSurface(mesh, (1, 3), lambda a, b: n + edge_key(a, b, n))
    # a pressure like Hertz's on the lower block's top, 0 elsewhere
    r2 = (surface.X[:, 0] - 0.5) ** 2 + (surface.X[:, 1] - 0.5) ** 2
    pressure = np.where(np.isclose(surface.X[:, 2], 0.4), np.sqrt(np.maximum(0.0, 1.0 - r2 / 0.16)), 0.0)
    paths = write_pictures_3d(tmp_path, "blocks", mesh, u, (1, 3), surface, pressure)
    assert [p.name for p in paths] == ["blocks-deformed.png", "blocks-clip.png", "blocks-pressure.png"]
    for path in paths:
        image = plt.imread(path)[..., :3]
        assert image.shape[:2] == (WINDOW_SIZE[1], WINDOW_SIZE[0])
        assert image.std() > 0.05, f"{path.name} is blank"
        assert (image[:, -3:] > 0.95).all(), f"{path.name}: something drawn across the window's right edge"
    # coloured pixels (saturation) in the pressure picture: the colour map, not only grey
    image = plt.imread(paths[2])[..., :3]
    saturation = image.max(axis=2) - image.min(axis=2)
    assert (saturation > 0.3).mean() > 0.01
    # without a pressure: the deformed and clipped views only
    assert len(write_pictures_3d(tmp_path, "plain", mesh, u, (1, 3))) == 2


@pytest.mark.parametrize("cell", ["hexahedron", "tetrahedron"])
def test_pressure_view_on_the_surface_of_the_peak(box_grid, cell):
    """Both faces against the medium carry a pressure (as two bodies pressed together do), the upper
    one's larger: the pressure picture looks at the upper block's face, along its outward normal -z,
    at its centre (the two faces' normals together would cancel)."""
    from dolfinx_sfvem.output.pictures3d import _contact_view
    mesh, u = two_blocks(box_grid, cell)
    n = mesh.points.shape[0]
    surface = SolidSurface(mesh, (1, 3), lambda a, b: n + edge_key(a, b, n))
    z = surface.X[:, 2]
    pressure = np.where(np.isclose(z, 0.4), 1.0, 0.0) + np.where(np.isclose(z, 0.6), 1.1, 0.0)
    centre, normal = _contact_view(mesh, mesh.points + u, surface, pressure)
    assert normal == pytest.approx([0.0, 0.0, -1.0], abs=1e-12)   # the sides' normals left out at the rim
    assert centre[:2] == pytest.approx([0.5, 0.5], abs=1e-12) and centre[2] < 0.6 - 0.15 + 1e-12


# ---------------------------------------------------------------------- the SFVEM's polyhedra
def octree_sandwich():
    """[0, 1]³ in 2 x 2 x 5 octree boxes: solid (tag 1) below z = 0.4, medium (2) up to 0.6, solid (3)
    above; the box at the corner x, y > 1/2 above the medium refined (hanging vertices)."""
    import dolfinx_sfvem as sf
    return sf.meshes.octree_box([0, 0, 0], [1, 1, 1], [2, 2, 5]).refine(
        lambda c: (c[0] > 0.5) & (c[1] > 0.5) & (c[2] > 0.6) & (c[2] < 0.8)).polyhedra(
        lambda c: np.where(c[2] < 0.4, 1, np.where(c[2] < 0.6, 2, 3)))


def face_sides(polyhedra, faces) -> set[tuple[int, int]]:
    """The sides of the polyhedron mesh's ``faces`` as sorted point pairs."""
    return {tuple(sorted((int(f[i]), int(f[(i + 1) % len(f)])))) for f in map(polyhedra.face, faces) for i in range(len(f))}


def solid_boundary_sides(polyhedra) -> set[tuple[int, int]]:
    """The sides of the faces between a solid polyhedron and the medium or the outside."""
    solid = np.append(polyhedra.tags != 2, False)          # [-1]: no cell
    return face_sides(polyhedra, np.flatnonzero(solid[polyhedra.face_cells].sum(axis=1) == 1))


def test_outlines_of_polyhedra_on_the_fan():
    """On the fan tetrahedra of an octree with hanging vertices: the outline edges drawn on the
    solids' surface are the sides of the polyhedra's faces on the solids' boundary, those of the
    medium's cells the sides of the medium polyhedra's faces, none ends at a face or cell centre;
    the cut of the solids by a plane y = c across the octree's boxes is their rectangles' sides, of
    length (Σ perimeters + the perimeter of the two blocks' sections) / 2."""
    from dolfinx_sfvem.mesh.cell_mesh import CellMesh, CellOutlines
    from dolfinx_sfvem.output.pictures3d import _cut_outlines, _grid, cells_outlines, surface_outlines
    from dolfinx_sfvem.discretizations.polyhedral_space import fan_mesh
    polyhedra = octree_sandwich()
    fan = fan_mesh(polyhedra)
    mesh = CellMesh(fan.nodes, fan.tetrahedra, polyhedra.tags[fan.tetrahedron_cell], "tetrahedron")
    outlines = CellOutlines(polyhedra.edges(), fan.tetrahedron_cell)
    n = mesh.points.shape[0]
    solid = mesh.tags != 2
    solids = _grid(mesh, mesh.points, mesh.cells[solid])
    solids.point_data["point"] = np.arange(n)
    solids.cell_data["cell"] = outlines.cell[solid]
    drawn = surface_outlines(solids, outlines, n)
    assert drawn.max() < polyhedra.n_points                       # no face or cell centre
    assert {tuple(e) for e in drawn.tolist()} == solid_boundary_sides(polyhedra)
    assert len(drawn) == len(solid_boundary_sides(polyhedra))     # each once
    medium = cells_outlines(mesh, mesh.cells[~solid], outlines)
    in_medium = polyhedra.cell_faces[polyhedra.tags[segment_owner(polyhedra.cell_offsets)] == 2]
    assert {tuple(e) for e in medium.tolist()} == face_sides(polyhedra, in_medium)
    # across the refined boxes (y in [0.5, 0.75]), and along faces: the kept side's (the refined ones)
    for c, direction in ((0.6, 1.0), (0.5, 1.0), (0.5, -1.0)):
        plane = np.array([0.0, direction, 0.0]), np.array([0.0, c, 0.0])
        cut = _cut_outlines(solids, *plane)
        ends = np.asarray(cut.points)[cut.lines.reshape(-1, 3)[:, 1:]]
        np.testing.assert_allclose(ends[..., 1], c, atol=1e-15)
        y = np.array([[polyhedra.polyhedron(k)[0][:, 1].min(), polyhedra.polyhedron(k)[0][:, 1].max()]
                      for k in range(polyhedra.n_cells)])
        kept = (y[:, 0] < c) & (c < y[:, 1]) | np.isclose(y[:, 1 if direction > 0 else 0], c)
        perimeters = sum(2 * np.ptp(polyhedra.polyhedron(k)[0][:, [0, 2]], axis=0).sum()
                         for k in np.flatnonzero(kept & (polyhedra.tags != 2)))
        blocks = 2 * (1.0 + 0.4) * 2                               # two 1 x 0.4 sections
        assert np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1).sum() == pytest.approx((perimeters + blocks) / 2,
                                                                                      rel=1e-12), (c, direction)


def test_pictures_of_an_sfvem_run(tmp_path, monkeypatch):
    """A run of the SFVEM on the octree sandwich (the top's quarter pressed into the medium) writes
    the pictures with the polyhedra's outlines: all of PolyhedronMesh.edges and every fan
    tetrahedron's polyhedron (its centroid inside the polyhedron's box); the deformed view draws the
    sides of the faces on the solids' boundary; the PNGs are not blank."""
    import dolfinx_sfvem as sf
    from dolfinx_sfvem.output import pictures3d
    calls, drawn = [], []
    write, outlines_on = pictures3d.write_pictures_3d, pictures3d.surface_outlines
    monkeypatch.setattr(pictures3d, "write_pictures_3d", lambda *a, **k: calls.append(k) or write(*a, **k))
    monkeypatch.setattr(pictures3d, "surface_outlines", lambda *a: drawn.append(outlines_on(*a)) or drawn[-1])
    polyhedra = octree_sandwich()
    solid = sf.Hyperelastic(K=5 / 3, mu=5 / 14)
    medium = sf.ThirdMedium(mu=5 / 14, K=5 / 3, gamma=0.05, alpha_r=1e-3, regularization="huhu")
    problem = sf.ContactProblem(polyhedra, {1: solid, 2: medium, 3: solid}, comm=MPI.COMM_SELF, verbose=False)
    problem.fix(lambda x: np.isclose(x[0], 0.0), components="x", name="x0")
    problem.fix(lambda x: np.isclose(x[1], 0.0), components="y", name="y0")
    problem.fix(lambda x: np.isclose(x[2], 0.0), components="z", name="bottom")
    problem.prescribe(lambda x: np.isclose(x[2], 1.0) & (x[0] <= 0.5 + 1e-12) & (x[1] <= 0.5 + 1e-12), uz=-0.1,
                      name="press")
    assert problem.solve(steps=1, out=tmp_path).converged
    (outlines,) = [k["outlines"] for k in calls]
    np.testing.assert_array_equal(outlines.edges, polyhedra.edges())
    centre = problem.disc.output_mesh.points[problem.disc.output_mesh.cells].mean(axis=1)
    box = np.array([[p.min(axis=0), p.max(axis=0)] for p, _ in map(polyhedra.polyhedron, range(polyhedra.n_cells))])
    assert np.all((box[outlines.cell, 0] < centre) & (centre < box[outlines.cell, 1]))
    assert {tuple(e) for e in drawn[0].tolist()} == solid_boundary_sides(polyhedra)
    for name in ("final-deformed.png", "final-clip.png", "final-pressure.png"):
        assert plt.imread(tmp_path / name)[..., :3].std() > 0.05, f"{name} is blank"
