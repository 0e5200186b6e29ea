"""Diagnose a stalled load step of demos/hertz.py (serial; docs/notes/2026-11-23-gamma-1e-6.md).

From the checkpoint of a stopped run (``--from DIR``, the same options as that run), this
measures at the last converged state and after a Newton solve to ``--target``:

- the residual norm, the solver's absolute tolerance and the round-off level eps * F_c;
- the inertia of the tangent's free block (MUMPS LDL^T, ``-mat_mumps_sym 2``: INFOG(12) is
  the number of negative pivots) and its eigenvalues nearest zero (scipy shift-invert), with
  where the lowest eigenvector lives;
- which rows carry the residual: per region, constrained rows, and the largest entries.

    .venv/bin/python bench/gamma6_diagnose.py --gamma 1e-6 --h 0.03 --steps 20 --from out/cyl-h03-g6 --target 0.679834

``--energy-ls`` instead runs a prototype Newton with a line search on the energy (slope
R(x + t dx) . dx) from the checkpoint to ``--target``.
"""
from __future__ import annotations

import pathlib
import sys

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from petsc4py import PETSc

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "demos"))
import hertz as cb  # noqa: E402
import _common as common  # noqa: E402
import dolfinx_sfvem as sf  # noqa: E402
from dolfinx_sfvem.path_following.snes import SNESNewton  # noqa: E402


def restored(problem: sf.ContactProblem, src: pathlib.Path) -> tuple[SNESNewton, np.ndarray, np.ndarray, float]:
    """The Newton solver of ``problem`` at the state of the checkpoint in ``src``: (solver, values
    of the owned constrained unknowns at load factor 1, constrained mask, the checkpoint's load)."""
    constraints = problem.constraints()
    problem.disc.set_constraints(constraints.dofs)
    newton = SNESNewton(problem.equilibrium(), None, problem.petsc_options_prefix)
    data = np.load(src / "checkpoint.npz")
    problem.disc.set_state(data["keys"], data["values"], problem.x)
    problem.x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
    return newton, constraints.final, problem.disc.constraints.mask, float(data["control_load"])


def free_block(A: PETSc.Mat, free: np.ndarray) -> sp.csr_matrix:
    indptr, indices, values = A.getValuesCSR()
    M = sp.csr_matrix((values, indices, indptr), shape=A.getSize())
    return M[free][:, free].tocsr()


def inertia(K: sp.csr_matrix) -> tuple[int, int]:
    """(negative pivots, zero pivots) of K by MUMPS LDL^T (sym = 2)."""
    Kp = PETSc.Mat().createAIJ(size=K.shape, csr=(K.indptr, K.indices, K.data), comm=PETSc.COMM_SELF)
    Kp.setOption(PETSc.Mat.Option.SYMMETRIC, True)
    Kp.assemble()
    ksp = PETSc.KSP().create(PETSc.COMM_SELF)
    ksp.setOperators(Kp)
    ksp.setType("preonly")
    pc = ksp.getPC()
    pc.setType("cholesky")
    pc.setFactorSolverType("mumps")
    pc.setFactorSetUpSolverType()
    F = pc.getFactorMatrix()
    F.setMumpsIcntl(13, 1)          # no ScaLAPACK on the root node: exact inertia
    F.setMumpsIcntl(24, 1)          # null pivot detection
    F.setMumpsCntl(3, 1e-12)
    pc.setUp()
    return int(F.getMumpsInfog(12)), int(F.getMumpsInfog(28))


