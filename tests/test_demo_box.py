"""The box self-contact demo (paper §5.1) as a user runs it, in a reduced form: a subprocess per
run (coarse mesh, a small load, few steps), checked through exit code and the files written."""
from __future__ import annotations

import csv
import json
import pathlib
import re
import subprocess
import sys

import pytest

from dolfinx_sfvem.output.run_summary import read_summary
from dolfinx_sfvem.mpi_launcher import job_environment
from process_report import report

DEMO = pathlib.Path(__file__).resolve().parents[1] / "demos" / "box_self_contact.py"

#: a short load path before contact on the coarsest mesh the walls allow (h = wall thickness)
SMALL = ["--h", "0.1", "--uy", "-0.2", "--fixed-increments", "--quiet"]
G0 = 0.3


def run_demo(*args: str, out: pathlib.Path) -> subprocess.CompletedProcess:
    cmd = [sys.executable, str(DEMO), *args, "--out", str(out)]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=job_environment())


def test_box_single_run(tmp_path):
    proc = run_demo(*SMALL, "--steps", "4", out=tmp_path)
    assert proc.returncode == 0, report(proc)
    assert "converged: yes" in proc.stdout.splitlines()[-1]

    summary = read_summary(tmp_path)
    assert summary.converged and summary.dofs > 0
    assert {"uy": -0.2, "mesh": 1, "h": 0.1, "steps": 4, "gamma": 1e-6, "alpha_r": 0.1,
            "regularization": "huhu_lulu", "beta": 5.0}.items() <= summary.parameters.items()
    medium = summary.parameters["materials"]["2"]
    assert medium["mu"] == 10 and medium["beta"] == 5.0 and medium["K"] == 0
    assert summary.parameters["materials"]["1"]["K"] == 20

    steps = summary.converged_steps
    assert [s.load for s in steps] == pytest.approx([0.25, 0.5, 0.75, 1.0])
    gaps = []
    for s in steps:
        extra = s.extra
        assert set(extra) == {"gap", "top_uy", "bottom_uy"}
        # the gap is the initial 0.3 minus the relative displacement of the two inner surface points
        assert extra["gap"] == pytest.approx(G0 + extra["top_uy"] - extra["bottom_uy"], abs=1e-12)
        # before contact the inner surface of the top follows the load point (the wall is stiff)
        prescribed = -0.2 * s.load
        assert extra["top_uy"] == pytest.approx(prescribed, rel=0.05)
        assert 0 < G0 - extra["gap"] < 1.05 * abs(prescribed)
        assert set(s.reaction) == {"fixed", "roller", "load"}
        # no body force: the reactions balance
        assert sum(r[1] for r in s.reaction.values()) == pytest.approx(0, abs=1e-8)
        assert sum(r[0] for r in s.reaction.values()) == pytest.approx(0, abs=1e-8)
        assert s.reaction["load"][1] < 0 < s.reaction["roller"][1]
        gaps.append(extra["gap"])
    assert gaps[0] == pytest.approx(G0 - 0.05, abs=0.01)              # close to 0.3 - 0.05 at the first step
    assert all(b < a for a, b in zip([G0] + gaps, gaps))                # closes monotonically
    forces = [-s.reaction["load"][1] for s in steps]
    assert all(b > a for a, b in zip(forces, forces[1:]))

    with open(tmp_path / "load_path.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 4
    assert [float(r["gap"]) for r in rows] == pytest.approx(gaps, abs=1e-12)
    assert float(rows[-1]["load_Ry"]) == pytest.approx(steps[-1].reaction["load"][1])
    for name in ("gap.png", "reaction.png", "deformed.png", "uy.png", "displacement.xdmf"):
        assert (tmp_path / name).stat().st_size > 0, name


def test_box_table2_reduced_and_restart(tmp_path):
    sweep = ["--table2", "--meshes", "1", "--alpha-rs", "10", "1", "--gammas", "1e-4", "--steps", "2", *SMALL]
    proc = run_demo(*sweep, out=tmp_path)
    assert proc.returncode == 0, report(proc)
    assert proc.stdout.count(": running") == 2

    runs = {a: tmp_path / "huhu_lulu-beta5" / f"alpha_r{a}-gamma1e-04-mesh1" for a in ("10", "1")}
    for d in runs.values():
        summary = read_summary(d)
        assert summary.converged and len(summary.converged_steps) == 2
        assert summary.parameters["gamma"] == 1e-4 and summary.parameters["beta"] == 5.0
        assert "table2" not in summary.parameters
        assert (d / "gap.png").exists()

    table = (tmp_path / "table2.md").read_text()
    rows = [line for line in table.splitlines() if re.match(r"\| [0-9]", line)]
    assert len(rows) == 2
    assert rows[0].startswith("| 10 | 1e-04 |") and rows[1].startswith("| 1 | 1e-04 |")
    assert "8.6882e-03" in rows[0] and "7.9000e-03" in rows[1]          # the paper's Table 2, mesh 1
    assert "mesh 2" not in table

    data = json.loads((tmp_path / "table2.json").read_text())["runs"]
    assert [(r["alpha_r"], r["gamma"], r["mesh"]) for r in data] == [(10.0, 1e-4, 1), (1.0, 1e-4, 1)]
    assert [r["paper"] for r in data] == [8.6882e-3, 7.9000e-3]
    for r, d in zip(data, runs.values()):
        last = read_summary(d).final_step
        assert r["converged"] and r["gap"] == last.extra["gap"]
        assert r["ratio"] == pytest.approx(r["gap"] / r["paper"])
        assert f"{r['gap']:.4e}" in table

    # a restarted sweep skips the finished runs and writes the same table
    stamps = {a: (d / "summary.json").stat().st_mtime_ns for a, d in runs.items()}
    again = run_demo(*sweep, out=tmp_path)
    assert again.returncode == 0, report(again)
    assert again.stdout.count("converged before, skipped") == 2 and ": running" not in again.stdout
    assert {a: (d / "summary.json").stat().st_mtime_ns for a, d in runs.items()} == stamps
    assert (tmp_path / "table2.md").read_text() == table


def test_box_table2_rejects_unknown_parameters(tmp_path):
    proc = run_demo("--table2", "--alpha-rs", "5", "--quiet", out=tmp_path)
    assert proc.returncode == 2
    assert "Table 2 has no entry for alpha_r = 5" in proc.stderr and "Traceback" not in proc.stderr
