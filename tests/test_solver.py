"""Newton solver and load stepping (docs/method.md §6, §7; paper §4.3, Eqs. 52-56 solved by Newton).

- Newton converges quadratically in the contact phase of a small C-box (paper §5.2).
- A step that fails is cut back and retried from the last converged state; when the smallest
  increment fails too, the run stops with a message naming the load factor, keeping every
  converged step (Result, summary.json, load_path.csv), or raises SolveFailed on request.
- PETSc options given from Python to one solve do not leak into later solves.
- The default absolute tolerance scales with the moduli (the same iterations and solution for
  moduli and loads scaled by 1e-6 .. 1e6); a given ``snes_atol`` is used as is.
- A boundary condition that selects no degree of freedom is an error naming it.

The block most tests load is conftest.py's ``block`` (test_run_summary uses it too).
"""
import csv
import functools
import json

import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

import dolfinx_sfvem as sf
from dolfinx_sfvem import meshes
from dolfinx_sfvem.path_following import snes as solver
from dolfinx_sfvem.discretizations.discretization import AssemblyInfo

COMM = MPI.COMM_SELF
SOLID, MEDIUM = meshes.SOLID, meshes.MEDIUM
#: pure Newton (no line search), stopped just above round-off so that the last residuals of
#: every step show the asymptotic rate and the final one sits at the round-off level
PURE_NEWTON = {"snes_linesearch_type": "basic", "snes_rtol": 1e-14, "snes_atol": 1e-13}


# ----------------------------------------------------------------------------- problems
@functools.lru_cache(maxsize=None)
def cbox_benchmark() -> meshes.Benchmark:
    """The C-box of paper §5.2 with a coarse solid (h = 0.1, about 100 polygons)."""
    return meshes.cbox(0.1)


def at_point(point):
    return lambda x: np.isclose(x[0], point[0]) & np.isclose(x[1], point[1])


def cbox_problem(uy: float) -> sf.ContactProblem:
    """C-box, left side clamped, u_y prescribed at the top-right corner; initial gap 0.3."""
    bench = cbox_benchmark()
    problem = sf.ContactProblem(bench.mesh, {SOLID: sf.Hyperelastic(K=5 / 3, mu=5 / 14),
                                             MEDIUM: sf.ThirdMedium(mu=5 / 14, gamma=1e-5, alpha_r=1.0)},
                                comm=COMM, verbose=False)
    problem.fix(lambda x: np.isclose(x[0], 0.0), name="fixed")
    problem.prescribe(at_point(bench.points["load"]), uy=uy, name="load")
    return problem


def converged(steps: list[dict]) -> list[dict]:
    return [s for s in steps if s["converged"]]


# ----------------------------------------------------------------------------- convergence order
def order_estimate(norms) -> float:
    """Order p of the last Newton iteration above round-off, p = log(r_{k+1}/r_k) / log(r_k/r_{k-1}).

    ``norms[0]`` is the jump of the prescribed values (the lifted Dirichlet rows), not a
    Newton residual of the equilibrium, so k - 1 >= 1. "Above round-off" means r_{k+1} at
    least 100 times the final residual, which a solve run to ``snes_atol`` just above the
    round-off level leaves there.
    """
    r = np.asarray(norms, dtype=float)
    usable = [k for k in range(2, r.size - 1) if r[k + 1] >= 100 * r[-1]]
    assert usable, f"too few Newton iterations above round-off to estimate an order: {r}"
    k = usable[-1]
    return float(np.log(r[k + 1] / r[k]) / np.log(r[k] / r[k - 1]))


def model_sequence(update, r1: float, floor: float = 1e-15) -> list[float]:
    """[jump, r1, r2, ...] with r_{k+1} = update(r_k) until round-off, then two round-off values."""
    r = [1.0, r1]
    while update(r[-1]) > 1e3 * floor:
        r.append(update(r[-1]))
    return r + [floor, floor]


@pytest.mark.parametrize("update,order", [(lambda r: 50 * r ** 2, 2.0), (lambda r: 0.2 * r, 1.0),
                                          (lambda r: 0.01 * r, 1.0)], ids=["quadratic", "linear", "fast-linear"])
