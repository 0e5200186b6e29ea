"""Reliability: bad input is rejected by name, failed and interrupted runs lose nothing.

The random malformed-mesh fuzz test lives in ``test_polygon_mesh_fuzz.py``.
"""
import json
import os
import pathlib
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import dolfinx_sfvem as sf
from dolfinx_sfvem.output.run_summary import RunSummary
from dolfinx_sfvem.mpi_launcher import job_environment

ROOT = pathlib.Path(__file__).resolve().parents[1]
SOLID, MEDIUM = 1, 2
K, MU = 5 / 3, 5 / 14


def strip_mesh() -> sf.PolygonMesh:
    """A 6 x 3 strip of unit-ish squares, medium in the middle of the central row."""
    nx, ny = 6, 3
    pts = np.array([[2 * i / nx, j / ny] for j in range(ny + 1) for i in range(nx + 1)])
    polys = [[j * (nx + 1) + i, j * (nx + 1) + i + 1, (j + 1) * (nx + 1) + i + 1, (j + 1) * (nx + 1) + i]
             for j in range(ny) for i in range(nx)]
    tags = [MEDIUM if (j == 1 and 0 < i < nx - 1) else SOLID for j in range(ny) for i in range(nx)]
    return sf.PolygonMesh(pts, polys, tags)


def materials(**medium):
    return {SOLID: sf.Hyperelastic(K=K, mu=MU),
            MEDIUM: sf.ThirdMedium(**{"mu": MU, "gamma": 1e-3, "alpha_r": 1.0, **medium})}


def strip_problem(**options) -> sf.ContactProblem:
    p = sf.ContactProblem(strip_mesh(), materials(), verbose=False, **options)
    p.fix(lambda x: np.isclose(x[0], 0.0))
    p.prescribe(lambda x: np.isclose(x[0], 2.0), uy=-0.5)
    return p


# --------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("materials_, culprit", [
    ({SOLID: sf.Hyperelastic(K=K, mu=MU)}, "2"),                                       # medium tag missing
    ({**materials(), 7: sf.Hyperelastic(K=K, mu=MU)}, "7"),                            # unknown tag
    ({SOLID: sf.Hyperelastic(K=K, mu=MU), MEDIUM: "rubber"}, "2"),                     # not an energy
])
def test_material_map_errors_name_the_tag(materials_, culprit):
    with pytest.raises(ValueError, match=culprit):
        sf.ContactProblem(strip_mesh(), materials_, verbose=False)


@pytest.mark.parametrize("make, culprit", [
    (lambda: sf.Hyperelastic(K=0.0, mu=MU), "K"),
    (lambda: sf.Hyperelastic(K=K, mu=-1.0), "mu"),
    (lambda: sf.ThirdMedium(mu=MU, gamma=0.0, alpha_r=1.0), "gamma"),
    (lambda: sf.ThirdMedium(mu=MU, gamma=1e-5, alpha_r=-1.0), "alpha_r"),
    (lambda: sf.ThirdMedium(mu=MU, gamma=1e-5, alpha_r=1.0, beta=-5.0), "beta"),
    (lambda: sf.ThirdMedium(mu=MU, gamma=1e-5, alpha_r=1.0, regularization="rotaton"), "rotation"),
    (lambda: sf.ThirdMedium(mu=MU, gamma=float("nan"), alpha_r=1.0), "gamma"),
])
def test_parameter_errors_name_the_parameter(make, culprit):
    with pytest.raises(ValueError, match=culprit):
        make()


def test_boundary_condition_selecting_nothing_is_named():
    p = sf.ContactProblem(strip_mesh(), materials(), verbose=False)
    p.fix(lambda x: np.isclose(x[0], 0.0))
    p.prescribe(lambda x: np.isclose(x[0], 5.0), uy=-0.5, name="nowhere")
    with pytest.raises(ValueError, match="nowhere"):
        p.solve(steps=2)


@pytest.mark.parametrize("steps", [0, -3, 2.5])
def test_empty_load_path_is_rejected(steps):
    with pytest.raises(ValueError, match="steps"):
        strip_problem().solve(steps=steps)


def test_non_finite_load_is_rejected():
    p = sf.ContactProblem(strip_mesh(), materials(), verbose=False)
    with pytest.raises(ValueError, match="finite"):
        p.prescribe(lambda x: np.isclose(x[0], 2.0), uy=float("inf"), name="load")


