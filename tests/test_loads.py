"""Loads ramped by the load factor (dolfinx_sfvem/physics/loads.py, docs/guide/loads.md): traction, pressure,
point force, cavity pressure, body force, for the SFVEM and the FEM reference.

- A dead traction and a follower or dead pressure on the end of a block give the homogeneous
  plane-strain states of the neo-Hookean solid of paper Eq. 2 (solved here independently), which
  both methods reproduce exactly; their records hold magnitude and work-conjugate displacement.
- A point force gives the state in which its node, held at the displacement it had, needs that
  force; a point off the nodes names the nearest node.
- A cavity filled with third medium under cavity_pressure deforms as the same hole without medium
  under a follower pressure (up to the medium's own stiffness, gamma), and its recorded
  displacement is the cavity's area change.
- A follower pressure whose loaded edges end freely makes the tangent non-symmetric: LU, not LDLᵀ.
- Bad input is named; a resumed run refuses a changed load.
"""
import csv

import numpy as np
import pytest
import scipy.optimize
from mpi4py import MPI

import dolfinx_sfvem as sf
from dolfinx_sfvem import meshes
from dolfinx_sfvem.discretizations.compiled_energy import compile_kernels, evaluate

COMM = MPI.COMM_WORLD
SOLID, MEDIUM = meshes.SOLID, meshes.MEDIUM
K, MU = 5 / 3, 5 / 14
L, H = 1.0, 0.25


def block(method: str, nx: int = 4, ny: int = 2) -> sf.ContactProblem:
    """A L x H block of squares, u_x = 0 on its left end, u_y = 0 at its lower left corner: free
    to stretch and contract homogeneously."""
    mesh = meshes.quad_rectangle(L, H, nx, ny, tag=SOLID)
    problem = sf.ContactProblem(mesh, {SOLID: sf.Hyperelastic(K=K, mu=MU)}, method=method, comm=COMM, verbose=False,
                                **({"fem_mesh": mesh} if method == "fem" else {}))
    problem.fix(lambda x: np.isclose(x[0], 0.0), components=("x",), name="left")
    problem.fix(lambda x: np.isclose(x[0], 0.0) & np.isclose(x[1], 0.0), components=("y",), name="corner")
    return problem


def right_end(x: np.ndarray) -> np.ndarray:
    return np.isclose(x[0], L)


def homogeneous_stretches(P11: callable) -> tuple[float, float]:
    """Stretches (λ1, λ2) of the homogeneous plane-strain state of Eq. 2 with first Piola stress
    P = diag(P11(λ1, λ2), 0) (P from the compiled kernel of the energy, independent of the solvers)."""
    kernels = compile_kernels(sf.Hyperelastic(K=K, mu=MU))

    def residual(stretch):
        P = evaluate(kernels, np.diag(stretch), params={"K": K, "mu": MU})["P"]
        return [P[0, 0] - P11(*stretch), P[1, 1]]
    return tuple(scipy.optimize.fsolve(residual, [1.0, 1.0], xtol=1e-13))


def end_displacement(problem: sf.ContactProblem) -> np.ndarray:
    """Displacement (n, 2) of the right end's nodes (vertices and midpoints), on every rank."""
    points = problem.mesh.boundary_points(SOLID)
    return problem.displacement_at(points[np.isclose(points[:, 0], L)])


@pytest.mark.mpi
@pytest.mark.parametrize("method", ["vem", "fem"])
def test_dead_traction_gives_the_homogeneous_stretch(method):
    """t = (σ, 0) per reference length on the right end: P11 = σ everywhere, u_x(L) = (λ1 - 1) L;
    the record's magnitude is σ H and its displacement the mean u_x of the end."""
    sigma = 0.3
    problem = block(method)
    problem.traction(right_end, t=(sigma, 0.0), name="pull")
    result = problem.solve(2)
    assert result.converged, result.message
    l1, l2 = homogeneous_stretches(lambda a, b: sigma)
    u = end_displacement(problem)
    np.testing.assert_allclose(u[:, 0], (l1 - 1) * L, rtol=1e-9)
    record = result.steps[-1]["loads"]["pull"]
    assert record["magnitude"] == pytest.approx(sigma * H, rel=1e-12)
    assert record["displacement"] == pytest.approx((l1 - 1) * L, rel=1e-9)
    assert result.steps[0]["loads"]["pull"]["magnitude"] == pytest.approx(sigma * H / 2, rel=1e-12)
    assert result.steps[-1]["reaction"]["left"][0] == pytest.approx(-sigma * H, rel=1e-9)