def test_order_estimate_tells_quadratic_from_linear(update, order):
    """Control for :func:`test_newton_converges_quadratically_in_contact`: the order estimate
    returns 2 for a quadratically and 1 for a linearly converging sequence (e.g. a Newton
    iteration with an inconsistent tangent), also when the last residuals sit at round-off."""
    assert order_estimate(model_sequence(update, r1=1e-3)) == pytest.approx(order, abs=0.05)


def test_newton_converges_quadratically_in_contact():
    """In every load step of the contact phase (medium squeezed below 5 % of its area: the beam
    tip lies on the lower beam), pure Newton with the tangent of Eq. 56 converges with order
    ≈ 2 until round-off. The converged steps also reach the full load.

    Bound 1.6: the three-residual estimate is biased low by the constant of
    r_{k+1} = C r_k² (C ~ 1e4 in these steps: 1.2e-6 -> 6.6e-9 -> 8.9e-13 reads as 1.72);
    an inconsistent tangent reads as ≈ 1 (control test above)."""
    result = cbox_problem(uy=-0.5).solve(8, petsc_options=PURE_NEWTON)
    assert result.converged, result.message
    contact = [s for s in converged(result.steps) if s["min_J"] < 0.05]
    assert len(contact) >= 3, [(s["load"], s["min_J"]) for s in converged(result.steps)]
    orders = {s["load"]: order_estimate(s["residual_norms"]) for s in contact}
    assert min(orders.values()) > 1.6, orders


def test_each_state_is_assembled_once(monkeypatch, block):
    """A converged state's residual is the one SNES evaluated last: the state diagnostics and the
    reactions reuse it, so a load path costs one residual per Newton iteration plus one per load
    step (SNES's first at the new load) and one for the initial-state check, and the reactions
    equal the internal force assembled afresh."""
    problem = block.compressed(uy=-0.02)
    calls = []
    assemble = type(problem.disc).residual
    monkeypatch.setattr(type(problem.disc), "residual", lambda self, x, b: calls.append(1) or assemble(self, x, b))
    result = problem.solve(4, petsc_options={"snes_linesearch_type": "basic"})
    assert result.converged, result.message
    steps = converged(result.steps)
    assert len(calls) == sum(s["newton_iterations"] for s in steps) + len(steps) + 1
    fresh = problem.reactions()
    np.testing.assert_allclose(steps[-1]["reaction"]["top"], fresh["top"], rtol=1e-12, atol=1e-14)


def strut(strain: float) -> sf.ContactProblem:
    """A clamped 1 x 0.05 strut (40 x 2 quads) shortened by ``strain``: it stays straight (the
    symmetric solution), Euler buckling at a strain of about pi^2 h^2 / (3 L^2) = 0.8 % (first
    mode) and 1.7 % (second) makes that state unstable."""
    mesh = meshes.quad_rectangle(1.0, 0.05, 40, 2, tag=SOLID)
    problem = sf.ContactProblem(mesh, {SOLID: sf.Hyperelastic(K=5 / 3, mu=5 / 14)}, comm=COMM, verbose=False)
    problem.fix(lambda x: np.isclose(x[0], 0.0), name="left")
    problem.prescribe(lambda x: np.isclose(x[0], 1.0), ux=-strain, uy=0.0, name="right")
    return problem


@pytest.mark.mpi
def test_negative_pivots_count_the_unstable_modes():
    """With the default LDL^T factorization every step reports the tangent's negative
    eigenvalues: none before buckling, one past the first critical strain, two past the second;
    on one rank the count equals that of the dense tangent's eigenvalues."""
    for strain, expected in ((0.004, [0, 0, 0, 0]), (0.012, [0, 0, 1, 1]), (0.02, [0, 1, 1, 2])):
        problem = strut(strain)
        result = problem.solve(control=sf.LoadStepping(4, adaptive=False, predictor=False))   # at known strains
        assert result.converged, result.message
        assert [s["negative_pivots"] for s in result.steps] == expected, strain
        if COMM.size == 1:
            A = problem.disc.create_matrix()
            problem.disc.jacobian(problem.x, A)
            K = A.convert("dense").getDenseArray()
            assert int((np.linalg.eigvalsh((K + K.T) / 2) < 0).sum()) == expected[-1]


