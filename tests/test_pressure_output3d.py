"""The contact pressure of a 3D run as a field of its output (run_output.PressureField, the
XDMF series) and in its pictures: two blocks pressed together through a thin medium layer by a
prescribed displacement (Q2 hexahedra, P2 tetrahedra; the Hu-Hu regularization, which compiles
in seconds).

With the sides on rollers every layer is in uniaxial strain F = diag(1, 1, λ): the exact solution
is piecewise linear (in the discrete space, with second gradient 0, so the regularization does
not act) and the normal stress is the same in every layer, found here from Eq. 2 with numpy. The
recovered pressure must equal it at every node of the two contact faces, and the reaction. With
free sides the pressure varies over the face; its integral over the face must still carry the
reaction to the discretization's tolerance."""
from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest
import scipy.optimize
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem.mesh.cell_mesh import CellMesh
from dolfinx_sfvem.output.run_output import PRESSURE_FIELD, PressureField

K, MU, GAMMA = 5 / 3, 5 / 14, 0.05
#: the layers: lower block [0, 0.5], medium [0.5, 0.6], upper block [0.6, 1.1] (z)
Z = (0.0, 0.5, 0.6, 1.1)
PRESS = 0.02                 # the upper face moves down by this
CELLS = ["hexahedron", "tetrahedron"]


def neo_hookean_Pzz(stretch: float, scale: float = 1.0) -> float:
    """P_zz of Eq. 2 (times ``scale``) in uniaxial strain F = diag(1, 1, stretch), with numpy."""
    F = np.diag([1.0, 1.0, stretch])
    J = np.linalg.det(F)
    Finv_T = np.linalg.inv(F).T
    return scale * (K * np.log(J) * Finv_T + MU * J ** (-2 / 3) * (F - np.trace(F.T @ F) / 3 * Finv_T))[2, 2]


def exact_stress() -> float:
    """The normal stress P_zz (< 0) of the stack in uniaxial strain: the same in the solids
    (stretch s) and the medium (stretch m, energy gamma x Eq. 2), the thicknesses adding up."""
    h_solid, h_medium = (Z[1] - Z[0]) + (Z[3] - Z[2]), Z[2] - Z[1]

    def medium_stretch(s):
        return 1.0 + (-PRESS - h_solid * (s - 1.0)) / h_medium
    s = scipy.optimize.brentq(lambda s: neo_hookean_Pzz(s) - neo_hookean_Pzz(medium_stretch(s), GAMMA),
                              1.0 - PRESS / h_solid, 1.0, xtol=1e-15)
    return neo_hookean_Pzz(s)


def sandwich(box_grid, cell, n=1, rollers=True, comm=MPI.COMM_WORLD, method="fem") -> sf.ContactProblem:
    """The stack on [0, 1]² (n x n cells across), bottom held in z, the top pressed down by PRESS;
    the sides on rollers, or else only the planes x = 0 and y = 0 (a quarter of a wider stack) and
    only the top's quarter x, y <= 1/2 pressed (a punch)."""
    grid = np.linspace(0.0, 1.0, n + 1)
    arrays = box_grid(grid, grid, Z, lambda c: 1 if c[2] < Z[1] else (2 if c[2] < Z[2] else 3), cell)
    mesh = CellMesh(arrays.points, arrays.cells, arrays.tags, cell)
    solid = sf.Hyperelastic(K=K, mu=MU)
    medium = sf.ThirdMedium(mu=MU, K=K, gamma=GAMMA, alpha_r=1e-3, regularization="huhu")
    problem = sf.ContactProblem(mesh, {1: solid, 2: medium, 3: solid}, method=method, comm=comm, verbose=False)
    for axis, name in ((0, "x"), (1, "y")):
        sides = (0.0, 1.0) if rollers else (0.0,)
        problem.fix(lambda x, a=axis, s=sides: np.isin(np.round(x[a], 12), s), components=name, name=f"{name}-rollers")
    problem.fix(lambda x: np.isclose(x[2], 0.0), components="z", name="bottom")
    punch = 1.0 if rollers else 0.5
    problem.prescribe(lambda x: np.isclose(x[2], Z[-1]) & (x[0] <= punch + 1e-12) & (x[1] <= punch + 1e-12),
                      uz=-PRESS, name="press")
    return problem


def contact_faces(pressure: sf.ContactPressure) -> np.ndarray:
    """The nodes on the two faces against the medium (reference z = 0.5 or 0.6), bool (n_nodes,)."""
    return np.isclose(pressure.X[:, 2], Z[1]) | np.isclose(pressure.X[:, 2], Z[2])


