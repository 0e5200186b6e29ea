"""The compiled pointwise kernels in 3D (dolfinx_sfvem.discretizations.compiled_energy with dim=3, paper Eqs. 30, 32).

References from outside the code under test (conftest.py's ``by_hand``): Psi written with numpy
(Eq. 2 and Eqs. 3, 6, 8), and central finite differences of it: P = dPsi/dF, T = dPsi/dG, then
D = dP/dF, A = dT/dF, B = dT/dG as differences of the compiled P and T.
"""
import numpy as np
import pytest

from dolfinx_sfvem import Hyperelastic, ThirdMedium
from dolfinx_sfvem.discretizations.compiled_energy import compile_kernels, evaluate, shapes

SOLID = Hyperelastic(K=5.0, mu=1.5)
MEDIUM = ThirdMedium(mu=1.5, gamma=0.3, alpha_r=0.7, regularization="huhu", beta=0.4, K=2.0)


def state(seed):
    rng = np.random.default_rng(seed)
    return np.eye(3) + 0.2 * rng.standard_normal((3, 3)), 0.5 * rng.standard_normal((3, 3, 3))


@pytest.mark.parametrize("energy", [SOLID, MEDIUM], ids=["neo-Hooke", "huhu medium"])
def test_kernels_3d(energy, by_hand):
    central = by_hand.central_difference
    k = compile_kernels(energy, dim=3)
    assert k.dim == 3 and k.G_offset == 9 and min(k.param_offsets.values()) == 36
    assert k.n_residual == (37 if energy.uses_gradient else 10)
    for seed in range(2):
        F, G = state(seed)
        r = evaluate(k, F, G, energy.params)
        at = lambda F_, G_: evaluate(k, F_, G_, energy.params)  # noqa: E731
        assert r["psi"] == pytest.approx(by_hand.psi(energy, F, G), rel=1e-13)
        P = central(lambda X: by_hand.psi(energy, X, G), F)
        np.testing.assert_allclose(r["P"], P, rtol=0, atol=1e-7 * np.abs(P).max())
        D = central(lambda X: at(X, G)["P"], F)
        np.testing.assert_allclose(r["D"], D, rtol=0, atol=1e-7 * np.abs(D).max())
        if energy.uses_gradient:
            T = central(lambda X: by_hand.psi(energy, F, X), G)
            np.testing.assert_allclose(r["T"], T, rtol=0, atol=1e-7 * np.abs(T).max())
            A = central(lambda X: at(X, G)["T"], F)
            np.testing.assert_allclose(r["A"], A, rtol=0, atol=1e-7 * np.abs(A).max())
            B = central(lambda X: at(F, X)["T"], G)
            np.testing.assert_allclose(r["B"], B, rtol=0, atol=1e-7 * np.abs(B).max())
        else:
            for name in ("T", "A", "B"):
                assert r[name].shape == shapes(3)[name] and not r[name].any()


def test_2d_and_3d_kernels_are_distinct():
    assert compile_kernels(SOLID, dim=3) is not compile_kernels(SOLID)
    assert compile_kernels(SOLID).dim == 2 and compile_kernels(SOLID).n_constants == 14
    with pytest.raises(ValueError, match="dim=4"):
        compile_kernels(SOLID, dim=4)
