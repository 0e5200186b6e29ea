"""Our 3D benchmarks beside the peer's: dolfiny's own third-medium demos on the same node grids.

dolfiny (fenics-dolfiny, the demos ``demo/tmc/3D/Cbox_Wriggers_3D.py`` and ``Hertz_Wriggers_3D.py``
of its pull request 4) runs the Wriggers et al. 2025 rotation regularization on an auxiliary field,
Q1/P1, MUMPS, fixed steps without cut-back. The cases, each one process:

- ``cbox-line``: the C-box's line contact, corner (2, 0, 0.7) moved by (0, 0.5, -2.0), gamma 2e-6;
  ours on Q2 hexahedra 20 x 7 x 7 (41 x 15 x 15 nodes, dolfiny's 40 x 14 x 14 Q1 grid), 20 steps;
- ``hertz-deep``: the quarter sphere through a 0.1 medium gap to u_z = -0.6 (indentation 0.5) in
  60 steps, gamma 1e-6, h 0.2; ours on P2 tetrahedra.

Per case and code: the load factor reached, Newton iterations (ours: also the share in failed
attempts), CPU seconds of the whole process, its peak memory, and our wall time to the load the
peer reached (the sum of the attempts' times up to our first converged step at or beyond it).

dolfiny is optional: ``--dolfiny DIR`` (its ``demo/tmc/3D`` folder) with ``--dolfiny-python PY``
(a Python with dolfiny and DOLFINx 0.11, e.g. the 0.11 venv after ``pip install --no-deps
dolfiny==0.10.0``). Times mean something only on an otherwise idle machine.

Variants of the peer's demo, to tell its element from its medium (:func:`peer_variant`):
``--peer-degree K`` (Lagrange degree of the displacement; its output file is then not written),
``--peer-quadrature-degree Q`` (the degree of its one rule), ``--peer-no-aux`` (the auxiliary field
held at p = 0: its rotation regularization is then the local penalty beta1/2 |skew(F)|², which is
``ThirdMedium(beta1=beta1/4)`` here, its skew being half ours).

Usage: ``python bench/peer3d.py [--cases cbox-line hertz-deep] [--dolfiny DIR --dolfiny-python PY]
[--ours-option=--alpha-r=100 ...] [--peer-degree 2 --peer-quadrature-degree 2 --peer-no-aux]``; writes bench/peer3d.json (a case run again replaces its row)
and bench/peer3d.md.
"""
from __future__ import annotations

import argparse
import dataclasses
import datetime
import json
import os
import pathlib
import re
import subprocess
import sys
import tempfile
import typing

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from dolfinx_sfvem.mpi_launcher import job_environment  # noqa: E402
from dolfinx_sfvem.output import markdown  # noqa: E402
from dolfinx_sfvem.output.run_summary import newton_economy  # noqa: E402


@dataclasses.dataclass(frozen=True)
class Case:
    """A benchmark: our demo and options, the peer's script and its number of load steps."""
    demo: str
    options: tuple[str, ...]
    peer_script: str
    peer_steps: int


CASES = {
    "cbox-line": Case("cbox3d.py", ("--contact", "line", "--n", "20", "7", "7", "--gamma", "2e-6", "--steps", "20"),
                      "Cbox_Wriggers_3D.py", 20),
    "hertz-deep": Case("hertz3d.py", ("--gamma", "1e-6", "--indent", "0.5", "--h", "0.2", "--h-far", "0.2",
                                      "--h-core", "0", "--steps", "60"), "Hertz_Wriggers_3D.py", 60),
}


@dataclasses.dataclass
class Run:
    """What one run of a case measured."""
    case: str
    code: str
    options: str
    load: float
    newton_iterations: int
    failed_share: float | None
    cpu_s: float
    peak_memory_gb: float
    message: str = ""
    wall_to_peer_load_s: float | None = None


def run_measured(argv: list[str], cwd: pathlib.Path) -> tuple[subprocess.CompletedProcess, float, float]:
    """Run ``argv`` in ``cwd``: (the finished process, its CPU seconds, its peak resident memory in
    GB), both from the resource usage of this process alone (``os.wait4``; its own children that it
    waited for included), not of the runs before it."""
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        child = subprocess.Popen(argv, cwd=cwd, stdout=out, stderr=err, text=True, env=job_environment())
        _, status, usage = os.wait4(child.pid, 0)
        child.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        proc = subprocess.CompletedProcess(argv, child.returncode, out.read(), err.read())
    return proc, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024 ** 2


def wall_time_to(steps: typing.Sequence[dict], load: float) -> float | None:
    """Our wall time [s] up to the first converged step at load factor >= ``load`` (every attempt
    before it included); None if no converged step gets there."""
    total = 0.0
    for step in steps:
        total += float(step["wall_time_s"])
        if step["converged"] and step["load"] >= load - 1e-9:
            return total
    return None


