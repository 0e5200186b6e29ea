"""The results of the equal-accuracy benchmark (``accuracy.py``) from its run records: per example
the reference force and gap with their errors, the cheapest run of each method meeting the
criteria, the SFVEM/FEM time ratio and the goal's verdict; as a dict (accuracy.json) and a
Markdown page (accuracy.md). No solver, no timing: the records hold the measurements."""
from __future__ import annotations

import dataclasses
import datetime
import math
import typing

from accuracy_plan import EXAMPLES, METHOD_NAMES, METHODS, Config
from accuracy_reference import Extrapolation, Outcome, Reference, cheapest, reference, relative_deviation, richardson

#: the accuracy criteria: force within 1 %, gap within 5 % of the reference (relative)
FORCE_TOLERANCE, GAP_TOLERANCE = 0.01, 0.05
#: a reference is sound when its own relative error is at most this fraction of the tolerance
SOUND_FRACTION = 1.0 / 3.0
#: the goal: SFVEM time to the answer <= the FEM's on at least this many of the four examples
GOAL_EXAMPLES = 3
QUANTITIES = ("force", "gap")
TOLERANCES = {"force": FORCE_TOLERANCE, "gap": GAP_TOLERANCE}


def time_to_answer(record: dict) -> float:
    """Set-up (mesh, discretization, local refinement) + the load path (summary.json's wall time) [s]."""
    path = record["summary_wall_s"]
    return record["setup"]["wall"] + (path if path is not None else record["solve"]["wall"])


def outcome(config: Config, record: dict) -> Outcome:
    return Outcome(config.name, config.method, config.kind, bool(record["converged"]) and record["exit_code"] == 0,
                   record["force"] if record["force"] is not None else math.nan,
                   record["gap"] if record["gap"] is not None else math.nan, time_to_answer(record))


def extrapolations(configs: typing.Sequence[Config], records: typing.Mapping[str, dict], quantity: str
                   ) -> dict[str, Extrapolation]:
    """Per method, the Richardson limit of ``quantity`` over its converged uniform runs (two or more)."""
    parts = {}
    for method in METHODS:
        ladder = sorted(((c.h, records[c.name][quantity]) for c in configs
                         if c.method == method and c.kind == "uniform" and c.name in records
                         and records[c.name]["converged"] and records[c.name][quantity] is not None), reverse=True)
        if len(ladder) >= 2:
            parts[method] = richardson([h for h, _ in ladder], [f for _, f in ladder])
    return parts


@dataclasses.dataclass
class ExampleResult:
    """The analysis of one example."""

    key: str
    configs: list[Config]
    records: dict[str, dict]
    references: dict[str, Reference]
    best: dict[str, Outcome | None]          # "vem" (uniform or local), "vem uniform", "vem local", "fem"

    @property
    def complete(self) -> bool:
        return all(c.name in self.records for c in self.configs)

    @property
    def sound(self) -> dict[str, bool]:
        """Per quantity: the reference's relative error is well below the criterion."""
        return {q: r.relative_error <= SOUND_FRACTION * TOLERANCES[q] for q, r in self.references.items()}

    @property
    def ratio(self) -> float | None:
        """SFVEM / FEM time to the answer (None unless both met the criteria)."""
        vem, fem = self.best.get("vem"), self.best.get("fem")
        return vem.time_s / fem.time_s if vem and fem else None

    @property
    def verdict(self) -> str:
        """``SFVEM`` (its time <= the FEM's, or only it met the criteria), ``FEM``, or ``undecided``
        (no reference, or neither met the criteria)."""
        vem, fem = self.best.get("vem"), self.best.get("fem")
        if len(self.references) < 2 or not (vem or fem):
            return "undecided"
        if vem and fem:
            return "SFVEM" if vem.time_s <= fem.time_s else "FEM"
        return "SFVEM" if vem else "FEM"


def analyse(key: str, configs: typing.Sequence[Config], records: typing.Mapping[str, dict]) -> ExampleResult:
    """References, and the cheapest run of each method meeting the criteria, for one example."""
    mine = [c for c in configs if c.example.key == key]
    done = {c.name: records[c.name] for c in mine if c.name in records}
    references = {}
    for q in QUANTITIES:
        parts = extrapolations(mine, done, q)
        if parts:
            references[q] = reference(parts)
    best: dict[str, Outcome | None] = {}
    if len(references) == 2:
        outcomes = [outcome(c, done[c.name]) for c in mine if c.name in done]
        choose = {"vem": lambda o: o.method == "vem", "vem uniform": lambda o: o.method == "vem" and o.kind == "uniform",
                  "vem local": lambda o: o.method == "vem" and o.kind == "local", "fem": lambda o: o.method == "fem"}
        best = {k: cheapest([o for o in outcomes if pick(o)], references["force"], references["gap"],
                            FORCE_TOLERANCE, GAP_TOLERANCE) for k, pick in choose.items()}
    return ExampleResult(key, mine, done, references, best)


