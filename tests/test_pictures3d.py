"""The 3D pictures (dolfinx_sfvem/pictures3d.py): two blocks across a medium layer, the upper one
pressed down and bulged, rendered offscreen; the PNGs exist, have the window's size, show something
and the pressure picture is in colour."""
import numpy as np
import pytest

from dolfinx_sfvem.pictures3d import WINDOW_SIZE, offscreen_unavailable, write_pictures_3d
from dolfinx_sfvem.polygon_mesh import edge_key
from dolfinx_sfvem.solid_surface import SolidSurface

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
    from dolfinx_sfvem.pictures3d import _contact_view
    mesh, u = two_blocks(box_grid, cell)
    n = mesh.points.shape[0]
    surface = SolidSurface(mesh, (1, 3), lambda a, b: n + edge_key(a, b, n))
    z = surface.X[:, 2]
    pressure = np.where(np.isclose(z, 0.4), 1.0, 0.0) + np.where(np.isclose(z, 0.6), 1.1, 0.0)
    centre, normal = _contact_view(mesh, mesh.points + u, surface, pressure)
    assert normal == pytest.approx([0.0, 0.0, -1.0], abs=1e-12)   # the sides' normals left out at the rim
    assert centre[:2] == pytest.approx([0.5, 0.5], abs=1e-12) and centre[2] < 0.6 - 0.15 + 1e-12
