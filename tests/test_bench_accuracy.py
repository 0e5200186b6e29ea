"""The arithmetic of the equal-accuracy benchmark (bench/accuracy_reference.py, bench/accuracy_report.py)
on constructed ladders and records: Richardson limits and their error estimates, the reference of
two methods, the cheapest run meeting the criteria, and the verdict. No solves, no timing."""
from __future__ import annotations

import math

import accuracy_plan
import accuracy_report
import pytest
from accuracy_reference import Extrapolation, Outcome, cheapest, reference, richardson


def test_richardson_recovers_the_limit_and_order_of_a_pure_power():
    h = [0.4, 0.2, 0.1]
    e = richardson(h, [3.0 + 0.7 * x ** 1.5 for x in h])
    assert e.observed and e.order == pytest.approx(1.5, abs=1e-12)
    assert e.value == pytest.approx(3.0, abs=1e-12)
    # error = change with the assumed order 1: f_2 + d_2 instead of f_2 + d_2 / (2^1.5 - 1)
    d2 = 0.7 * (0.1 ** 1.5 - 0.2 ** 1.5)
    assert e.error == pytest.approx(abs(d2 - d2 / (2 ** 1.5 - 1)), rel=1e-12)


@pytest.mark.parametrize("b", [-3.0, -2.0, 3.0, 10.0])
def test_richardson_error_estimate_covers_the_true_error_with_a_second_term(b):
    h = [0.2, 0.1, 0.05, 0.025]
    e = richardson(h, [2.0 + x + b * x ** 2 for x in h])
    assert e.observed
    assert abs(e.value - 2.0) <= e.error
    assert abs(e.value - 2.0) < abs(2.0 + 0.025 + b * 0.025 ** 2 - 2.0)      # better than the finest level


def test_richardson_with_two_levels_assumes_first_order():
    e = richardson([0.1, 0.05], [5.0, 4.6])
    assert not e.observed and e.order == 1.0
    assert e.value == pytest.approx(4.2)
    assert e.error == pytest.approx(abs(4.2 - (4.6 - 0.4 / 3)))


@pytest.mark.parametrize("values", [[5.0, 4.6, 4.7], [5.0, 4.9, 4.7]])
def test_richardson_outside_the_asymptotic_range_gives_the_finest_value(values):
    """Differences that change sign, or grow: no extrapolation, the finest value with the larger difference."""
    e = richardson([0.1, 0.05, 0.025], values)
    assert e.order is None and not e.observed
    assert e.value == values[-1]
    assert e.error == pytest.approx(max(abs(values[1] - values[0]), abs(values[2] - values[1])))


@pytest.mark.parametrize("h, f, match", [([0.1], [1.0], "two or more"), ([0.1, 0.05], [1.0], "two or more"),
                                         ([0.05, 0.1], [1.0, 2.0], "decrease"),
                                         ([0.1, 0.05, 0.02], [1.0, 2.0, 3.0], "constant ratio")])
def test_richardson_rejects_bad_ladders(h, f, match):
    with pytest.raises(ValueError, match=match):
        richardson(h, f)


def test_reference_is_the_mean_with_the_larger_of_spread_and_own_errors():
    a = Extrapolation(3.32, 0.01, 1.1, True, (0.05, 0.025, 0.0125), "")
    b = Extrapolation(3.30, 0.004, 0.8, True, (0.05, 0.025, 0.0125), "")
    ref = reference({"vem": a, "fem": b})
    assert ref.value == pytest.approx(3.31)
    assert ref.error == pytest.approx(0.01)                  # own error of a > half the spread 0.01? equal: 0.01
    ref = reference({"vem": a, "fem": Extrapolation(3.26, 0.0, 1.0, True, (), "")})
    assert ref.error == pytest.approx(0.03)                  # half the spread
    with pytest.raises(ValueError):
        reference({})


def test_cheapest_takes_the_fastest_run_meeting_both_criteria():
    force = reference({"vem": Extrapolation(100.0, 0.1, 1.0, True, (), "")})
    gap = reference({"vem": Extrapolation(1.0, 0.0, 1.0, True, (), "")})
    runs = [Outcome("fast-force-off", "vem", "uniform", True, 101.5, 1.0, 1.0),
            Outcome("fast-gap-off", "vem", "uniform", True, 100.0, 1.06, 2.0),
            Outcome("fast-stopped", "vem", "uniform", False, 100.0, 1.0, 3.0),
            Outcome("edge", "vem", "local", True, 99.1, 0.96, 9.0),           # -0.9 % and -4 %: inside
            Outcome("slow", "vem", "uniform", True, 100.2, 1.01, 20.0)]
    assert cheapest(runs, force, gap).name == "edge"
    assert cheapest(runs[:3], force, gap) is None


def record(force: float, gap: float, seconds: float, converged: bool = True) -> dict:
    return {"converged": converged, "exit_code": 0 if converged else 1, "force": force, "gap": gap, "load": 1.0,
            "unknowns": 100, "newton_iterations": 10, "steps": 5, "setup": {"wall": 0.0, "cpu": 0.0},
            "solve": {"wall": seconds, "cpu": seconds}, "summary_wall_s": seconds, "process_wall_s": seconds,
            "load_average": {"before": [1.0], "after": [1.0]}}


def test_analyse_builds_the_reference_from_converged_uniform_runs_and_decides():
    ex = accuracy_plan.EXAMPLES["cbox"]
    hs = (0.1, 0.05, 0.025)
    configs = [accuracy_plan.Config(ex, m, h, 1.0) for m in ("vem", "fem") for h in hs]
    configs.append(accuracy_plan.Config(ex, "vem", 0.1, 1.0, (("contact", 2),)))
    # both methods first order towards force 1 and gap 2, the FEM with half the error constant
    records = {c.name: record(1.0 + (0.5 if c.method == "fem" else 1.0) * c.h, 2.0 + 4 * c.h, 10 * 0.1 / c.h)
               for c in configs if c.kind == "uniform"}
    local = configs[-1].name
    records[local] = record(1.005, 2.05, 5.0)
    result = accuracy_report.analyse("cbox", configs, records)
    assert result.references["force"].value == pytest.approx(1.0)
    assert result.references["gap"].value == pytest.approx(2.0)
    # within 1 % and 5 %: FEM h = 0.025 (force +1.25 % fails), no uniform FEM; SFVEM only the local run
    assert result.best["fem"] is None and result.best["vem uniform"] is None
    assert result.best["vem"].name == local
    assert result.verdict == "SFVEM" and result.ratio is None
    # a stopped run does not enter the ladder: two FEM levels, first order assumed, still exact here
    records[configs[5].name] = record(float("nan"), float("nan"), 1.0, converged=False)
    result = accuracy_report.analyse("cbox", configs, records)
    assert result.references["force"].parts["fem"].h == (0.1, 0.05)
    assert result.complete
    assert math.isclose(result.references["force"].parts["fem"].value, 1.0)
