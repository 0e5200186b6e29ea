"""From the measurements of the benchmark processes to results.json, the table and results.md.

Standard library only: the driver may run on any Python 3.10+.

What each reported quantity is: :data:`DEFINITIONS` (also written to results.md).
"""
from __future__ import annotations

import math
import os
import platform
import statistics
import typing

METHODS = ("vem", "fem")
SETUP_STAGES = ("mesh", "discretization", "matrix")
#: pieces of the assembly breakdown that are pure per-cell computation (no communication)
COMPUTE_PARTS = {"vem": ("residual_loop", "injectivity_guard", "tangent_loop"),
                 "fem": ("residual_form", "energy_form", "det_F", "injectivity_guard", "tangent_form")}
#: pieces of the residual in the breakdown; the others are pieces of the tangent
RESIDUAL_PARTS = ("residual_loop", "residual_form", "energy_form", "det_F", "injectivity_guard")

DEFINITIONS = """\
All times are wall times unless marked CPU.

- assembly time per unknown: smallest time of one residual (tangent) assembly at the
  deformed state, divided by the number of unknowns; "assembly" = residual + tangent;
- ratio SFVEM/FEM: (t_SFVEM / n_SFVEM) / (t_FEM / n_FEM) on the same polygon mesh (the FEM
  mesh is matched to the SFVEM unknowns);
- per Newton iteration: the load path's time in the residual/jacobian calls (line-search
  and reaction residuals included), in the linear solve (LU factorization + solve) and the
  rest (SNES, vector operations, matrix creation, reactions, Python), each divided by the
  Newton iterations of the load path (failed attempts included);
- set-up: mesh generation + discretization (space, projections and choice of l,
  quadrature (compression), basis derivative tables, kernel/form compilation, gmsh
  remeshing for the FEM) + matrix pattern;
- start-up: imports + set-up + first residual + first tangent, in a fresh process;
  "cold" with empty numba and FFCx caches, "warm" a second start with the caches the cold
  start filled;
- MPI speed-up: assembly time (residual + tangent) on 1 rank / on N ranks, largest size;
  "compute" speed-up: the same for the per-cell computation alone (SFVEM polygon loops,
  FEM form kernels; slowest rank), which shows whether the ranks got a full core each;
- breakdown: share of the residual (tangent) time in its pieces (1 rank, largest size, mean
  of 3 calls): SFVEM compiled polygon loop (force vector, energy and J in one pass), COO
  insertion into the PETSc matrix; FEM residual form, energy form, det F at the quadrature
  points and nodes; both, the injectivity guard (folded and kinked solid elements);
- force vector alone: the SFVEM/FEM ratio per unknown of the SFVEM polygon loop and the FEM
  residual form from the breakdown, without the state checks (energy, J, guard) that both
  residuals also deliver;
- growth exponent: least-squares slope of log(assembly time) against log(polygons).

Caveats: the machine may be shared (the load average before and after is recorded);
minima over repeats and over two passes per size damp, but do not remove, slowdowns
caused by other work, and the MPI speed-up is the most sensitive to them. With more
runnable jobs than cores, a call longer than the scheduler's time slice (the SFVEM tangent
of the largest quick box, 7 ms) is preempted on every repeat and its wall time grows while
shorter calls escape: then the serial CPU-time ratio is the one to read. Under MPI
the CPU times include Open MPI's busy waiting and are not used for the speed-up.
"""


# --------------------------------------------------------------------------- machine
def _cpu_model() -> str:
    with open("/proc/cpuinfo") as f:
        for line in f:
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    return platform.processor() or "unknown"


def _memory_gib() -> float:
    with open("/proc/meminfo") as f:
        for line in f:
            if line.startswith("MemTotal:"):
                return int(line.split()[1]) / 2 ** 20
    return float("nan")


def machine(versions: typing.Mapping[str, str]) -> dict:
    """CPU model, cores, memory, OS, load and library versions (``versions`` from a benchmark process)."""
    return {"cpu_model": _cpu_model(), "logical_cpus": os.cpu_count(),
            "usable_cpus": len(os.sched_getaffinity(0)), "memory_gib": round(_memory_gib(), 1),
            "os": platform.platform(), **versions}


