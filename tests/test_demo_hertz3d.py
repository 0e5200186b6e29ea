"""The 3D Hertz demo (demos/hertz3d.py) on a coarse mesh: Hertz's formulas, and a short run into
contact: equilibrium of the forces and the bodies kept apart. (Hertz's radius and peak are not
asserted: at the meshes a test can afford the contact radius is below one element,
docs/notes/2026-11-26-demos3d.md.)"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

import hertz3d
from dolfinx_sfvem.output.run_summary import read_summary

#: coarse mesh (h = 0.15 within 0.4 of the contact point, 0.12 within 0.15 of it); the sphere closes
#: the gap 0.1 and indents the block by 0.005 in 5 steps
COARSE = ["--h", "0.15", "--h-core", "0.12", "--core-radius", "0.15", "--h-far", "0.5", "--fine-radius", "0.4",
          "--steps", "5", "--indent", "0.005", "--quiet",
          "--regularization", "huhu"]    # the default (rotation) compiles for minutes on a cold cache


def test_hertz_formulas():
    """K = 5/4, mu = 5/14 give E and nu of Eq. 2; Hertz's force F = 4/3 E* sqrt(R) delta^(3/2)."""
    assert hertz3d.E == pytest.approx(9 * 1.25 * (5 / 14) / (3.75 + 5 / 14))
    h = hertz3d.hertz(0.02, 100.0)
    E_star = 1 / ((1 - hertz3d.NU ** 2) / hertz3d.E * (1 + 1 / 100))
    assert 0.02 == pytest.approx(4 / 3 * E_star * math.sqrt(h.delta) ** 3, rel=1e-12)


def test_ellipse_fit_recovers_hertz_profile():
    """The fit returns a and p0 of an exact Hertz profile sampled at scattered radii, zeros outside
    the zone included (they fall below the fit's threshold)."""
    r = np.sort(np.random.default_rng(1).uniform(0.0, 0.3, 40))
    a, p0 = 0.2, 0.14
    p = p0 * np.sqrt(np.clip(1 - (r / a) ** 2, 0.0, None))
    assert hertz3d.ellipse_fit(np.stack([r, p], axis=1)) == pytest.approx((a, p0), rel=1e-10)
    assert all(math.isnan(v) for v in hertz3d.ellipse_fit(np.array([[0.0, 1.0], [0.1, 0.5]])))


def test_moment_radius_of_hertz_profile():
    """The pressure's second moment gives Hertz's a from scattered nodes of a quarter plane (zeros
    outside the zone included), to the linear interpolation's error, for any a, and a small far
    pressure moves it unless it lies beyond ``within``; a pressure uniform
    on a disc of radius a (second moment a^2 / 2) gives sqrt(5/4) a."""
    rng = np.random.default_rng(2)
    xy = np.concatenate([rng.uniform(0.0, 0.6, (20000, 2)), [[0.0, 0.0], [0.6, 0.0], [0.0, 0.6], [0.6, 0.6]]])
    r = np.hypot(xy[:, 0], xy[:, 1])
    for a in (0.15, 0.25):
        p = 0.14 * np.sqrt(np.clip(1 - (r / a) ** 2, 0.0, None))
        assert hertz3d.moment_radius(xy, p) == pytest.approx(a, rel=0.01)
        tail = p + 1e-2 * 0.14 * (r > 0.52)                         # a small far pressure, beyond 2 a
        assert hertz3d.moment_radius(xy, tail) > 1.03 * a
        assert hertz3d.moment_radius(xy, tail, within=2 * a) == pytest.approx(a, rel=0.01)
    fine = np.stack(np.meshgrid(np.linspace(0, 0.6, 241), np.linspace(0, 0.6, 241)), axis=-1).reshape(-1, 2)
    disc = (np.hypot(fine[:, 0], fine[:, 1]) <= 0.2).astype(float)
    assert hertz3d.moment_radius(fine, disc) == pytest.approx(math.sqrt(1.25) * 0.2, rel=0.01)
    assert math.isnan(hertz3d.moment_radius(fine, np.zeros(len(fine))))