def goal(results: typing.Sequence[ExampleResult]) -> str:
    """The goal's verdict in one sentence."""
    wins = [r.key for r in results if r.verdict == "SFVEM"]
    state = "met" if len(wins) >= GOAL_EXAMPLES else "not met"
    return (f"SFVEM time to the answer <= the FEM's on {len(wins)} of {len(results)} examples "
            f"({', '.join(wins) or 'none'}): goal ({GOAL_EXAMPLES} of 4) {state}")


# --------------------------------------------------------------------------- JSON
def _extrapolation_dict(e: Extrapolation) -> dict:
    return dataclasses.asdict(e)


def as_json(results: typing.Sequence[ExampleResult], machine: dict, quick: bool) -> dict:
    """accuracy.json: every run's record, the references, the choices, ratios and the verdict."""
    examples = {}
    for r in results:
        examples[r.key] = {
            "references": {q: {"value": ref.value, "error": ref.error, "relative_error": ref.relative_error,
                               "sound": r.sound[q], "methods": {m: _extrapolation_dict(e) for m, e in ref.parts.items()}}
                           for q, ref in r.references.items()},
            "cheapest": {k: (dataclasses.asdict(o) if o else None) for k, o in r.best.items()},
            "ratio_vem_over_fem": r.ratio, "verdict": r.verdict, "complete": r.complete,
            "runs": [{"name": c.name, "method": c.method, "kind": c.kind, "label": c.label, "h": c.h,
                      "refine": [list(x) for x in c.refine], "record": r.records.get(c.name),
                      "time_to_answer_s": time_to_answer(r.records[c.name]) if c.name in r.records else None}
                     for c in r.configs]}
    return {"quick": quick, "machine": machine, "criteria": {"force": FORCE_TOLERANCE, "gap": GAP_TOLERANCE},
            "goal": goal(results), "examples": examples}


# --------------------------------------------------------------------------- Markdown
def _pct(x: float | None, digits: int = 2) -> str:
    return "—" if x is None or not math.isfinite(x) else f"{100 * x:+.{digits}f} %"


def _seconds(s: float | None) -> str:
    return "—" if s is None else f"{s:.1f}"


def _reference_cell(ref: Reference | None, digits: int = 5) -> str:
    if ref is None:
        return "—"
    return f"{ref.value:.{digits}g} ± {100 * ref.relative_error:.2f} %"


def _best_cell(r: ExampleResult, key: str) -> str:
    o = r.best.get(key)
    if o is None:
        return "none in the ladder" if len(r.references) == 2 else "—"
    rec = r.records[o.name]
    config = next(c for c in r.configs if c.name == o.name)
    return (f"{config.label}: {rec['unknowns']} unknowns, {rec['newton_iterations']} Newton its, "
            f"{o.time_s:.1f} s")


def summary_table(results: typing.Sequence[ExampleResult]) -> list[str]:
    lines = ["| example | reference force | reference gap | SFVEM cheapest | FEM cheapest | SFVEM/FEM time | verdict |",
             "|---|---|---|---|---|---|---|"]
    for r in results:
        caveat = [q for q, ok in r.sound.items() if not ok]
        verdict = r.verdict + (f" (reference {' and '.join(caveat)} error not well below the criterion)" if caveat else "")
        if not r.complete:
            verdict += " (incomplete)"
        lines.append(f"| {EXAMPLES[r.key].title} | {_reference_cell(r.references.get('force'))} | "
                     f"{_reference_cell(r.references.get('gap'), 4)} | {_best_cell(r, 'vem')} | {_best_cell(r, 'fem')} | "
                     f"{'—' if r.ratio is None else f'{r.ratio:.2f}'} | {verdict} |")
    return lines


def runs_table(r: ExampleResult) -> list[str]:
    lines = ["| method | configuration | unknowns | Newton its | steps | time [s] | set-up / path / process [s] | "
             "CPU [s] | force | vs ref | gap | vs ref | meets |",
             "|---|---|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|---|"]
    force, gap = r.references.get("force"), r.references.get("gap")
    for c in sorted(r.configs, key=lambda c: (c.method != "vem", c.kind, -c.h)):
        rec = r.records.get(c.name)
        if rec is None:
            lines.append(f"| {METHOD_NAMES[c.method]} | {c.label} | not run | | | | | | | | | | |")
            continue
        o = outcome(c, rec)
        status = "" if o.converged else f" (stopped at load {rec['load']:.3g})"
        ok = (force is not None and gap is not None and o.converged
              and abs(relative_deviation(o.force, force)) <= FORCE_TOLERANCE
              and abs(relative_deviation(o.gap, gap)) <= GAP_TOLERANCE)
        cpu = rec["setup"]["cpu"] + rec["solve"]["cpu"]
        lines.append(
            f"| {METHOD_NAMES[c.method]} | {c.label}{status} | {rec['unknowns']} | {rec['newton_iterations']} | "
            f"{rec.get('steps', 0)} | {o.time_s:.1f} | {rec['setup']['wall']:.1f} / {rec['summary_wall_s']:.1f} / "
            f"{rec['process_wall_s']:.1f} | {cpu:.1f} | "
            f"{o.force:.5e} | {_pct(relative_deviation(o.force, force)) if force else '—'} | {o.gap:.4e} | "
            f"{_pct(relative_deviation(o.gap, gap), 1) if gap else '—'} | {'yes' if ok else ''} |")
    return lines