# --------------------------------------------------------------------------- derived quantities
def assembly_time(size: dict, kind: str = "wall") -> float:
    """Residual + tangent time (s) of one size's repeated assembly."""
    return size["assembly"]["residual"][kind] + size["assembly"]["jacobian"][kind]


def per_unknown_us(size: dict) -> dict[str, float]:
    """Assembly time per unknown (µs): residual, tangent and their sum, wall and CPU."""
    n = size["unknowns"]
    out = {}
    for kind in ("wall", "cpu"):
        for part in ("residual", "jacobian"):
            out[f"{part}_{kind}"] = 1e6 * size["assembly"][part][kind] / n
        out[f"assembly_{kind}"] = 1e6 * assembly_time(size, kind) / n
    return out


def ratio_vem_over_fem(vem: dict, fem: dict) -> dict[str, float]:
    """SFVEM/FEM ratio of every per-unknown assembly time."""
    a, b = per_unknown_us(vem), per_unknown_us(fem)
    return {key: a[key] / b[key] for key in a}


def per_iteration_ms(load_path: dict) -> dict[str, float]:
    """Assembly / linear solve / other time per Newton iteration (ms)."""
    its = max(load_path["newton_iterations"], 1)
    return {part: 1e3 * load_path[f"{part}_wall"] / its for part in ("assembly", "linear_solve", "other")}


def setup_time(size: dict) -> dict[str, float]:
    """Total set-up time (wall, CPU) of one size."""
    return {kind: sum(size["setup"][s][kind] for s in SETUP_STAGES) for kind in ("wall", "cpu")}


def first_assembly(size: dict) -> float:
    """Wall time of the first residual + first tangent."""
    return size["first_assembly"]["residual"]["wall"] + size["first_assembly"]["jacobian"]["wall"]


def startup(process: dict) -> dict[str, float]:
    """Start-up of a fresh process at its first size: imports, set-up, first assembly and their sum."""
    first = process["sizes"][0]
    parts = {"imports": process["imports"]["wall"], "setup": setup_time(first)["wall"],
             "first_assembly": first_assembly(first)}
    return {**parts, "total": sum(parts.values())}


def growth_exponent(sizes: typing.Sequence[dict], key: str = "polygons") -> dict[str, float] | None:
    """Least-squares slopes of log(time) against log(sizes[key]) for residual, tangent and both."""
    if len(sizes) < 2:
        return None
    x = [math.log(s[key]) for s in sizes]
    times = {"residual": [s["assembly"]["residual"]["wall"] for s in sizes],
             "jacobian": [s["assembly"]["jacobian"]["wall"] for s in sizes],
             "assembly": [assembly_time(s) for s in sizes]}
    return {part: statistics.linear_regression(x, [math.log(v) for v in t]).slope for part, t in times.items()}


def compute_time_ms(size: dict) -> float:
    """Per-cell computation time (ms) of one residual + one tangent on the slowest rank."""
    parts = size["assembly_breakdown_ms_per_rank"]
    per_rank = [sum(ranks) for ranks in zip(*(parts[p] for p in COMPUTE_PARTS[size["method"]]))]
    return max(per_rank)


def mpi_speedup(serial: dict, parallel: dict) -> dict:
    """Speed-up of residual, tangent, both, and the computation alone, from 1 rank (``serial``)
    to ``parallel`` (same size)."""
    out = {"ranks": parallel["ranks"], "unknowns": parallel["unknowns"]}
    for part in ("residual", "jacobian"):
        out[part] = serial["assembly"][part]["wall"] / parallel["assembly"][part]["wall"]
    out["assembly"] = assembly_time(serial) / assembly_time(parallel)
    out["compute"] = compute_time_ms(serial) / compute_time_ms(parallel)
    return out


