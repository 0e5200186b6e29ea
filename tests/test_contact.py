"""Contact honesty: the injectivity guard, the signed gap between the solids, and runs whose
solids pass through each other never ending as converged (docs/contact.md)."""
import csv
import json
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import dolfinx_sfvem as sf
from dolfinx_sfvem.physics.contact import OVERLAP_TOLERANCE
from dolfinx_sfvem.discretizations.injectivity import folded_elements
from dolfinx_sfvem.physics.energy import neo_hookean
from dolfinx_sfvem.problem import Result
from dolfinx_sfvem.mpi_launcher import job_environment
from process_report import report

ROOT = pathlib.Path(__file__).resolve().parents[1]
SOLID, MEDIUM, OTHER = 1, 2, 3
K, MU = 5 / 3, 5 / 14


def medium(**kw) -> sf.ThirdMedium:
    return sf.ThirdMedium(**{"mu": MU, "gamma": 1e-5, "alpha_r": 1.0, **kw})


# --------------------------------------------------------------------------- the guard
SQUARE = np.array([[0, 0], [0.5, 0], [1, 0], [1, 0.5], [1, 1], [0.5, 1], [0, 1], [0, 0.5]], dtype=float)


def guard(u: np.ndarray, solid: bool = True) -> tuple[bool, bool]:
    """(folded, kinked) of the one square whose boundary nodes (vertex, midpoint, ...) move by u (8, 2)."""
    folded, kinked = folded_elements(np.array([0, 8]), np.arange(8), SQUARE, u, np.array([0]), np.array([solid]))
    return bool(folded[0]), bool(kinked[0])


def test_guard_on_one_element():
    assert guard(np.zeros((8, 2))) == (False, False)
    assert guard(SQUARE @ np.array([[0.0, 0.3], [0.2, 0.0]])) == (False, False)    # sheared, one-to-one
    mirrored = SQUARE * [-1, 1] - SQUARE                                          # x -> -x: turned over
    assert guard(mirrored) == (True, False)
    pulled = np.zeros((8, 2))
    pulled[1] = [0.0, 1.3]                    # bottom midpoint pulled through the top side: area still > 0
    assert guard(pulled) == (False, True)
    assert guard(mirrored, solid=False) == guard(pulled, solid=False) == (False, False)   # medium: not checked


def octagon_problem(energy: sf.Energy) -> sf.ContactProblem:
    angles = 2 * np.pi * np.arange(8) / 8
    mesh = sf.PolygonMesh(np.column_stack([np.cos(angles), np.sin(angles)]), [list(range(8))], [SOLID])
    return sf.ContactProblem(mesh, {SOLID: energy}, verbose=False)


def moved_vertex(problem: sf.ContactProblem, at, by) -> None:
    """The state: every node at rest except the one at ``at``, moved by ``by``."""
    node = np.flatnonzero(np.hypot(*(problem.disc.space.x_nodes - at).T) < 1e-12)
    with problem.x.localForm() as xl:
        u = xl.array.reshape(-1, 2)
        u[:] = 0.0
        u[node] = by


def assembly_info(problem: sf.ContactProblem):
    return problem.disc.residual(problem.x, problem.disc.create_vector())


def test_sfvem_guard_reports_a_kink_that_J_at_the_quadrature_points_misses():
    """A regular octagon whose vertex (1, 0) is pushed past its neighbour's edge: J > 0 at every
    quadrature point, but the deformed boundary crosses itself: reported as kinked (a point load
    crushes solid polygons like this, so it is not rejected); turned over, it is rejected."""
    problem = octagon_problem(sf.Hyperelastic(K=K, mu=MU))
    moved_vertex(problem, (1.0, 0.0), (-0.2, 0.7))
    info = assembly_info(problem)
    assert info.min_J > 0.0
    assert info.kinked == 1 and info.folded == 0 and info.admissible
    with problem.x.localForm() as xl:
        xl.array.reshape(-1, 2)[:] = problem.disc.space.x_nodes * [-2.0, 0.0]      # x -> -x
    info = assembly_info(problem)
    assert info.folded == 1 and info.folded_cell == 0 and not info.admissible
    with pytest.raises(ValueError, match="folded"):
        problem.solve(steps=1)
    squeezed = octagon_problem(medium())                # the medium is not checked
    moved_vertex(squeezed, (1.0, 0.0), (-0.2, 0.7))
    assert assembly_info(squeezed).kinked == 0