def ours(name: str, extra: typing.Sequence[str], peer_load: float | None) -> Run:
    """Our demo of case ``name`` with the options ``extra`` after the case's; with the wall time to
    ``peer_load`` when given."""
    case = CASES[name]
    with tempfile.TemporaryDirectory() as out:
        argv = [sys.executable, str(ROOT / "demos" / case.demo), *case.options, *extra, "--quiet", "--out", out]
        proc, cpu, memory = run_measured(argv, ROOT)
        summary_path = pathlib.Path(out) / "summary.json"
        if not summary_path.exists():
            raise RuntimeError(f"{' '.join(argv)} wrote no summary ({proc.returncode}):\n{proc.stderr[-3000:]}")
        summary = json.loads(summary_path.read_text())
    done = [s for s in summary["steps"] if s["converged"]]
    economy = newton_economy(summary["steps"])
    return Run(name, "dolfinx-sfvem", " ".join(extra), max((s["load"] for s in done), default=0.0),
               economy["iterations"], economy["failed_share"], cpu, memory, summary["message"],
               wall_time_to(summary["steps"], peer_load) if peer_load else None)


#: dolfiny's progress lines: a load step's start, and SNES's converged reason
_STEP = re.compile(r"Load step (\d+)")
_REASON = re.compile(r"Nonlinear \S* ?solve (converged|did not converge) due to (\S+) iterations (\d+)")


def parse_peer(stdout: str, steps: int) -> tuple[float, int, str]:
    """(load factor reached, Newton iterations, the last reason) from a dolfiny demo's output: load
    step k of ``steps`` fixed ones is at k / steps; a step counts when SNES says it converged."""
    load, iterations, reason = 0.0, 0, ""
    step = 0
    for line in stdout.splitlines():
        if (match := _STEP.search(line)) is not None:
            step = int(match.group(1))
        elif (match := _REASON.search(line)) is not None:
            iterations += int(match.group(3))
            reason = match.group(2)
            if match.group(1) == "converged":
                load = step / steps
    return load, iterations, reason


#: runs the script argv[1] as __main__, MPI's libraries loaded first where the dolfinx-solver-* wheel
#: provides them (its ``dolfinx_solver`` must be imported before dolfinx)
_RUN_PEER = ("import runpy, sys\ntry:\n    import dolfinx_solver  # noqa: F401\nexcept ImportError:\n    pass\n"
             "sys.argv = sys.argv[1:]\nrunpy.run_path(sys.argv[0], run_name='__main__')")


@dataclasses.dataclass(frozen=True)
class PeerVariant:
    """A change to the peer's demo: None / False keeps what the demo has."""
    degree: int | None = None
    quadrature_degree: int | None = None
    no_aux: bool = False

    @property
    def label(self) -> str:
        """The row's options: empty for the demo as it is."""
        return ", ".join([f"P{self.degree}/Q{self.degree}"] * (self.degree is not None)
                         + [f"quadrature degree {self.quadrature_degree}"] * (self.quadrature_degree is not None)
                         + ["p = 0"] * self.no_aux)


def _replace_once(source: str, pattern: str, replacement: str) -> str:
    """``source`` with the one match of the regular expression ``pattern`` replaced (ValueError
    when the demo does not have exactly one: it changed, and the variant would be wrong)."""
    new, count = re.subn(pattern, replacement, source, flags=re.MULTILINE)
    if count != 1:
        raise ValueError(f"the peer's demo has {count} matches of {pattern!r}, not 1")
    return new


def peer_variant(source: str, variant: PeerVariant) -> str:
    """The peer's demo ``source`` changed as ``variant`` says: the displacement's degree, the
    quadrature degree of its measure, the auxiliary field p held at 0 by a Dirichlet condition on
    all its dofs. A degree other than 1 also drops the demo's VTX output (written for degree 1)."""
    if variant.degree is not None:
        source = _replace_once(source, r'fem\.functionspace\(mesh, \("Lagrange", 1, \(tdim,\)\)\)',
                               f'fem.functionspace(mesh, ("Lagrange", {variant.degree}, (tdim,)))')
        if variant.degree != 1:
            source = _replace_once(source, r"^ofile = VTXWriter\(.*\)$",
                                   "ofile = type('NoOutput', (), {'write': lambda *a: None, 'close': lambda *a: None})()")
    if variant.quadrature_degree is not None:
        source = _replace_once(source, r'metadata = \{"quadrature_degree": \d+\}',
                               f'metadata = {{"quadrature_degree": {variant.quadrature_degree}}}')
    if variant.no_aux:
        source = _replace_once(source, r"^(bcs = \[.*\])$",
                               "\\1\nbcs.append(dolfinx.fem.dirichletbc(np.zeros(3), np.arange(P.dofmap.index_map.size_local "
                               "+ P.dofmap.index_map.num_ghosts, dtype=np.int32), P))")
    return source


