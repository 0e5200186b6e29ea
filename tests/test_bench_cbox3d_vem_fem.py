"""bench/cbox3d_vem_fem.py's comparison table from records made up here (no solve): the differences
it reports are the ones computed by hand."""
from __future__ import annotations

import cbox3d_vem_fem as bench


def record(method: str, R: list[float], gap: float) -> dict:
    return {"grid": "20x1x7", "method": method, "scale": 0.25, "steps": 2, "unknowns": 5535, "converged": True,
            "load": 1.0 if method == "fem" else 1 - 1e-16,          # the same load, to round-off (adaptive steps)
            "message": "", "R": R, "R_clamp": [-r for r in R], "gaps": [[0.5, 0.45], [1.0, gap]],
            "min_gap": gap, "min_J": 0.8, "newton": 10, "setup_s": 1.0, "solve_s": 10.0,
            "s_per_newton": 3.0 if method == "vem" else 0.5}


def test_differences_of_reaction_and_gap_closure():
    """R_vem = (0, 3.3, -4.4), R_fem = (0, 3, -4): |R_vem - R_fem| / |R_fem| = 0.5 / 5 = 10 %, R_z 10 %;
    closures 0.1 and 0.08 of the initial gap 0.5: 25 %; time ratio 6."""
    rows = bench.comparison_rows([record("vem", [0.0, 3.3, -4.4], 0.4), record("fem", [0.0, 3.0, -4.0], 0.42)])
    assert len(rows) == 1
    cells = [c.strip() for c in rows[0].strip("|").split("|")]
    assert cells[1:3] == ["corner", "10 (demo)"]
    assert cells[7:10] == ["10.00%", "10.00%", "0.4000"] and cells[11] == "25.00%" and cells[-1] == "6.0"


def test_cases_pair_only_with_the_same_loading():
    """A patch or alpha_r case of one method is not compared with the other method's corner case."""
    patch = dict(record("vem", [0.0, 3.3, -4.4], 0.4), patch=0.35)
    alpha = dict(record("vem", [0.0, 3.3, -4.4], 0.4), alpha_r=0.0)
    fem = record("fem", [0.0, 3.0, -4.0], 0.42)
    assert bench.comparison_rows([patch, fem]) == [] and bench.comparison_rows([alpha, fem]) == []
    rows = bench.comparison_rows([patch, dict(fem, patch=0.35)])
    assert [c.strip() for c in rows[0].strip("|").split("|")][1:3] == ["0.35 patch", "10 (demo)"]
    end = [dict(record(m, R, 0.4), patch="end") for m, R in (("vem", [0.0, 3.3, -4.4]), ("fem", [0.0, 3.0, -4.0]))]
    rows = bench.comparison_rows([patch, dict(fem, patch=0.35), *end, fem, record("vem", [0.0, 3.3, -4.4], 0.4)])
    assert [[c.strip() for c in row.strip("|").split("|")][1] for row in rows] == ["corner", "0.35 patch", "end face"]


def test_a_grid_with_one_method_has_no_row():
    assert bench.comparison_rows([record("vem", [0.0, 1.0, 0.0], 0.4)]) == []
