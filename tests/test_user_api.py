"""What a new user meets setting up a contact problem of their own: materials by region name,
conflicting conditions, components by letter, a second solve, observers with several values,
converged steps apart from attempts, gmsh sessions of their own, bad output paths."""
import logging
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import dolfinx_sfvem as sf
from dolfinx_sfvem.mpi_launcher import job_environment

ROOT = pathlib.Path(__file__).resolve().parents[1]
SOLID, MEDIUM = 1, 2
K, MU = 5 / 3, 5 / 14


def strip_mesh() -> sf.PolygonMesh:
    """A 4 x 2 strip of squares, all solid."""
    return sf.meshes.quad_rectangle(2.0, 1.0, 4, 2, tag=SOLID)


def strip(**options) -> sf.ContactProblem:
    p = sf.ContactProblem(strip_mesh(), {SOLID: sf.Hyperelastic(K=K, mu=MU)}, verbose=False, **options)
    p.fix(lambda x: np.isclose(x[0], 0.0))
    p.prescribe(lambda x: np.isclose(x[0], 2.0), uy=-0.1)
    return p


def test_materials_by_region_name():
    box = sf.meshes.cbox(h_solid=0.1)
    by_name = sf.ContactProblem(box.mesh, {"solid": sf.Hyperelastic(K=K, mu=MU),
                                           "medium": sf.ThirdMedium(mu=MU, gamma=1e-5, alpha_r=1.0)}, verbose=False)
    assert set(by_name.materials) == {SOLID, MEDIUM} and by_name.materials[MEDIUM].is_medium
    with pytest.raises(ValueError, match=r"'rubber' is not a region name.*'solid' = 1, 'medium' = 2"):
        sf.ContactProblem(box.mesh, {"rubber": sf.Hyperelastic(K=K, mu=MU), MEDIUM: sf.Hyperelastic(K=K, mu=MU)},
                          verbose=False)
    with pytest.raises(ValueError, match="two materials given for region 1"):
        sf.ContactProblem(box.mesh, {"solid": sf.Hyperelastic(K=K, mu=MU), SOLID: sf.Hyperelastic(K=K, mu=MU)},
                          verbose=False)


def test_conflicting_conditions_are_rejected_equal_ones_allowed():
    p = sf.ContactProblem(strip_mesh(), {SOLID: sf.Hyperelastic(K=K, mu=MU)}, verbose=False)
    p.fix(lambda x: np.isclose(x[0], 0.0))
    right = lambda x: np.isclose(x[0], 2.0)                                      # noqa: E731
    p.prescribe(right, uy=-0.03, name="load")
    p.prescribe(right, uy=+0.03, name="load2")
    with pytest.raises(ValueError, match=r"'load' and 'load2' prescribe different u_y \(-0.03 and 0.03\) at the node"):
        p.solve(steps=1)
    q = strip()
    q.fix(lambda x: np.isclose(x[0], 0.0) & np.isclose(x[1], 0.0), components=("y",), name="corner")   # shared, equal
    assert q.solve(steps=1).converged


@pytest.mark.parametrize("components, expected", [(("x",), {0}), (("y",), {1}), ((0, "y"), {0, 1})])
def test_components_by_letter(components, expected):
    p = sf.ContactProblem(strip_mesh(), {SOLID: sf.Hyperelastic(K=K, mu=MU)}, verbose=False)
    assert set(p.fix(lambda x: np.isclose(x[0], 0.0), components=components).values) == expected


@pytest.mark.parametrize("bad", ["z", 2, True, 0.5])
def test_bad_component_says_what_is_accepted(bad):
    p = sf.ContactProblem(strip_mesh(), {SOLID: sf.Hyperelastic(K=K, mu=MU)}, verbose=False)
    with pytest.raises(ValueError, match="use 0 or 'x', 1 or 'y'"):
        p.fix(lambda x: np.isclose(x[0], 0.0), components=(bad,))


def test_second_solve_is_an_explicit_choice():
    p = strip()
    first = p.solve(steps=2).steps[-1]["reaction"]["load"]
    with pytest.raises(ValueError, match="solved already"):
        p.solve(steps=2)
    again = p.solve(steps=2, from_current_state=True)
    assert again.converged and again.steps[-1]["reaction"]["load"] == pytest.approx(first, rel=1e-8)
    p.reset()
    with p.x.localForm() as xl:
        assert not xl.array.any()
    assert p.solve(steps=2).steps[-1]["reaction"]["load"] == pytest.approx(first, rel=1e-8)


def test_converged_steps_apart_from_attempts():
    p = strip()
    result = p.solve(steps=1, petsc_options={"snes_max_it": 1}, min_increment=0.25)
    assert not result.converged and result.steps == [] and result.attempts
    assert all(not a["converged"] and a["failure"] for a in result.attempts)
    done = strip().solve(steps=2)
    assert [s["step"] for s in done.steps] == [1, 2] and all(s["reaction"]["load"] for s in done.steps)