def test_fem_guard_catches_a_fold_that_J_at_the_quadrature_points_misses():
    """One P2 triangle whose bottom edge midpoint is pulled down and back: J > 0 at the six
    quadrature points, J < 0 at a vertex node."""
    triangle = sf.PolygonMesh([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]], [SOLID])
    problem = sf.ContactProblem(triangle, {SOLID: sf.Hyperelastic(K=K, mu=MU)}, method="fem", fem_mesh=triangle,
                                verbose=False)
    node = np.flatnonzero(np.hypot(*(problem.disc.x_nodes - (0.5, 0.0)).T) < 1e-12)
    with problem.x.localForm() as xl:
        xl.array.reshape(-1, 2)[node] = (-0.3, -0.8)
    info = assembly_info(problem)
    assert info.min_J > 0.0 and info.folded == 1 and not info.admissible


# --------------------------------------------------------------------------- the gap
def two_blocks() -> sf.PolygonMesh:
    """Block [0,1]x[0,1] (SOLID), medium layer [0,1]x[1,1.2], block [0,1]x[1.2,2.2] (OTHER)."""
    return sf.meshes.glue(sf.meshes.quad_rectangle(1.0, 1.0, 4, 4, tag=SOLID),
                          sf.meshes.quad_rectangle(1.0, 0.2, 4, 1, origin=(0.0, 1.0), tag=MEDIUM),
                          sf.meshes.quad_rectangle(1.0, 1.0, 4, 4, origin=(0.0, 1.2), tag=OTHER))


@pytest.mark.mpi
@pytest.mark.parametrize("method", ["vem", "fem"])
@pytest.mark.parametrize("drop, gap", [(0.0, 0.2), (0.1, 0.1), (0.3, -0.1)])
def test_gap_between_two_bodies(method, drop, gap):
    """The upper block moved down by ``drop`` onto the lower one: gap 0.2 - drop, negative when
    they overlap, with the two regions named."""
    options = {"fem_mesh": two_blocks()} if method == "fem" else {}
    problem = sf.ContactProblem(two_blocks(), {SOLID: sf.Hyperelastic(K=K, mu=MU), MEDIUM: medium(),
                                               OTHER: sf.Hyperelastic(K=K, mu=MU)},
                                method=method, verbose=False, **options)
    problem.set_displacement(uy=lambda x: np.where(x[1] > 1.1, -drop, 0.0))
    g = problem.contact_gap()
    assert g.value == pytest.approx(gap, abs=1e-12)
    assert {g.region, g.partner_region} == {SOLID, OTHER} and g.body != g.partner_body
    assert g.overlapping == (gap < 0)
    if gap < 0:                  # 0.1 deep, tolerance 0.02 x edge length 0.25
        assert g.overlap == pytest.approx(0.1 / (0.02 * 0.25))
        assert "inside region" in g.describe()


@pytest.mark.mpi
def test_self_contact_gap_is_objective():
    """C-box at rest: the beams' facing surfaces are 0.3 apart (the other surfaces of the one body
    do not face each other); the same after a rigid motion, 1.5 times that after a uniform stretch."""
    box = sf.meshes.cbox(h_solid=0.1)
    problem = sf.ContactProblem(box.mesh, {SOLID: sf.Hyperelastic(K=K, mu=MU), MEDIUM: medium()}, verbose=False)
    assert problem.boundary.n_bodies == 1
    assert problem.contact_gap().value == pytest.approx(0.3, abs=1e-12)
    c, s = np.cos(0.5), np.sin(0.5)
    problem.set_displacement(ux=lambda x: c * x[0] - s * x[1] + 2.0 - x[0], uy=lambda x: s * x[0] + c * x[1] - 1.0 - x[1])
    assert problem.contact_gap().value == pytest.approx(0.3, abs=1e-12)
    problem.set_displacement(ux=lambda x: 0.5 * x[0], uy=lambda x: 0.5 * x[1])
    assert problem.contact_gap().value == pytest.approx(0.45, abs=1e-12)


def test_overlap_tolerance_must_be_positive():
    with pytest.raises(ValueError, match="overlap tolerance"):
        sf.ContactProblem(two_blocks(), {SOLID: sf.Hyperelastic(K=K, mu=MU), MEDIUM: medium(),
                                         OTHER: sf.Hyperelastic(K=K, mu=MU)}, verbose=False, overlap_tolerance=0.0)


