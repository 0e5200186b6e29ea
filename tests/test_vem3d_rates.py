"""The order-2 SFVEM on polyhedral meshes, assembled serially (bench/vem3d_solve.py): the patch test
and the manufactured-solution rates of bench/vem3d_rates.py on the two coarsest levels of the
octree (hanging vertices) and Voronoi families (issue 31 item 4; expected rates 3 in L2, 2 in H1)."""
from __future__ import annotations

import numpy as np
import pytest
import vem3d_rates as rates
from vem3d_solve import error_norms, solve

A = np.array([[0.1, -0.2, 0.3], [0.05, 0.2, -0.1], [0.3, 0.1, 0.15]])


def linear(x: np.ndarray) -> np.ndarray:
    return x @ A.T + np.array([0.1, -0.3, 0.2])


@pytest.mark.parametrize("family", ["octree", "voronoi"])
def test_linear_displacement_reproduced_to_round_off(family):
    """Patch test of the assembled problem: a linear field, no body force, its boundary DOFs."""
    mesh = rates.FAMILIES[family][0](2 if family == "octree" else 3)
    solution = solve(mesh, linear, np.zeros_like)
    e0, e1 = error_norms(solution, linear, lambda x: np.repeat(A[None], x.shape[0], axis=0))
    assert e0 < 1e-11 and e1 < 1e-10, (e0, e1)


def test_manufactured_body_force_is_minus_div_sigma():
    """The body force against central differences of the exact stress."""
    x = np.array([[0.3, 0.6, 0.2], [0.8, 0.1, 0.5]])
    step = 1e-5
    C = np.zeros((3, 3, 3, 3))
    d = np.eye(3)
    C += rates.LAMBDA * np.einsum("ij,kl->ijkl", d, d) + rates.MU * (np.einsum("ik,jl->ijkl", d, d)
                                                                      + np.einsum("il,jk->ijkl", d, d))
    div = np.zeros((2, 3))
    for j in range(3):
        e = step * d[j]
        sigma = [np.einsum("ijkl,qkl->qij", C, rates.grad_exact(x + s * e)) for s in (1, -1)]
        div += (sigma[0][:, :, j] - sigma[1][:, :, j]) / (2 * step)
    assert np.allclose(rates.body_force(x), -div, atol=1e-7)


@pytest.mark.parametrize("family", ["octree", pytest.param("voronoi", marks=pytest.mark.slow)])
def test_manufactured_solution_rates(family):
    make, sizes = rates.FAMILIES[family]
    levels = [rates.run_level(make(n)) for n in sizes[:2]]
    if family == "octree":
        assert levels[0]["faces_per_cell"] > 6 and levels[1]["faces_per_cell"] > 6   # hanging vertices, split faces
    h = np.log([r["h"] for r in levels])
    rate_L2, rate_H1 = (np.diff(np.log([r[k] for r in levels]))[0] / np.diff(h)[0] for k in ("L2", "H1"))
    assert rate_L2 > 2.6 and rate_H1 > 1.7, (rate_L2, rate_H1, levels)