@pytest.mark.mpi
@pytest.mark.parametrize("method", ["vem", "fem"])
@pytest.mark.parametrize("follower", [True, False])
def test_pressure_on_the_end_compresses_homogeneously(method, follower):
    """p on the right end pushes it in: dead, P11 = -p; follower (Cauchy σ11 = -p on the deformed
    end, whose length is λ2 H), P11 = -p λ2. The recorded displacement is the swept area
    (follower) or ∫ u·(-N) (dead), both (1 - λ1) L H here."""
    p = 0.4
    problem = block(method)
    problem.pressure(right_end, p, follower=follower, name="push")
    result = problem.solve(2)
    assert result.converged, result.message
    l1, l2 = homogeneous_stretches((lambda a, b: -p * b) if follower else (lambda a, b: -p))
    u = end_displacement(problem)
    np.testing.assert_allclose(u[:, 0], (l1 - 1) * L, rtol=1e-9)
    record = result.steps[-1]["loads"]["push"]
    # follower: the trapezoid between the reference end and the deformed one (closed by straight
    # lines from the corners); dead: ∫ -u_x over the reference end
    expected = (1 - l1) * L * (H + l2 * H) / 2 if follower else (1 - l1) * L * H
    assert record["magnitude"] == pytest.approx(p) and record["displacement"] == pytest.approx(expected, rel=1e-9)


def test_follower_pressure_on_an_open_chain_uses_lu():
    """The follower load stiffness of loaded edges whose chain ends are free is not symmetric:
    the solver factorizes with LU (no negative pivots reported); with a constrained component
    at each end (a clamped edge) it stays LDLᵀ."""
    free_ends = block("vem")
    free_ends.pressure(lambda x: np.isclose(x[1], H) & (x[0] > 0.2) & (x[0] < 0.8), 0.01, name="top")
    result = free_ends.solve(1)
    assert result.converged and result.steps[-1]["negative_pivots"] is None
    clamped = block("vem")
    clamped.fix(lambda x: np.isclose(x[0], L), name="right")
    clamped.pressure(lambda x: np.isclose(x[1], H), 0.01, name="top")
    result = clamped.solve(1)
    assert result.converged and result.steps[-1]["negative_pivots"] == 0


def cantilever(method: str) -> sf.ContactProblem:
    """An L x H cantilever of 8 x 2 squares clamped on its left end."""
    mesh = meshes.quad_rectangle(L, H, 8, 2, tag=SOLID)
    problem = sf.ContactProblem(mesh, {SOLID: sf.Hyperelastic(K=K, mu=MU)}, method=method, comm=COMM, verbose=False,
                                **({"fem_mesh": mesh} if method == "fem" else {}))
    problem.fix(lambda x: np.isclose(x[0], 0.0), name="clamped")
    return problem


@pytest.mark.mpi
@pytest.mark.parametrize("method", ["vem", "fem"])
def test_point_force_gives_the_state_of_its_displacement(method):
    """A downward force at the cantilever's free top corner: the corner's u_y prescribed instead, at
    the deflection the force gave (u_x free), needs exactly that force, so the force is applied at
    that node with its magnitude and direction; the record's displacement is the corner's downward
    displacement."""
    force = 1e-3
    loaded = cantilever(method)
    loaded.point_force((L, H), fy=-force, name="tip")
    result = loaded.solve(2)
    assert result.converged, result.message
    corner = nodal_displacement(loaded, (L, H))
    assert corner[1] < 0 and result.steps[-1]["loads"]["tip"]["displacement"] == pytest.approx(-corner[1], rel=1e-9)
    held = cantilever(method)
    held.prescribe(lambda x: np.hypot(x[0] - L, x[1] - H) < 1e-10, uy=corner[1], name="tip")
    result = held.solve(2)
    assert result.converged, result.message
    np.testing.assert_allclose(result.steps[-1]["reaction"]["tip"][1], -force, rtol=1e-7)
    np.testing.assert_allclose(nodal_displacement(held, (L, H)), corner, rtol=1e-7)


def nodal_displacement(problem: sf.ContactProblem, point) -> np.ndarray:
    """The displacement (2,) of the vertex node at ``point`` (on every rank)."""
    u = COMM.bcast(problem.point_displacements(), root=0)
    points = problem.disc.output_mesh.points
    return u[int(np.argmin(np.linalg.norm(points - np.asarray(point), axis=1)))]


def test_point_force_off_the_nodes_names_the_nearest():
    problem = block("vem")
    with pytest.raises(ValueError, match=r"\(0.9, 0.2\) is not a node of the mesh; the nearest node is \(0.875, 0.25\)"):
        problem.point_force((0.9, 0.2), fx=1.0)
    assert not problem.loads


