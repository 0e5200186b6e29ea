"""First use of the 3D forms: compile CPU-seconds and tangent assembly with gcc and with clang, per DOLFINx stack.

Usage::

    python3 bench/compile3d.py [--python011 PATH] [--cells hexahedron tetrahedron] [--grid 20x4x7]
                               [--out DIR] [--results DIR]

Every case is a fresh process of ``compile3d_case.py`` with an empty JIT cache and ``CC`` set to
``gcc`` or to the clang on ``PATH``, for this Python (DOLFINx 0.5.2 on Debian) and, when given or
found at ``.venv-dolfinx011/bin/python``, the DOLFINx 0.11 venv's. Writes ``DIR/compile3d.json``
(every case, appended as it finishes; a rerun skips the cases there) and ``DIR/compile3d.md``: the
cases, and per stack and cell the ratios clang / gcc of the compile and of the tangent assembly, and
whether both modules give the same matrix. Timings are as measured on the machine's state at the
time, never asserted; compare rows of one run.
"""
from __future__ import annotations

import argparse
import json
import os
import pathlib
import shutil
import subprocess
import sys
import typing

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
from dolfinx_sfvem.discretizations.c_compiler import clang  # noqa: E402
from case_store import CaseStore, machine  # noqa: E402

#: the DOLFINx 0.11 venv of the Makefile
PYTHON011 = HERE.parent / ".venv-dolfinx011" / "bin" / "python"


def run_case(out: pathlib.Path, python: str, cell: str, grid: str, compiler: str) -> dict | None:
    """One case in its own process and empty cache; its record, or None if it failed (log in ``out``)."""
    name = f"{pathlib.Path(python).parent.parent.name}_{cell}_{grid}_{pathlib.Path(compiler).name}"
    cache = out / f"{name}.cache"
    shutil.rmtree(cache, ignore_errors=True)
    env = dict(os.environ, XDG_CACHE_HOME=str(cache), CC=compiler, OMP_NUM_THREADS="1")
    with open(out / f"{name}.log", "w") as log:
        code = subprocess.call([python, str(HERE / "compile3d_case.py"), cell, grid, str(out / f"{name}.json")],
                               stdout=log, stderr=subprocess.STDOUT, env=env)
    shutil.rmtree(cache, ignore_errors=True)
    if code != 0 or not (out / f"{name}.json").exists():
        return None
    return json.loads((out / f"{name}.json").read_text())


def ratios(records: typing.Sequence[dict]) -> list[dict]:
    """Per (stack, cell, grid) with a gcc and a clang case: clang / gcc of the compile (process +
    compiler CPU) and of the tangent assembly, and the relative difference of the matrices' norms."""
    by_case = {(r["stack"], r["cell"], r["grid"], pathlib.Path(r["compiler"]).name.split("-")[0]): r for r in records}
    rows = []
    for (stack, cell, grid, compiler), gcc in sorted(by_case.items()):
        other = by_case.get((stack, cell, grid, "clang"))
        if compiler != "gcc" or other is None:
            continue
        total = [r["setup_cpu_s"] + r["compiler_cpu_s"] for r in (gcc, other)]
        rows.append({"stack": stack, "cell": cell, "grid": grid, "compile": total[1] / total[0],
                     "tangent": other["tangent_cpu_s"] / gcc["tangent_cpu_s"],
                     "norm_difference": abs(other["tangent_norm"] - gcc["tangent_norm"]) / gcc["tangent_norm"]})
    return rows


def markdown(records: typing.Sequence[dict], machine: str) -> str:
    """The cases' table and the ratios' table."""
    lines = ["# First use of the 3D forms (bench/compile3d.py)", "",
             f"The 3D C-box's FEM forms (rotation regularization, quadrature degree 4) compiled in an empty JIT "
             f"cache, {machine}. Set-up: CPU seconds of the process (FFCx, the rest of the set-up) + of the C "
             "compiler; tangent: median CPU seconds of an assembly afterwards. Timings as measured on a machine "
             "that other jobs may have shared (compare rows of one run).", "",
             "| DOLFINx | cell | grid | unknowns | C compiler | set-up CPU-s | tangent CPU-s | tangent norm |",
             "|---|---|---|---:|---|---:|---:|---:|"]
    for r in sorted(records, key=lambda r: (r["stack"], r["cell"], r["compiler"])):
        lines.append(f"| {r['stack']} | {r['cell']} | {r['grid']} | {r['unknowns']} | {r['compiler']} | "
                     f"{r['setup_cpu_s']:.1f} + {r['compiler_cpu_s']:.1f} | {r['tangent_cpu_s']:.3f} | "
                     f"{r['tangent_norm']:.12g} |")
    lines += ["", "| DOLFINx | cell | grid | compile clang / gcc | tangent clang / gcc | norms differ by |",
              "|---|---|---|---:|---:|---:|"]
    for row in ratios(records):
        lines.append(f"| {row['stack']} | {row['cell']} | {row['grid']} | {row['compile']:.2f} | {row['tangent']:.2f} | "
                     f"{row['norm_difference']:.1e} |")
    return "\n".join(lines) + "\n"


def parse_args(argv: typing.Sequence[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--python011", default=str(PYTHON011) if PYTHON011.exists() else None,
                        help="the DOLFINx 0.11 venv's python (default: the Makefile's, when there)")
    parser.add_argument("--cells", nargs="+", default=["hexahedron", "tetrahedron"])
    parser.add_argument("--grid", default="20x4x7", help="NXxNYxNZ (a coarser grid compiles the same forms)")
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out/compile3d"))
    parser.add_argument("--results", type=pathlib.Path, default=None)
    return parser.parse_args(argv)


def main(argv: typing.Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    if clang() is None:
        print("compile3d: no clang on PATH (the Makefile installs it)", file=sys.stderr)
        return 1
    store = CaseStore(args.out, "compile3d")
    done = {(r["python"], r["cell"], r["grid"], r["compiler"]) for r in store.records}
    pythons = [sys.executable] + ([args.python011] if args.python011 else [])
    for python in pythons:
        for cell in args.cells:
            for compiler in ("gcc", clang()):
                if (python, cell, args.grid, compiler) in done:
                    continue
                record = run_case(args.out, python, cell, args.grid, compiler)
                print(python, cell, compiler, record if record else "FAILED (see its log)", flush=True)
                if record:
                    store.add(dict(record, python=python))
    store.write(markdown(store.records, machine()), args.results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