def peer(name: str, demos: pathlib.Path, python: str, variant: PeerVariant = PeerVariant()) -> Run:
    """dolfiny's demo of case ``name`` from the folder ``demos``, changed as ``variant`` says, run by
    ``python`` in a scratch directory (the demo writes its outputs beside it)."""
    case = CASES[name]
    with tempfile.TemporaryDirectory() as scratch:
        for script in demos.glob("*.py"):                      # the Hertz demo imports its mesh module
            source = script.read_text()
            if script.name == case.peer_script:
                source = peer_variant(source, variant)
            (pathlib.Path(scratch) / script.name).write_text(source)
        proc, cpu, memory = run_measured([python, "-c", _RUN_PEER, case.peer_script], pathlib.Path(scratch))
    load, iterations, reason = parse_peer(proc.stdout, case.peer_steps)
    return Run(name, "dolfiny", variant.label, load, iterations, None, cpu, memory, reason)


def table(rows: list[dict]) -> str:
    """The markdown table of all rows."""
    header = ("case", "code", "options", "load reached", "Newton its", "in failed attempts", "CPU [s]",
              "peak memory [GB]", "our wall time to the peer's load [s]", "date")

    def fmt(value, spec):
        return "-" if value is None else format(value, spec)
    body = [(r["case"], r["code"], r["options"] or "defaults", f"{r['load']:.3f}", str(r["newton_iterations"]),
             fmt(r["failed_share"], ".0%"), f"{r['cpu_s']:.0f}", f"{r['peak_memory_gb']:.2f}",
             fmt(r.get("wall_to_peer_load_s"), ".0f"), r["date"]) for r in rows]
    return "\n".join(markdown.table(header, body))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cases", nargs="+", choices=sorted(CASES), default=sorted(CASES))
    p.add_argument("--dolfiny", type=pathlib.Path, default=None, help="dolfiny's demo/tmc/3D folder")
    p.add_argument("--dolfiny-python", default=None, help="a Python with dolfiny and DOLFINx 0.11")
    p.add_argument("--ours-option", action="append", default=[],
                   help="an option for our demos, as --ours-option=--alpha-r=100 (repeatable)")
    p.add_argument("--peer-degree", type=int, default=None, help="the peer's displacement degree (default its own, 1)")
    p.add_argument("--peer-quadrature-degree", type=int, default=None, help="the peer's quadrature degree")
    p.add_argument("--peer-no-aux", action="store_true", help="the peer's auxiliary field held at p = 0")
    p.add_argument("--peer-only", action="store_true", help="run the peer's demo only, not ours")
    p.add_argument("--results", type=pathlib.Path, default=ROOT / "bench")
    p.add_argument("--report", action="store_true", help="only write peer3d.md again from peer3d.json")
    args = p.parse_args()
    if (args.dolfiny is None) != (args.dolfiny_python is None):
        p.error("give --dolfiny and --dolfiny-python together")
    if args.peer_only and args.dolfiny is None:
        p.error("--peer-only needs --dolfiny")
    path = args.results / "peer3d.json"
    rows = json.loads(path.read_text()) if path.exists() else []
    today = datetime.date.today().isoformat()
    extra = [token for option in args.ours_option for token in option.split("=", 1)]
    for name in [] if args.report else args.cases:
        variant = PeerVariant(args.peer_degree, args.peer_quadrature_degree, args.peer_no_aux)
        runs = [peer(name, args.dolfiny, args.dolfiny_python, variant)] if args.dolfiny is not None else []
        if not args.peer_only:
            peer_load = runs[0].load if runs and not variant.label else \
                next((r["load"] for r in rows if (r["case"], r["code"], r["options"]) == (name, "dolfiny", "")), None)
            runs.append(ours(name, extra, peer_load))
        for run in runs:
            row = {**dataclasses.asdict(run), "date": today}
            rows = [r for r in rows if (r["case"], r["code"], r["options"]) != (run.case, run.code, run.options)]
            rows.append(row)
            print(json.dumps(row), flush=True)
    peers = {r["case"]: r["load"] for r in rows if r["code"] == "dolfiny" and not r["options"]}
    path.write_text(json.dumps(rows, indent=1) + "\n")
    (args.results / "peer3d.md").write_text(
        "# Our 3D benchmarks beside dolfiny's demos\n\n"
        "Written by `bench/peer3d.py`: each case as our demo runs it with its defaults and as dolfiny's own "
        "demo does, on the same geometry and mesh size, one process each (the cases: the script's docstring). "
        f"The peer's loads reached: {', '.join(f'{k} {v:.3f}' for k, v in sorted(peers.items())) or 'not measured'}.\n\n"
        + table(sorted(rows, key=lambda r: (r["case"], r["code"], r["options"]))) + "\n")


if __name__ == "__main__":
    main()
