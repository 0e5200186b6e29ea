"""The demos as a user runs them: a subprocess per run, checked through exit code, stderr and
the files written (summary.json, load_path.csv, XDMF, PNG)."""
from __future__ import annotations

import csv
import importlib.util
import json
import pathlib
import signal
import subprocess
import sys

import pytest

from dolfinx_sfvem import mpi_launcher
from dolfinx_sfvem.path_following import interrupt
from dolfinx_sfvem.output.run_summary import read_summary
from dolfinx_sfvem.mpi_launcher import job_environment
from process_report import report

DEMOS = pathlib.Path(__file__).resolve().parents[1] / "demos"

#: a short C-box load path: before contact, coarse mesh, a few seconds
SMALL = ["--uy", "-0.1", "--steps", "3", "--h", "0.1", "--quiet"]


def run_demo(name: str, *args: str, out: pathlib.Path | None = None) -> subprocess.CompletedProcess:
    """Run ``demos/<name>.py`` serially with the given arguments (and ``--out out``)."""
    cmd = [sys.executable, str(DEMOS / f"{name}.py"), *args] + (["--out", str(out)] if out else [])
    return subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=job_environment())


def csv_rows(path: pathlib.Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_cbox_outputs(tmp_path):
    proc = run_demo("cbox", *SMALL, "--method", "vem", out=tmp_path)
    assert proc.returncode == 0, report(proc)
    assert "converged: yes" in proc.stdout.splitlines()[-1]

    content = json.loads((tmp_path / "summary.json").read_text())
    for key in ("method", "dofs", "wall_time_s", "parameters", "steps", "converged"):
        assert key in content, key
    for step in content["steps"]:
        for key in ("load", "newton_iterations", "residual_norms", "reaction", "converged"):
            assert key in step, key
    summary = read_summary(tmp_path)
    assert summary.method == "vem" and summary.converged and summary.dofs > 0
    params = summary.parameters
    assert {"uy": -0.1, "mesh": 1, "h": 0.1, "gamma": 1e-5, "alpha_r": 1.0, "regularization": "rotation",
            "beta": None}.items() <= params.items()

    steps = summary.converged_steps
    assert len(steps) == 3
    for step in steps:
        assert len(step.residual_norms) == step.newton_iterations + 1
        assert set(step.reaction) == {"fixed", "load"}
    assert steps[-1].load == pytest.approx(1.0)
    assert steps[-1].extra["tip_uy"] == pytest.approx(-0.1, abs=1e-9)
    assert [s.extra["tip_uy"] for s in steps] == pytest.approx([-0.1 * s.load for s in steps], abs=1e-9)
    assert steps[-1].reaction["load"][1] < 0          # the tip is pulled down

    rows = csv_rows(tmp_path / "load_path.csv")
    assert len(rows) == len(steps)
    assert float(rows[-1]["tip_uy"]) == pytest.approx(-0.1, abs=1e-9)
    for name in ("deformed.png", "uy.png", "displacement.xdmf", "displacement.h5"):
        assert (tmp_path / name).stat().st_size > 0, name


def test_cbox_lobatto_medium(tmp_path):
    """--medium-quadrature lobatto: the Q2 FEM integrates the medium at its nodes; summary.json says so."""
    proc = run_demo("cbox", *SMALL, "--method", "fem", "--medium-quadrature", "lobatto", out=tmp_path)
    assert proc.returncode == 0, report(proc)
    assert read_summary(tmp_path).parameters["medium_quadrature"] == "lobatto"


@pytest.mark.parametrize("args, message", [
    (["--steps", "0"], "argument --steps: must be an integer >= 1"),
    (["--gamma", "-1"], "argument --gamma: must be a number > 0"),
    (["--h", "0.5"], "argument --h: must be a number in (0, 0.1]"),
    (["--regularization", "foo"], "argument --regularization: invalid choice"),
    (["--stepz", "3"], "unrecognized argument '--stepz'"),
    (["--fem-jump-penalty", "40"], "--fem-jump-penalty needs --method fem"),
    (["--method", "fem", "--fem-jump-penalty", "0"], "argument --fem-jump-penalty: must be a number > 0"),
    (["--fem-cells", "triangles"], "--fem-cells needs --method fem"),
    (["--method", "fem", "--fem-cells", "hexagons"], "argument --fem-cells: invalid choice"),
    (["--medium-quadrature", "lobatto"], "quadrature='lobatto' is not available with the SFVEM"),
    (["--method", "fem", "--fem-cells", "triangles", "--medium-quadrature", "lobatto"],
     "quadrature='lobatto' is not available on P2 triangles"),
])
def test_cbox_rejects_bad_input(tmp_path, args, message):
    proc = run_demo("cbox", *args, out=tmp_path)
    assert proc.returncode == 2
    assert message in proc.stderr
    assert "Traceback" not in proc.stderr
    assert not (tmp_path / "summary.json").exists()


def test_petsc_options_reach_snes(tmp_path):
    """One Newton iteration per try (two tries per attempt: the default line search and its
    fallback) cannot converge even the smallest cut-back increment: the run stops with exit
    code 1 and keeps its (failed) history."""
    proc = run_demo("cbox", "--uy", "-1", "--steps", "2", "--h", "0.1", "--quiet", "-tmc_snes_max_it", "1",
                    out=tmp_path)
    assert proc.returncode == 1, report(proc)
    assert "Traceback" not in proc.stderr
    assert "converged: no" in proc.stdout.splitlines()[-1]

    summary = read_summary(tmp_path)
    assert not summary.converged and "failed" in summary.message
    assert summary.parameters["petsc_options"] == ["-tmc_snes_max_it", "1"]
    assert summary.steps and all(s.newton_iterations <= 2 for s in summary.steps)
    assert len(csv_rows(tmp_path / "load_path.csv")) == len(summary.converged_steps)


def load_common():
    """demos/_common.py as a module."""
    spec = importlib.util.spec_from_file_location("_common", DEMOS / "_common.py")
    common = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(common)
    return common


@pytest.mark.parametrize("error", ["ValueError", "SolveFailed"])
def test_expected_errors_become_exit_code_2(capsys, error):
    common = load_common()
    exception = ValueError if error == "ValueError" else common.sf.SolveFailed

    def main(argv):
        raise exception("polygon 7: self-intersection")

    assert common.exit_code(main) == 2
    assert capsys.readouterr().err.strip() == "error: polygon 7: self-intersection"


@pytest.mark.parametrize("raised, code, name", [
    (KeyboardInterrupt(), 130, "2 (SIGINT)"),                        # Ctrl-C where no handler is installed
    (interrupt.Interrupted(signal.SIGINT), 130, "2 (SIGINT)"),       # a second Ctrl-C
    (interrupt.Interrupted(signal.SIGTERM), 143, "15 (SIGTERM)"),    # a second SIGTERM
])
def test_a_second_signal_ends_with_one_line_and_the_shells_exit_code(capsys, raised, code, name):
    """KeyboardInterrupt (the load path raises it on a second Ctrl-C or SIGTERM, after saying what
    it kept): no traceback, one line, the shell's exit code for the signal (128 + its number)."""
    common = load_common()

    def main(argv):
        raise raised

    assert common.exit_code(main) == code
    assert capsys.readouterr().err.strip() == f"interrupted by signal {name}"


def test_an_interrupt_wrapped_by_the_code_it_interrupted_is_still_an_interrupt(capsys):
    """A second SIGTERM that lands in code which wraps exceptions (Python's class creation raises
    RuntimeError from it): the same one line and exit code 143, no traceback."""
    common = load_common()

    def main(argv):
        try:
            raise interrupt.Interrupted(signal.SIGTERM)
        except KeyboardInterrupt as err:
            raise RuntimeError("Error calling __set_name__") from err

    assert common.exit_code(main) == 143
    assert capsys.readouterr().err.strip() == "interrupted by signal 15 (SIGTERM)"


def test_an_unexpected_error_ends_with_what_and_where(capsys):
    """Any other exception: its traceback, then a last line naming it and the line that raised it,
    and exit code 3."""
    common = load_common()

    def main(argv):
        return {}["tip"]

    assert common.exit_code(main) == 3
    err = capsys.readouterr().err.strip().splitlines()
    assert err[0].startswith("Traceback")
    assert err[-1] == f"error: KeyError in {__file__}:{main.__code__.co_firstlineno + 1} (main): 'tip'"


@pytest.mark.parametrize("error, message", [
    ("RuntimeError", "error: RuntimeError in {script}:8 (main): only here"),
    ("ValueError", "error: only here"),      # an expected failure, raised on one rank alone
])
def test_an_error_on_one_rank_ends_every_rank(tmp_path, error, message):
    """A rank that raises while the other waits in a collective call ends the whole run (no hang)
    with a non-zero exit code and the message of that rank."""
    script = tmp_path / "one_rank_fails.py"
    script.write_text(f"""import sys
sys.path.insert(0, {str(DEMOS)!r})
from mpi4py import MPI
import _common

def main(argv):
    if MPI.COMM_WORLD.rank == 1:
        raise {error}("only here")
    MPI.COMM_WORLD.barrier()
    return 0

sys.exit(_common.exit_code(main))
""")
    command = [*mpi_launcher.command(2), sys.executable, str(script)]
    proc = subprocess.run(command, capture_output=True, text=True, timeout=600, env=job_environment())
    assert proc.returncode != 0
    assert "rank 1 of 2: " + message.format(script=script) in proc.stderr, proc.stdout + proc.stderr


def test_fem_jump_penalty_reaches_the_discretization(tmp_path):
    proc = run_demo("cbox", *SMALL, "--method", "fem", "--fem-jump-penalty", "40", out=tmp_path)
    assert proc.returncode == 0, report(proc)
    summary = read_summary(tmp_path)
    assert summary.converged and summary.method == "fem"
    assert summary.discretization["jump_penalty"] == 40.0 and summary.parameters["fem_jump_penalty"] == 40.0


@pytest.mark.parametrize("cells, cell_type", [(None, "quadrilateral"), ("triangles", "triangle")])
def test_cbox_fem_cells(tmp_path, cells, cell_type):
    """The C-box FEM is Q2 on cbox_grid by default, P2 on a matched triangulation on request."""
    proc = run_demo("cbox", *SMALL, "--method", "fem", *(["--fem-cells", cells] if cells else []), out=tmp_path)
    assert proc.returncode == 0, report(proc)
    summary = read_summary(tmp_path)
    assert summary.converged and summary.discretization["cell_type"] == cell_type
    if cells is None:                     # h = 0.1: 11 x 5 rectangles, (2 * 11 + 1) (2 * 5 + 1) nodes
        assert summary.discretization["cells"] == 55 and summary.dofs == 2 * 23 * 11


def test_gamma_start_reaches_the_path(tmp_path):
    """--gamma-start G0: the medium is solved at G0^(1 - λ) gamma^λ per step, summary.json keeps the
    asked gamma and the schedule; without the option nothing of it is recorded (earlier runs'
    parameters unchanged)."""
    proc = run_demo("cbox", *SMALL, "--method", "vem", "--gamma-start", "1e-3", out=tmp_path)
    assert proc.returncode == 0, report(proc)
    summary = read_summary(tmp_path)
    assert summary.parameters["gamma_continuation"]["gamma_start"] == 1e-3
    assert summary.parameters["materials"]["2"]["gamma"] == 1e-5
    for step in summary.converged_steps:
        assert step.extra["gamma"] == pytest.approx(1e-3 ** (1 - step.load) * 1e-5 ** step.load, rel=1e-12)
    plain = run_demo("cbox", *SMALL, "--method", "vem", out=tmp_path / "plain")
    assert plain.returncode == 0, report(plain)
    params = read_summary(tmp_path / "plain").parameters
    assert "gamma_start" not in params and "gamma_continuation" not in params


@pytest.mark.parametrize("status", [1, 7])
def test_a_library_exit_still_leaves_a_message(tmp_path, status):
    """A compiled library that ends the process with C's exit() inside a demo's main (no Python
    exception, no traceback) still leaves a message on stderr: where Python was (the function
    names of the stack) and the run's last phase; the exit status stays the library's."""
    script = tmp_path / "library_exits.py"
    script.write_text(f"""import ctypes, sys
sys.path.insert(0, {str(DEMOS)!r})
import _common
from dolfinx_sfvem.output import run_phase

def deep_inside_a_library():
    ctypes.CDLL(None).exit({status})

def main(argv):
    print("started", flush=True)
    run_phase.phase("the load step after load 0.25 (2 converged steps)")
    deep_inside_a_library()
    return 0

sys.exit(_common.exit_code(main))
""")
    proc = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=600,
                          env=job_environment())
    assert proc.returncode == status, report(proc)
    assert "error: the process is ending inside a compiled library's call to exit()" in proc.stderr, report(proc)
    assert "last phase of the run: the load step after load 0.25 (2 converged steps)" in proc.stderr
    assert "deep_inside_a_library" in proc.stderr and "in main" in proc.stderr


def test_a_normal_end_has_no_last_word(tmp_path):
    """The backstop stays silent when Python ends the process: a return code, an uncaught error."""
    script = tmp_path / "normal_end.py"
    script.write_text(f"""import sys
sys.path.insert(0, {str(DEMOS)!r})
import _common

def main(argv):
    if argv and argv[0] == "raise":
        raise KeyboardInterrupt
    return int(argv[0]) if argv else 0

sys.exit(_common.exit_code(main, sys.argv[1:]))
""")
    for args, code in (([], 0), (["1"], 1), (["raise"], None)):
        proc = subprocess.run([sys.executable, str(script), *args], capture_output=True, text=True, timeout=600,
                              env=job_environment())
        assert code is None or proc.returncode == code, report(proc)
        assert "ending inside a compiled library" not in proc.stderr, report(proc)