def test_negative_pivots_need_ldlt():
    result = strut(0.012).solve(2, petsc_options={"pc_type": "lu"})
    assert result.converged and all(s["negative_pivots"] is None for s in result.steps)


# ----------------------------------------------------------------------------- cut-back
def test_failed_step_is_cut_back():
    """With at most 4 Newton iterations the single full step fails; the stepper retries from the
    last converged state with half the increment, grows it again after successes, and reaches
    the full load. Failed attempts are recorded (converged False) and do not count as steps.
    A failed attempt is a try with the default line search and one with the fallback
    (solver.FALLBACK_LINE_SEARCH), at most 4 iterations each."""
    result = cbox_problem(uy=-0.2).solve(1, petsc_options={"snes_max_it": 4})
    assert result.converged and result.load == 1.0, result.message
    steps = result.attempts
    assert not steps[0]["converged"] and steps[0]["load"] == 1.0
    last = 0.0
    for attempt, following in zip(steps, steps[1:]):
        if attempt["converged"]:
            last = attempt["load"]
        else:
            assert 4 < attempt["newton_iterations"] <= 2 * 4
            assert 0 < following["load"] - last < attempt["load"] - last, (attempt, following)
    done = converged(steps)
    assert [s["step"] for s in done] == list(range(1, len(done) + 1))
    assert np.all(np.diff([s["load"] for s in done]) > 0) and done[-1]["load"] == 1.0
    assert len(done) < len(steps)


def test_given_line_search_has_no_fallback():
    """A line search given by the user is used alone: a failed attempt is one try of at most
    snes_max_it iterations, and the run still reaches the full load by cut-back."""
    result = cbox_problem(uy=-0.2).solve(1, petsc_options={"snes_max_it": 4, "snes_linesearch_type": "bt"})
    assert result.converged and result.load == 1.0, result.message
    failed = [a for a in result.attempts if not a["converged"]]
    assert failed and all(a["newton_iterations"] <= 4 for a in failed)