def test_observer_with_several_values(tmp_path):
    calls = []

    def tip(problem):
        calls.append(1)
        return {"ux": 0.5, "uy": -0.25}
    result = strip().solve(steps=2, out=tmp_path, observers={"tip": tip, "one": lambda p: 3.0})
    assert len(calls) == 2                                           # once per step
    assert result.steps[-1]["extra"] == {"tip.ux": 0.5, "tip.uy": -0.25, "one": 3.0}
    header = (tmp_path / "load_path.csv").read_text().splitlines()[0]
    assert "tip.ux" in header and "tip.uy" in header


def test_progress_line_stays_short():
    """Read from the package logger with a handler of our own: pytest >= 9 attaches its capture
    handlers to non-propagating loggers, and then the library's console steps aside."""
    p = sf.ContactProblem(strip_mesh(), {SOLID: sf.Hyperelastic(K=K, mu=MU)})
    for k in range(4):
        p.prescribe(lambda x, k=k: np.isclose(x[0], 2.0) & np.isclose(x[1], k * 0.25), uy=-0.01, name=f"point{k}")
    p.fix(lambda x: np.isclose(x[0], 0.0))
    messages = []
    handler = logging.Handler()
    handler.emit = lambda record: messages.append(record.getMessage())
    logger = logging.getLogger("dolfinx_sfvem")
    logger.addHandler(handler)
    try:
        p.solve(steps=1, observers={f"o{k}": (lambda q: 1.0) for k in range(6)})
    finally:
        logger.removeHandler(handler)
    lines = [line for line in messages if line.startswith("step ")]
    assert lines and all(len(line) <= 140 for line in lines), lines


def test_from_gmsh_leaves_the_callers_session_open(tmp_path):
    import gmsh
    msh = tmp_path / "square.msh"
    with sf.meshes.gmsh_session() as g:               # a mesh file with two named regions
        g.model.occ.addRectangle(0, 0, 0, 1, 1)
        g.model.occ.addRectangle(1, 0, 0, 1, 1)
        g.model.occ.fragment([(2, 1)], [(2, 2)])
        g.model.occ.synchronize()
        g.model.setPhysicalName(2, g.model.addPhysicalGroup(2, [1], 5), "block")
        g.model.setPhysicalName(2, g.model.addPhysicalGroup(2, [2], 6), "layer")
        g.option.setNumber("Mesh.MeshSizeMax", 0.5)
        g.model.mesh.generate(2)
        g.write(str(msh))
    gmsh.initialize()
    try:
        gmsh.model.add("mine")
        gmsh.model.occ.addDisk(0, 0, 0, 1, 1)
        gmsh.model.occ.synchronize()
        mesh = sf.meshes.from_gmsh(msh)
        assert mesh.region_names == {"block": 5, "layer": 6} and set(np.unique(mesh.tags)) == {5, 6}
        assert gmsh.model.getCurrent() == "mine" and gmsh.model.getEntities(2) == [(2, 1)]
        gmsh.model.mesh.generate(2)                   # the caller's session still works
    finally:
        gmsh.finalize()


def test_out_that_is_a_file_is_bad_input(tmp_path):
    target = tmp_path / "taken"
    target.write_text("")
    proc = subprocess.run([sys.executable, str(ROOT / "demos" / "cbox.py"), "--h", "0.1", "--steps", "1", "--quiet",
                           "--out", str(target)], capture_output=True, text=True, cwd=ROOT, timeout=300,
                          env=job_environment())
    assert proc.returncode == 2 and "is not a directory" in proc.stderr and "Traceback" not in proc.stderr


@pytest.mark.mpi
@pytest.mark.parametrize("method", ["vem", "fem"])
def test_displacement_at_points_reproduces_a_quadratic_field(method):
    """A quadratic displacement set at the nodes is returned exactly anywhere (Π^∇_2 reproduces
    quadratics; so does P2), on a boundary through its vertices and edge midpoints; NaN outside."""
    box = sf.meshes.cbox(h_solid=0.1)
    p = sf.ContactProblem(box.mesh, {"solid": sf.Hyperelastic(K=K, mu=MU),
                                     "medium": sf.ThirdMedium(mu=MU, gamma=1e-5, alpha_r=1.0)},
                          method=method, verbose=False)

    def u(x):
        return 0.01 * np.array([x[0] ** 2 - x[0] * x[1], 0.5 * x[1] ** 2 + x[0]])
    p.set_displacement(ux=lambda x: u(x)[0], uy=lambda x: u(x)[1])
    interface = box.mesh.boundary_points(SOLID, MEDIUM)
    assert np.allclose(np.sort(interface[:, 1][np.isclose(interface[:, 0], 0.5)]), [0.1, 0.4])
    points = np.concatenate([interface, [[0.37, 0.21], [0.05, 0.3], [2.0, 2.0]]])
    values = p.displacement_at(points)
    assert np.allclose(values[:-1], u(points[:-1].T).T, rtol=0, atol=1e-12)
    assert np.isnan(values[-1]).all()
