"""The punch (§5.3) and multiple-object (§5.4) demos: a reduced run of each in a subprocess
(coarse mesh, a few steps, a small load), checked through exit code and the files written;
the other material / boundary-condition variant of each is parsed and built in-process."""
from __future__ import annotations

import csv
import importlib
import json
import pathlib
import subprocess
import sys

import numpy as np
import pytest

from dolfinx_sfvem.output.run_summary import RunSummary, Step, read_summary
from dolfinx_sfvem.mpi_launcher import job_environment
from process_report import report

DEMOS = pathlib.Path(__file__).resolve().parents[1] / "demos"
OUTPUTS = ("summary.json", "load_path.csv", "displacement.xdmf", "displacement.h5",
           "deformed.png", "uy.png", "reaction.png")


def run_demo(name: str, *args: str, out: pathlib.Path) -> subprocess.CompletedProcess:
    """Run ``demos/<name>.py`` serially with the given arguments and ``--out out``."""
    cmd = [sys.executable, str(DEMOS / f"{name}.py"), *args, "--out", str(out)]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=job_environment())


def check_run(proc: subprocess.CompletedProcess, out: pathlib.Path, n_steps: int, reactions: set[str],
              extra: tuple[str, ...]) -> tuple[RunSummary, list[Step], list[dict]]:
    """Common checks of a completed reduced run; returns summary, converged steps, CSV rows."""
    assert proc.returncode == 0, report(proc)
    assert "Traceback" not in proc.stderr
    assert "converged: yes" in proc.stdout.splitlines()[-1]
    content = json.loads((out / "summary.json").read_text())
    for key in ("method", "dofs", "wall_time_s", "parameters", "steps", "converged", "message"):
        assert key in content, key
    summary = read_summary(out)
    assert summary.converged and summary.dofs > 0 and summary.message == ""
    steps = summary.converged_steps
    assert len(steps) == n_steps
    assert steps[-1].load == pytest.approx(1.0)
    for step in steps:
        assert set(step.reaction) == reactions
        assert set(extra) <= set(step.extra)
        assert len(step.residual_norms) == step.newton_iterations + 1
    with open(out / "load_path.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == n_steps
    for name in OUTPUTS:
        assert (out / name).stat().st_size > 0, name
    return summary, steps, rows


def test_punch_soft_reduced(tmp_path):
    uy = -0.3
    proc = run_demo("punch", "--h", "0.25", "--steps", "3", "--uy", str(uy), "--quiet", out=tmp_path)
    summary, steps, rows = check_run(proc, tmp_path, 3, {"fixed", "symmetry", "load"},
                                     ("punch_uy", "tip_uy", "block_uy", "gap"))
    params = summary.parameters
    assert {"punch": "soft", "uy": uy, "h": 0.25, "gamma": 1e-4, "alpha_r": 1.0,
            "regularization": "rotation", "steps": 3}.items() <= params.items()
    assert params["materials"]["3"]["K"] == pytest.approx(5 / 3)
    # the recorded punch-top displacement is the prescribed one, step by step
    assert [s.extra["punch_uy"] for s in steps] == pytest.approx([uy * s.load for s in steps], abs=1e-10)
    assert float(rows[-1]["punch_uy"]) == pytest.approx(uy, abs=1e-10)
    # before contact the punch moves almost rigidly and the gap closes by |u_y|
    assert steps[-1].extra["gap"] == pytest.approx(1.0 + uy, abs=1e-3)
    assert steps[-1].reaction["load"][1] < 0


def test_multi_object_bc2_reduced(tmp_path):
    uy = -0.05
    proc = run_demo("multi_object", "--bc", "2", "--h", "0.1", "--steps", "2", "--uy", str(uy), "--quiet",
                    out=tmp_path)
    extra = tuple(f"{q}{i}_{c}" for i in (1, 4, 7) for q, c in (("disc", "ux"), ("disc", "uy"), ("tip", "uy")))
    summary, steps, rows = check_run(proc, tmp_path, 2, {"left", "right", "discs"}, extra)
    assert (tmp_path / "zoom.png").stat().st_size > 0
    params = summary.parameters
    assert {"bc": 2, "uy": uy, "h": 0.1, "gamma": 1e-4, "alpha_r": 10.0, "regularization": "rotation",
            "snes_atol": "1e-8"}.items() <= params.items()
    assert set(params["boundary_conditions"]["discs"]["values"]) == {"1"}          # u_x free
    assert set(params["boundary_conditions"]["right"]["values"]) == {"1"}          # roller
    for i in (1, 4, 7):
        assert [s.extra[f"disc{i}_uy"] for s in steps] == pytest.approx([uy * s.load for s in steps], abs=1e-10)
        assert float(rows[-1][f"disc{i}_uy"]) == pytest.approx(uy, abs=1e-10)
        assert steps[-1].extra[f"tip{i}_uy"] == pytest.approx(uy, abs=1e-4)        # hard discs
    assert steps[-1].reaction["discs"][0] == 0.0                                  # no x constraint


@pytest.mark.parametrize("name, args, message", [
    ("punch", ["--punch", "steel"], "argument --punch: invalid choice"),
    ("punch", ["--h", "0.5"], "argument --h: must be a number in (0, 0.25]"),
    ("punch", ["--min-increment", "0"], "argument --min-increment: must be a number > 0"),
    ("multi_object", ["--bc", "3"], "argument --bc: invalid choice"),
    ("multi_object", ["--h", "0.2"], "argument --h: must be a number in (0, 0.1]"),
])
def test_bad_input(tmp_path, name, args, message):
    proc = run_demo(name, *args, out=tmp_path)
    assert proc.returncode == 2
    assert message in proc.stderr and "Traceback" not in proc.stderr
    assert not (tmp_path / "summary.json").exists()


def test_punch_rigid_builds():
    punch = importlib.import_module("punch")
    args = punch.common.parse_args(punch.make_parser(), ["--punch", "rigid", "--h", "0.25", "--quiet",
                                                          "--min-increment", "1e-4"])
    problem, observers = punch.build(args)
    assert problem.materials[3].params["K"] == pytest.approx(500 / 3)
    assert problem.materials[3].params["mu"] == pytest.approx(500 / 14)
    assert problem.materials[1].params["K"] == pytest.approx(5 / 3)
    assert {bc.name: sorted(bc.values) for bc in problem.bcs} == {"fixed": [0, 1], "symmetry": [0], "load": [1]}
    assert problem.bcs[-1].values[1] == pytest.approx(-1.3) and args.steps == 130
    assert set(observers) == {"punch_uy", "tip_uy", "block_uy", "gap"}
    assert args.min_increment == pytest.approx(1e-4)       # handed to solve() by common.run
    # the load acts on the punch top only: every selected node lies on y = 3, x <= 1
    dofs = problem.disc.locate_dofs(problem.bcs[-1].marker, problem.bcs[-1].tags, 1)
    xy = problem.disc.space.x_nodes[dofs // 2]
    assert dofs.size > 0 and np.allclose(xy[:, 1], 3.0) and np.all(xy[:, 0] <= 1.0 + 1e-12)


def test_multi_object_bc1_builds():
    multi = importlib.import_module("multi_object")
    args = multi.common.parse_args(multi.make_parser(), ["--bc", "1", "--h", "0.1", "--quiet"])
    problem, observers = multi.build(args)
    assert problem.materials[1].params["K"] == 50.0 and problem.materials[3].params["K"] == 50000.0
    assert {bc.name: sorted(bc.values) for bc in problem.bcs} == {"left": [0, 1], "right": [0, 1],
                                                                  "discs": [0, 1]}
    discs = problem.bcs[-1]
    assert discs.values == {0: 0.0, 1: pytest.approx(-0.3)}
    # all seven flat tops (y = 0.5), disc nodes only
    dofs = problem.disc.locate_dofs(discs.marker, discs.tags, 1)
    xy = problem.disc.space.x_nodes[dofs // 2]
    assert np.allclose(xy[:, 1], 0.5)
    assert sorted({int(round(x)) for x in xy[:, 0]}) == list(range(1, 8))
    assert np.all(np.min(np.abs(xy[:, 0, None] - np.arange(1, 8)), axis=1) <= 0.2 + 1e-12)
    assert len(observers) == 9