def xdmf_attribute(path, name: str) -> list[tuple[float, tuple[int, ...]]]:
    """(time, dimensions of the values) of every time step of the field ``name`` in an XDMF file."""
    out = []
    for grid in ET.parse(path).getroot().iter("Grid"):
        attribute = grid.find("Attribute")
        if grid.find("Time") is not None and attribute is not None and attribute.get("Name") == name:
            out.append((float(grid.find("Time").get("Value")),
                        tuple(int(k) for k in attribute.find("DataItem").get("Dimensions").split())))
    return out


def assert_nodal_forces_sum_to(pressure, pair) -> None:
    """The medium's nodal forces (``ContactPressure.force``) on the pair's nodes sum to its force,
    and vanish on the nodes that face no medium."""
    mine = (pressure.body == pair.body) & (pressure.partner_body == pair.partner_body)
    np.testing.assert_allclose(pressure.force[mine].sum(axis=0), pair.force, rtol=1e-12, atol=1e-12 * abs(pair.force[2]))
    assert np.all(pressure.force[pressure.partner_body < 0] == 0.0)


@pytest.mark.parametrize("cell", CELLS)
def test_uniaxial_strain_pressure_is_exact(box_grid, cell, tmp_path):
    """Rollers: the pressure at every node of both contact faces, the reaction and the pair's force
    are the exact stress; the pressure field of the output holds it at the faces' vertices and 0
    elsewhere, and the XDMF series has it at every converged step, one value per mesh point."""
    problem = sandwich(box_grid, cell)
    tmp = problem.comm.bcast(tmp_path if problem.comm.rank == 0 else None)
    result = problem.solve(steps=2, out=tmp)
    assert result.converged
    P = exact_stress()
    assert P < 0.0
    assert problem.reactions()["press"][2] == pytest.approx(P, rel=1e-8)
    pressure = problem.contact_pressure()
    on = contact_faces(pressure)
    assert on.sum() == 2 * 9                     # the Q2 (P2, two triangles) nodes of two unit squares
    np.testing.assert_allclose(pressure.pressure[on], -P, rtol=1e-8)
    assert problem.boundary.recovered.all()      # the FEM recovers at every node
    assert np.all(pressure.pressure[~on] == 0.0)
    for pair in pressure.pairs:
        assert pair.force[2] == pytest.approx(P if pair.region == 1 else -P, rel=1e-8)   # down on the lower block
        assert pair.zone_length == pytest.approx(1.0, rel=1e-12)     # the deformed area of the face
        assert_nodal_forces_sum_to(pressure, pair)
    # the field of the output: the exact pressure at the faces' vertices, 0 at the other vertices
    field = PressureField(problem.disc.dolfinx_mesh).set(pressure)
    z = field.function_space.tabulate_dof_coordinates()[:, 2]
    at_faces = np.isclose(z, Z[1]) | np.isclose(z, Z[2])
    np.testing.assert_allclose(field.x.array[at_faces], -P, rtol=1e-8)
    assert np.all(field.x.array[~at_faces] == 0.0)
    steps = xdmf_attribute(tmp / "displacement.xdmf", PRESSURE_FIELD)
    assert [t for t, _ in steps] == pytest.approx([0.5, 1.0])
    assert all(dims in ((16,), (16, 1)) for _, dims in steps)      # the 4 x 4 points of the grid
    assert [t for t, _ in xdmf_attribute(tmp / "displacement.xdmf", "u")] == pytest.approx([0.5, 1.0])


def test_sfvem_uniaxial_strain_pressure_is_exact(box_grid):
    """The SFVEM on the hexahedra as polyhedra: the medium's force on a face sits on its face-mean
    DOF (a homogeneous stress's flux), and the recovered pressure at every node of the fan
    triangles of both contact faces, the reaction and the pair's force are the exact stress."""
    problem = sandwich(box_grid, "hexahedron", method="vem")
    result = problem.solve(steps=2)
    assert result.converged
    P = exact_stress()
    assert problem.reactions()["press"][2] == pytest.approx(P, rel=1e-8)
    pressure = problem.contact_pressure()
    on = contact_faces(pressure)
    assert on.sum() == 2 * 13        # per face: 4 vertices, 4 edge midpoints, the centre, 4 spoke midpoints
    np.testing.assert_allclose(pressure.pressure[on], -P, rtol=1e-8)
    # recovered at the polyhedra's vertices (the fan mesh's first points), interpolated elsewhere
    n_vertices = problem.disc.space.polyhedron_mesh.points.shape[0]
    np.testing.assert_array_equal(problem.boundary.recovered, problem.boundary.node_keys < n_vertices)
    assert problem.boundary.recovered[on].sum() == 2 * 4
    for pair in pressure.pairs:
        assert pair.force[2] == pytest.approx(P if pair.region == 1 else -P, rel=1e-8)
        assert pair.zone_length == pytest.approx(1.0, rel=1e-12)
        assert_nodal_forces_sum_to(pressure, pair)
    gap = problem.contact_gap()
    h_solid = (Z[1] - Z[0]) + (Z[3] - Z[2])
    assert gap.value == pytest.approx(Z[2] - Z[1] - PRESS - h_solid * (exact_stress_stretch() - 1.0), rel=1e-8)


