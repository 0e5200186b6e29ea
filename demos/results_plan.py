"""The plan of ``make results``: the paper's examples, their configurations, the box sweeps and the
rank check as a list of runs (demo, options, ranks, output directory, estimated time)."""
from __future__ import annotations

import dataclasses
import datetime
import fnmatch
import pathlib
import typing

import box_self_contact as box
from dolfinx_sfvem import paper

DEMOS = pathlib.Path(__file__).resolve().parent
REPO = DEMOS.parent
METHODS = ("vem", "fem")
METHOD_NAMES = {"vem": "SFVEM", "fem": "FEM"}
#: run-time factor of a 1-rank run against a 2-rank run (estimates only)
SERIAL_FACTOR = 1.8
TABLE2_DIR, TABLE3_DIR = "box-table2", "box-table3"
BOX_QUICK = ("--h", "0.1", "--steps", "10")
CBOX_QUICK = ("--h", "0.1", "--steps", "10")
PUNCH_QUICK = ("--h", "0.15", "--steps", "26")
MULTI_QUICK = ("--h", "0.1", "--steps", "6")


@dataclasses.dataclass(frozen=True)
class Case:
    """One configuration of an example, run with both methods.

    Attributes
    ----------
    name, label
        Short name (part of the run names) and its description on the page.
    args
        Demo options of the full run (``--name value`` pairs); ``quick`` replaces or adds
        some in ``--quick`` mode.
    seconds, quick_seconds
        Estimated wall time of the SFVEM run on 2 ranks (start-up included), full and quick.
    vem_out
        Output directory of the SFVEM run if not its own (the box case lives in the Table 2
        sweep, which then reuses it).
    """

    name: str
    label: str
    args: tuple[str, ...]
    quick: tuple[str, ...]
    seconds: float
    quick_seconds: float = 10.0
    vem_out: str | None = None


@dataclasses.dataclass(frozen=True)
class Example:
    """One of the paper's examples: its demo, what is compared, which pictures are shown.

    Attributes
    ----------
    force
        Boundary condition whose reaction -R_y is the example's force.
    output
        (key, label) of the key output: an observer in the steps' ``extra`` or a step field
        such as ``max_displacement``; ``log_output`` plots it on a logarithmic scale.
    figures
        PNGs of the SFVEM runs shown besides deformed.png and uy.png.
    """

    key: str
    title: str
    demo: str
    force: str
    output: tuple[str, str]
    cases: tuple[Case, ...]
    figures: tuple[str, ...] = ()
    log_output: bool = False


@dataclasses.dataclass(frozen=True)
class Run:
    """One subprocess: a demo run (or sweep) with its options, ranks and output directory."""

    name: str
    demo: str
    argv: tuple[str, ...]
    ranks: int
    out: str
    seconds: float
    sweep: bool = False
    reference: str | None = None


BOX_CASE_DIR = str(box.run_dir(pathlib.Path(TABLE2_DIR), "huhu_lulu", paper.TABLE2_BETA, 1.0, 1e-5, 1))
EXAMPLES = (
    Example("cbox", "C-box (§5.2)", "cbox", "load", ("tip_ux", "u_x of the loaded tip"), (
        Case("mesh1", "u_y = -0.5, gamma = 1e-5, alpha_r = 1, medium mesh 1",
             ("--uy", "-0.5", "--steps", "50", "--mesh", "1"), CBOX_QUICK, 40, 4),
        Case("mesh2", "u_y = -0.5, gamma = 1e-5, alpha_r = 1, medium mesh 2",
             ("--uy", "-0.5", "--steps", "50", "--mesh", "2"), CBOX_QUICK, 90, 5),
        Case("uy1", "u_y = -1, gamma = 1e-5, alpha_r = 20, medium mesh 2",
             ("--uy", "-1", "--alpha-r", "20", "--steps", "100", "--mesh", "2"), ("--h", "0.1", "--steps", "20"),
             150, 6))),
    Example("box", "Box self-contact (§5.1)", "box_self_contact", "load", ("gap", "gap g at mid-span"), (
        Case("mesh1", "mesh 1, gamma = 1e-5, alpha_r = 1, huhu_lulu with exp(-5 J)",
             ("--mesh", "1", "--gamma", "1e-5", "--alpha-r", "1"), BOX_QUICK, 240, 5, vem_out=BOX_CASE_DIR),),
        figures=("gap.png",), log_output=True),
    Example("multi", "Multiple objects (§5.4)", "multi_object", "discs", ("max_displacement", "max |u|"), (
        Case("bc1", "BC 1: block clamped at both ends, discs u_x = 0", ("--bc", "1"), MULTI_QUICK, 330, 13),
        Case("bc2", "BC 2: block clamped left, simply supported right, discs u_x free", ("--bc", "2"),
             MULTI_QUICK, 330, 13)),
        figures=("zoom.png",)),
    Example("punch", "Punch (§5.3)", "punch", "load", ("gap", "gap on the axis"), (
        Case("soft", "soft punch (K = 5/3, mu = 5/14), u_y = -1.3 in 130 steps", ("--punch", "soft"),
             PUNCH_QUICK, 1500, 15),
        Case("rigid", "rigid punch (K = 500/3, mu = 500/14), u_y = -1.3 in 130 steps", ("--punch", "rigid"),
             PUNCH_QUICK, 1800, 30)), log_output=True),
)
#: the box sweeps: (run name, options, output directory, estimated full / quick seconds); Fig. 4 on
#: medium meshes 2 and 3 (the paper's mesh 3 stops short, docs/results-notes.md)
SWEEPS = (("box-table2", ("--table2",), TABLE2_DIR, 3 * 3600, 60),
          ("box-table3", ("--table3",), TABLE3_DIR, 3600, 20),
          ("box-fig4", ("--fig4", "--meshes", "2", "3"), TABLE2_DIR, 0, 5))


