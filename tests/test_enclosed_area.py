"""The SFVEM's cavity pressure from the deformed boundary trace (dolfinx_sfvem/physics/enclosed_area.py):
−p ∫ (J − 1) dΩ as −p times the change of the area enclosed by the deformed quadratic edges.

- For random nodal displacements the term's area change equals the area of the deformed
  polygons computed independently, by Archimedes' quadrature of the parabola (a parabolic
  segment is 4/3 of its inscribed triangle), to round-off.
- Its force is the gradient of its energy and its tangent the gradient of its force (central
  differences, exact for this quadratic form up to round-off).
- The weakly regularized medium in a pressurized cavity (thick cylinder, gamma = 1e-6,
  alpha_r = 0) has no negative pivots on its path: with ∫ det Π⁰_l∇u it had 170 to 395
  (docs/thick-cylinder.md).
"""
import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

import dolfinx_sfvem as sf
from dolfinx_sfvem import meshes
from dolfinx_sfvem.physics.energy import VolumeWork
import thick_cylinder as tc

COMM = MPI.COMM_WORLD
MEDIUM = meshes.MEDIUM


def shoelace(points: np.ndarray) -> float:
    x, y = points[:, 0], points[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def archimedes_area(loop: np.ndarray) -> float:
    """Area enclosed by the closed curve of quadratic edges through ``loop`` (2N, 2) = v_0, m_0, v_1,
    m_1, ...: the polygon of the vertices plus, per edge, the parabolic segment between the curve and
    its chord, 4/3 of the triangle (v_k, m_k, v_k+1) (the tangent at m_k is parallel to the chord)."""
    vertices = shoelace(loop[0::2])
    return vertices + 4.0 / 3.0 * (shoelace(loop) - vertices)


def cavity(method: str = "vem", h: float = 0.4):
    """The filled quarter cylinder's discretization with the cavity term at p = 1."""
    benchmark = sf.meshes.thick_cylinder(1.0, 2.0, h, filled=True)
    problem = sf.ContactProblem(benchmark.mesh, {"solid": sf.Hyperelastic(K=5 / 3, mu=1.0),
                                                 "cavity": sf.ThirdMedium(mu=1.0, gamma=1e-6, alpha_r=0.0)},
                                method=method, comm=COMM, verbose=False)
    disc = problem.disc
    return disc, disc.add_energy_term(MEDIUM, VolumeWork(p=1.0, uses_gradient=True))


def random_state(disc, size: float, seed: int) -> PETSc.Vec:
    """Random nodal displacements, uniform in [-size, size] per component (the same on every partition:
    drawn by node key)."""
    x = disc.create_vector()
    values = np.random.default_rng(seed).uniform(-size, size, (disc.node_key.max() + 1, 2))
    with x.localForm() as xl:
        xl.array[:] = values[disc.node_key].reshape(-1)
    return x


def enclosed_area_change(disc, x: PETSc.Vec) -> float:
    """Σ over the medium's polygons of the deformed minus the reference Archimedes area (collective)."""
    offsets, loop, element = disc.element_loops
    X = disc.x_nodes
    with x.localForm() as xl:
        u = xl.array_r.reshape(-1, 2)
        change = sum(archimedes_area(X[nodes] + u[nodes]) - archimedes_area(X[nodes])
                     for e in np.flatnonzero(disc.output_mesh.tags[element] == MEDIUM)
                     for nodes in [loop[offsets[e]:offsets[e + 1]]])
    return COMM.allreduce(change, op=MPI.SUM)


@pytest.mark.mpi
@pytest.mark.parametrize("method", ["vem", "fem"])
@pytest.mark.parametrize("size", [0.01, 0.2])
def test_area_change_is_exact_for_random_displacements(size, method):
    """The term's energy with p = 1 is −(area change of the cavity); for random displacements up to
    half an edge the Archimedes areas of the deformed polygons (FEM: cells) agree to round-off
    (1e-13 of the cavity's area, pi/4), while the straight-chord polygon through the same nodes
    would miss by more than 1e-4 (the curved edges count). The SFVEM sums the boundary traces'
    areas; the FEM integrates det F of its P2 field with the degree-4 rule, exact for its degree 2."""
    disc, term = cavity(method)
    x = random_state(disc, size, seed=1)
    b = disc.create_vector()
    work = disc.term_force(term, x, b)
    exact = enclosed_area_change(disc, x)
    assert abs(-work - exact) < 1e-13 * np.pi / 4, (-work, exact)
    offsets, loop, element = disc.element_loops
    with x.localForm() as xl:
        u = xl.array_r.reshape(-1, 2)
        chords = sum(shoelace(disc.x_nodes[nodes] + u[nodes]) - shoelace(disc.x_nodes[nodes])
                     for e in np.flatnonzero(disc.output_mesh.tags[element] == MEDIUM)
                     for nodes in [loop[offsets[e]:offsets[e + 1]]])
    assert abs(COMM.allreduce(chords, op=MPI.SUM) - exact) > 1e-4 * size


def test_force_and_tangent_against_central_differences():
    """At a random state (displacements 1e-3, the regions' energies finite): the force is the
    derivative of the energy and the tangent (the assembled tangent with the term at p = 1 minus
    the one at p = 0) the derivative of the force, along a random direction, by central
    differences (exact for the area, a quadratic form of the positions, so to round-off)."""
    disc, term = cavity()
    x, d = random_state(disc, 1e-3, seed=2), random_state(disc, 1.0, seed=3)
    b, b_plus, b_minus = disc.create_vector(), disc.create_vector(), disc.create_vector()
    step = 1e-3
    energy = disc.term_force(term, x, b)
    x_plus, x_minus = x.copy(), x.copy()
    x_plus.axpy(step, d)
    x_minus.axpy(-step, d)
    e_plus, e_minus = disc.term_force(term, x_plus, b_plus), disc.term_force(term, x_minus, b_minus)
    assert abs(energy) > 1e-5 and b.dot(d) == pytest.approx((e_plus - e_minus) / (2 * step), rel=1e-9)
    A = disc.create_matrix()
    A0 = disc.create_matrix()
    disc.assemble_tangent(x, A)
    term.params["p"] = 0.0
    disc.assemble_tangent(x, A0)
    A.axpy(-1.0, A0)
    Hd = disc.create_vector()
    A.mult(d, Hd)
    difference = b_plus.copy()
    difference.axpy(-1.0, b_minus)
    difference.scale(1 / (2 * step))
    scale = Hd.norm(PETSc.NormType.NORM_INFINITY)
    difference.axpy(-1.0, Hd)
    assert scale > 1e-2 and difference.norm(PETSc.NormType.NORM_INFINITY) < 1e-8 * scale


@pytest.mark.parametrize("p", [1e-4, tc.P_REF])
def test_weak_medium_in_a_pressurized_cavity_has_no_negative_pivots(p):
    """Thick cylinder, cavity pressure on a medium of gamma = 1e-6, alpha_r = 0 (h = 0.2, four
    steps or more): every step stable (0 negative pivots; 170 at p = 1e-4 and 395 at 2/15 after one step
    with ∫ det Π⁰_l∇u), and the answer within the coarse mesh's error of the BVP with that
    medium (the chords' O(h^2): conjugate 2.6e-4 short, L2 2e-4)."""
    a = tc.common.parse_args(tc.make_parser(), ["--quiet", "--gamma", "1e-6", "--alpha-r", "0"])
    benchmark = tc.benchmark_for("cavity", 0.2, "vem", a)
    problem = tc.build("cavity", p, "vem", benchmark, a)
    result = problem.solve(4)
    assert result.converged, result.message
    pivots = [s["negative_pivots"] for s in result.steps]
    assert len(pivots) >= 4 and pivots == [0] * len(pivots), pivots
    r = tc.compare(problem, tc.RunSummary.from_dict(result.summary), tc.radial_answer("cavity", p, 1e-6), benchmark)
    assert abs(r["conjugate_error"]) < 1e-3 and r["L2"] < 5e-4, r
