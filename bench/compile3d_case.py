"""First use of the 3D C-box's forms in a fresh JIT cache, timed: the case that bench/compile3d.py
runs in its own process per (DOLFINx stack, cell, C compiler).

Builds ``demos/cbox3d.py``'s problem (the FEM, the ``ThirdMedium`` defaults: rotation
regularization, quadrature degree 4) on an ``nx x ny x nz`` grid with the cache directory of
``XDG_CACHE_HOME`` (the driver gives an empty one), assembles the tangent once at a smooth state
(every form compiled), then times :data:`REPEATS` more tangent assemblies. CPU seconds are those of
the process and of its children (the C compiler), from ``getrusage``; the C compiler is ``CC`` as the
driver sets it (the package's own choice when ``CC`` is unset).

Usage::

    python bench/compile3d_case.py CELL NXxNYxNZ OUT.json
"""
from __future__ import annotations

import json
import os
import pathlib
import resource
import sys
import time

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "demos"))
sys.path.insert(0, str(HERE.parent))
import cbox3d  # noqa: E402
import dolfinx_sfvem  # noqa: E402
from dolfinx_sfvem.discretizations.c_compiler import jit_c_compiler  # noqa: E402

#: timed tangent assemblies after the first
REPEATS = 5


def cpu() -> tuple[float, float]:
    """CPU seconds (user + system) of this process and of its waited-for children."""
    own, children = (resource.getrusage(who) for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))
    return own.ru_utime + own.ru_stime, children.ru_utime + children.ru_stime


def main(argv: list[str]) -> int:
    cell, grid, out = argv[0], argv[1], pathlib.Path(argv[2])
    start = cpu()
    args = cbox3d.make_parser().parse_args(["--method", "fem", "--cell", cell, "--n", *grid.split("x")])
    problem, _ = cbox3d.build(args)
    disc = problem.disc
    A = disc.create_matrix()
    x = problem.x.copy()
    with x.localForm() as xl:
        xl.array[:] = 0.01 * np.sin(0.37 * np.arange(xl.array.size))
    disc.assemble_tangent(x, A)
    compiled = cpu()
    times = []
    for _ in range(REPEATS):
        t = time.process_time()
        disc.assemble_tangent(x, A)
        times.append(time.process_time() - t)
    record = {"stack": dolfinx_sfvem._compat.DOLFINX_VERSION, "cell": cell, "grid": grid,
              "unknowns": int(A.getSize()[0]),
              "compiler": os.environ.get("CC") or jit_c_compiler() or "default (Python's CC)",
              "setup_cpu_s": compiled[0] - start[0], "compiler_cpu_s": compiled[1] - start[1],
              "tangent_cpu_s": float(np.median(times)), "tangent_norm": float(A.norm())}
    out.write_text(json.dumps(record))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
