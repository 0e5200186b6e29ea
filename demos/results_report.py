"""The results page of ``make results`` (``docs/results.md``) from whatever summary.json files
exist: Table 2 and Table 3 beside the paper's values with an acceptance check, Fig. 4, per example
an SFVEM vs FEM table with curves and deformed configurations, the 1-rank vs N-rank check, where
we differ from the paper, the machine and the date. What it cannot compute (analysed causes, our
stated choices) is read from ``docs/results-notes.md``."""
from __future__ import annotations

import dataclasses
import datetime
import fnmatch
import math
import os
import pathlib
import re
import platform
import shutil
import statistics
import subprocess
import typing

import compare
from dolfinx_sfvem.output import markdown, post
from dolfinx_sfvem import paper
from dolfinx_sfvem.output.figure_output import save_png
from dolfinx_sfvem.output.run_summary import RunSummary, Step, read_summary
from results_plan import (EXAMPLES, METHOD_NAMES, METHODS, REPO, TABLE2_DIR, Case, Example, Run, clock,
                          run_name, sweep_dirs, table2_dirs, table3_dirs)

#: relative differences above these are listed under "Where we differ"
METHOD_TOLERANCE, RANK_TOLERANCE = 0.05, 1e-6
#: our gap counts as different from the paper's outside the paper's own mesh-to-mesh spread of
#: that row, or this factor if that is larger
GAP_FACTOR = 1.1
#: the Table 2 acceptance band of our gap / the paper's
RATIO_BAND = (0.1, 10.0)
#: Table 2 acceptance: every gap at this gamma is below this value
SMALL_GAMMA, SMALL_GAP = 1e-6, 1e-3


#: the measured notes the page includes (one section each)
NOTES = REPO / "docs" / "results-notes.md"


def read_notes(path: pathlib.Path) -> dict[str, str]:
    """The ``## `` sections of a Markdown file by heading; within a section, wrapped lines are joined
    into one line, a line starting with ``- `` and a blank line start a new one."""
    sections: dict[str, list[str]] = {}
    lines: list[str] = []
    for line in path.read_text().splitlines():
        if line.startswith("## "):
            lines = sections[line[3:].strip()] = []
            continue
        text = line.strip()
        if text and lines and lines[-1] and not text.startswith("- "):
            lines[-1] += " " + text
        else:
            lines.append(text)
    return {heading: "\n".join(body).strip("\n") for heading, body in sections.items()}


#: studies outside the paper's examples (kept by hand from their own demos), included verbatim
STUDIES = REPO / "docs" / "results-studies.md"

_NOTES = read_notes(NOTES)
#: what the FEM reference is, at the top of the page
FEM_NOTE = _NOTES["FEM reference"]
#: analysed causes of stopping short: (fnmatch pattern of run directories, what stops them)
ANALYSED_STOPS = [(heading.split("`")[1], text) for heading, text in _NOTES.items()
                  if heading.startswith("Stopped short:")]
#: analysed causes of SFVEM vs FEM force differences above METHOD_TOLERANCE, by example key
ANALYSED_METHOD_DIFFERENCES = {heading.split("`")[1]: text for heading, text in _NOTES.items()
                               if heading.startswith("SFVEM vs FEM:")}
#: choices stated in the demos' docstrings and meshes/README.md (not computed), one line each
STATED = _NOTES["Our choices"].split("\n")


def step_value(step: Step | None, key: str) -> float | None:
    """:meth:`Step.value` of ``step`` (None without a step)."""
    return step.value(key) if step is not None else None


def force(step: Step | None, condition: str) -> float | None:
    """-R_y of the boundary condition ``condition`` in ``step`` (None without a step)."""
    return step.force(condition) if step is not None else None


def final_step(summary: RunSummary | None) -> Step | None:
    """The last converged step (None if there is none)."""
    return summary.final_step if summary is not None else None


def field(summary: RunSummary | None, name: str) -> typing.Any:
    """An attribute of ``summary`` (None without a summary)."""
    return getattr(summary, name) if summary is not None else None


