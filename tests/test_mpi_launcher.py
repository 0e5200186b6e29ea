"""The MPI launcher command (dolfinx_sfvem/mpi_launcher.py) for Open MPI, MPICH and unknown launchers."""
import os
import pathlib
import shlex
import subprocess
import sys

import pytest

from dolfinx_sfvem import mpi_launcher

SCRIPT = pathlib.Path(mpi_launcher.__file__)
VERSIONS = {"openmpi": "mpirun (Open MPI) 4.1.4\n\nReport bugs to http://www.open-mpi.org/community/help/",
            "mpich": "HYDRA build details:\n    Version:                                 5.0.2",
            "other": "some launcher 1.0"}
AS_ROOT = hasattr(os, "geteuid") and os.geteuid() == 0


def fake_launcher(directory: pathlib.Path, name: str, version: str) -> str:
    """An executable ``directory/name`` that prints ``version`` for ``--version``."""
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / name
    path.write_text(f"#!/bin/sh\ncat <<'EOF'\n{version}\nEOF\n")
    path.chmod(0o755)
    return str(path)


@pytest.mark.parametrize("flavour, flags", [
    ("openmpi", ["--oversubscribe", *(["--allow-run-as-root"] if AS_ROOT else [])]),
    ("mpich", []), ("other", [])])
def test_flags_follow_the_launcher(tmp_path, flavour, flags):
    launcher = fake_launcher(tmp_path, f"mpiexec-{flavour}", VERSIONS[flavour])
    assert mpi_launcher.command(3, launcher=launcher) == [launcher, "-n", "3", *flags]


def test_no_ranks_no_launcher():
    assert mpi_launcher.command(None) == []


def test_the_launcher_beside_the_interpreter_wins(tmp_path):
    bin_dir = tmp_path / "venv" / "bin"
    launcher = fake_launcher(bin_dir, "mpiexec", VERSIONS["mpich"])
    python = bin_dir / "python"
    python.symlink_to(sys.executable)          # a venv's interpreter: a link to elsewhere
    assert mpi_launcher.find_launcher(python) == launcher
    assert mpi_launcher.command(2, python) == [launcher, "-n", "2"]


def test_this_stack_has_a_known_launcher():
    """Debian 12's Open MPI and the wheel's MPICH are both recognised."""
    assert mpi_launcher.kind(mpi_launcher.find_launcher()) in (mpi_launcher.OPEN_MPI, mpi_launcher.MPICH)


def test_script_prints_the_command_without_importing_the_package(tmp_path):
    launcher = fake_launcher(tmp_path, "mpirun", VERSIONS["openmpi"])
    proc = subprocess.run([sys.executable, "-X", "importtime", str(SCRIPT), "-n", "2", "--launcher", launcher],
                          capture_output=True, text=True, check=True)
    assert shlex.split(proc.stdout) == mpi_launcher.command(2, launcher=launcher)
    imported = {line.rsplit("|", 1)[-1].strip() for line in proc.stderr.splitlines() if line.startswith("import time:")}
    assert "mpi4py" not in imported and not {"dolfinx", "dolfinx_sfvem"} & imported