def exact_stress_stretch() -> float:
    """The solids' stretch s of :func:`exact_stress`'s state."""
    h_solid, h_medium = (Z[1] - Z[0]) + (Z[3] - Z[2]), Z[2] - Z[1]
    return scipy.optimize.brentq(
        lambda s: neo_hookean_Pzz(s) - neo_hookean_Pzz(1.0 + (-PRESS - h_solid * (s - 1.0)) / h_medium, GAMMA),
        1.0 - PRESS / h_solid, 1.0, xtol=1e-15)


def integrated_pressure(problem: sf.ContactProblem, pressure: sf.ContactPressure, region: int) -> np.ndarray:
    """∫ p n da over the deformed face of ``region`` against the medium: the pressure linear on the
    surface's flat sub-triangles between its degree-2 nodes, n their outward normal (3,)."""
    surface = problem.boundary
    tri = surface.triangles[np.isin(surface.triangle_face, np.flatnonzero(surface.face_faces_medium))]
    tri = tri[surface.node_tag[tri[:, 0]] == region]
    x = pressure.x[tri]
    area_vector = 0.5 * np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
    return (pressure.pressure[tri].mean(axis=1)[:, None] * area_vector).sum(axis=0)


@pytest.mark.parametrize("cell, method", [(cell, "fem") for cell in CELLS] + [("hexahedron", "vem")])
def test_integrated_pressure_carries_the_reaction(box_grid, cell, method):
    """Free sides and a punch on a quarter of the top: the pressure varies over the contact faces,
    and its integral over each of them carries the reaction."""
    problem = sandwich(box_grid, cell, n=2, rollers=False, method=method)
    assert problem.solve(steps=2).converged
    R = problem.reactions()["press"][2]
    pressure = problem.contact_pressure()
    on = contact_faces(pressure)
    assert pressure.pressure[on].min() < 0.5 * pressure.pressure[on].max()
    lower, upper = (integrated_pressure(problem, pressure, region) for region in (1, 3))
    # the face's outward normal is +z below the medium and -z above it; p pushes against it
    assert -lower[2] == pytest.approx(R, rel=0.02)
    assert upper[2] == pytest.approx(R, rel=0.02)


@pytest.mark.mpi
def test_output_on_two_ranks_equals_one(box_grid, tmp_path):
    """The field written collectively: on all ranks the same series and values as on one rank."""
    tmp = MPI.COMM_WORLD.bcast(tmp_path if MPI.COMM_WORLD.rank == 0 else None)
    for name, comm in (("world", MPI.COMM_WORLD), ("self", MPI.COMM_SELF)):
        if comm is MPI.COMM_SELF and MPI.COMM_WORLD.rank != 0:
            continue
        problem = sandwich(box_grid, "hexahedron", n=2, comm=comm)
        assert problem.solve(steps=1, out=tmp / name).converged
        pressure = problem.contact_pressure()
        np.testing.assert_allclose(pressure.pressure[contact_faces(pressure)], -exact_stress(), rtol=1e-8)
    MPI.COMM_WORLD.barrier()
    if MPI.COMM_WORLD.rank == 0:
        world, alone = (xdmf_attribute(tmp / name / "displacement.xdmf", PRESSURE_FIELD) for name in ("world", "self"))
        assert world == alone and len(world) == 1 and world[0][1][0] == 3 * 3 * 4


@pytest.mark.mpi
def test_pressure_picture_of_a_run(box_grid, tmp_path):
    """The pictures of the last state and of a load of ``pressure_at``: final-pressure.png and
    contact_pressure_0.5-pressure.png show the contact pressure (not blank, in colour)."""
    pictures3d = pytest.importorskip("dolfinx_sfvem.output.pictures3d")
    reason = pictures3d.offscreen_unavailable()
    if reason is not None:
        pytest.skip(f"no offscreen rendering: {reason}")
    plt = pytest.importorskip("matplotlib.pyplot")
    problem = sandwich(box_grid, "hexahedron", n=2, rollers=False)
    tmp = problem.comm.bcast(tmp_path if problem.comm.rank == 0 else None)
    assert problem.solve(steps=2, out=tmp, pressure_at=(0.5,)).converged
    if problem.comm.rank == 0:
        for name in ("final-pressure.png", "contact_pressure_0.5-pressure.png"):
            image = plt.imread(tmp / name)[..., :3]
            assert image.std() > 0.05, f"{name} is blank"
            assert ((image.max(axis=2) - image.min(axis=2)) > 0.3).mean() > 0.01, name    # the colour map's pixels
        assert (tmp / "contact_pressure_0.5-clip.png").is_file() and not (tmp / "contact_pressure_1-pressure.png").exists()