def status(summary: RunSummary | None, why: bool = False) -> str:
    """"full load", "full load, unstable" (a final state with negative pivots, not an answer),
    "not run", "interrupted at load ..." or "stopped at load ..." (with the failure message if ``why``)."""
    if summary is None:
        return "not run"
    if summary.converged:
        return "full load" if summary.stable is not False else "full load, unstable"
    how = "interrupted" if summary.interrupted else "stopped"
    message = f": {summary.message}" if why and not summary.interrupted else ""
    return f"{how} at load {summary.load_reached:.3g}{message}"


def relative(a: float | None, b: float | None) -> float | None:
    """(b - a) / |a|; None if either is missing or a = 0."""
    if a is None or b is None or a == 0 or not (math.isfinite(a) and math.isfinite(b)):
        return None
    return (b - a) / abs(a)


def fmt(value, spec: str = ".4g", missing: str = "—") -> str:
    """``value`` formatted with ``spec``; ``missing`` for None."""
    return missing if value is None else format(value, spec)


def final_gap(summary: RunSummary | None) -> float | None:
    """Gap at the full load (None if the run is missing or short of it)."""
    return step_value(final_step(summary), "gap") if summary and summary.converged else None


def table2_summaries(root: pathlib.Path) -> dict[tuple[float, float, int], RunSummary | None]:
    """Summary of every Table 2 run (None if not run)."""
    return {key: read_summary(d) for key, d in table2_dirs(root).items()}


def table3_summaries(root: pathlib.Path) -> dict[tuple[str, int], RunSummary | None]:
    """Summary of every Table 3 run (None if not run)."""
    return {key: read_summary(d) for key, d in table3_dirs(root).items()}


def gap_cell(summary: RunSummary | None) -> str:
    """Our final gap, or the run's status when there is none."""
    gap = final_gap(summary)
    return f"{gap:.4e}" if gap is not None else status(summary)


def ratio_cell(summary: RunSummary | None, theirs: float) -> str:
    """Our final gap over the paper's (— when there is none)."""
    gap = final_gap(summary)
    return "—" if gap is None else f"{gap / theirs:.3f}"


def gap_row(row: tuple, theirs: typing.Sequence[float], summaries: typing.Mapping[tuple, RunSummary | None]
            ) -> list[str]:
    """The row's parameters, then our gap, the paper's and their ratio on meshes 1-3."""
    cells = [f"{v:g}" if isinstance(v, float) else v for v in row]
    for m in (1, 2, 3):
        summary = summaries[(*row, m)]
        cells += [gap_cell(summary), f"{theirs[m - 1]:.4e}", ratio_cell(summary, theirs[m - 1])]
    return cells


def gap_table(row_names: typing.Sequence[str], rows: typing.Mapping[tuple, typing.Sequence[float]],
              summaries: typing.Mapping[tuple, RunSummary | None]) -> list[str]:
    """Our gap beside the paper's per row and mesh, then unknowns, run counts and wall time."""
    header = list(row_names) + [f"{what} mesh {m}" for m in (1, 2, 3) for what in ("g", "paper", "g/paper")]
    lines = markdown.table(header, [gap_row(row, theirs, summaries) for row, theirs in rows.items()])
    done = [s for s in summaries.values() if s is not None]
    dofs = {m: next((s.dofs for (*_, mm), s in summaries.items() if mm == m and s), None) for m in (1, 2, 3)}
    lines += ["", f"Unknowns (SFVEM): mesh 1 {fmt(dofs[1], 'd')}, mesh 2 {fmt(dofs[2], 'd')}, "
                  f"mesh 3 {fmt(dofs[3], 'd')}. Runs: {sum(s.converged for s in done)} of "
                  f"{len(summaries)} at full load, {len(summaries) - len(done)} not run; "
                  f"{sum(s.newton_iterations for s in done)} Newton iterations, solve wall time "
                  f"{clock(sum(s.wall_time_s for s in done if math.isfinite(s.wall_time_s)))} in all."]
    return lines


@dataclasses.dataclass(frozen=True)
class Check:
    """One acceptance criterion: PASS, FAIL, or INCOMPLETE (no failure, data missing)."""

    criterion: str
    result: str
    detail: str


def _verdict(outcomes: typing.Iterable[bool | None]) -> str:
    """FAIL if any is False, else INCOMPLETE if any is None (not evaluable), else PASS."""
    outcomes = list(outcomes)
    return "FAIL" if False in outcomes else "INCOMPLETE" if None in outcomes or not outcomes else "PASS"