# --------------------------------------------------------------------------- runs
def thin_column_cbox(overlap_tolerance: float) -> Result:
    """The paper's C-box (u_y = -0.5 in 25 steps, h = 0.05) with a medium column only 0.0125 wide:
    the medium between the beams is dragged out sideways and the upper beam passes through the
    lower one (docs/contact.md)."""
    box = sf.meshes.cbox(h_solid=0.05, column=0.0125)
    problem = sf.ContactProblem(box.mesh, {SOLID: sf.Hyperelastic(K=K, mu=MU), MEDIUM: medium()}, verbose=False,
                                overlap_tolerance=overlap_tolerance)
    problem.fix(lambda x: np.isclose(x[0], 0.0))
    problem.prescribe(lambda x: np.hypot(x[0] - 1.0, x[1] - 0.5) < 1e-10, uy=-0.5, name="load")
    return problem.solve(steps=25)


def converged_gaps(result) -> np.ndarray:
    return np.array([s["gap"]["value"] for s in result.steps if s["converged"]])


@pytest.mark.slow
def test_penetrating_run_never_ends_as_converged():
    """Unchecked (tolerance 1e9), the thin-column C-box reaches the full load with the beams 0.05
    through each other; checked, it stops as not converged, naming the overlap, and every step
    it kept has the solids apart (within the tolerance, 0.02 x 0.05 = 1e-3)."""
    unchecked = thin_column_cbox(1e9)
    assert unchecked.converged and converged_gaps(unchecked).min() < -0.02
    checked = thin_column_cbox(OVERLAP_TOLERANCE)
    assert not checked.converged and checked.load < 1.0
    assert "solids overlap" in checked.message and "region 1 (body 0)" in checked.message
    assert converged_gaps(checked).min() >= -0.02 * 0.05


def run_cbox(*args, out):
    return subprocess.run([sys.executable, str(ROOT / "demos" / "cbox.py"), "--h", "0.1", "--quiet", "--out", str(out),
                           *args], capture_output=True, text=True, cwd=ROOT, timeout=600,
                          env=job_environment())


def test_cbox_gap_is_recorded_per_step(tmp_path):
    proc = run_cbox("--uy", "-0.2", "--steps", "4", "--fixed-increments", "--pressure-at", "0.5", "0.6",
                    out=tmp_path)
    assert proc.returncode == 0, report(proc)
    summary = json.loads((tmp_path / "summary.json").read_text())
    gaps = [s["gap"]["value"] for s in summary["steps"]]
    assert gaps[0] < 0.3 and all(np.diff(gaps) < 0) and gaps[-1] > 0     # the beams approach
    header = (tmp_path / "load_path.csv").read_text().splitlines()[0].split(",")
    assert header[3:6] == ["gap", "gap_x", "gap_y"]
    # pressure plots at the first steps reaching 0.5 and 0.6 (loads 0.5 and 0.75) and at the end
    plots = sorted(f.name for f in tmp_path.glob("contact_pressure*.png"))
    assert plots == ["contact_pressure.png", "contact_pressure_0.5.png", "contact_pressure_0.75.png"]
    assert "pressure_at" not in summary["parameters"]      # output choice, not part of the problem


def test_resume_of_another_problem_is_refused(tmp_path):
    """Resuming with another prescribed displacement would relabel the saved state: refused,
    naming what differs; the saved run is untouched."""
    assert run_cbox("--uy", "-0.2", "--steps", "8", out=tmp_path).returncode == 0
    before = (tmp_path / "summary.json").read_text()
    proc = run_cbox("--uy", "-0.3", "--steps", "8", "--resume", str(tmp_path), out=tmp_path)
    assert proc.returncode == 2
    assert "cannot resume" in proc.stderr and "parameters.uy: saved -0.2, now -0.3" in proc.stderr
    assert (tmp_path / "summary.json").read_text() == before