def frame(with_medium: bool, method: str = "vem") -> tuple[sf.ContactProblem, float]:
    """A 1 x 1 square frame of width 0.25 around a 0.5 x 0.5 hole, clamped at its outer left
    edge; the hole filled with third medium or empty. Returns the problem and the hole's area."""
    n = 8
    mesh = meshes.quad_rectangle(1.0, 1.0, n, n, tag=SOLID)
    centre = mesh.centroids
    hole = (np.abs(centre[:, 0] - 0.5) < 0.25) & (np.abs(centre[:, 1] - 0.5) < 0.25)
    keep = np.ones(mesh.n_polygons, dtype=bool) if with_medium else ~hole
    tags = np.where(hole, MEDIUM, SOLID)[keep]
    mesh = sf.PolygonMesh(mesh.points, [mesh.polygon(i) for i in np.flatnonzero(keep)], tags)
    materials = {SOLID: sf.Hyperelastic(K=K, mu=MU)}
    if with_medium:
        materials[MEDIUM] = sf.ThirdMedium(mu=MU, gamma=1e-7, alpha_r=0.0)
    problem = sf.ContactProblem(mesh, materials, method=method, comm=COMM, verbose=False,
                                **({"fem_mesh": mesh} if method == "fem" else {}))
    problem.fix(lambda x: np.isclose(x[0], 0.0), name="clamped")
    return problem, 0.25


@pytest.mark.mpi
@pytest.mark.parametrize("method", ["vem", "fem"])
def test_cavity_pressure_equals_the_follower_pressure_on_the_empty_hole(method):
    """cavity_pressure(p) in the medium-filled hole and pressure(p, follower) on the empty hole's
    boundary deform the frame alike (to the medium's own stiffness, gamma = 1e-7), and the
    recorded displacements (area change, swept area) agree."""
    p = 0.05
    filled, area = frame(True, method)
    filled.cavity_pressure(MEDIUM, p, name="gas")
    empty, _ = frame(False, method)
    empty.pressure(lambda x: (np.abs(x[0] - 0.5) <= 0.25 + 1e-12) & (np.abs(x[1] - 0.5) <= 0.25 + 1e-12), p,
                   name="gas")
    a, b = filled.solve(4), empty.solve(4)
    assert a.converged and b.converged, (a.message, b.message)
    points = empty.disc.output_mesh.points[np.unique(empty.disc.output_mesh.vertices)]
    u_filled, u_empty = (np.array([nodal_displacement(p, x) for x in points]) for p in (filled, empty))
    scale = np.abs(u_empty).max()
    assert scale > 1e-3 and np.abs(u_filled - u_empty).max() < 1e-4 * scale, np.abs(u_filled - u_empty).max() / scale
    dA_filled, dA_empty = (r.steps[-1]["loads"]["gas"]["displacement"] for r in (a, b))
    assert dA_empty > 0 and dA_filled == pytest.approx(dA_empty, rel=1e-3)


def test_bad_loads_are_named():
    problem = block("vem")
    with pytest.raises(ValueError, match=r"the marker selects the edge \(0.25, 0\)-\(0.25, 0.125\), which is not on the boundary"):
        problem.pressure(lambda x: x[0] <= 0.5 + 1e-12, 1.0, name="inside")
    with pytest.raises(ValueError, match="selects no boundary edge"):
        problem.traction(lambda x: x[0] > 2.0, t=(1.0, 0.0), name="nowhere")
    with pytest.raises(ValueError, match="region 1 is not a third-medium region"):
        problem.cavity_pressure(SOLID, 1.0)
    assert not problem.loads
    with pytest.raises(ValueError, match="used twice"):
        block("vem").pressure(right_end, 1.0, name="left")
    with pytest.raises(ValueError, match="must be finite"):
        block("vem").pressure(right_end, np.nan)
    with pytest.raises(ValueError, match="must be a pair"):
        block("vem").traction(right_end, t=(1.0,))
    with pytest.raises(ValueError, match="no region 7"):
        block("vem").traction(7, t=(1.0, 0.0))