def _decreasing(values: typing.Sequence[float | None]) -> bool | None:
    """Strictly decreasing over the available values (None if fewer than 2, or one missing)."""
    known = [v for v in values if v is not None]
    if len(known) < 2:
        return None
    falls = all(b < a for a, b in zip(known, known[1:]))
    return False if not falls else (None if len(known) < len(values) else True)


def _spread(values: typing.Iterable[float | None]) -> float | None:
    """log10(max / min) of the available values (None if fewer than 2)."""
    known = [v for v in values if v is not None]
    return math.log10(max(known) / min(known)) if len(known) >= 2 else None


def table2_acceptance(gaps: typing.Mapping[tuple[float, float, int], float | None]) -> list[Check]:
    """Acceptance of our Table 2 against the paper's (``paper.TABLE2``).

    Parameters
    ----------
    gaps
        Our final gap per (alpha_r, gamma, mesh); None or absent: not available (not run,
        or short of the full load).

    Returns
    -------
    list of Check
        Per row of Table 2: every gap within a factor 10 of the paper's; then: the gap falls
        as gamma falls (every alpha_r and mesh); gamma matters more than alpha_r (per mesh,
        the smallest log-spread over gamma exceeds the largest log-spread over alpha_r); every
        gamma = 1e-6 gap below 1e-3.
    """
    alpha_rs = sorted({a for a, _ in paper.TABLE2}, reverse=True)
    gammas = sorted({g for _, g in paper.TABLE2}, reverse=True)
    meshes = (1, 2, 3)
    gap = {key: gaps.get(key) for key in ((a, g, m) for a in alpha_rs for g in gammas for m in meshes)}
    lo, hi = RATIO_BAND
    checks = []
    for (a, g), theirs in paper.TABLE2.items():
        ratios = [None if gap[(a, g, m)] is None else gap[(a, g, m)] / theirs[m - 1] for m in meshes]
        checks.append(Check(f"alpha_r = {a:g}, gamma = {g:g}: g / paper in [{lo:g}, {hi:g}]",
                            _verdict(None if r is None else lo <= r <= hi for r in ratios),
                            " / ".join(fmt(r, ".3f") for r in ratios)))
    falls = {(a, m): _decreasing([gap[(a, g, m)] for g in gammas]) for a in alpha_rs for m in meshes}
    checks.append(Check("g falls as gamma falls (every alpha_r, mesh)", _verdict(falls.values()),
                        "; ".join(f"alpha_r {a:g} mesh {m}: {'—' if ok is None else 'yes' if ok else 'NO'}"
                                  for (a, m), ok in falls.items())))
    details, outcomes = [], []
    for m in meshes:
        by_gamma = [_spread(gap[(a, g, m)] for g in gammas) for a in alpha_rs]
        by_alpha = [_spread(gap[(a, g, m)] for a in alpha_rs) for g in gammas]
        complete = None not in by_gamma + by_alpha
        known_g, known_a = [s for s in by_gamma if s is not None], [s for s in by_alpha if s is not None]
        ok = min(known_g) > max(known_a) if known_g and known_a else None
        outcomes.append(ok if complete or ok is False else None)
        details.append(f"mesh {m}: {fmt(min(known_g, default=None), '.2f')} vs "
                       f"{fmt(max(known_a, default=None), '.2f')}")
    checks.append(Check("gamma matters more than alpha_r (smallest log10 spread over gamma > largest over alpha_r)",
                        _verdict(outcomes), "; ".join(details)))
    small = [gap[(a, SMALL_GAMMA, m)] for a in alpha_rs for m in meshes]
    checks.append(Check(f"every gamma = {SMALL_GAMMA:g} gap < {SMALL_GAP:g}",
                        _verdict(None if v is None else v < SMALL_GAP for v in small),
                        f"largest {fmt(max((v for v in small if v is not None), default=None), '.4e')}"))
    return checks


def overall(checks: typing.Sequence[Check]) -> str:
    """PASS, FAIL or INCOMPLETE over all checks (as :func:`_verdict`)."""
    return _verdict(False if c.result == "FAIL" else None if c.result == "INCOMPLETE" else True for c in checks)