def test_inverted_initial_configuration_names_the_cell():
    p = strip_problem()
    # fold the rightmost column over itself: J < 0 there
    p.set_displacement(ux=lambda x: np.where(x[0] > 1.5, -3.0 * (x[0] - 1.5), 0.0))
    with pytest.raises(ValueError, match=r"inverted .* cell \d+ of region \d"):
        p.solve(steps=2)


def test_gmsh_file_without_physical_groups(tmp_path):
    import gmsh
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("square")
        gmsh.model.occ.addRectangle(0, 0, 0, 1, 1)
        gmsh.model.occ.synchronize()
        gmsh.model.mesh.generate(2)
        gmsh.write(str(tmp_path / "square.msh"))
    finally:
        gmsh.finalize()
    with pytest.raises(ValueError, match="medium"):
        sf.meshes.from_gmsh(tmp_path / "square.msh", {"solid": SOLID, "medium": MEDIUM})


# --------------------------------------------------------------------------- failures
def test_failed_step_reports_step_load_residuals_and_smallest_J(tmp_path):
    p = strip_problem()
    result = p.solve(steps=2, out=tmp_path, petsc_options={"snes_max_it": 1}, min_increment=0.25)
    assert not result.converged
    msg = result.message
    assert msg.startswith("step 1:")
    assert "load factor" in msg and "last residuals" in msg and "min J" in msg
    assert "cell" in msg and "region" in msg
    assert "DIVERGED_MAX_IT" in msg and "x atol" in msg and "x round-off" in msg   # where Newton stalled
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["converged"] is False and summary["message"] == msg
    assert all(not s["converged"] for s in summary["steps"]) and len(summary["steps"]) >= 2


# --------------------------------------------------------------------------- resume
def test_resume_equals_uninterrupted_run(tmp_path):
    full = strip_problem()
    full.solve(out=tmp_path / "full", control=fixed(6))
    count = {"n": 0}

    def stop_after_three(problem):
        count["n"] += 1
        if count["n"] == 3:
            os.kill(os.getpid(), signal.SIGINT)
        return 0.0

    stopped = strip_problem()
    partial = stopped.solve(out=tmp_path / "part", observers={"stop": stop_after_three}, control=fixed(6))
    assert not partial.converged and "signal" in partial.message and partial.load == pytest.approx(0.5)
    kept = json.loads((tmp_path / "part" / "summary.json").read_text())["steps"]
    assert [s["step"] for s in kept if s["converged"]] == [1, 2, 3]

    resumed = strip_problem()
    result = resumed.solve(out=tmp_path / "part", resume=True, control=fixed(6))
    assert result.converged and [s["step"] for s in result.steps] == list(range(1, 7))
    u_full, u_resumed = full.point_displacements(), resumed.point_displacements()
    assert np.max(np.abs(u_full - u_resumed)) <= 1e-10 * np.max(np.abs(u_full))
    # max |u| over all nodes bounds the vertices' (midpoint/interior nodes may move a little more)
    largest_vertex = np.max(np.linalg.norm(u_full, axis=1))
    assert largest_vertex <= result.steps[-1]["max_displacement"] <= 1.05 * largest_vertex
    assert not list((tmp_path / "part").glob(".*tmp*"))       # nothing half-written left behind
    assert xdmf_times(tmp_path / "part" / "displacement.xdmf") == pytest.approx([k / 6 for k in range(1, 7)])


def xdmf_times(path) -> list[float]:
    """Time values of the displacement series (field ``u``) in an XDMF file."""
    import xml.etree.ElementTree as ET
    return [float(grid.find("Time").get("Value")) for grid in ET.parse(path).getroot().iter("Grid")
            if grid.find("Time") is not None and grid.find("Attribute").get("Name") == "u"]


