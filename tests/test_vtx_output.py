"""The VTX (ADIOS2) series of a run beside its XDMF pair (run_output.VTXSeries): written where
DOLFINx was built with ADIOS2 (the 0.11 wheel), skipped cleanly where it was not (Debian's 0.5.2).

The series is read back without ADIOS2's Python bindings, from its BP4 metadata: the index table
``md.idx`` has a 64-byte header and one 64-byte record per step, each opening with the step's
number (1, 2, ...), and ``md.0`` holds the ``vtk.xml`` attribute that names the fields."""
from __future__ import annotations

import pathlib
import re
import xml.etree.ElementTree as ET

import dolfinx_sfvem as sf  # first: with the dolfinx-solver wheel it loads MPI before the bindings
from dolfinx_sfvem import _compat, meshes
from dolfinx_sfvem.output.run_output import PRESSURE_FIELD

import numpy as np
import pytest
from mpi4py import MPI

from dolfinx_sfvem.mesh.cell_mesh import CellMesh

#: the layers of the stack: lower block, medium, upper block (z)
LAYERS = (0.0, 0.5, 0.6, 1.1)


def pressed_stack(box_grid, cell: str, n: int = 1, comm=MPI.COMM_WORLD, method: str = "fem") -> sf.ContactProblem:
    """Two blocks on [0, 1]² (n x n cells across) through a medium layer, the bottom held, the top
    pressed down by 0.02: a 3D run with a contact pressure."""
    grid = np.linspace(0.0, 1.0, n + 1)
    arrays = box_grid(grid, grid, LAYERS, lambda c: 1 + (c[2] > LAYERS[1]) + (c[2] > LAYERS[2]), cell)
    solid = sf.Hyperelastic(K=5 / 3, mu=5 / 14)
    materials = {1: solid, 2: sf.ThirdMedium(mu=5 / 14, gamma=0.05, alpha_r=1e-3, regularization="huhu"), 3: solid}
    problem = sf.ContactProblem(CellMesh(arrays.points, arrays.cells, arrays.tags, cell), materials, method=method,
                                comm=comm, verbose=False)
    problem.fix(lambda x: np.isclose(x[2], 0.0), name="bottom")
    problem.prescribe(lambda x: np.isclose(x[2], LAYERS[-1]), uz=-0.02, name="press")
    return problem


needs_vtx = pytest.mark.skipif(not _compat.has_vtx(), reason=f"DOLFINx {_compat.DOLFINX_VERSION} was built without "
                                                               "ADIOS2: no dolfinx.io.VTXWriter, no VTX series")


def bp_steps(path: pathlib.Path) -> list[int]:
    """The step numbers of the BP4 index table of the directory ``path``."""
    table = (path / "md.idx").read_bytes()
    assert table.startswith(b"ADIOS-BP") and (len(table) - 64) % 64 == 0
    return [int(np.frombuffer(table, dtype="<u8", count=1, offset=k)[0]) for k in range(64, len(table), 64)]


def bp_point_fields(path: pathlib.Path) -> list[str]:
    """The point fields that the series' ``vtk.xml`` attribute names (the time ``TIME`` and
    VTK's own ``vtk*`` arrays left out)."""
    text = (path / "md.0").read_bytes().decode("latin-1")
    xml = re.search(r"<VTKFile.*?</VTKFile>", text, re.S).group(0)
    names = [a.get("Name") for a in ET.fromstring(xml).iter("DataArray")
             if a.text is None and a.get("Name") not in ("geometry", "connectivity", "types")]
    return [n for n in names if not n.startswith("vtk")]


@needs_vtx
@pytest.mark.parametrize("cell, method", [("hexahedron", "fem"), ("tetrahedron", "fem"), ("hexahedron", "vem")])
def test_3d_run_writes_the_vtx_series(box_grid, cell, method, tmp_path):
    """Two converged steps of a 3D run (the SFVEM: on its fan mesh): displacement.bp holds steps 1
    and 2 with u and the contact pressure, as displacement.xdmf does."""
    problem = pressed_stack(box_grid, cell, method=method)
    tmp = problem.comm.bcast(tmp_path if problem.comm.rank == 0 else None)
    assert problem.solve(steps=2, out=tmp).converged
    bp = tmp / "displacement.bp"
    assert bp_steps(bp) == [1, 2]
    assert bp_point_fields(bp) == ["u", PRESSURE_FIELD]


def strip() -> sf.ContactProblem:
    """A clamped 2D strip (SFVEM, 8 x 2 quadrilaterals) bent down at its tip."""
    problem = sf.ContactProblem(meshes.quad_rectangle(2.0, 0.2, 8, 2, tag=meshes.SOLID),
                                {meshes.SOLID: sf.Hyperelastic(K=5 / 3, mu=5 / 14)}, verbose=False)
    problem.fix(lambda x: np.isclose(x[0], 0.0), name="clamped")
    problem.prescribe(lambda x: np.isclose(x[0], 2.0), uy=-0.5, name="tip")
    return problem


@needs_vtx
def test_2d_series_and_its_resumption(tmp_path):
    """A 2D run stopped after its second step writes two steps into displacement.bp; resumed, it
    cannot append there and writes the remaining steps into displacement_resumed1.bp."""
    def interrupting(problem):
        if problem.load > 0.25:
            raise KeyboardInterrupt
        return 0.0
    with pytest.raises(KeyboardInterrupt):
        strip().solve(4, out=tmp_path, observers={"w": interrupting}, handle_signals=False)
    assert bp_steps(tmp_path / "displacement.bp") == [1, 2]
    resumed = strip().solve(4, out=tmp_path, resume=True, observers={"w": lambda p: 0.0})
    assert resumed.converged and len(resumed.steps) == 4
    assert bp_steps(tmp_path / "displacement.bp") == [1, 2]
    assert bp_steps(tmp_path / "displacement_resumed1.bp") == [1, 2]
    assert bp_point_fields(tmp_path / "displacement_resumed1.bp") == ["u", PRESSURE_FIELD]


@pytest.mark.skipif(_compat.has_vtx(), reason="this DOLFINx has ADIOS2")
def test_without_adios2_the_run_writes_xdmf_alone(tmp_path):
    """Where DOLFINx has no ADIOS2 the run goes on without a VTX series."""
    assert strip().solve(2, out=tmp_path).converged
    assert (tmp_path / "displacement.xdmf").is_file() and not (tmp_path / "displacement.bp").exists()


@needs_vtx
@pytest.mark.mpi
def test_vtx_series_on_two_ranks(box_grid, tmp_path):
    """Written collectively: one series with one record per step."""
    problem = pressed_stack(box_grid, "hexahedron", n=2, comm=MPI.COMM_WORLD)
    tmp = MPI.COMM_WORLD.bcast(tmp_path if MPI.COMM_WORLD.rank == 0 else None)
    assert problem.solve(steps=2, out=tmp).converged
    MPI.COMM_WORLD.barrier()
    if MPI.COMM_WORLD.rank == 0:
        assert bp_steps(tmp / "displacement.bp") == [1, 2]
        assert bp_point_fields(tmp / "displacement.bp") == ["u", PRESSURE_FIELD]
