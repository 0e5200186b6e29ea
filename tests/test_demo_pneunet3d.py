"""The 3D PneuNet demo (demos/pneunet3d.py) on its coarsest grid (h = 4: a box per wall, 108 Q2
hexahedra, 3,705 unknowns) with two chambers, a few load steps up to contact between them.

What could fail: the walls approaching each other through the medium must never cross (the
smallest gap falls and stays positive), the chambers must grow and the tip bend towards the base
as the pressure grows, the cavity loads are internal (the reactions balance), the stored energy
equals the work of the chamber pressures along the path (the work-conjugate volumes are the
right ones), and 1 and 2 ranks give the same state. The medium has the demo's default Hu-Hu
regularization (one compiled form for the whole file, seconds to compile)."""
from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

import pneunet3d as pn

P = 0.003
COARSE = ["--h", "4", "--steps", "3", "--fixed-increments", "--p", str(P), "--quiet"]


def solved(comm: MPI.Comm = MPI.COMM_WORLD, argv=()):
    """The coarse problem solved on ``comm`` (no output directory) and its run summary."""
    args = pn.common.parse_args(pn.make_parser(), [*COARSE, *argv])
    problem, observers = pn.build(pn.benchmark(args), args, comm)
    result = problem.solve(control=pn.common.load_stepping(args), observers=observers)
    assert result.converged, result.message
    return problem, result.summary


@pytest.fixture(scope="module")
def run():
    return solved()


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    """The demo's command line on the coarse grid (serial): exit code and its curve."""
    out = tmp_path_factory.mktemp("pneunet3d")
    code = pn.common.exit_code(pn.main, [*COARSE, "--out", str(out)])
    return code, out


def test_demo_writes_its_outputs(demo):
    code, out = demo
    assert code == 0
    for name in ("actuator.md", "actuator.png", "load_path.csv", "summary.json"):
        assert (out / name).is_file(), name
    assert "The load path:" in (out / "actuator.md").read_text()


def test_walls_approach_without_crossing_and_the_chambers_grow(demo):
    """The gap between the chambers falls at every step from the 2 mm spacing, below half of it,
    and stays positive; every chamber's volume and the bending angle grow at every step."""
    _, out = demo
    curve = pn.read_curve(out, "fem")
    assert curve.pressure[-1] == pytest.approx(P, rel=1e-12)
    assert curve.gap[0] == pn.GEOMETRY.spacing
    assert np.all(np.diff(curve.gap) < 0) and np.all(curve.gap > 0.0), curve.gap
    assert curve.gap[-1] < 0.5 * pn.GEOMETRY.spacing, curve.gap
    assert curve.area.shape == (4, 2) and np.all(np.diff(curve.area, axis=0) > 0), curve.area
    assert np.all(np.diff(curve.angle) > 0), curve.angle


def test_reactions_balance(run):
    """The chamber pressures are internal loads: the clamp holds no force along x and z (the
    symmetry plane takes none), and along y the clamp and the symmetry plane's nodes off the clamp
    hold equal and opposite forces."""
    problem, _ = run
    r = problem.reactions()
    clamp, symmetry = np.array(r["clamp"]), np.array(r["symmetry"])
    scale = abs(clamp[1])
    assert scale > 0.0
    assert abs(clamp[0]) < 1e-8 * scale and abs(clamp[2]) < 1e-8 * scale, clamp
    assert symmetry[0] == 0.0 and symmetry[2] == 0.0
    assert clamp[1] + symmetry[1] == pytest.approx(0.0, abs=1e-8 * scale)


def test_stored_energy_is_the_work_of_the_pressures(run):
    """W(u) at the end equals sum_i ∫ p dV_i along the path (trapezoidal rule on the steps, the
    volume changes ∫ (J - 1) the cavity loads' work conjugates): the potential's energy terms
    -p ∫ (J - 1) added back to it. A wrong conjugate (e.g. the full chamber for the half) or a
    load applied twice breaks it by far more than the trapezoidal rule's error."""
    problem, summary = run
    steps = [s for s in summary["steps"] if s["converged"]]
    names = [name for name in steps[-1]["loads"]]
    equilibrium = problem.equilibrium()
    equilibrium.set_load(problem.load)
    potential = equilibrium.potential(problem.x)
    equilibrium.destroy()
    work, stored = 0.0, potential
    for name in names:
        p = np.array([0.0] + [s["loads"][name]["magnitude"] for s in steps])
        v = np.array([0.0] + [s["loads"][name]["displacement"] for s in steps])
        work += float(np.sum(0.5 * (p[1:] + p[:-1]) * np.diff(v)))
        stored += p[-1] * v[-1]
    assert stored > 0.0
    assert stored == pytest.approx(work, rel=0.03)          # 1.2 % measured (3 steps)


@pytest.mark.mpi
def test_same_state_on_one_and_two_ranks(run):
    """The coarse run on all ranks and on each rank alone: the tip displacements, volumes and
    reactions agree to 1e-9."""
    problem, summary = run
    alone, alone_summary = solved(MPI.COMM_SELF)
    last, last_alone = summary["steps"][-1], alone_summary["steps"][-1]
    for name in last["loads"]:
        assert last["loads"][name]["displacement"] == pytest.approx(last_alone["loads"][name]["displacement"],
                                                                    rel=1e-9)
    world, single = problem.reactions(), alone.reactions()
    for name in single:
        assert np.allclose(world[name], single[name], rtol=1e-9, atol=1e-12 * np.abs(single[name]).max())