def load_path_summary(size: dict) -> dict[str, float]:
    """Total time of the load path, the shares of assembly and linear solve, residuals per iteration."""
    lp = size["load_path"]
    its = max(lp["newton_iterations"], 1)
    return {"wall": lp["wall"], "assembly_share": lp["assembly_wall"] / lp["wall"],
            "linear_solve_share": lp["linear_solve_wall"] / lp["wall"],
            "residuals_per_iteration": lp["residual_calls"] / its, "converged": lp["converged"]}


def breakdown_shares(size: dict) -> dict[str, float]:
    """Shares of the residual and tangent time (rank 0) in their pieces."""
    parts = {k: v[0] for k, v in size["assembly_breakdown_ms_per_rank"].items()}
    out = {"residual_ms": parts["residual"], "jacobian_ms": parts["jacobian"]}
    for part, value in parts.items():
        if part not in ("residual", "jacobian"):
            whole = "residual" if part in RESIDUAL_PARTS else "jacobian"
            out[f"{part}_share_of_{whole}"] = value / parts[whole]
    return out


def force_alone_ratio(vem: dict, fem: dict) -> float:
    """SFVEM/FEM per unknown of the force vector alone: SFVEM polygon loop against FEM residual form
    (breakdown, rank 0)."""
    v, f = (s["assembly_breakdown_ms_per_rank"] for s in (vem, fem))
    return (v["residual_loop"][0] / vem["unknowns"]) / (f["residual_form"][0] / fem["unknowns"])


def cold_warm(cold: dict, warm: dict) -> dict:
    """Cold and warm start-up (same geometry and size) and their ratios."""
    c, w = startup(cold), startup(warm)
    first_c, first_w = cold["sizes"][0], warm["sizes"][0]
    return {"geometry": cold["geometry"], "h": first_c["h"], "cold": c, "warm": w,
            "cold_setup_stages": first_c["setup"], "warm_setup_stages": first_w["setup"],
            "cold_first_assembly": first_c["first_assembly"], "warm_first_assembly": first_w["first_assembly"],
            "first_assembly_ratio_cold_over_warm": c["first_assembly"] / w["first_assembly"],
            "setup_ratio_cold_over_warm": c["setup"] / w["setup"],
            "startup_ratio_cold_over_warm": c["total"] / w["total"]}


def derive(main: dict, mpi: dict, startups: dict) -> dict:
    """Every derived quantity.

    Parameters
    ----------
    main
        ``main[geometry][method]``: the serial process of all sizes.
    mpi
        ``mpi[geometry][method]``: the N-rank process of the largest size.
    startups
        ``startups[method]``: the cold process (first geometry, smallest size).
    """
    out = {"by_geometry": {}, "cold_warm": {}}
    for geometry, runs in main.items():
        vem, fem = runs["vem"]["sizes"], runs["fem"]["sizes"]
        out["by_geometry"][geometry] = {
            "sizes": [{"h": v["h"], "unknowns": {"vem": v["unknowns"], "fem": f["unknowns"]},
                       "per_unknown_us": {"vem": per_unknown_us(v), "fem": per_unknown_us(f)},
                       "ratio_vem_over_fem": ratio_vem_over_fem(v, f)} for v, f in zip(vem, fem)],
            "growth_exponent_vem_vs_polygons": growth_exponent(vem),
            "breakdown_largest": {"vem": breakdown_shares(vem[-1]), "fem": breakdown_shares(fem[-1])},
            "force_alone_ratio_largest": force_alone_ratio(vem[-1], fem[-1]),
            "load_path_largest": {"vem": load_path_summary(vem[-1]), "fem": load_path_summary(fem[-1])},
            "mpi_speedup": {m: mpi_speedup(runs[m]["sizes"][-1], mpi[geometry][m]["sizes"][0]) for m in METHODS},
        }
    for method, cold in startups.items():
        out["cold_warm"][method] = cold_warm(cold, main[cold["geometry"]][method])
    headline = max(main, key=lambda g: main[g]["vem"]["sizes"][-1]["unknowns"])
    largest = out["by_geometry"][headline]
    out["headline_case"] = {"geometry": headline, "h": main[headline]["vem"]["sizes"][-1]["h"],
                            "unknowns": main[headline]["vem"]["sizes"][-1]["unknowns"]}
    out["assembly_ratio_vem_over_fem"] = largest["sizes"][-1]["ratio_vem_over_fem"]["assembly_wall"]
    out["mpi_speedup_assembly_2"] = largest["mpi_speedup"]["vem"]["assembly"]
    out["mpi_speedup_assembly_2_fem"] = largest["mpi_speedup"]["fem"]["assembly"]
    return out