def acceptance_lines(ours: typing.Sequence[Check], paper: typing.Sequence[Check]) -> list[str]:
    """The acceptance table with our result and the same check applied to the paper's values."""
    return markdown.table(("criterion", "ours", "detail (ours)", "paper's values"),
                 [(c.criterion, f"**{c.result}**", c.detail, p.result) for c, p in zip(ours, paper)]) + [
        "", f"Overall: **{overall(ours)}** (the paper's own values: {overall(paper)})."]


def paper_gaps() -> dict[tuple[float, float, int], float]:
    """The paper's Table 2 gaps keyed (alpha_r, gamma, mesh)."""
    return {(a, g, m): values[m - 1] for (a, g), values in paper.TABLE2.items() for m in (1, 2, 3)}


def summaries_of(example: Example, runs: typing.Mapping[str, Run], root: pathlib.Path
                 ) -> dict[tuple[str, str], RunSummary | None]:
    """Summary of every (case, method) run of ``example`` (None if not run or not planned)."""
    return {(c.name, m): read_summary(root / runs[run_name(example, c, m)].out) if run_name(example, c, m) in runs
            else None for c in example.cases for m in METHODS}


def method_difference(example: Example, vem: RunSummary | None, fem: RunSummary | None
                      ) -> tuple[float | None, float | None, float | None]:
    """(load factor, force difference, key-output difference): (FEM − SFVEM) / |SFVEM| at the
    largest load factor both runs reached (None where not available)."""
    load = compare.common_load(vem, fem) if vem and fem else None
    if load is None:
        return None, None, None
    a, b = (compare.step_at(x, load) for x in (vem, fem))
    key = example.output[0]
    return (load, relative(force(a, example.force), force(b, example.force)),
            relative(step_value(a, key), step_value(b, key)))


def method_label(method: str, summary: RunSummary | None) -> str:
    """SFVEM, or the FEM with its element (P2 on triangles, Q2 on quadrilaterals) from its summary."""
    if method == "fem" and summary is not None and "cell_type" in summary.discretization:
        return {"triangle": "P2 FEM", "quadrilateral": "Q2 FEM"}[summary.discretization["cell_type"]]
    return METHOD_NAMES[method]


def method_rows(example: Example, case: Case, vem: RunSummary | None, fem: RunSummary | None) -> list[list[str]]:
    """Rows SFVEM, FEM (P2 or Q2) and their relative difference at the largest load both reached."""
    key, _ = example.output
    rows = []
    for method, summary in (("vem", vem), ("fem", fem)):
        last = final_step(summary)
        rows.append([case.label, method_label(method, summary), status(summary),
                     fmt(field(summary, "ranks"), "d"), fmt(field(summary, "dofs"), "d"),
                     fmt(field(summary, "load_reached"), ".4g"), fmt(force(last, example.force)),
                     fmt(step_value(last, key)), fmt(field(summary, "newton_iterations"), "d"),
                     fmt(field(summary, "wall_time_s"), ".0f")])
    load, *diff = method_difference(example, vem, fem)
    where = "" if load is None or load >= 1 - 1e-9 else f" at load {load:.3g}"
    rows.append(["", f"FEM vs SFVEM{where}", "", "", "", ""] + [fmt(d, "+.2%") for d in diff] + ["", ""])
    return rows


def method_table(example: Example, summaries: typing.Mapping[tuple[str, str], RunSummary | None]) -> list[str]:
    """The SFVEM vs FEM table of an example, all its configurations."""
    header = ("configuration", "method", "status", "ranks", "unknowns", "load reached",
              f"force -R_y ({example.force})", example.output[1], "Newton iterations", "solve wall time [s]")
    rows = [r for c in example.cases for r in method_rows(example, c, summaries[(c.name, "vem")],
                                                          summaries[(c.name, "fem")])]
    return markdown.table(header, rows) + ["", "Values at the last converged step; the difference row is "
                                               "(FEM − SFVEM) / |SFVEM| at the largest load factor both runs "
                                               "reached."]