@pytest.mark.mpi
@pytest.mark.parametrize("method", ["vem", "fem"])
def test_contact_pressure_through_a_flat_layer(method):
    """The upper block pressed onto the lower one through a flat medium layer: the medium's force
    on each block balances the reaction at the upper block's top exactly (discrete equilibrium),
    and its pressure along the layer is nearly uniform, about that force per unit width."""
    options = {"fem_mesh": two_blocks()} if method == "fem" else {}
    p = sf.ContactProblem(two_blocks(), {SOLID: sf.Hyperelastic(K=K, mu=MU), MEDIUM: medium(gamma=1e-2),
                                         OTHER: sf.Hyperelastic(K=K, mu=MU)}, method=method, verbose=False, **options)
    p.fix(lambda x: np.isclose(x[1], 0.0))
    p.prescribe(lambda x: np.isclose(x[1], 2.2), uy=-0.1, name="top")
    result = p.solve(steps=2)
    assert result.converged
    top = result.steps[-1]["reaction"]["top"]
    contact = p.contact_pressure()
    lower, upper = sorted(contact.pairs, key=lambda pair: pair.region)
    assert (lower.region, lower.partner_region, upper.region) == (SOLID, OTHER, OTHER)
    assert upper.force == pytest.approx((-top[0], -top[1]), rel=1e-6, abs=1e-12)
    assert lower.force == pytest.approx((top[0], top[1]), rel=1e-6, abs=1e-12)
    assert upper.force[1] > 0 and upper.zone_length == pytest.approx(1.0, rel=0.01)
    surface = (contact.body == upper.body) & np.isclose(contact.X[:, 1], 1.2)
    pressure = contact.pressure[surface]
    assert pressure.size == 9 and np.all(np.abs(pressure / upper.force[1] - 1) < 0.05)
    assert contact.zone[surface].all() and not contact.zone[(contact.body == upper.body) & (contact.X[:, 1] > 2.0)].any()
    assert result.steps[-1]["contact"][0]["force"] == pytest.approx(list(lower.force))


# --------------------------------------------------------------------------- pressure recovery
def layer_on_block(mesh: str) -> sf.PolygonMesh:
    """Block [0,1]x[0,1] (SOLID) under a medium layer [0,1]x[1,1.2], their interface cut into
    edges of unequal lengths: ``"hanging"`` 3 solid quads against 4 medium quads (sub-edges 1/4,
    1/12, 1/6, 1/6, 1/12, 1/4 between hanging nodes), ``"graded"`` one graded grid of rectangles
    (edges 0.1, 0.35, 0.15, 0.4; conforming, so the Q2 FEM can use it)."""
    if mesh == "hanging":
        return sf.meshes.glue(sf.meshes.quad_rectangle(1.0, 1.0, 3, 3, tag=SOLID),
                              sf.meshes.quad_rectangle(1.0, 0.2, 4, 1, origin=(0.0, 1.0), tag=MEDIUM))
    xs, ys = np.array([0.0, 0.1, 0.45, 0.6, 1.0]), np.array([0.0, 0.5, 1.0, 1.2])
    points = np.array([(x, y) for y in ys for x in xs])
    n = xs.size
    cells = [[j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i]
             for j in range(ys.size - 1) for i in range(n - 1)]
    tags = [SOLID if ys[j] < 1.0 else MEDIUM for j in range(ys.size - 1) for i in range(n - 1)]
    return sf.PolygonMesh(points, cells, tags)


@pytest.mark.mpi
@pytest.mark.parametrize("method, mesh", [("vem", "hanging"), ("vem", "graded"), ("fem", "graded")])
def test_pressure_of_a_uniformly_compressed_layer(method, mesh):
    """Everything compressed homogeneously, F = diag(1, lambda): the medium's first Piola stress is
    uniform, and its normal traction on the block's top, p = -P_yy = -dPsi/dlambda of Psi(lambda) =
    gamma [mu/2 (lambda^(-2/3) (2 + lambda^2) - 3) + K/2 ln(lambda)^2] (Eq. 3; G = 0, so the
    regularization adds nothing), is recovered at every node of the top, whatever its edge lengths."""
    lam, gamma, mu_m, K_m = 0.6, 1e-2, MU, 0.5
    options = {"fem_mesh": layer_on_block(mesh)} if method == "fem" else {}
    p = sf.ContactProblem(layer_on_block(mesh), {SOLID: sf.Hyperelastic(K=K, mu=MU),
                                                  MEDIUM: medium(gamma=gamma, K=K_m)}, method=method, verbose=False,
                          **options)
    p.set_displacement(uy=lambda x: (lam - 1.0) * x[1])
    P_yy = gamma * (mu_m / 2 * (-2 / 3 * lam ** (-5 / 3) * (2 + lam ** 2) + 2 * lam ** (1 / 3)) + K_m * np.log(lam) / lam)
    contact = p.contact_pressure()
    top = np.isclose(contact.X[:, 1], 1.0)
    assert top.sum() == {"hanging": 13, "graded": 9}[mesh]
    assert contact.pressure[top] == pytest.approx(np.full(top.sum(), -P_yy), rel=1e-9)
    assert np.all(contact.pressure[~top] == 0.0)         # no other solid edge faces the medium