def p2_nodal_forces(pressure, L: float = 0.6, n: int = 30) -> tuple[np.ndarray, np.ndarray]:
    """Nodes (m, 2) of P2 triangles on [0, L]^2 (n x n squares, two triangles each) and the consistent
    nodal forces (m,) int p phi_i dA of ``pressure`` (a function of (k, 2) points), by a degree-12 rule."""
    from dolfinx_sfvem.discretizations.quadrature import triangle_rule

    t = np.linspace(0.0, L, 2 * n + 1)                     # vertices at even, midpoints at odd indices
    index = np.arange(t.size ** 2).reshape(t.size, t.size)
    nodes = np.stack(np.meshgrid(t, t, indexing="ij"), axis=-1).reshape(-1, 2)
    i, j = np.meshgrid(2 * np.arange(n), 2 * np.arange(n), indexing="ij")
    i, j = i.ravel(), j.ravel()
    # corners then the midpoints of edges (1, 2), (2, 0), (0, 1)
    lower = np.stack([index[i, j], index[i + 2, j], index[i + 2, j + 2],
                      index[i + 2, j + 1], index[i + 1, j + 1], index[i + 1, j]], axis=1)
    upper = np.stack([index[i, j], index[i + 2, j + 2], index[i, j + 2],
                      index[i + 1, j + 2], index[i, j + 1], index[i + 1, j + 1]], axis=1)
    cells = np.concatenate([lower, upper])
    points, weights = triangle_rule(12)
    lam = np.column_stack([1.0 - points.sum(axis=1), points])                      # (q, 3)
    phi = np.column_stack([lam * (2 * lam - 1), 4 * lam[:, [1, 2, 0]] * lam[:, [2, 0, 1]]])   # (q, 6)
    corners = nodes[cells[:, :3]]
    e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    jacobian = np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])                  # (c,): twice the area
    p = pressure(np.einsum("qk,ckd->cqd", lam, corners).reshape(-1, 2)).reshape(len(cells), -1)  # (c, q)
    f = np.zeros(len(nodes))
    np.add.at(f, cells, jacobian[:, None] * np.einsum("q,cq,qi->ci", weights, p, phi))
    return nodes, f


def test_force_moment_radius_from_consistent_p2_forces():
    """The nodal forces' second moment is exact for P2 forces (a uniform pressure on the square:
    a_F^2 = 5/2 (2 L^4 / 3) / L^2 to round-off, though P2 vertices carry no force), gives Hertz's a
    from the consistent forces of Hertz's profile, and leaves out forces beyond ``within``."""
    L = 0.6
    nodes, f = p2_nodal_forces(lambda x: np.ones(len(x)), L)
    assert f.sum() == pytest.approx(L ** 2, rel=1e-12)
    assert hertz3d.force_moment_radius(nodes, f) == pytest.approx(math.sqrt(5 * L ** 2 / 3), rel=1e-12)
    for a in (0.15, 0.25):
        hertz_profile = lambda x: 0.14 * np.sqrt(np.clip(1 - np.sum(x ** 2, axis=1) / a ** 2, 0.0, None))  # noqa: E731
        nodes, f = p2_nodal_forces(hertz_profile, L)
        assert hertz3d.force_moment_radius(nodes, f) == pytest.approx(a, rel=2e-3)
        tail = f + 1e-2 * 0.14 * 0.02 ** 2 * (np.hypot(*nodes.T) > 0.52)
        assert hertz3d.force_moment_radius(nodes, tail) > 1.03 * a
        assert hertz3d.force_moment_radius(nodes, tail, within=2 * a) == pytest.approx(a, rel=2e-3)
    assert math.isnan(hertz3d.force_moment_radius(nodes, np.zeros(len(nodes))))


@pytest.fixture(scope="module")
def coarse_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("hertz3d")
    code = hertz3d.common.exit_code(hertz3d.main, [*COARSE, "--out", str(out)])
    return code, out


def test_coarse_run_into_contact(coarse_run):
    code, out = coarse_run
    assert code == 0
    for name in ("hertz3d.md", "hertz3d.json", "hertz3d.png", "pressure.csv", "summary.json", "final-pressure.png"):
        assert (out / name).is_file(), name
    summary = read_summary(out)
    last = summary.final_step
    # equilibrium: the medium's force on the block is what pushes the sphere down, and the block's
    # bottom and the symmetry planes hold all of it
    block = next(c for c in last.contact if c["region"] == hertz3d.sf.meshes.SOLID)
    F_quarter = -block["force"][2]
    assert F_quarter == pytest.approx(-last.reaction["load"][2], rel=2e-3)
    assert sum(r[2] for r in last.reaction.values()) == pytest.approx(0.0, abs=1e-6 * F_quarter)
    assert min(c["gap"] for s in summary.converged_steps for c in s.contact) > 0.0
    assert F_quarter > 0.0 and block["zone_length"] > 0.0 and block["max_pressure"] > 0.0
    record = json.loads((out / "hertz3d.json").read_text())       # the table's numbers, for bench/
    assert record["rows"][-1]["F"] == pytest.approx(4 * F_quarter, rel=2e-3)
    assert set(record["last"]) == {"a_fit", "p0_fit", "a_m", "a_m_H", "a_F"}
    assert record["last"]["a_m"] > 0.0 and record["last"]["a_F"] > 0.0
