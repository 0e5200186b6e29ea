"""The command that starts a Python program on N MPI ranks, for Open MPI and for MPICH.

Debian 12's stack runs under Open MPI's ``mpirun``, which refuses to start as root without
``--allow-run-as-root`` and more ranks than cores without ``--oversubscribe``; the
``dolfinx-solver-real`` wheel brings MPICH, whose ``mpiexec`` (Hydra) needs neither flag and
rejects both. The launcher is the ``mpiexec`` beside the interpreter (a venv or conda
environment that ships its MPI) if there is one, else ``mpiexec`` or ``mpirun`` on ``PATH``; its
kind is read from its ``--version`` output.

The Makefile, ``demos/compare.py``, ``bench/run.py`` and ``demos/results.py``
all take the command from here. As a script (standard library only, nothing is imported from
the package)::

    python dolfinx_sfvem/mpi_launcher.py -n 2 [--python PATH] [--launcher PATH]

prints the command prefix, e.g. ``/usr/bin/mpiexec -n 2 --allow-run-as-root --oversubscribe``.

A program started from a process that has MPI initialised (a test run, a driver script, a rank
of an ``mpirun`` job) must get :func:`job_environment`: otherwise it inherits the variables by
which the parent's MPI knows its own job, and its ``MPI_Init`` joins that job under the parent's
identity instead of starting its own (the child then hangs or exits without a word).
"""
from __future__ import annotations

import argparse
import functools
import os
import pathlib
import shlex
import shutil
import subprocess
import sys
import typing

OPEN_MPI = "Open MPI"
MPICH = "MPICH"
#: flags Open MPI's launcher needs on a shared development machine (more ranks than cores)
OPEN_MPI_FLAGS = ("--oversubscribe",)
#: and as root
OPEN_MPI_ROOT_FLAGS = ("--allow-run-as-root",)

#: prefixes of the variables through which a launcher or an initialised MPI tells a process which
#: job it belongs to and where that job's server is: PMIx (Open MPI's singletons and ``mpirun``),
#: Open MPI's own (ranks, the daemon's URI, session directories), MPICH's Hydra and PMI
JOB_VARIABLE_PREFIXES = ("PMIX_", "PMI_", "HYDI_", "HYDRA_", "OMPI_COMM_WORLD_", "OMPI_MCA_orte_",
                         "OMPI_MCA_ess", "OMPI_MCA_pmix", "OMPI_MCA_initial_wdir",
                         "OMPI_MCA_shmem_RUNTIME_QUERY_hint", "OMPI_MCA_mpi_oversubscribe",
                         "OMPI_APP_CTX_NUM_PROCS", "OMPI_COMMAND", "OMPI_FILE_LOCATION",
                         "OMPI_FIRST_RANKS", "OMPI_NUM_APP_CTX", "OMPI_UNIVERSE_SIZE",
                         "ORTE_SCHIZO_DETECTION", "MPI_LOCALNRANKS", "MPI_LOCALRANKID")


def find_launcher(python: str | os.PathLike = sys.executable) -> str:
    """The MPI launcher for ``python``: ``mpiexec`` in its ``bin`` directory (not resolving
    symbolic links: a venv's ``bin/python`` points elsewhere), else ``mpiexec`` or ``mpirun`` on
    ``PATH``.

    Raises
    ------
    FileNotFoundError
        If there is none.
    """
    beside = pathlib.Path(os.path.abspath(python)).parent / "mpiexec"
    if beside.is_file() and os.access(beside, os.X_OK):
        return str(beside)
    for name in ("mpiexec", "mpirun"):
        found = shutil.which(name)
        if found:
            return found
    raise FileNotFoundError(f"no MPI launcher beside {python} nor mpiexec/mpirun on PATH")


@functools.lru_cache(maxsize=None)
def kind(launcher: str) -> str | None:
    """:data:`OPEN_MPI`, :data:`MPICH` (Hydra: MPICH, Intel MPI) or None (unknown), from
    ``launcher --version``."""
    try:
        proc = subprocess.run([launcher, "--version"], capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired):
        return None
    text = proc.stdout + proc.stderr
    if "Open MPI" in text or "OpenRTE" in text:
        return OPEN_MPI
    if "HYDRA" in text or "MPICH" in text:
        return MPICH
    return None


def command(np: int | None, python: str | os.PathLike = sys.executable, launcher: str | None = None) -> list[str]:
    """Command prefix that runs ``python ...`` on ``np`` ranks.

    Parameters
    ----------
    np
        Number of ranks; None gives ``[]`` (run the program directly).
    python
        The interpreter the command will start (its environment's launcher is used).
    launcher
        The launcher to use instead of :func:`find_launcher`'s.

    Returns
    -------
    list[str]
        ``[launcher, "-n", np, flags...]``: Open MPI's :data:`OPEN_MPI_FLAGS` and, as root,
        :data:`OPEN_MPI_ROOT_FLAGS`; no flags for any other launcher.
    """
    if np is None:
        return []
    launcher = launcher or find_launcher(python)
    flags: tuple[str, ...] = ()
    if kind(launcher) == OPEN_MPI:
        flags = OPEN_MPI_FLAGS + (OPEN_MPI_ROOT_FLAGS if hasattr(os, "geteuid") and os.geteuid() == 0 else ())
    return [launcher, "-n", str(int(np)), *flags]


def job_environment(base: typing.Mapping[str, str] | None = None, **extra: str) -> dict[str, str]:
    """The environment for a program that starts an MPI job of its own (serially or through
    :func:`command`) from a process that may have MPI initialised.

    Pass it as ``env=`` to :mod:`subprocess`: with ``env=None`` the child inherits the process's
    C-level environment, to which ``MPI_Init`` of an Open MPI singleton added the identity of its
    job (``PMIX_RANK=0``, ``PMIX_NAMESPACE``, the server's ``PMIX_SERVER_URI*``, ...) and the
    child's ``MPI_Init`` then connects to the parent's job as the parent's rank.

    Parameters
    ----------
    base
        The variables to start from; default ``os.environ`` (Python's copy of the environment at
        start-up: without what this process's own ``MPI_Init`` set, but with what a launcher that
        started this process set).
    extra
        Variables to set on top (e.g. ``XDG_CACHE_HOME``).

    Returns
    -------
    dict[str, str]
        ``base`` without the variables named by :data:`JOB_VARIABLE_PREFIXES`, plus ``extra``.
    """
    base = os.environ if base is None else base
    return {**{k: v for k, v in base.items() if not k.startswith(JOB_VARIABLE_PREFIXES)}, **extra}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description="Print the command prefix that runs a Python program on N MPI ranks.")
    p.add_argument("-n", "--np", type=int, required=True, help="number of ranks")
    p.add_argument("--python", default=sys.executable, help="the interpreter to be started (default: this one)")
    p.add_argument("--launcher", default=None, help="use this launcher instead of the one found")
    args = p.parse_args(argv)
    print(shlex.join(command(args.np, args.python, args.launcher)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
