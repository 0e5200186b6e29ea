"""Processes started at the same time on an empty compiler cache all finish (issue 30 item 1).

Five C-box demo runs (SFVEM and FEM, serial and one on 2 ranks) start at once on a fresh FFCx
cache. FFCx makes a process that finds another's compile of the same form under way poll for its
end and give up after DOLFINx's ``timeout`` (10 s by default); the runs here set it to 1 s
(``dolfinx_jit_parameters.json`` / ``dolfinx_jit_options.json`` in their working directory), so
a run that ever waits in that loop fails at once instead of on a loaded machine only: with the
package's compile lock (dolfinx_sfvem/discretizations/compile_lock.py) no run waits there, whatever the timeout.
"""
import json
import os
import pathlib
import subprocess
import sys

import pytest

from dolfinx_sfvem import mpi_launcher
from dolfinx_sfvem.mpi_launcher import job_environment

ROOT = pathlib.Path(__file__).resolve().parents[1]
#: run name -> (method, ranks (None: serial))
RUNS = {"vem-a": ("vem", None), "vem-b": ("vem", None), "fem-a": ("fem", None), "fem-b": ("fem", None),
        "fem-2ranks": ("fem", 2)}
#: seconds FFCx waits for another process's compile
JIT_TIMEOUT = 1


def start(name: str, method: str, ranks: int | None, work: pathlib.Path, env: dict) -> subprocess.Popen:
    """The C-box demo at a small load on a coarse mesh, writing to ``work/name``."""
    command = [*mpi_launcher.command(ranks), sys.executable, str(ROOT / "demos" / "cbox.py"), "--method", method,
               "--h", "0.1", "--uy", "-0.05", "--steps", "1", "--quiet", "--out", str(work / name)]
    return subprocess.Popen(command, cwd=work, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def tip_force(out: pathlib.Path) -> float:
    """The reaction at the C-box's tip in the last step of summary.json."""
    return json.loads((out / "summary.json").read_text())["steps"][-1]["reaction"]["load"][1]


def test_runs_started_together_on_an_empty_cache_all_finish(tmp_path):
    for name in ("dolfinx_jit_parameters.json", "dolfinx_jit_options.json"):      # DOLFINx 0.5, 0.11
        (tmp_path / name).write_text(json.dumps({"timeout": JIT_TIMEOUT}))
    # os.environ: not this (MPI) process's C environment, whose MPI variables would stop the launcher
    env = job_environment()
    env.update(XDG_CACHE_HOME=str(tmp_path / "cache"),
               PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")])))
    processes = {name: start(name, method, ranks, tmp_path, env) for name, (method, ranks) in RUNS.items()}
    finished = {name: (p.communicate(timeout=900), p.returncode) for name, p in processes.items()}
    for name, ((out, err), code) in finished.items():
        assert code == 0, f"{name} exited with {code}:\n{out[-2000:]}\n{err[-4000:]}"
        assert "load reached 1 of 1 | converged: yes" in out, f"{name} printed no result:\n{out}"
    # the same run gives the same answer whichever process compiled its forms
    force = {name: tip_force(tmp_path / name) for name in RUNS}
    assert force["vem-a"] == pytest.approx(force["vem-b"], rel=1e-12)
    assert force["fem-a"] == pytest.approx(force["fem-b"], rel=1e-12)
    assert force["fem-2ranks"] == pytest.approx(force["fem-a"], rel=1e-8)