def neo_hookean_medium(F, G, gamma, mu, K):
    return gamma * neo_hookean(F, K, mu)


@pytest.mark.parametrize("method", ["vem", "fem"])
def test_medium_force_without_regularization_is_its_neo_hookean_part(method):
    """On a curved state (G != 0), the medium force without regularization equals that of the
    medium's neo-Hookean part written as an energy of its own, and the regularization's force
    is not zero there."""
    def problem(energy):
        options = {"fem_mesh": two_blocks()} if method == "fem" else {}
        p = sf.ContactProblem(two_blocks(), {SOLID: sf.Hyperelastic(K=K, mu=MU), MEDIUM: energy,
                                             OTHER: sf.Hyperelastic(K=K, mu=MU)}, method=method, verbose=False,
                              **options)
        p.set_displacement(ux=lambda x: 0.05 * x[0] * x[1], uy=lambda x: -0.1 * (x[1] - 1.0) ** 2 * (x[0] + 1.0))
        return p

    def force(p, regularization=True):
        f = p.disc.create_vector()
        p.disc.medium_force(p.x, f, regularization)
        return f.getArray().copy()
    full = problem(medium(K=0.3))
    material = problem(sf.UserEnergy(neo_hookean_medium, uses_gradient=False, medium=True, gamma=1e-5, mu=MU, K=0.3))
    expected = force(material)
    assert np.abs(expected).max() > 0.0
    assert force(full, regularization=False) == pytest.approx(expected, rel=1e-10, abs=1e-12 * np.abs(expected).max())
    assert np.abs(force(full) - expected).max() > 1e-3 * np.abs(expected).max()


@pytest.fixture(scope="module")
def cbox_end_state() -> sf.ContactProblem:
    """The paper's C-box (u_y = -0.5, gamma = 1e-5, alpha_r = 1, rotation; h = 0.05, 25 steps) at
    the full load: the upper beam's tip corner pressed into the lower beam (docs/contact.md)."""
    box = sf.meshes.cbox(h_solid=0.05)
    problem = sf.ContactProblem(box.mesh, {SOLID: sf.Hyperelastic(K=K, mu=MU), MEDIUM: medium()}, verbose=False)
    problem.fix(lambda x: np.isclose(x[0], 0.0))
    problem.prescribe(lambda x: np.hypot(x[0] - 1.0, x[1] - 0.5) < 1e-10, uy=-0.5, name="load")
    assert problem.solve(steps=25).converged
    return problem


def gathered(problem: sf.ContactProblem, v) -> np.ndarray:
    """The values of ``v`` at the solids' boundary nodes, in :attr:`SolidBoundary.node_keys` order."""
    return problem.boundary.gather(problem.comm, *problem.disc.get_state(v))


def medium_forces(problem: sf.ContactProblem, regularization: bool = True) -> np.ndarray:
    f = problem.disc.create_vector()
    problem.disc.medium_force(problem.x, f, regularization)
    return gathered(problem, f)


def test_cbox_pressure_is_small_away_from_contact_and_nowhere_strongly_tensile(cbox_end_state):
    """Away from the contact (reference x < 0.5: the beams' inner halves, the C's inner corners),
    the pressure stays below 1 % of its peak, and it is nowhere tensile beyond 5 % of it. The
    regularization's nodal forces recovered in the same way would give a sawtooth of more than
    10 % of the peak there and tensile values at the inner corner (0.1, 0.4)."""
    problem = cbox_end_state
    contact = problem.contact_pressure()
    (pair,) = contact.pairs
    on = contact.partner_body >= 0
    away = on & (contact.X[:, 0] < 0.5)
    peak = contact.pressure[on].max()
    assert peak == pair.max_pressure and contact.X[on][np.argmax(contact.pressure[on]), 0] > 0.9
    assert np.abs(contact.pressure[away]).max() < 0.01 * peak
    assert contact.pressure.min() > -0.05 * peak
    assert sorted(np.unique(contact.surface[on])) == [0, 1]      # the two beams
    whole = medium_forces(problem)
    regularization = whole - medium_forces(problem, regularization=False)
    _, of_regularization = problem.boundary.gap_and_pressure(gathered(problem, problem.x), whole, regularization)
    corner = np.hypot(*(contact.X - (0.1, 0.4)).T) < 1e-12
    assert np.abs(of_regularization.pressure[away]).max() > 0.1 * peak
    assert of_regularization.pressure[corner] < -0.1 * peak