def half_medium(rotation: float = 0.0) -> sf.ContactProblem:
    """The unit square turned by ``rotation`` (radians), medium in its half x > 0.5 (before the
    turn), clamped at x = 0: the medium reaches the mesh boundary on three sides."""
    mesh = meshes.quad_rectangle(1.0, 1.0, 4, 4, tag=SOLID)
    tags = np.where(mesh.centroids[:, 0] > 0.5, MEDIUM, SOLID)
    c, s = np.cos(rotation), np.sin(rotation)
    mesh = sf.PolygonMesh(mesh.points @ np.array([[c, s], [-s, c]]), [mesh.polygon(i) for i in range(mesh.n_polygons)],
                          tags)
    problem = sf.ContactProblem(mesh, {SOLID: sf.Hyperelastic(K=K, mu=MU),
                                       MEDIUM: sf.ThirdMedium(mu=MU, gamma=1e-6, alpha_r=1.0)}, verbose=False)
    problem.fix(lambda x: np.isclose(x[0] * c + x[1] * s, 0.0))
    return problem


def test_open_cavity_is_refused():
    """A medium region reaching the mesh boundary is no closed cavity: refused when it is defined
    if the boundary there is not a line x = const or y = const, else at the solve when the normal
    displacement is not fixed there (a symmetry line closes a cavity only then)."""
    with pytest.raises(ValueError, match=r"region 2 is not closed: its edge .* lies on the boundary of the mesh "
                                         r"off the x and y directions"):
        half_medium(rotation=0.5).cavity_pressure(MEDIUM, 1.0)
    problem = half_medium()
    problem.cavity_pressure(MEDIUM, 1.0)
    with pytest.raises(ValueError, match=r"region 2 is not closed: its edge .* lies on the boundary of the mesh "
                                         r"without u_[xy] fixed at its nodes"):
        problem.solve(1)
    problem = half_medium()
    problem.cavity_pressure(MEDIUM, 1.0)
    problem.fix(lambda x: np.isclose(x[0], 1.0), components=("x",), name="right")
    with pytest.raises(ValueError, match=r"its edge \([.0-9]+, ([01])\)-\([.0-9]+, \1\) lies on the boundary of "
                                         r"the mesh without u_y fixed"):         # on y = 0 or y = 1
        problem.solve(1)


@pytest.mark.mpi
@pytest.mark.parametrize("method", ["vem", "fem"])
def test_cavity_pressure_on_a_symmetry_line(method):
    """The frame of the test above cut along its symmetry line y = 1/2 with u_y = 0 there: the
    cavity pressure on the half cavity, open on the line, deforms the half as the whole frame and
    its recorded area change is half the whole cavity's."""
    p = 0.05
    whole, _ = frame(True, method)
    whole.cavity_pressure(MEDIUM, p, name="gas")
    mesh = whole.mesh
    lower = np.flatnonzero(mesh.centroids[:, 1] < 0.5)
    half_mesh = sf.PolygonMesh(mesh.points, [mesh.polygon(i) for i in lower], mesh.tags[lower])
    half = sf.ContactProblem(half_mesh, whole.materials, method=method, comm=COMM, verbose=False,
                             **({"fem_mesh": half_mesh} if method == "fem" else {}))
    half.fix(lambda x: np.isclose(x[0], 0.0), name="clamped")
    half.fix(lambda x: np.isclose(x[1], 0.5), components=("y",), name="symmetry")
    half.cavity_pressure(MEDIUM, p, name="gas")
    a, b = whole.solve(4), half.solve(4)
    assert a.converged and b.converged, (a.message, b.message)
    points = half_mesh.points[np.unique(half_mesh.vertices)]
    u_whole, u_half = (np.array([nodal_displacement(q, x) for x in points]) for q in (whole, half))
    scale = np.abs(u_whole).max()
    assert scale > 1e-3 and np.abs(u_half - u_whole).max() < 1e-8 * scale, np.abs(u_half - u_whole).max() / scale
    dA_whole, dA_half = (r.steps[-1]["loads"]["gas"]["displacement"] for r in (a, b))
    assert dA_whole > 0 and dA_half == pytest.approx(dA_whole / 2, rel=1e-8)


def test_loads_are_written_and_a_changed_load_is_not_resumed(tmp_path):
    problem = block("vem")
    problem.traction(right_end, t=(0.1, 0.0), name="pull")
    result = problem.solve(2, out=tmp_path)
    assert result.converged
    with open(tmp_path / "load_path.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [float(r["pull_magnitude"]) for r in rows] == pytest.approx([0.05 * H, 0.1 * H])
    assert float(rows[-1]["pull_displacement"]) == pytest.approx(result.steps[-1]["loads"]["pull"]["displacement"])
    changed = block("vem")
    changed.traction(right_end, t=(0.2, 0.0), name="pull")
    with pytest.raises(ValueError, match=r"cannot resume.*parameters.loads.pull.t"):
        changed.solve(2, out=tmp_path, resume=True)
