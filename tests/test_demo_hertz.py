"""The Hertz demo (demos/hertz.py) in reduced form: coarse mesh, few steps, gamma = 1e-5, checked
against Hertz's cylinder-on-half-space solution and against equilibrium."""
from __future__ import annotations

import csv
import math
import pathlib
import subprocess
import sys

import numpy as np
import hertz
import pytest

from dolfinx_sfvem.output.run_summary import read_summary
from dolfinx_sfvem.mpi_launcher import job_environment
from process_report import report

DEMOS = pathlib.Path(__file__).resolve().parents[1] / "demos"


def test_hertz_formulas_against_closed_form():
    """a = sqrt(4 P R / (pi E*)) with E* = E / (1 - nu^2) from K = 5/3, mu = 5/14 (E = 1, nu = 0.4),
    and the pressure profile integrating to P."""
    assert hertz.E == pytest.approx(1.0) and hertz.NU == pytest.approx(0.4)
    P = 0.05
    a = hertz.hertz_half_width(P)
    assert a == pytest.approx(math.sqrt(4 * P * 0.84 / math.pi))
    x = np.linspace(-a, a, 20001)
    p = hertz.hertz_pressure(x, P)
    assert np.sum(0.5 * (p[1:] + p[:-1]) * np.diff(x)) == pytest.approx(P, rel=1e-3)   # trapezoidal rule
    assert hertz.hertz_pressure(np.array([1.01 * a]), P)[0] == 0.0


@pytest.fixture(scope="module")
def coarse_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("hertz")
    cmd = [sys.executable, str(DEMOS / "hertz.py"), "--h", "0.1", "--steps", "10", "--gamma", "1e-5",
           "--quiet", "--out", str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=job_environment())
    return proc, out


def test_hertz_demo_coarse_run_matches_hertz(coarse_run):
    proc, out = coarse_run
    assert proc.returncode == 0, report(proc)
    assert "converged: yes" in proc.stdout
    for name in ("hertz.md", "hertz.png", "pressure.csv", "summary.json"):
        assert (out / name).is_file(), name
    summary = read_summary(out)
    last = summary.final_step
    pairs = last.contact
    assert len(pairs) == 2                                   # block <- cylinder and cylinder <- block
    block = next(c for c in pairs if c["region"] == hertz.sf.meshes.SOLID)
    P = -2 * block["force"][1]
    reaction = 2 * last.force("load")
    assert P > 0.0
    assert P == pytest.approx(reaction, rel=1e-3)            # medium force on the block = pushing force
    assert block["gap"] > 0.0                                # the bodies stay apart
    assert min(c["gap"] for c in pairs) > 0.0
    # half-width: the peak-based a_p = 2 P / (pi p_max) within 5 %, the 1 %-zone length within
    # 2 coarse (h = 0.1) block-top edges of Hertz
    a_h = hertz.hertz_half_width(P)
    assert 2 * P / (math.pi * block["max_pressure"]) == pytest.approx(a_h, rel=0.05)
    assert abs(block["zone_length"] - a_h) < 0.2
    with open(out / "pressure.csv", newline="") as f:
        xp = np.array([[float(r["x"]), float(r["p"])] for r in csv.DictReader(f)])
    inside = xp[:, 0] < 0.9 * a_h
    assert inside.sum() >= 3 and np.all(xp[inside, 1] > 0.0)   # compressive throughout the zone
    assert np.all(xp[xp[:, 0] > 2 * a_h, 1] < 0.05 * xp[:, 1].max())   # and nearly none outside
    table = (out / "hertz.md").read_text()
    assert table.count("\n| ") >= 3                          # several indentations after contact


def test_hertz_demo_rejects_small_block(tmp_path):
    cmd = [sys.executable, str(DEMOS / "hertz.py"), "--block", "0.8", "--quiet", "--out", str(tmp_path)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120, env=job_environment())
    assert proc.returncode == 2 and "--block" in proc.stderr