def test_cbox_pair_force_is_the_whole_medium_force(cbox_end_state):
    """The pair's force sums the medium's whole force (regularization included) over the pair's
    nodes, not its material part's; the whole medium force on the body vanishes (the medium's
    own nodes are in equilibrium and its energy is translation invariant), its material part's
    does not."""
    problem = cbox_end_state
    contact = problem.contact_pressure()
    (pair,) = contact.pairs
    b = problem.boundary
    whole, material = (b._in_node_order(medium_forces(problem, r)) for r in (True, False))
    on = contact.partner_body >= 0
    assert pair.force == pytest.approx(tuple(-whole[on].sum(axis=0)), rel=1e-12, abs=1e-18)
    assert np.abs(np.array(pair.force) + material[on].sum(axis=0)).max() > 0.05 * np.abs(pair.force).max()
    scale = np.abs(whole).sum()
    assert np.abs(whole.sum(axis=0)).max() < 1e-6 * scale < np.abs(material.sum(axis=0)).max()


@pytest.mark.parametrize("p, q, r, s, meet", [
    ((0, 0), (2, 0), (1, -1), (1, 1), True),          # proper crossing
    ((0, 0), (2, 0), (2, 0), (3, 1), True),           # touching at an end point
    ((0, 0), (2, 0), (1, 0), (3, 0), True),           # collinear, overlapping
    ((0, 0), (2, 0), (2, 0), (3, 0), True),           # collinear, touching end to end
    ((0, 0), (2, 0), (2.5, 0), (3, 0), False),        # collinear, apart
    ((0, 0), (2, 0), (1, 0.5), (1, 2), False),        # bounding boxes overlap in x, the segments do not meet
    ((0, 0), (2, 2), (1, 1.2), (2, 0.5), True),       # crossing a diagonal
    ((0, 0), (2, 2), (1.5, 1.2), (2, 0.5), False),    # beside it
])
def test_segments_cross_on_touching_and_collinear_segments(p, q, r, s, meet):
    """The guard's segment test (injectivity.segments_cross) on the closed segments [p, q], [r, s],
    in both orders of the two segments and of their end points."""
    from dolfinx_sfvem.discretizations.injectivity import segments_cross
    for a, b in ((p, q), (q, p)):
        for c, d in ((r, s), (s, r)):
            assert segments_cross(*map(float, (*a, *b, *c, *d))) is meet
            assert segments_cross(*map(float, (*c, *d, *a, *b))) is meet


def test_load_path_csv_has_three_columns_per_vector_in_3d(tmp_path):
    """A 3D step's gap position, reactions and contact forces have three components: three columns
    each, in the header and in the row (a 2D header would shift every later column)."""
    from dolfinx_sfvem.output.post import write_load_path_csv
    step = {"step": 1, "load": 0.5, "newton_iterations": 3, "converged": True, "negative_pivots": 0,
            "gap": {"value": 0.1, "x": [1.0, 2.0, 3.0]}, "reaction": {"load": [4.0, 5.0, 6.0]},
            "contact": [{"body": 0, "partner_body": 1, "force": [7.0, 8.0, 9.0], "max_pressure": 10.0,
                         "zone_length": 11.0}], "extra": {"tip": 12.0}, "dofs": 99}
    write_load_path_csv(tmp_path / "lp.csv", [step])
    with open(tmp_path / "lp.csv", newline="") as f:
        row = next(csv.DictReader(f))
    assert [float(row[k]) for k in ("gap_x", "gap_y", "gap_z", "load_Rx", "load_Ry", "load_Rz")] == [1, 2, 3, 4, 5, 6]
    assert [float(row[f"contact_0-1_{q}"]) for q in ("Fx", "Fy", "Fz", "p_max", "zone")] == [7, 8, 9, 10, 11]
    assert float(row["tip"]) == 12.0 and int(row["dofs"]) == 99