# --------------------------------------------------------------------------- table
HEADER = ("geometry", "h", "method", "unknowns", "cells", "qp/unknown", "residual µs/unk wall/cpu",
          "tangent µs/unk wall/cpu", "VEM/FEM per unk", "Newton its", "per it ms asm/solve/other",
          "load path s", "setup s", "peak RSS MB")


def _pair(a: float, b: float) -> str:
    return f"{a:.2f}/{b:.2f}"


def _row(size: dict, ratio: float | None) -> tuple[str, ...]:
    us = per_unknown_us(size)
    lp = size["load_path"]
    it = per_iteration_ms(lp)
    its = f"{lp['newton_iterations']}" + ("" if lp["converged"] else f" (load {lp['load']:.3g})")
    return (size["geometry"], f"{size['h']:g}", size["method"], str(size["unknowns"]),
            str(size.get("polygons", size.get("triangles"))), f"{size['quadrature_points'] / size['unknowns']:.2f}",
            _pair(us["residual_wall"], us["residual_cpu"]), _pair(us["jacobian_wall"], us["jacobian_cpu"]),
            "—" if ratio is None else f"{ratio:.2f}", its,
            f"{it['assembly']:.1f}/{it['linear_solve']:.1f}/{it['other']:.1f}", f"{lp['wall']:.2f}",
            f"{setup_time(size)['wall']:.2f}", f"{size['peak_rss_mb']:.0f}")


def table_rows(main: dict) -> list[tuple[str, ...]]:
    """One row per geometry, size and method; the SFVEM row carries the ratio (residual + tangent)."""
    rows = []
    for runs in main.values():
        for v, f in zip(runs["vem"]["sizes"], runs["fem"]["sizes"]):
            rows.append(_row(v, ratio_vem_over_fem(v, f)["assembly_wall"]))
            rows.append(_row(f, None))
    return rows


