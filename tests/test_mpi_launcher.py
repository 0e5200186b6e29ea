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


def test_job_environment_drops_the_job_identity_and_keeps_the_users_settings():
    base = {"PMIX_RANK": "0", "PMIX_NAMESPACE": "1234", "PMIX_SERVER_URI4": "1234.0;tcp4://127.0.0.1:1",
            "OMPI_COMM_WORLD_RANK": "1", "OMPI_MCA_orte_hnp_uri": "x", "OMPI_MCA_ess": "singleton",
            "PMI_RANK": "1", "PMI_FD": "7", "HYDI_CONTROL_FD": "9", "MPI_LOCALRANKID": "1",
            "OMPI_MCA_btl": "self,vader", "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMP_NUM_THREADS": "4", "HOME": "/root"}
    env = mpi_launcher.job_environment(base, OMP_NUM_THREADS="1", XDG_CACHE_HOME="/tmp/c")
    assert env == {"OMPI_MCA_btl": "self,vader", "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMP_NUM_THREADS": "1",
                   "HOME": "/root", "XDG_CACHE_HOME": "/tmp/c"}


CHILD = ("import os, sys; from mpi4py import MPI; "
         "print(MPI.COMM_WORLD.size, sorted(k for k in os.environ if k.startswith(tuple(sys.argv[1:]))))")


def test_a_child_of_an_mpi_process_starts_a_job_of_its_own():
    """This process has MPI initialised (the package is imported). A Python child started with
    ``job_environment()`` sees none of the variables of this process's job and runs as a
    singleton of its own; started with the inherited environment (``env=None``) under Open MPI
    it would get this process's PMIx identity (``PMIX_RANK``, the server's URI)."""
    from mpi4py import MPI             # initialised, as in every test process

    prefixes = mpi_launcher.JOB_VARIABLE_PREFIXES
    clean = subprocess.run([sys.executable, "-c", CHILD, *prefixes], capture_output=True, text=True,
                           env=mpi_launcher.job_environment(), timeout=120, check=True)
    assert clean.stdout.strip() == "1 []"
    inherited = subprocess.run([sys.executable, "-c", "import os, sys; print(sorted(k for k in os.environ "
                                "if k.startswith(tuple(sys.argv[1:]))))", *prefixes],
                               capture_output=True, text=True, timeout=120, check=True)
    if "Open MPI" in MPI.Get_library_version() and "PMIX_RANK" not in os.environ:   # a singleton
        assert "PMIX_RANK" in inherited.stdout and "PMIX_NAMESPACE" in inherited.stdout