def plot_curves(example: Example, summaries: typing.Mapping[tuple[str, str], RunSummary | None],
                path: pathlib.Path) -> bool:
    """Force and key output over the prescribed displacement, SFVEM solid, FEM dashed (False if no data)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4), dpi=110, layout="constrained")
    key, label = example.output
    drawn = False
    for k, case in enumerate(example.cases):
        for method, style in zip(METHODS, ("-", "--")):
            summary = summaries[(case.name, method)]
            steps = summary.converged_steps if summary else []
            if not steps:
                continue
            uy = abs(float(summary.parameters["uy"]))
            x = [uy * s.load for s in steps]
            curves = ([force(s, example.force) for s in steps], [step_value(s, key) for s in steps])
            for ax, ys in zip(axes, curves):
                ax.plot(x, [math.nan if y is None else y for y in ys], style, color=f"C{k}",
                        label=f"{case.name} {METHOD_NAMES[method]}")
            drawn = True
    for ax, ylabel in zip(axes, (f"force $-R_y$ ({example.force})", label)):
        ax.set_xlabel("prescribed displacement $|u_y|$")
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
        if drawn:
            ax.legend(fontsize=8)
    if example.log_output:
        axes[1].set_yscale("log")
    fig.suptitle(f"{example.title}: SFVEM (solid) and FEM (dashed)")
    if drawn:
        path.parent.mkdir(parents=True, exist_ok=True)
        save_png(fig, path)
    else:
        plt.close(fig)
    return drawn


def copy_figure(source: pathlib.Path, docs: pathlib.Path, name: str) -> str | None:
    """Copy a PNG to ``docs/figures/<name>``; the relative link, or None if there is none."""
    if not source.is_file():
        return None
    (docs / "figures").mkdir(parents=True, exist_ok=True)
    shutil.copyfile(source, docs / "figures" / name)
    return f"figures/{name}"


def image(link: str | None, alt: str) -> str:
    """Markdown image, or "not run" without a link."""
    return f"![{alt}]({link})" if link else "not run"


def figure_lines(example: Example, runs: typing.Mapping[str, Run], root: pathlib.Path,
                 docs: pathlib.Path) -> list[str]:
    """Per case: deformed mesh and u_y of both methods, and the example's own SFVEM plots."""
    lines = []
    for case in example.cases:
        names = {m: run_name(example, case, m) for m in METHODS}
        dirs = {m: root / runs[n].out if n in runs else None for m, n in names.items()}
        rows = []
        for picture in ("deformed.png", "uy.png"):
            rows.append([image(copy_figure(dirs[m] / picture, docs, f"{names[m]}-{picture}") if dirs[m] else None,
                               f"{names[m]} {picture}") for m in METHODS])
        for picture in example.figures:
            link = copy_figure(dirs["vem"] / picture, docs, f"{names['vem']}-{picture}") if dirs["vem"] else None
            rows.append([image(link, picture), ""])
        lines += [f"#### {case.label}", ""] + markdown.table([METHOD_NAMES[m] for m in METHODS], rows) + [""]
    return lines


def example_section(example: Example, runs: typing.Mapping[str, Run], root: pathlib.Path,
                    docs: pathlib.Path) -> list[str]:
    """An example's SFVEM vs FEM table, its curves and its deformed configurations."""
    summaries = summaries_of(example, runs, root)
    lines = ["### SFVEM vs FEM", ""] + method_table(example, summaries) + [""]
    curves = docs / "figures" / f"{example.key}-curves.png"
    if plot_curves(example, summaries, curves):
        lines += [f"![{example.key} curves](figures/{curves.name})", ""]
    return lines + ["### Deformed configurations", ""] + figure_lines(example, runs, root, docs)


def rank_pairs(runs: typing.Sequence[Run], root: pathlib.Path
               ) -> list[tuple[Example, str, RunSummary | None, RunSummary | None]]:
    """(example, N-rank run name, 1-rank summary, N-rank summary) of every rank-check run."""
    by_name = {r.name: r for r in runs}
    return [(next(e for e in EXAMPLES if e.demo == run.demo), run.reference, read_summary(root / run.out),
             read_summary(root / by_name[run.reference].out) if run.reference in by_name else None)
            for run in runs if run.reference is not None]


def rank_row(example: Example, name: str, one: RunSummary | None, many: RunSummary | None) -> list[str]:
    """Load reached, force and key output on 1 and N ranks, wall times."""
    forces = [force(final_step(s), example.force) for s in (one, many)]
    outputs = [step_value(final_step(s), example.output[0]) for s in (one, many)]
    return [name, fmt(field(many, "ranks"), "d"), fmt(field(one, "load_reached")),
            fmt(field(many, "load_reached")), fmt(forces[0], ".6g"), fmt(forces[1], ".6g"),
            fmt(relative(forces[1], forces[0]), ".1e"), fmt(outputs[0], ".6g"), fmt(outputs[1], ".6g"),
            fmt(field(one, "wall_time_s"), ".0f"), fmt(field(many, "wall_time_s"), ".0f")]


