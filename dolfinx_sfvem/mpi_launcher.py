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

OPEN_MPI = "Open MPI"
MPICH = "MPICH"
#: flags Open MPI's launcher needs on a shared development machine (more ranks than cores)
OPEN_MPI_FLAGS = ("--oversubscribe",)
#: and as root
OPEN_MPI_ROOT_FLAGS = ("--allow-run-as-root",)


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