def test_resume_after_a_kill_sets_a_broken_hdf5_aside(tmp_path):
    """A run killed while its HDF5 file was open leaves it without a superblock; resuming keeps
    it as *.broken and starts a new series instead of failing. The summary a kill leaves (the
    one written after the last converged step) holds the wall time so far, which the resumed
    run adds to its own."""
    count = {"n": 0}
    running = {}

    def stop_after_two(problem):
        count["n"] += 1
        if count["n"] == 2:
            running.update(json.loads((tmp_path / "summary.json").read_text()))
            os.kill(os.getpid(), signal.SIGINT)
        return 0.0

    strip_problem().solve(out=tmp_path, observers={"stop": stop_after_two}, control=fixed(4))
    assert running["message"] == "running" and 0.0 < running["wall_time_s"] < float("inf")
    stopped = json.loads((tmp_path / "summary.json").read_text())
    assert RunSummary.from_dict(running).interrupted and RunSummary.from_dict(stopped).interrupted
    assert not RunSummary.from_dict({**stopped, "message": "step 3: load step failed"}).interrupted
    killed = {**json.loads((tmp_path / "summary.json").read_text()), "message": "running"}
    (tmp_path / "summary.json").write_text(json.dumps(killed))   # as a SIGKILL after step 2 leaves it
    h5 = tmp_path / "displacement.h5"
    assert xdmf_times(tmp_path / "displacement.xdmf") == pytest.approx([0.25, 0.5])
    h5.write_bytes(bytes(4096))                                   # what a SIGKILL can leave
    result = strip_problem().solve(out=tmp_path, resume=True, control=fixed(4))
    assert result.converged and result.wall_time_s > killed["wall_time_s"] > running["wall_time_s"]
    assert (tmp_path / "displacement.h5.broken").exists() and (tmp_path / "displacement.xdmf.broken").exists()
    assert xdmf_times(tmp_path / "displacement.xdmf") == pytest.approx([0.75, 1.0])


def test_resume_with_other_steps_is_refused(tmp_path):
    strip_problem().solve(steps=2, out=tmp_path)
    with pytest.raises(ValueError, match="steps"):
        strip_problem().solve(steps=3, out=tmp_path, resume=True)


def fixed(steps: int) -> sf.LoadStepping:
    """Increments of 1/steps (no adaptivity, no predictor): the resume tests know where each step lands."""
    return sf.LoadStepping(steps, adaptive=False, predictor=False)


def _demo(args, **kw):
    return subprocess.Popen([sys.executable, str(ROOT / "demos" / "cbox.py"), *args], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=job_environment(), **kw)


def test_sigterm_keeps_converged_steps_and_resume_finishes(tmp_path):
    common = ["--h", "0.1", "--uy", "-0.3", "--steps", "30", "--fixed-increments", "--quiet"]
    run = _demo([*common, "--out", str(tmp_path / "run")])
    summary = tmp_path / "run" / "summary.json"
    deadline = time.time() + 120
    while time.time() < deadline:
        if summary.exists() and len(json.loads(summary.read_text())["steps"]) >= 2:
            break
        time.sleep(0.2)
    run.send_signal(signal.SIGTERM)
    out, err = run.communicate(timeout=120)
    assert run.returncode == 1, err
    assert "Traceback" not in err
    stopped = json.loads(summary.read_text())
    assert "signal" in stopped["message"] and not stopped["converged"]
    n_kept = sum(s["converged"] for s in stopped["steps"])
    assert 2 <= n_kept < 30
    assert (tmp_path / "run" / "checkpoint.npz").exists()

    resumed = _demo([*common, "--resume", str(tmp_path / "run")])
    _, err = resumed.communicate(timeout=300)
    assert resumed.returncode == 0, err
    final = json.loads(summary.read_text())
    assert final["converged"] and [s["step"] for s in final["steps"]] == list(range(1, 31))
    assert final["steps"][-1]["extra"]["tip_uy"] == pytest.approx(-0.3, abs=1e-9)


def test_a_second_sigterm_ends_the_run_at_once_with_one_line(tmp_path):
    """SIGTERM twice, as a batch scheduler sends it before it kills: the run ends within the step
    under way or its outputs, with one line on stderr, exit code 143 (128 + SIGTERM) and the
    converged steps kept."""
    run = _demo(["--h", "0.1", "--uy", "-0.3", "--steps", "30", "--fixed-increments", "--quiet",
                 "--out", str(tmp_path / "run")])
    summary = tmp_path / "run" / "summary.json"
    deadline = time.time() + 120
    while time.time() < deadline and not (summary.exists() and len(json.loads(summary.read_text())["steps"]) >= 2):
        time.sleep(0.2)
    run.send_signal(signal.SIGTERM)
    time.sleep(0.2)
    run.send_signal(signal.SIGTERM)
    _, err = run.communicate(timeout=120)
    assert run.returncode == 128 + signal.SIGTERM, err
    assert "Traceback" not in err and err.strip().splitlines()[-1] == "interrupted by signal 15 (SIGTERM)"
    stopped = json.loads(summary.read_text())
    assert stopped["message"].startswith("stopped by signal 15") and not stopped["converged"]
    assert 2 <= sum(s["converged"] for s in stopped["steps"]) < 30