def override(options: typing.Sequence[str], new: typing.Sequence[str]) -> tuple[str, ...]:
    """``options`` (``--name value`` pairs) with the values in ``new`` replacing or added."""
    pairs = dict(zip(options[::2], options[1::2]))
    pairs.update(zip(new[::2], new[1::2]))
    return tuple(item for pair in pairs.items() for item in pair)


def run_name(example: Example, case: Case, method: str, ranks: int | None = None) -> str:
    """``<example>-<case>-<method>``, with ``-np<ranks>`` for the rank check runs."""
    return f"{example.key}-{case.name}-{method}" + (f"-np{ranks}" if ranks is not None else "")


def plan(quick: bool, ranks: int) -> list[Run]:
    """All runs in the order they are made: examples, sweeps, then the 1-rank check."""
    def case_run(example: Example, case: Case, method: str, n: int, check: bool) -> Run:
        name = run_name(example, case, method, n if check else None)
        out = case.vem_out if method == "vem" and not check and case.vem_out else name
        seconds = (case.quick_seconds if quick else case.seconds) * (SERIAL_FACTOR if n == 1 else 1.0)
        return Run(name, example.demo, ("--method", method, *override(case.args, case.quick if quick else ())), n, out,
                   seconds, reference=run_name(example, case, method) if check else None)

    runs = [case_run(e, c, m, ranks, False) for e in EXAMPLES for c in e.cases for m in METHODS]
    sweep_quick = ("--meshes", "1", *BOX_QUICK) if quick else ()
    runs += [Run(name, box.__name__, (*options, *sweep_quick), ranks, out, quick_s if quick else full_s, sweep=True)
             for name, options, out, full_s, quick_s in SWEEPS]
    if ranks != 1:
        runs += [case_run(e, e.cases[0], m, 1, True) for e in EXAMPLES for m in METHODS]
    return runs


def select(runs: typing.Sequence[Run], only: str | None) -> list[Run]:
    """The runs matching one of the comma-separated shell patterns of ``only`` (all for None)."""
    if only is None:
        return list(runs)
    patterns = [p.strip() for p in only.split(",") if p.strip()]
    unknown = [p for p in patterns if not any(fnmatch.fnmatchcase(r.name, p) for r in runs)]
    if unknown:
        raise ValueError(f"--only: no run matches {', '.join(unknown)}; runs: {', '.join(r.name for r in runs)}")
    return [r for r in runs if any(fnmatch.fnmatchcase(r.name, p) for p in patterns)]


def table2_dirs(root: pathlib.Path) -> dict[tuple[float, float, int], pathlib.Path]:
    """Directory of every Table 2 run, keyed (alpha_r, gamma, mesh)."""
    return {(a, g, m): box.run_dir(root / TABLE2_DIR, "huhu_lulu", paper.TABLE2_BETA, a, g, m)
            for a, g in paper.TABLE2 for m in (1, 2, 3)}


def table3_dirs(root: pathlib.Path) -> dict[tuple[str, int], pathlib.Path]:
    """Directory of every Table 3 run, keyed (regularization, mesh)."""
    return {(r, m): box.run_dir(root / TABLE3_DIR, r, None, paper.TABLE3_ALPHA_R, paper.TABLE3_GAMMA, m)
            for r in paper.TABLE3 for m in (1, 2, 3)}


def sweep_dirs(run: Run, root: pathlib.Path) -> dict[tuple, pathlib.Path]:
    """The directories of a sweep's runs (Fig. 4: those of Table 2, whose runs it shares)."""
    return table2_dirs(root) if run.out == TABLE2_DIR else table3_dirs(root)


def clock(seconds: float) -> str:
    """h:mm:ss."""
    return str(datetime.timedelta(seconds=round(seconds)))