def main(argv=None) -> None:
    p = cb.make_parser()
    p.add_argument("--from", dest="src", type=pathlib.Path, required=True)
    p.add_argument("--target", type=float, required=True)
    p.add_argument("--neig", type=int, default=6)
    args = common.parse_args(p, argv)
    problem = cb.build(args)
    disc, comm = problem.disc, problem.comm
    assert comm.size == 1, "serial only"
    newton, final, constrained, load0 = restored(problem, args.src)
    n = disc.n_owned_dofs
    free = np.flatnonzero(~constrained[:n])
    cons = np.flatnonzero(constrained[:n])
    xn = disc.space.x_nodes[: n // 2]
    tag_of = {}
    for name, tag in (("block", sf.meshes.SOLID), ("cylinder", cb.CYLINDER), ("medium", sf.meshes.MEDIUM)):
        tag_of[name] = np.unique(disc.locate_dofs(tags=[tag]))
    eps = np.finfo(float).eps

    def report(label: str, load: float) -> None:
        x = problem.x
        newton.g = load * final
        newton.equilibrium.set_load(load)
        newton._residual(newton.snes, x, newton.b)
        newton.disc.jacobian(x, newton.A)
        stiff = newton.tolerance.free_row_norm(newton.A)
        atol = newton.tolerance(x, newton.g, stiff)
        b = newton.b.getArray().copy()
        xa = x.getArray()
        Fc = stiff * max(np.abs(xa).max(), np.abs(newton.g).max())
        print(f"\n== {label}: load {load:.8g}")
        print(f"|R|_2 = {np.linalg.norm(b):.3e}  (free {np.linalg.norm(b[free]):.3e}, constrained "
              f"{np.linalg.norm(b[cons]):.3e});  atol = {atol:.3e};  eps*F_c = {eps * Fc:.3e};  "
              f"||K||_inf(free) = {stiff:.3e};  max|x| = {np.abs(xa).max():.3e}")
        # element force size per region: sum |row| * |x| proxy
        for name, dofs in tag_of.items():
            d = np.intersect1d(dofs, free)
            print(f"   rows touching {name:8s}: |R|_2 = {np.linalg.norm(b[d]):.3e}, |R|_inf = {np.abs(b[d]).max():.3e}")
        worst = np.argsort(-np.abs(b))[:6]
        for d in worst:
            regs = [nm for nm, dofs in tag_of.items() if d in dofs]
            print(f"   R[{d}] = {b[d]:+.3e} at ({xn[d // 2, 0]:.4f}, {xn[d // 2, 1]:.4f}) comp {d % 2} "
                  f"{'constrained' if constrained[d] else ''} {regs}")
        K = free_block(newton.A, free)
        asym = abs(K - K.T).max()
        print(f"   free tangent: n = {K.shape[0]}, max|K - K^T| = {asym:.2e}, max|K| = {abs(K).max():.2e}")
        Ks = ((K + K.T) * 0.5).tocsr()
        neg, zero = inertia(Ks)
        print(f"   inertia (MUMPS LDL^T): {neg} negative pivots, {zero} null pivots")
        vals, vecs = spla.eigsh(Ks.tocsc(), k=args.neig, sigma=-1e-12, which="LM")
        order = np.argsort(vals)
        print("   eigenvalues nearest 0:", " ".join(f"{v:.3e}" for v in vals[order]))
        v = vecs[:, order[0]]
        top = np.argsort(-np.abs(v))[:5]
        share = {nm: float(np.sum(v[np.isin(free, dofs)] ** 2)) for nm, dofs in tag_of.items()}
        print("   lowest mode: share of |v|^2 on rows of " + ", ".join(f"{k} {s:.2f}" for k, s in share.items()))
        for t in top:
            d = free[t]
            print(f"      v = {v[t]:+.3f} at ({xn[d // 2, 0]:.4f}, {xn[d // 2, 1]:.4f}) comp {d % 2}")
        zone = (xn[free // 2, 0] < 0.3) & (xn[free // 2, 1] > 1.8) & (xn[free // 2, 1] < 2.3)
        Kz = Ks[zone][:, zone].tocsc()
        vz = spla.eigsh(Kz, k=4, sigma=-1e-12, which="LM", return_eigenvectors=False)
        print(f"   contact zone x < 0.3, 1.8 < y < 2.3 ({zone.sum()} free unknowns, the rest held): lowest eigenvalues "
              + " ".join(f"{v:.3e}" for v in np.sort(vz)))
        return Ks

    report("last converged state", load0)
    print(f"\n== Newton to load {args.target} from {load0}")
    x_old = problem.x.copy()
    newton.disc.jacobian(x_old, newton.A)
    K_old = free_block(newton.A, free)
    res = newton.solve(problem.x, args.target * final, args.target)
    d = (problem.x.getArray() - x_old.getArray())[free]
    k = int(np.argmax(np.abs(d)))
    fk = free[k]
    big = np.abs(d) > 0.1 * abs(d[k])
    print(f"step change: |dx|_inf = {abs(d[k]):.3e} at ({xn[fk // 2, 0]:.4f}, {xn[fk // 2, 1]:.4f}) comp {fk % 2}; "
          f"{big.sum()} unknowns above 10 %, in x = [{xn[free[big] // 2, 0].min():.3f}, {xn[free[big] // 2, 0].max():.3f}], "
          f"y = [{xn[free[big] // 2, 1].min():.3f}, {xn[free[big] // 2, 1].max():.3f}]; "
          f"Rayleigh quotient at the old state d^T K d / d^T d = {d @ (K_old @ d) / (d @ d):.3e}")
    print(f"reason {res.reason}, its {res.iterations}, residuals " + " ".join(f"{r:.2e}" for r in res.residual_norms))
    report("final Newton iterate", args.target)
    taylor_check(newton, problem, constrained, xn)


def taylor_check(newton, problem, constrained, xn) -> None:
    """Newton direction at the current iterate: accuracy of the linear solve, its size, and the
    Taylor remainder |R(x + t dx) - R(x) - t K dx| / t (O(t) for a consistent tangent)."""
    x, A = problem.x, newton.A
    newton._residual(newton.snes, x, newton.b)
    newton.disc.jacobian(x, A)
    b0 = newton.b.copy()
    ksp = newton.snes.getKSP()
    ksp.setOperators(A)
    dx = b0.duplicate()
    ksp.solve(b0, dx)
    dx.scale(-1.0)
    r = b0.duplicate()
    A.mult(dx, r)
    r.axpy(1.0, b0)
    d = dx.getArray()
    k = int(np.argmax(np.abs(d)))
    print(f"\n== Newton direction: ||K dx + R|| / ||R|| = {r.norm() / b0.norm():.2e}, |dx|_inf = {abs(d[k]):.3e} "
          f"at ({xn[k // 2, 0]:.4f}, {xn[k // 2, 1]:.4f}) comp {k % 2}, |dx|_2 = {dx.norm():.3e}")
    Kdx = b0.duplicate()
    A.mult(dx, Kdx)
    x0 = x.copy()
    for t in (1.0, 0.3, 0.1, 0.03, 0.01, 1e-3, 1e-4):
        x0.copy(x)
        x.axpy(t, dx)
        info = newton.disc.residual(x, newton.b)
        newton._residual(newton.snes, x, newton.b)
        rem = newton.b.copy()
        rem.axpy(-1.0, b0)
        rem.axpy(-t, Kdx)
        print(f"   t = {t:.0e}: |R(x + t dx)| = {newton.b.norm():.3e}, Taylor remainder / t = {rem.norm() / t:.3e}, "
              f"min J {info.min_J:.3e}")
    x0.copy(x)




def energy_newton(newton, problem, constrained, g, load, max_it=60, verbose=True):
    """Prototype: Newton with a line search on the total energy (the residual is its gradient):
    accept t = 1 if the directional derivative R(x + dx) . dx <= 0.5 |R(x) . dx| and J > 0,
    else find t in (0, 1) with |R(x + t dx) . dx| <= 0.5 |R(x) . dx| by safeguarded secant/bisection
    (a domain error counts as positive slope)."""
    newton.g = np.asarray(g)
    newton.equilibrium.set_load(load)
    x, A, b = problem.x, newton.A, newton.b
    ksp = newton.snes.getKSP()
    dx = b.duplicate()
    x0 = x.copy()
    hist = []

    def slope(t):
        x0.copy(x)
        x.axpy(t, dx)
        info = newton.disc.residual(x, b)
        newton._residual(newton.snes, x, b)
        if not (info.min_J > 0):
            return np.inf, np.nan
        return b.dot(dx), b.norm()

    for it in range(max_it):
        newton._residual(newton.snes, x, b)
        r = b.norm()
        hist.append(r)
        if r < 1e-9:
            break
        newton.disc.jacobian(x, A)
        ksp.setOperators(A)
        ksp.solve(b, dx)
        dx.scale(-1.0)
        x.copy(x0)
        s0 = b.dot(dx)
        if verbose and it in (1, 2):     # the slope along dx (energy change rate) at a few t
            print(f"   s0 = {s0:.3e}; " + ", ".join(f"s({tt:.0e}) = {slope(tt)[0]:.3e}" for tt in (1e-8, 1e-6, 1e-4, 1e-2, 1)))
        lo, hi, s_lo, s_hi = 0.0, 1.0, s0, None
        t = 1.0
        for _ in range(30):
            s, rn = slope(t)
            if abs(s) <= 0.5 * abs(s0):
                break
            if s < 0:
                lo, s_lo = t, s
                if hi is None:
                    t = 2 * t
                    continue
            else:
                hi, s_hi = t, s
            t = (lo * s_hi - hi * s_lo) / (s_hi - s_lo) if s_hi is not None and np.isfinite(s_hi) else 0.5 * (lo + hi)
            if not (lo < t < hi) or (hi - lo) * 0.1 > min(t - lo, hi - t):
                t = 0.5 * (lo + hi)
        if verbose:
            print(f"   it {it}: |R| = {r:.3e}, step t = {t:.3g}, |dx|_inf = {np.abs(dx.getArray()).max():.2e}")
    return hist


def main_energy(argv=None):
    p = cb.make_parser()
    p.add_argument("--from", dest="src", type=pathlib.Path, required=True)
    p.add_argument("--target", type=float, required=True)
    args = common.parse_args(p, argv)
    problem = cb.build(args)
    newton, final, constrained, _ = restored(problem, args.src)
    hist = energy_newton(newton, problem, constrained, args.target * final, args.target)
    print("residuals", " ".join(f"{r:.2e}" for r in hist))


if __name__ == "__main__":
    if "--energy-ls" in sys.argv:
        sys.argv.remove("--energy-ls")
        main_energy()
    else:
        main()