def rank_section(runs: typing.Sequence[Run], root: pathlib.Path) -> list[str]:
    """The 1-rank vs N-rank table of all examples."""
    header = ("run", "N", "load (1 rank)", "load (N ranks)", "force (1)", "force (N)", "relative difference",
              "key output (1)", "key output (N)", "wall [s] (1)", "wall [s] (N)")
    rows = [rank_row(*pair) for pair in rank_pairs(runs, root)]
    if not rows:
        return ["Not planned (--np 1).", ""]
    return markdown.table(header, rows) + ["", "Force and key output (as in the example's table) at the last "
                                               "converged step; relative difference (1 rank − N ranks) / |N ranks|.",
                                           ""]


def overview(runs: typing.Sequence[Run], root: pathlib.Path) -> list[str]:
    """Every planned run: status, ranks, unknowns, load reached, solve wall time, options."""
    rows = []
    for run in runs:
        if run.sweep:
            rows.append([run.name, sweep_status(run, root), str(run.ranks), "", "", "", " ".join(run.argv)])
            continue
        summary = read_summary(root / run.out)
        rows.append([run.name, status(summary), str(run.ranks), fmt(field(summary, "dofs"), "d"),
                     fmt(field(summary, "load_reached")), fmt(field(summary, "wall_time_s"), ".0f"),
                     " ".join(run.argv)])
    return markdown.table(("run", "status", "ranks", "unknowns", "load reached", "solve wall time [s]", "options"),
                          rows)


def sweep_status(run: Run, root: pathlib.Path) -> str:
    """How many of a sweep's runs are at full load (Fig. 4: whether fig4.png exists)."""
    if run.name == "box-fig4":
        return "fig4.png written" if (root / run.out / "fig4.png").is_file() else "not run"
    summaries = {key: read_summary(d) for key, d in sweep_dirs(run, root).items()}
    done = sum(bool(s and s.converged) for s in summaries.values())
    return f"{done} of {len(summaries)} runs at full load"