def key_figures(derived: dict, ranks: int) -> list[str]:
    """The headline numbers as sentences (printed under the table and in results.md)."""
    lines = []
    for geometry, g in derived["by_geometry"].items():
        r = g["sizes"][-1]["ratio_vem_over_fem"]
        lines.append(f"{geometry}, largest size ({g['sizes'][-1]['unknowns']['vem']} SFVEM unknowns): SFVEM/FEM "
                     f"assembly time per unknown {r['assembly_wall']:.2f} (residual {r['residual_wall']:.2f}, "
                     f"tangent {r['jacobian_wall']:.2f}; CPU time {r['assembly_cpu']:.2f}, residual "
                     f"{r['residual_cpu']:.2f}, tangent {r['jacobian_cpu']:.2f})")
        s = g["mpi_speedup"]
        lines.append(f"{geometry}: assembly speed-up on {ranks} ranks, SFVEM {s['vem']['assembly']:.2f} "
                     f"(residual {s['vem']['residual']:.2f}, tangent {s['vem']['jacobian']:.2f}, computation "
                     f"alone {s['vem']['compute']:.2f}), FEM {s['fem']['assembly']:.2f} (computation alone "
                     f"{s['fem']['compute']:.2f})")
        b = g["breakdown_largest"]["vem"]
        lines.append(f"{geometry}, largest size, where SFVEM assembly time goes: residual {b['residual_ms']:.1f} ms, "
                     f"{100 * b['residual_loop_share_of_residual']:.0f}% in the polygon loop, "
                     f"{100 * b['injectivity_guard_share_of_residual']:.0f}% in the injectivity guard; tangent "
                     f"{b['jacobian_ms']:.1f} ms, {100 * b['tangent_loop_share_of_jacobian']:.0f}% in the polygon "
                     f"loop, {100 * b['matrix_insert_share_of_jacobian']:.0f}% in the COO insertion")
        b = g["breakdown_largest"]["fem"]
        lines.append(f"{geometry}, largest size, where the FEM residual's time goes: {b['residual_ms']:.1f} ms, "
                     f"{100 * b['residual_form_share_of_residual']:.0f}% in the residual form, "
                     f"{100 * b['energy_form_share_of_residual']:.0f}% the energy form, "
                     f"{100 * b['det_F_share_of_residual']:.0f}% det F, "
                     f"{100 * b['injectivity_guard_share_of_residual']:.0f}% the injectivity guard; SFVEM/FEM per "
                     f"unknown of the force vector alone (polygon loop / residual form) "
                     f"{g['force_alone_ratio_largest']:.2f}")
        lp = g["load_path_largest"]
        v, f = lp["vem"], lp["fem"]
        lines.append(f"{geometry}, largest size, load path: SFVEM {v['wall']:.1f} s (assembly "
                     f"{100 * v['assembly_share']:.0f}%, linear solve {100 * v['linear_solve_share']:.0f}%), "
                     f"FEM {f['wall']:.1f} s (assembly {100 * f['assembly_share']:.0f}%, linear solve "
                     f"{100 * f['linear_solve_share']:.0f}%); {v['residuals_per_iteration']:.1f} residuals per "
                     f"Newton iteration (line search, reactions)")
        e = g["growth_exponent_vem_vs_polygons"]
        if e is not None:
            lines.append(f"{geometry}: SFVEM assembly time ~ polygons^{e['assembly']:.2f} "
                         f"(residual ^{e['residual']:.2f}, tangent ^{e['jacobian']:.2f})")
    for method, c in derived["cold_warm"].items():
        lines.append(f"{method} start-up ({c['geometry']}, h = {c['h']:g}): cold {c['cold']['total']:.1f} s, "
                     f"warm {c['warm']['total']:.1f} s; set-up cold/warm {c['setup_ratio_cold_over_warm']:.1f}, "
                     f"first assembly cold/warm {c['first_assembly_ratio_cold_over_warm']:.1f} "
                     f"({c['cold']['first_assembly']:.3g} s / {c['warm']['first_assembly']:.3g} s)")
    return lines


def _machine_line(m: dict) -> str:
    return (f"{m['cpu_model']}, {m['usable_cpus']} usable CPUs, {m['memory_gib']} GiB; DOLFINx {m['dolfinx']}, "
            f"PETSc {m['petsc']}, numba {m['numba']}; load average {m['load_average_before']} before, "
            f"{m['load_average_after']} after")


def format_text(rows: list[tuple[str, ...]], lines: list[str], m: dict) -> str:
    """The table in fixed-width columns, then the key figures and the machine."""
    widths = [max(len(r[i]) for r in [HEADER, *rows]) for i in range(len(HEADER))]
    fmt = "  ".join(f"{{:>{w}}}" for w in widths)
    out = [fmt.format(*HEADER), fmt.format(*("-" * w for w in widths))] + [fmt.format(*r) for r in rows]
    return "\n".join(out + [""] + lines + ["", "machine: " + _machine_line(m)])


def format_markdown(rows: list[tuple[str, ...]], lines: list[str], m: dict, quick: bool) -> str:
    """results.md: the table, the key figures, the machine and the definitions."""
    out = [f"# Benchmark: SFVEM vs P2 FEM{' (quick)' if quick else ''}", "",
           "| " + " | ".join(HEADER) + " |", "|" + "---:|" * len(HEADER)]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    out += [""] + [f"- {line}" for line in lines]
    out += ["", f"Machine: {_machine_line(m)}.", "", "Definitions:", "", DEFINITIONS]
    return "\n".join(out) + "\n"


def finite(value):
    """``value`` with non-finite floats replaced by None (strict JSON)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite(v) for v in value]
    return value