def reference_lines(r: ExampleResult) -> list[str]:
    lines = []
    for q in QUANTITIES:
        ref = r.references.get(q)
        if ref is None:
            lines.append(f"- {q}: no reference (fewer than two converged uniform levels of either method)")
            continue
        parts = "; ".join(f"{METHOD_NAMES[m]} {e.value:.6g} ± {e.error:.2g} from h = "
                          f"{', '.join(f'{h:g}' for h in e.h)} ({e.note})" for m, e in ref.parts.items())
        sound = "well below" if r.sound[q] else "**not** well below"
        lines.append(f"- {q}: {ref.value:.6g} ± {ref.error:.2g} ({100 * ref.relative_error:.2f} %, {sound} the "
                     f"{100 * TOLERANCES[q]:g} % criterion); {parts}")
    return lines


def markdown(results: typing.Sequence[ExampleResult], machine: dict, quick: bool, command: str) -> str:
    """The page accuracy.md."""
    done = [rec for r in results for rec in r.records.values()]
    loads = [x for rec in done for x in (rec["load_average"]["before"][0], rec["load_average"]["after"][0])]
    out = ["# SFVEM vs FEM at equal accuracy: time to the answer", "",
           f"Written by `{command}` on {datetime.date.today().isoformat()}"
           + (" (**--quick: a pipeline check on coarse meshes and small loads, not the benchmark**)" if quick else "")
           + f". Machine: {machine['cpu']}, 1 rank per run (OMP_NUM_THREADS=1), one run at a time, shared with "
           f"other jobs: 1-minute load average {min(loads, default=0):.1f} to {max(loads, default=0):.1f} "
           f"over the runs. How the reference and the verdicts are made: below the summary table.", "",
           f"**Goal:** {goal(results)}.", ""]
    out += summary_table(results)
    out += ["", "Criteria: full load, force within 1 % and gap within 5 % of the reference. Time = set-up (mesh, "
            "discretization, local refinement) + the load path (summary.json's wall time), wall clock of a fresh "
            "process at 1 rank with the demo's defaults. Reference ± its estimated relative error.", "",
            "Reference, per quantity: each method's converged uniform runs (mesh sizes halving) are extrapolated "
            "by Richardson with the order observed on the finest three; its error estimate is the change of the "
            "limit when the order is taken as 1 instead, or when the three levels are taken one level coarser "
            "(the larger). Three levels whose differences change sign or do not shrink are not extrapolated: "
            "the finest value, ± the larger of the last two differences. Two levels: order 1 assumed, ± the "
            "change with order 2. The reference is the mean of the two methods' values, its error the largest "
            f"of half their difference and their own errors; it is called sound when that error is at most "
            f"{SOUND_FRACTION:.2g} of the criterion (1 % force, 5 % gap). Verdict per example: SFVEM when its "
            "cheapest run meeting the criteria (uniform or locally refined) takes no longer than the FEM's "
            "cheapest, or only it meets them; undecided when neither does."]
    for r in results:
        ex = EXAMPLES[r.key]
        options = " ".join(r.configs[0].argv[4:]) if r.configs else ""
        out += ["", f"## {ex.title}", "",
                f"`demos/{ex.demo}.py {options}`; force: -R_y of `{ex.force}`; gap: {ex.gap_label}; "
                f"FEM: {ex.fem}.", ""]
        out += reference_lines(r) + [""]
        out += runs_table(r)
        ratio = "—" if r.ratio is None else f"{r.ratio:.2f}"
        out += ["", f"Cheapest meeting the criteria: SFVEM uniform: {_best_cell(r, 'vem uniform')}; SFVEM local: "
                f"{_best_cell(r, 'vem local')}; FEM: {_best_cell(r, 'fem')}. SFVEM/FEM time {ratio}, verdict "
                f"{r.verdict}."]
        missing = [c.name for c in r.configs if c.name not in r.records]
        if missing:
            out += ["", f"Not run yet: {', '.join(missing)}."]
    out += ["", "Columns: time = set-up + path; process = the whole fresh process (interpreter start, imports, "
            "pictures); CPU = CPU time of set-up + `ContactProblem.solve`; Newton its include failed attempts; "
            "steps = converged load steps; vs ref = value / reference - 1."]
    return "\n".join(out) + "\n"