def machine() -> str:
    """CPU model, cores, OS, date and commit."""
    model = platform.processor() or platform.machine()
    try:
        model = next(line.split(":", 1)[1].strip() for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines()
                     if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    try:
        commit = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        commit = "unknown"
    return (f"{model}, {os.cpu_count()} cores, {platform.system()} {platform.release()}; "
            f"generated {datetime.datetime.now():%Y-%m-%d %H:%M}, commit {commit}")


def differences(runs: typing.Sequence[Run], root: pathlib.Path) -> list[str]:
    """Bullet points computed from the data, then the stated modelling choices."""
    items = _gap_differences(root) + _short_runs(root) + _method_differences(runs, root) \
        + _rank_differences(runs, root) + _projection_orders(root)
    return [f"- {item}" for item in items] + [""] + STATED + [""]


def label(key: tuple) -> str:
    """A Table 2 / Table 3 row key as text: "alpha_r 10, gamma 1e-06" or the regularization."""
    return f"alpha_r {key[0]:g}, gamma {key[1]:g}" if len(key) == 2 else str(key[0])


def _gap_differences(root: pathlib.Path) -> list[str]:
    """Our gap against the paper's, measured against the spread of the paper's own meshes."""
    items = []
    tables = (("Table 2", table2_summaries(root), paper.TABLE2),
              ("Table 3", table3_summaries(root), {(r,): v for r, v in paper.TABLE3.items()}))
    for name, summaries, theirs in tables:
        ratios, outside = [], []
        for key, values in theirs.items():
            spread = max(max(values) / min(values), GAP_FACTOR)
            for m in (1, 2, 3):
                gap = final_gap(summaries[(*key, m)])
                if gap is None:
                    continue
                r = gap / values[m - 1]
                ratios.append(r)
                if not 1 / spread <= r <= spread:
                    outside.append(f"{label(key)}, mesh {m}: {r:.2f}")
        if not ratios:
            items.append(f"{name}: not run.")
            continue
        items.append(f"{name}: our gap / the paper's over {len(ratios)} runs: median {statistics.median(ratios):.2f}, "
                     f"range {min(ratios):.2f} to {max(ratios):.2f}. "
                     + (f"Outside the paper's own spread over its three meshes for that row (or "
                        f"{GAP_FACTOR - 1:.0%} where that is smaller): {'; '.join(outside)}. "
                        f"Not analysed." if outside else
                        f"Every one is within the paper's own spread over its three meshes for that row (or "
                        f"{GAP_FACTOR - 1:.0%} where that is smaller)."))
    return items


def made_runs(root: pathlib.Path) -> dict[str, RunSummary]:
    """Every summary under ``root`` (sweep runs included, superseded ones not), by directory."""
    found = {str(path.parent.relative_to(root)): read_summary(path.parent) for path in root.glob("**/summary.json")
             if "superseded" not in path.relative_to(root).parts}
    return {name: found[name] for name in sorted(found) if found[name] is not None}


def explain_stops(names: typing.Iterable[str]) -> tuple[dict[str, list[str]], list[str]]:
    """Sort run directories that stopped short by :data:`ANALYSED_STOPS`.

    Returns
    -------
    explained
        Explanation -> the runs it covers.
    unexplained
        Runs no analysed cause covers.
    """
    explained: dict[str, list[str]] = {}
    unexplained = []
    for name in names:
        cause = next((why for pattern, why in ANALYSED_STOPS if fnmatch.fnmatch(name, pattern)), None)
        if cause is None:
            unexplained.append(name)
        else:
            explained.setdefault(cause, []).append(name)
    return explained, unexplained


def _short_runs(root: pathlib.Path) -> list[str]:
    """Every run made (sweeps included) that stopped short of the full load, with its message and,
    where analysed, the cause."""
    short = {name: s for name, s in made_runs(root).items() if not s.converged}
    paused = [name for name, s in short.items() if s.interrupted]
    failed = {name: s for name, s in short.items() if name not in paused}
    items = [f"Interrupted, `make results` continues them: {', '.join(paused)}."] if paused else []
    if not failed:
        return items + ["Every run that finished reached the full load."]
    explained, unexplained = explain_stops(failed)
    items += [f"Runs short of the full load: {'; '.join(f'{n} ({status(s, why=True)})' for n, s in failed.items())}."]
    items += [f"Why ({', '.join(names)}): {why}." for why, names in explained.items()]
    if unexplained:
        items.append(f"Not analysed: {', '.join(unexplained)}.")
    return items


def _method_differences(runs: typing.Sequence[Run], root: pathlib.Path) -> list[str]:
    """SFVEM vs FEM: the largest relative force difference per example."""
    by_name = {r.name: r for r in runs}
    items = []
    for example in EXAMPLES:
        summaries = summaries_of(example, by_name, root)
        diffs = {c.name: method_difference(example, summaries[(c.name, "vem")], summaries[(c.name, "fem")])[1]
                 for c in example.cases}
        known = {k: d for k, d in diffs.items() if d is not None}
        if not known:
            continue
        worst = max(known, key=lambda k: abs(known[k]))
        note = "" if abs(known[worst]) <= METHOD_TOLERANCE else \
            f", above {METHOD_TOLERANCE:.0%}. Why: {ANALYSED_METHOD_DIFFERENCES[example.key]}" \
            if example.key in ANALYSED_METHOD_DIFFERENCES else \
            f", above {METHOD_TOLERANCE:.0%}, not analysed"
        items.append(f"{example.title}: SFVEM and FEM forces differ by at most {known[worst]:+.2%} "
                     f"({worst}){note}.")
    return items


def _rank_differences(runs: typing.Sequence[Run], root: pathlib.Path) -> list[str]:
    """The largest relative difference of the final force between 1 and N ranks."""
    diffs = [(name, relative(force(final_step(many), example.force), force(final_step(one), example.force)))
             for example, name, one, many in rank_pairs(runs, root)
             if one and many and one.converged and many.converged]
    known = [(n, d) for n, d in diffs if d is not None]
    if not known:
        return []
    worst = max(known, key=lambda x: abs(x[1]))
    verdict = "" if abs(worst[1]) <= RANK_TOLERANCE else " Above 1e-6, not analysed."
    return [f"1 rank vs N ranks: final forces agree to {abs(worst[1]):.1e} relative at worst ({worst[0]}).{verdict}"]


def _projection_orders(root: pathlib.Path) -> list[str]:
    """Runs in which the rank check chose l > 3 (the paper uses l = 3 throughout)."""
    made = made_runs(root)
    higher = {name: sum(n for l, n in s.discretization.get("projection_order_histogram", {}).items()
                        if int(l) > 3) for name, s in made.items()}
    higher = {name: n for name, n in higher.items() if n}
    if not higher:
        return []
    most = max(higher, key=higher.get)
    return [f"Projection order l: the paper uses l = 3; our rank check ([method.md](method.md) §3) chose "
            f"l > 3 in {len(higher)} of {len(made)} runs, on at most {higher[most]} of {made[most].discretization['polygons']} "
            f"polygons ({most}): polygons with 8 or more vertices (the paper's Eq. 40 also asks for l > 3 "
            f"there) or with several hanging nodes on one side, which keep spurious zero-energy modes at "
            f"l = 3 (`meshes/summary.md`)."]


def box_tables(root: pathlib.Path, docs: pathlib.Path) -> tuple[list[str], list[Check]]:
    """Table 2 with the acceptance check, Table 3 and Fig. 4; also returns our checks."""
    t2 = table2_summaries(root)
    ours = table2_acceptance({k: final_gap(s) for k, s in t2.items()})
    fig4 = copy_figure(root / TABLE2_DIR / "fig4.png", docs, "box-fig4.png")
    lines = ["### Table 2: gap g at u_y = -1, huhu_lulu with exp(-5 J)", ""]
    lines += gap_table(("alpha_r", "gamma"), paper.TABLE2, t2) + ["", "#### Acceptance check", ""]
    lines += acceptance_lines(ours, table2_acceptance(paper_gaps())) + [""]
    lines += [f"### Table 3: gap g, gamma = {paper.TABLE3_GAMMA:g}, alpha_r = {paper.TABLE3_ALPHA_R:g}, "
              "no scaling", ""]
    lines += gap_table(("regularization",), {(r,): v for r, v in paper.TABLE3.items()}, table3_summaries(root))
    lines += ["", "### Fig. 4: gap and force over the load, alpha_r = 0.1, meshes 2 and 3", "", image(fig4, "Fig. 4"), ""]
    return lines, ours


def report(runs: typing.Sequence[Run], root: pathlib.Path, docs: pathlib.Path, quick: bool) -> tuple[str, list[Check]]:
    """The Markdown page (PNGs copied to ``docs/figures``) and the Table 2 acceptance checks."""
    by_name = {r.name: r for r in runs}
    lines = ["# Results: the paper's examples with SFVEM and FEM", "",
             f"Generated by `make results` (`demos/results.py`{' --quick' if quick else ''}) from the runs in "
             f"`{root}`. Machine: {machine()}.", "", FEM_NOTE, ""]
    if quick:
        lines += ["**Quick mode: coarse meshes and few load steps, not the paper's settings.**", ""]
    lines += ["## Runs", ""] + overview(runs, root) + [""]
    checks: list[Check] = []
    for example in EXAMPLES:
        lines += [f"## {example.title}", ""]
        if example.key == "box":
            box_lines, checks = box_tables(root, docs)
            lines += box_lines
        lines += example_section(example, by_name, root, docs)
    lines += [re.sub(r"<!--.*?-->\s*", "", STUDIES.read_text(), flags=re.S).rstrip(), ""]
    lines += ["## 1 rank vs N ranks", ""] + rank_section(runs, root)
    lines += ["## Where we differ from the paper and why", ""] + differences(runs, root)
    lines += ["## Reproduce", "", "```", "make results                 # everything (hours; restartable)",
              "make results RESULTS_OPTS=--quick   # the pipeline on coarse meshes in a few minutes",
              "python3 demos/results.py --list     # the plan with states and estimated times", "```", ""]
    return "\n".join(lines), checks


def write_report(runs: typing.Sequence[Run], root: pathlib.Path, docs: pathlib.Path, quick: bool) -> list[Check]:
    """Write ``docs/results.md``; returns the Table 2 acceptance checks."""
    docs.mkdir(parents=True, exist_ok=True)
    text, checks = report(runs, root, docs, quick)
    post.atomic_write_text(docs / "results.md", text)
    return checks