def read_outputs(out) -> tuple[dict, list[dict]]:
    with open(out / "summary.json") as f:
        summary = json.load(f)
    with open(out / "load_path.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    return summary, rows


def exhausted_run(block, out, raise_on_failure: bool):
    """Squeeze the block to 3 times its height in 6 steps with one halving allowed: at load
    factor 1/3 its top face would reach the clamped bottom (J > 0 impossible), so the run
    must stop there or before. Returns (steps, load reached, message)."""
    problem = block.compressed(uy=-3 * block.HEIGHT)
    if not raise_on_failure:
        result = problem.solve(6, out=out, min_increment=0.5 / 6)
        assert not result.converged
        return result.attempts, result.load, result.message
    with pytest.raises(sf.SolveFailed) as failure:
        problem.solve(6, out=out, min_increment=0.5 / 6, raise_on_failure=True)
    summary, _ = read_outputs(out)
    return summary["steps"], max(s["load"] for s in converged(summary["steps"])), str(failure.value)


@pytest.mark.parametrize("raise_on_failure", [False, True])
def test_exhausted_cut_back_keeps_converged_steps(tmp_path, raise_on_failure, block):
    """When the smallest increment fails, the message names the load factor of the failed step
    and the last converged one; every converged step is kept in the result and written to
    summary.json and load_path.csv; with raise_on_failure=True SolveFailed is raised as well."""
    out = tmp_path / "run"
    steps, load, message = exhausted_run(block, out, raise_on_failure)
    done = converged(steps)
    assert done, "the first step (50 % compression) should converge"
    assert load == done[-1]["load"] < 1 / 3 + 1e-12
    failed = steps[-1]
    assert not failed["converged"] and failed["load"] > load
    assert f"load factor {failed['load']:.6g}" in message
    assert f"last converged load factor {load:.6g}" in message
    summary, rows = read_outputs(out)
    assert summary["converged"] is False and summary["message"] == message
    assert [s["load"] for s in summary["steps"]] == pytest.approx([s["load"] for s in steps])
    assert [int(r["step"]) for r in rows] == [s["step"] for s in done]
    assert [float(r["load"]) for r in rows] == pytest.approx([s["load"] for s in done])
    assert [float(r["top_Ry"]) for r in rows] == pytest.approx([s["reaction"]["top"][1] for s in done])


# ----------------------------------------------------------------------------- options
@pytest.fixture
def user_option():
    """A user's global PETSc option (as from the command line), removed afterwards."""
    options = PETSc.Options()
    options["snes_max_it"] = "25"
    yield options
    options.delValue("snes_max_it")


def test_python_options_do_not_leak(user_option, block):
    """snes_max_it = 1 given to one solve makes it fail after one iteration per try (two tries per
    attempt: the default line search and its fallback); the next
    solve (another problem) again uses the user's global options and converges; the PETSc
    options database is the same before and after both solves."""
    before = user_option.getAll()
    limited = block.compressed(uy=-0.1 * block.HEIGHT).solve(2, petsc_options={"snes_max_it": 1}, min_increment=0.5)
    assert not limited.converged
    assert all(s["newton_iterations"] <= 2 for s in limited.attempts)
    assert user_option.getAll() == before
    normal = block.compressed(uy=-0.1 * block.HEIGHT).solve(2)
    assert normal.converged, normal.message
    assert max(s["newton_iterations"] for s in normal.attempts) > 1
    assert user_option.getAll() == before


# ----------------------------------------------------------------------------- absolute tolerance
#: the body force of :func:`cantilever_problem` per unit modulus scale
WEIGHT = 0.05


def cantilever_problem(block, scale: float) -> sf.ContactProblem:
    """The ``block`` clamped at its left end and bent by a body force (tip
    deflection about 0.9), moduli and body force multiplied by ``scale``: the deformation does
    not depend on it."""
    problem = sf.ContactProblem(block.mesh(), {SOLID: sf.Hyperelastic(K=5 / 3 * scale, mu=5 / 14 * scale)}, comm=COMM,
                                verbose=False)
    problem.fix(lambda x: np.isclose(x[0], 0.0), name="clamped")
    problem.body_force(lambda x: np.stack([np.zeros(x.shape[1]), np.full(x.shape[1], -WEIGHT * scale)]))
    return problem


def test_default_absolute_tolerance_scales_with_the_moduli(block):
    """Moduli and body force multiplied by 1e-6, 1 and 1e6: with the default absolute tolerance
    (proportional to eps ||K|| ||x||) every step takes the same Newton iterations, ends at the
    same deflection and at a final residual proportional to the scale (within 5 %: the first
    step's potential comparisons round differently at each scale)."""
    results = {scale: cantilever_problem(block, scale).solve(2) for scale in (1e-6, 1.0, 1e6)}
    assert all(r.converged for r in results.values()), {s: r.message for s, r in results.items()}
    iterations = {s: [step["newton_iterations"] for step in r.attempts] for s, r in results.items()}
    assert iterations[1e-6] == iterations[1.0] == iterations[1e6], iterations
    deflection = {s: r.steps[-1]["max_displacement"] for s, r in results.items()}
    assert deflection[1e-6] == pytest.approx(deflection[1.0], rel=1e-10)
    assert deflection[1e6] == pytest.approx(deflection[1.0], rel=1e-10)
    final = {s: r.steps[-1]["residual_norms"][-1] for s, r in results.items()}
    assert final[1e-6] / final[1.0] == pytest.approx(1e-6, rel=5e-2), final
    assert final[1e6] / final[1.0] == pytest.approx(1e6, rel=5e-2), final


@pytest.fixture(params=["python", "command line"])
def solve_with_fixed_atol(request):
    """Solve in 2 steps with ``snes_atol`` 1e-10 (the former fixed default) given as
    ``petsc_options`` or as a command-line option with the problem's prefix (removed afterwards)."""
    def solve(problem: sf.ContactProblem):
        if request.param == "python":
            return problem.solve(2, petsc_options={"snes_atol": 1e-10})
        options = PETSc.Options()
        options[problem.petsc_options_prefix + "snes_atol"] = "1e-10"
        try:
            return problem.solve(2)
        finally:
            options.delValue(problem.petsc_options_prefix + "snes_atol")
    return solve


def test_given_snes_atol_is_used_as_is(solve_with_fixed_atol, block):
    """With moduli and load scaled by 1e-6 the forces are of order 1e-7: a fixed ``snes_atol`` of
    1e-10, from Python or the command line, is used as given and stops Newton early (every step
    at or below 1e-10, all but at most one above 1e-12, where the default goes on), with a
    deflection off by more than 1e-5 (relative) from the converged one."""
    reference = cantilever_problem(block, 1e-6).solve(2)
    early = solve_with_fixed_atol(cantilever_problem(block, 1e-6))
    assert reference.converged and early.converged, (reference.message, early.message)
    assert sum(s["newton_iterations"] for s in early.attempts) < sum(s["newton_iterations"] for s in reference.attempts)
    final = [s["residual_norms"][-1] for s in early.steps]
    assert all(r <= 1e-10 for r in final) and sum(r > 1e-12 for r in final) >= len(final) - 1, final
    deflection, converged_deflection = early.steps[-1]["max_displacement"], reference.steps[-1]["max_displacement"]
    assert abs(deflection - converged_deflection) > 1e-5 * converged_deflection


# ----------------------------------------------------------------------------- boundary conditions
def nowhere(x):
    return x[0] < -1.0


@pytest.mark.parametrize("add", [
    lambda p: p.fix(nowhere, name="outside"),
    lambda p: p.prescribe(tags=[99], uy=-0.01, name="outside"),
    lambda p: p.fix(lambda x: x[1] > 1.0, tags=[SOLID], components=(0,), name="outside"),       # above the block
], ids=["marker", "missing-tag", "marker-and-tag"])
def test_empty_boundary_condition_is_named(add, block):
    """A boundary condition that selects no degree of freedom is a ValueError naming it."""
    problem = block.compressed(uy=-0.01)
    add(problem)
    with pytest.raises(ValueError, match="'outside'"):
        problem.solve(1)


def test_failure_names_the_trial_states_that_left_the_domain():
    """A line search that failed because its trial states were rejected says so and names the
    worst of them (a folded cell with J > 0 everywhere), not a residual stall; without
    rejected trial states the stall is classified as before."""
    folded = AssemblyInfo(1.0, 0.0095, 1103, 2, folded=1, folded_cell=1105)
    start = AssemblyInfo(1.0, 0.0094, 1103, 2)
    assert solver._worse(folded, start) and not solver._worse(start, folded)
    assert solver._worse(AssemblyInfo(1.0, 0.001, 7, 2), start)
    assert solver._worse(AssemblyInfo(1.0, float("nan"), -1, -1), start)
    reason = int(PETSc.SNES.ConvergedReason.DIVERGED_LINE_SEARCH)
    norms, atol = [4.9e-3, 4.5e-3, 4.48e-3], 9e-10
    text = solver._failure(reason, folded, norms, atol, 9e-14, rejected=612)
    assert "DIVERGED_LINE_SEARCH" in text
    assert "Newton's steps lead out of the admissible states (612 trial states rejected; the worst: " \
           "1 folded element(s)" in text and "e.g. 1105" in text
    assert "round-off" not in text
    assert "not a round-off limit" in solver._failure(reason, start, norms, atol, 9e-14)


@pytest.mark.parametrize("norms, atol, roundoff, kind", [
    ([1e-5, 5.9e-7, 4.1e-7, 6e-7], 8.9e-9, 8.9e-13, "not a round-off limit"),      # gamma 1e-6 cylinder
    ([3e-8, 2.818e-9, 2.9e-9], 2.786e-9, 2.786e-13, "bifurcation or limit point"),  # box mesh 3
    ([3e-8, 2.818e-9], 2.786e-9, None, "bifurcation or limit point"),              # snes_atol given
])
def test_stall_is_classified_by_its_residual_floor(norms, atol, roundoff, kind):
    text = solver._stall(norms, atol, roundoff)
    floor = min(norms)
    assert kind in text and f"{floor:.3e} = {floor / atol:.3g} x atol" in text
    assert ("round-off eps*F_c" in text) == (roundoff is not None)


# ----------------------------------------------------------------------------- abandoned solves
#: the residuals of a 3D Hertz step (h 0.2, core 0.1, gamma 1e-5, load 0.85) that creep by 1-4 %
#: per iteration for six iterations and then converge: a solve like it must run to its end
RECOVERING = [2.19e-2, 1.64e-2, 1.23e-2, 9.22e-3, 6.92e-3, 5.26e-4, 4.59e-4, 4.36e-4, 4.26e-4, 4.19e-4,
              4.08e-4, 3.93e-4, 3.27e-4, 1.77e-4, 9.51e-5, 8.43e-5, 8.19e-5, 9.54e-5, 7.08e-5, 6.84e-5,
              6.57e-5, 6.24e-5, 5.81e-5, 5.14e-5, 4.04e-5, 2.59e-5, 5.34e-6, 9.51e-8, 7.97e-11]


def linear(rate: float, n: int, r0: float = 1e-2) -> list[float]:
    return [r0 * rate ** k for k in range(n + 1)]


@pytest.mark.parametrize("norms, at", [
    (linear(0.95, 30), None),                                    # slow but steady: never abandoned
    (model_sequence(lambda r: 50 * r ** 2, 1e-2), None),         # quadratic
    ([1e-2] * solver.STALL_MIN_ITERATIONS, None),                # flat, but too few iterations to judge
    ([1e-2, 1e-3] + [2e-3, 1.5e-3] * 10, max(solver.STALL_MIN_ITERATIONS, 1 + solver.STALL_WINDOW)),  # wandering from 1 on
    (linear(0.5, 8) + [4e-5 * (1 + 0.01 * k) for k in range(10)], 8 + solver.STALL_WINDOW),
    (RECOVERING, None),
])
def test_a_stalled_residual_is_recognised_at_the_first_iteration_it_can_be(norms, at):
    """:func:`snes.stalled` flags the first iteration k >= STALL_MIN_ITERATIONS whose last
    STALL_WINDOW residuals are all above STALL_DECREASE times the smallest before them; a steady
    decrease of 5 % per iteration is never flagged."""
    flags = [solver.stalled(norms[:k + 1]) for k in range(len(norms))]
    first = flags.index(True) if any(flags) else None
    assert first == at


def test_a_solve_whose_trial_states_leave_the_domain_is_abandoned(block):
    """The block squeezed in one step to 3 times its height (no admissible state exists beyond
    load 1/3): every failed attempt stops after at most MAX_REJECTED + 1 rejected trial states per
    line search, says so, and the summary counts the rejected trial states and where the Newton
    iterations went."""
    problem = block.compressed(uy=-3 * block.HEIGHT)
    result = problem.solve(1, min_increment=1 / 16)
    failed = [a for a in result.attempts if not a["converged"]]
    assert failed
    abandoned = [a for a in failed if "abandoned after" in a["failure"]]
    assert abandoned, [a["failure"] for a in failed]
    assert all(0 < a["rejected_trial_states"] <= 2 * (solver.MAX_REJECTED + 1) for a in abandoned)
    economy = result.summary["newton"]
    assert economy["iterations"] == sum(a["newton_iterations"] for a in result.attempts)
    assert economy["in_failed_attempts"] == sum(a["newton_iterations"] for a in failed) > 0
    assert economy["failed_share"] == pytest.approx(economy["in_failed_attempts"] / economy["iterations"])
    assert economy["rejected_trial_states"] == sum(a["rejected_trial_states"] for a in result.attempts)
