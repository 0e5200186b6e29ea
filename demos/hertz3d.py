"""3D Hertz: a stiff sphere pressed into an elastic block across a thin third-medium layer.

Problem
-------
Quarter model (symmetry planes x = 0 and y = 0) of Xu, Xue & Wriggers (JMPS 2026), as dolfiny's
``demo/tmc/3D/Hertz_Wriggers_3D.py``: a sphere of radius R = 1, ``--stiffness`` (100) times
stiffer than the block, hangs ``--gap`` (0.1) above the block [0, 2] x [0, 2] x [0, 1]; the medium
fills the box above the block around the sphere. The sphere's flat top is pushed down by
u_z = -(gap + ``--indent``) x load factor: the gap closes through the medium, then the sphere
indents the block.

Geometry and mesh (``sf.meshes.hertz3d``)
-----------------------------------------
gmsh P2 tetrahedra of size ``--h`` within ``--fine-radius`` of the contact point, growing to
``--h-far`` away from it; with ``--h-core``, size ``--h-core`` within ``--core-radius`` (0.25) of
it: the medium layer the sphere squeezes, the block's top and the sphere's tip under the contact
zone (with one tetrahedron across the 0.1 gap, h = 0.1, the step after first contact inverts a
squeezed medium cell). With ``--block octree`` (and ``--method vem``) the block is an octree of cubes
refined toward the contact instead, its coarse cubes polyhedra with hanging vertices, under the same
tetrahedra made conforming to its top squares (``sf.meshes.hertz3d_octree``; give --h, --h-core and
--h-far as powers of 1/2, the cubes' sizes). Block bottom z = 0 clamped, u_x = 0 on x = 0, u_y = 0 on y = 0, u_z
prescribed on the sphere's top (boundary condition ``load``).

Parameters
----------
Block K = 5/4, mu = 5/14 (E = 0.978, nu = 0.370); sphere the same times ``--stiffness``.
Medium: mu = 5/14, K = 5/4 scaled by ``--gamma``, ``--alpha-r``, ``--regularization``.

Against Hertz
-------------
``exact.hertz_sphere``: with F = 4 x the quarter's contact force (the medium's force on the block),
a = (3 F R / (4 E*))^(1/3), p0 = 3 F / (2 pi a^2), delta = a^2 / R, 1/E* = (1 - nu^2)/E (1 + 1/stiffness).
The contact radius is measured four ways from the contact pressure field: ``a_zone`` from the
deformed area A of the quarter contact zone (pressure above 1 % of the peak), a = sqrt(4 A / pi)
(node-based: it over-estimates a by up to one element); ``a_p = sqrt(3 F / (2 pi p_max))``, the
radius Hertz's profile would have with the measured peak (a_p / a = sqrt(p0 / p_max): the peak's
error halved); and, at the last state, ``a_fit`` and ``p0_fit`` of Hertz's ellipse fitted to the
block-top pressure above 30 % of the peak (least squares of p^2 against r^2), ``a_m`` from the
pressure's second moment within 2 a of the axis, a_m^2 = 5/2 int p r^2 dA / int p dA (exact for
Hertz's profile; reported with the value Hertz's profile gives on the same nodes), and ``a_F``, the
same moment of the medium's nodal forces on the block's top, a_F^2 = 5/2 sum f_i r_i^2 / sum f_i (no
recovered pressure in between: exact sums for P2 faces). The indentation is
the approach of the sphere's top and the block's bottom less the closure of the gap,
delta = -u_z(top) - (gap - smallest gap); Hertz's delta is the approach of remote points of a
half-space, so the table and plot also give it less Boussinesq's settlement of the axis at the
bottom's depth 1, w = F (1 + nu)(3 - 2 nu) / (2 pi E), which the clamped bottom does not see.

What it prints and writes
-------------------------
Per step the load factor, Newton iterations, reactions; at the end the last contact row. In
``--out``, besides summary.json, load_path.csv, displacement.xdmf and the 3D pictures of the last
state (``final-deformed.png``, ``final-clip.png``, ``final-pressure.png``): hertz3d.md (per
converged step in contact: F, delta, Hertz's delta with and without the bottom's settlement,
a_zone, a_p, Hertz's a, p_max, Hertz's p0; then the last state's a_fit, p0_fit, a_m and a_F), the same
in hertz3d.json (``rows``: per step, ``last``: the last state's radii), pressure.csv
(radius and pressure of the block's top nodes at the last state), hertz3d.png (force against
indentation with Hertz's curves; pressure against radius with Hertz's profile).

Commands
--------
::

    python3 demos/hertz3d.py --out out/hertz3d      # h 0.1, core 0.05, gamma 1e-5
    python3 demos/hertz3d.py --h-core 0.03 --out out/hertz3d-core0.03   # the finest documented run
    # the paper's gamma on a layer half as thick, coarse mesh: full load, peak and radius within 1 %
    python3 demos/hertz3d.py --h 0.2 --h-core 0.1 --gap 0.05 --gamma 1e-6 --regularization huhu_lulu --out out/hertz3d-g6
    # dolfiny's deep Hertz (indentation 0.5, gamma 1e-6) with the peer's skew penalty: to 0.86 in about an hour
    python3 demos/hertz3d.py --method fem --gamma 1e-6 --indent 0.5 --h 0.2 --h-far 0.2 --h-core 0 --steps 60 \
        --beta1 0.25 --medium-quadrature reduced --out out/hertz3d-deep

Measured
--------
2026-11-26, 1 rank, on the shared machine (docs/notes/2026-11-26-hertz3d.md, where every number
below comes from). The finest documented mesh: h = 0.1 with a 0.03 core (39,402 unknowns),
gamma = 1e-5, to the full load in 21 steps (one cut-back, at 0.95), 49 min at load 3-4. The gap
closes at load 0.75 (1-3 Newton iterations per step before, 9-26 after). At the full load:
F = 0.01535, Hertz's a = 0.217 (7 core elements), p_max / p0 = 1.018 (+1.8 %), a_p / a_H = 0.991;
Hertz's ellipse fitted to the block-top pressure above 30 % of the peak: p0_fit / p0 = 1.029,
a_fit / a_H = 0.955 (-4.5 %; the profile lies a little inside the ellipse towards its edge);
a_zone / a_H = 1.070 (node-based, +0.5 element); indentation 0.0401 against Hertz's 0.0472 and
0.0395 after the clamped bottom's settlement (+1.5 %). With the 0.05 core (25,188 unknowns) at
load 0.9: p_max / p0 = 1.006, a_fit / a_H = 0.947; without a core (11,607 unknowns) at F = 0.00457:
p_max / p0 = 0.838. So the peak pressure and the indentation meet 3 %; the radius read from the
profile's shape approaches Hertz's slowly (-5.3 %, -4.5 %) and does not meet it at this mesh
(the block's depth, 4.6 a, is not a half-space: not separated here), while the radius from the
pressure's second moment within 2 a does: a_m / a_H = 1.005 (Hertz's profile on the same nodes:
1.001). The computed profile is a little above Hertz's inside and falls early over the last
element, leaving a tail the medium carries (1.9 % of the force beyond a_H): the fit of the shape
reads the early fall as a smaller radius, the moment weighs it against the tail. gamma = 1e-6 (the paper's
value), continued from 1e-5 (``--gamma-start 1e-5``, about 2e-6 at first contact) on the 0.03
core: the first contact step (0.725) converged in 19 iterations with the medium at J ~ 1e-4, the
next failed twice in 60 iterations each (J < 0 in the medium), stopped after 50 min. With
``--alpha-r 10`` (gamma = 1e-6 from the start, 0.05 core) five steps past first contact converge,
to load 0.85 (F = 0.0046, 30 % of the full load's): p_max / p0 = 0.986, a_p / a_H = 1.007,
indentation +0.9 %, the sphere up to 5.4e-5 inside the block (within the overlap tolerance); the
steps beyond invert medium cells at the edge of the contact zone. alpha_r 100, HuHu and more
cut-backs got no further (0.76-0.85); the 0.03 core was stopped for time at 0.725 (the hertz3d
note). On the coarse mesh (h 0.2, core 0.1) every regularization of Table 1 at alpha_r 1-10 stops
at 0.79-0.85 on the 0.1 layer; on a 0.05 layer ``--regularization huhu_lulu`` (alpha_r 1) reaches
the full load in 26 steps, 5 min: p_max / p0 = 1.002, p0_fit / p0 = 1.002, a_p / a_H = 0.999,
a_F / a_H = 0.990, the sphere up to 2.1e-4 inside the block (within the overlap tolerance). The
same thin layer on the 0.05 core stops at 0.717. With the medium's skew penalty ``--beta1 0.01``
(docs/guide/medium.md) the 0.1 layer reaches the full load at gamma = 1e-6 on the default mesh
(h 0.1, core 0.05; 204 Newton iterations, 16 % in failed attempts, 23 min): a_F / a_H = 1.016,
p0_fit / p0 = 1.023, as at gamma = 1e-5; on the coarse mesh in 2 min (a_F / a_H = 0.987).

The SFVEM on the octree block (``--method vem --block octree --h 0.2 --h-core 0.1``: cubes of
0.0625 under the sphere, 38,463 unknowns, 43 min): p0_fit / p0 = 0.988, p_max / p0 = 1.122 (the
vertex on the axis), a_fit / a_H = 0.958, a_m / a_H = 1.037. Its pressure is recovered over the
polyhedra's vertex patches, because the force on a single face scatters by ±28 % about Hertz's
(docs/notes/2026-11-27-sfvem-3d-pressure.md); the patches smooth the zone's edge over about one
face, which moves the radii. The nodal forces' second moment, without that recovery: a_F / a_H =
1.014 (the 0.03-core P2: 1.021, with a_m 1.004; the medium's force outside the zone counts in
both). Against the P2 meshes in bench/hertz_equal_accuracy.md
(docs/notes/2026-11-27-hertz-equal-accuracy.md).
"""
from __future__ import annotations

import argparse
import csv
import json
import math
import sys
import typing

import numpy as np

import dolfinx_sfvem as sf
from dolfinx_sfvem import exact
from dolfinx_sfvem.meshing.benchmarks3d import HERTZ3D_H, HERTZ3D_R, SPHERE
from dolfinx_sfvem.output.figure_output import save_png
from dolfinx_sfvem.discretizations.quadrature import triangle_rule
from dolfinx_sfvem.output.run_summary import RunSummary, read_summary

import _common as common

K, MU = 5 / 4, 5 / 14
E = 9 * K * MU / (3 * K + MU)
NU = (3 * K - 2 * MU) / (2 * (3 * K + MU))
#: a contact row needs the smallest gap below this fraction of the initial gap
TOUCHING = 0.05
#: :func:`ellipse_fit` uses the block-top nodes whose pressure is at least this fraction of the peak
FIT_FRACTION = 0.3
#: the second-moment radius counts the pressure within this many Hertz radii of the axis
MOMENT_WINDOW = 2.0


def make_parser() -> argparse.ArgumentParser:
    """The shared demo options with the Hertz defaults, plus the geometry and mesh options."""
    p = common.parser("hertz3d", __doc__, steps=20, meshes=(1,), h=0.1, gamma=1e-5, alpha_r=1.0,
                      regularization="rotation")
    p.set_defaults(method="fem", fixed_increments=True)
    p.add_argument("--gap", type=common.positive_float, default=0.1, help="initial gap (default %(default)s)")
    p.add_argument("--indent", type=common.positive_float, default=0.04,
                   help="sphere top displacement after the gap has closed (default %(default)s)")
    p.add_argument("--stiffness", type=common.positive_float, default=100.0,
                   help="sphere moduli / block moduli (default %(default)s)")
    p.add_argument("--h-far", type=common.positive_float, default=0.4, help="mesh size away from the contact")
    p.add_argument("--fine-radius", type=common.positive_float, default=0.5,
                   help="radius about the contact point meshed with size --h (default %(default)s)")
    p.add_argument("--h-core", type=common.non_negative_float, default=0.05,
                   help="mesh size within --core-radius of the contact point: the squeezed medium layer and "
                        "the contact zone, < --h; 0: no core (default %(default)s)")
    p.add_argument("--block", choices=("tetrahedra", "octree"), default="tetrahedra",
                   help="the block's mesh: gmsh tetrahedra like the rest, or an octree of cubes refined toward "
                        "the contact (polyhedra with hanging vertices; needs --method vem) (default %(default)s)")
    p.add_argument("--core-radius", type=common.positive_float, default=0.25,
                   help="radius about the contact point meshed with size --h-core (default %(default)s)")
    return p


def build(args: argparse.Namespace) -> tuple[sf.ContactProblem, dict]:
    """The quarter Hertz model of the command line and the observer ``top_uz``."""
    if args.block == "octree" and args.method != "vem":
        raise ValueError("--block octree needs --method vem (the octree's cubes with hanging vertices are polyhedra)")
    mesher = sf.meshes.hertz3d_octree if args.block == "octree" else sf.meshes.hertz3d
    bench = mesher(h_contact=args.h, h_far=args.h_far, gap=args.gap, fine_radius=args.fine_radius,
                   h_core=args.h_core or None, core_radius=args.core_radius)
    s = args.stiffness
    medium = common.third_medium(args, mu=MU, K=K)
    problem = sf.ContactProblem(bench.mesh, {sf.meshes.SOLID: sf.Hyperelastic(K=K, mu=MU),
                                             SPHERE: sf.Hyperelastic(K=s * K, mu=s * MU),
                                             sf.meshes.MEDIUM: medium}, **common.discretization(args))
    problem.fix(bench.marker("bottom"), name="bottom")
    problem.fix(bench.marker("symmetry_x"), components="x", name="symmetry_x")
    problem.fix(bench.marker("symmetry_y"), components="y", name="symmetry_y")
    top = bench.marker("sphere_top")
    problem.prescribe(top, tags=[SPHERE], uz=-(args.gap + args.indent), name="load")
    problem.parameters["geometry"] = {"R": HERTZ3D_R, "gap": args.gap, "h_far": args.h_far,
                                      "fine_radius": args.fine_radius, "h_core": args.h_core,
                                      "core_radius": args.core_radius, "block": args.block, "E": E, "nu": NU}
    point = np.array([0.0, 0.0, HERTZ3D_H + args.gap + HERTZ3D_R])[:, None]
    at_axis_top = lambda x: np.linalg.norm(x - point, axis=0) <= 1e-10       # noqa: E731
    return problem, {"top_uz": common.displacement_observer(problem, at_axis_top, 2)}


# --------------------------------------------------------------------------- against Hertz
def hertz(F: float, stiffness: float) -> exact.HertzContact:
    """Hertz's answer for the whole sphere's force F (block E, nu; sphere stiffness x E)."""
    return exact.hertz_sphere(F, HERTZ3D_R, E, NU, stiffness * E, NU)


def depth_settlement(F: float, depth: float = HERTZ3D_H) -> float:
    """Boussinesq's displacement on the axis at ``depth`` under a point force F on a half-space,
    w = F (1 + nu) (3 - 2 nu) / (2 pi E depth): how much of Hertz's approach of remote points the
    block's clamped bottom, ``depth`` below the contact, does not see (first order, a << depth)."""
    return F * (1 + NU) * (3 - 2 * NU) / (2 * math.pi * E * depth)


def block_body(pressure: sf.ContactPressure) -> int:
    """The body index of the block: the body of the boundary node nearest the origin."""
    return int(pressure.body[np.argmin(np.linalg.norm(pressure.X, axis=1))])


def hertz_rows(summary: RunSummary, block: int, gap: float, stiffness: float) -> list[dict[str, float]]:
    """Per converged step in contact (the block's smallest gap below TOUCHING x gap): load, F
    (whole sphere), delta, a_zone, a_p, p_max and Hertz's a, p0 and delta at that F, and Hertz's
    delta less :func:`depth_settlement`."""
    rows = []
    for s in summary.converged_steps:
        c = next((c for c in s.contact if c["body"] == block), None)
        if c is None or c["gap"] is None or c["gap"] > TOUCHING * gap or -c["force"][2] <= 0.0:
            continue
        F = -4 * c["force"][2]
        h = hertz(F, stiffness)
        rows.append({"load": s.load, "F": F, "delta": -s.extra["top_uz"] - (gap - c["gap"]),
                     "a_zone": math.sqrt(4 * c["zone_length"] / math.pi),
                     "a_p": math.sqrt(3 * F / (2 * math.pi * c["max_pressure"])),
                     "p_max": c["max_pressure"], "a_H": h.a, "p0_H": h.p0, "delta_H": h.delta,
                     "delta_Hb": h.delta - depth_settlement(F),
                     "gap": c["gap"], "F_reaction": -4 * s.reaction["load"][2]})
    return rows


def write_table(rows: list[dict[str, float]], last: dict[str, float], path, title: str) -> None:
    """The rows of :func:`hertz_rows` as a Markdown table, and the last state's radii ``last`` of
    :func:`last_state_radii` against Hertz."""
    lines = [f"# {title}", "", "| load | F | delta | delta Hertz | Hertz - bottom | a_zone | a_p | a Hertz "
             "| a_zone/a_H | a_p/a_H | p_max | p0 Hertz | p_max/p0 | smallest gap | F / reaction |", "|" + "---|" * 15]
    for r in rows:
        lines.append(f"| {r['load']:.4g} | {r['F']:.4g} | {r['delta']:.4f} | {r['delta_H']:.4f} | {r['delta_Hb']:.4f} "
                     f"| {r['a_zone']:.4f} "
                     f"| {r['a_p']:.4f} | {r['a_H']:.4f} | {r['a_zone'] / r['a_H']:.3f} | {r['a_p'] / r['a_H']:.3f} "
                     f"| {r['p_max']:.4g} | {r['p0_H']:.4g} | {r['p_max'] / r['p0_H']:.3f} | {r['gap']:.2e} "
                     f"| {r['F'] / r['F_reaction']:.4f} |")
    if rows:
        r = rows[-1]
        lines += ["", f"Last state, Hertz's ellipse fitted to the block-top pressure above {FIT_FRACTION:g} of the "
                      f"peak: a_fit = {last['a_fit']:.4f} (a_fit/a_H = {last['a_fit'] / r['a_H']:.3f}), "
                      f"p0_fit = {last['p0_fit']:.4g} (p0_fit/p0 = {last['p0_fit'] / r['p0_H']:.3f}); from the "
                      f"pressure's second moment within {MOMENT_WINDOW:g} a_H: a_m = {last['a_m']:.4f} (a_m/a_H = {last['a_m'] / r['a_H']:.3f}; "
                      f"Hertz's profile on the same nodes gives {last['a_m_H']:.4f}, ratio "
                      f"{last['a_m'] / last['a_m_H']:.3f}); from the nodal forces' second moment within "
                      f"{MOMENT_WINDOW:g} a_H: a_F = {last['a_F']:.4f} (a_F/a_H = {last['a_F'] / r['a_H']:.3f})"]
    path.write_text("\n".join(lines) + "\n")


def block_top(pressure: sf.ContactPressure, block: int) -> np.ndarray:
    """(n,) bool: the boundary nodes of ``pressure`` on the block's top, facing the sphere."""
    return (pressure.body == block) & np.isclose(pressure.X[:, 2], HERTZ3D_H) & (pressure.partner_body >= 0)


def block_top_nodes(pressure: sf.ContactPressure, block: int) -> tuple[np.ndarray, np.ndarray]:
    """(n, 2) deformed x, y and (n,) pressure of the block's top nodes facing the sphere."""
    on_top = block_top(pressure, block)
    return pressure.x[on_top, :2], pressure.pressure[on_top]


def block_top_forces(pressure: sf.ContactPressure, block: int) -> tuple[np.ndarray, np.ndarray]:
    """(n, 2) reference x, y and (n,) medium's nodal force along -z (pressing, positive) of the
    block's top nodes facing the sphere."""
    on_top = block_top(pressure, block)
    return pressure.X[on_top, :2], -pressure.force[on_top, 2]


def force_moment_radius(XY: np.ndarray, f: np.ndarray, within: float = math.inf) -> float:
    """Contact radius from the second moment of the nodal forces, a_F = sqrt(5/2 sum f r^2 / sum f),
    over the nodes at reference ``XY`` (n, 2) within radius ``within`` of the axis, with nodal
    forces ``f`` (n,) normal to the plane.

    With consistent nodal forces f_i = int p phi_i dA, sum_i f_i r_i^2 = int p (sum_i phi_i r_i^2) dA =
    int p r^2 dA whenever the faces interpolate r^2 exactly, as P2 faces on a plane do; then a_F
    is :func:`moment_radius` without a recovered pressure or an interpolation in between (a_F = a
    for Hertz's profile). The SFVEM's face-mean DOF carries r^2 at the face's centre instead of its
    face mean, which differs by the face's polar moment of inertia over its area (below 1e-3 a^2 for
    faces a tenth of a wide). NaN without force.
    """
    r2 = np.sum(XY ** 2, axis=1)
    keep = r2 <= within ** 2
    force = float(f[keep].sum())
    return math.sqrt(2.5 * float(f[keep] @ r2[keep]) / force) if force > 0.0 else math.nan


def radial_profile(xy: np.ndarray, p: np.ndarray) -> np.ndarray:
    """(n, 2) radius and pressure of the nodes at ``xy`` (n, 2) with pressure ``p`` (n,), by radius."""
    rp = np.stack([np.hypot(xy[:, 0], xy[:, 1]), p], axis=1)
    return rp[np.argsort(rp[:, 0])]


def moment_radius(xy: np.ndarray, p: np.ndarray, within: float = math.inf) -> float:
    """Contact radius from the pressure's second moment, a_m = sqrt(5/2 int p r^2 dA / int p dA),
    over the nodes within radius ``within`` of the axis.

    For Hertz's profile p0 sqrt(1 - r^2 / a^2), int p r^2 dA / int p dA = 2 a^2 / 5, so a_m = a
    exactly; unlike a threshold (a_zone) or a fit of the profile's shape (a_fit), it weighs every
    node by its share of the force, so a smoothed edge of the zone hardly moves it, while the r^2
    weight makes it sensitive to the medium's small pressure far outside the zone (hence
    ``within``). The nodal pressure ``p`` at the points ``xy`` (n, 2) (deformed, any quarter or
    whole plane around the axis) is interpolated linearly on their Delaunay triangulation and
    integrated exactly. NaN without pressure.
    """
    from scipy.spatial import Delaunay

    keep = np.hypot(xy[:, 0], xy[:, 1]) <= within
    xy, p = xy[keep], p[keep]
    triangles = Delaunay(xy).simplices                                     # (m, 3)
    corners = xy[triangles]                                                # (m, 3, 2)
    e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    jacobian = np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])          # (m,): twice the area
    reference, weights = triangle_rule(3)                                  # p linear times r^2: degree 3
    barycentric = np.column_stack([1.0 - reference.sum(axis=1), reference])  # (q, 3)
    points = np.einsum("qk,mkd->mqd", barycentric, corners)                # (m, q, 2)
    pq = barycentric @ p[triangles].T                                      # (q, m)
    force = np.sum(jacobian * (weights @ pq))
    second = np.sum(jacobian * np.einsum("q,qm,mq->m", weights, pq, np.sum(points ** 2, axis=2)))
    return math.sqrt(2.5 * second / force) if force > 0.0 else math.nan


def ellipse_fit(rp: np.ndarray, fraction: float = FIT_FRACTION) -> tuple[float, float]:
    """(a, p0) of Hertz's profile p = p0 sqrt(1 - r^2 / a^2) fitted to the block-top pressure ``rp``
    (rows r, p of :func:`radial_profile`): least squares of p^2 = p0^2 - (p0 / a)^2 r^2 over the
    nodes with p at least ``fraction`` of the largest (the edge of the zone, where the pressure falls
    to zero over the last element, left out). NaNs if fewer than three nodes qualify."""
    r, pressure = rp[rp[:, 1] >= fraction * rp[:, 1].max(initial=0.0)].T
    if r.size < 3:
        return math.nan, math.nan
    slope, intercept = np.polyfit(r ** 2, pressure ** 2, 1)
    if intercept <= 0.0 or slope >= 0.0:
        return math.nan, math.nan
    return math.sqrt(-intercept / slope), math.sqrt(intercept)


def last_state_radii(xy: np.ndarray, p: np.ndarray, XY: np.ndarray, f: np.ndarray,
                     row: dict[str, float] | None) -> dict[str, float]:
    """The last state's ``a_fit``, ``p0_fit`` (:func:`ellipse_fit`), and with the last row's Hertz
    radius a_H, within ``MOMENT_WINDOW`` a_H of the axis: ``a_m`` (:func:`moment_radius`), ``a_m_H``,
    the same of Hertz's profile on the same nodes (what the nodes' linear interpolation makes of an
    exact answer), and ``a_F`` (:func:`force_moment_radius`); from the block-top pressure ``xy``,
    ``p`` (:func:`block_top_nodes`) and forces ``XY``, ``f`` (:func:`block_top_forces`)."""
    r = np.hypot(xy[:, 0], xy[:, 1])
    a_fit, p0_fit = ellipse_fit(np.stack([r, p], axis=1))
    if row is None:
        return {"a_fit": a_fit, "p0_fit": p0_fit, "a_m": math.nan, "a_m_H": math.nan, "a_F": math.nan}
    within = MOMENT_WINDOW * row["a_H"]
    hertz_p = row["p0_H"] * np.sqrt(np.clip(1 - (r / row["a_H"]) ** 2, 0.0, None))
    return {"a_fit": a_fit, "p0_fit": p0_fit, "a_m": moment_radius(xy, p, within),
            "a_m_H": moment_radius(xy, hertz_p, within),
            "a_F": force_moment_radius(XY, f, within)}


def plot(rp: np.ndarray, rows: list[dict[str, float]], stiffness: float, path, title: str) -> None:
    """Force against indentation with Hertz's curve; the last pressure against radius with Hertz's."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9, 3.6))
    F = np.array([r["F"] for r in rows])
    ax1.plot([r["delta"] for r in rows], F, "o", ms=4, label="third medium")
    Fs = np.linspace(0.0, 1.2 * F.max(), 100)[1:]
    ax1.plot([hertz(f, stiffness).delta for f in Fs], Fs, "k--", label="Hertz (half-space)")
    ax1.plot([hertz(f, stiffness).delta - depth_settlement(f) for f in Fs], Fs, "k:",
             label="Hertz less Boussinesq at the bottom")
    ax1.set(xlabel="indentation delta", ylabel="force F (whole sphere)")
    ax1.legend(fontsize=8)
    h = hertz(rows[-1]["F"], stiffness)
    r = np.linspace(0.0, 1.5 * h.a, 200)
    ax2.plot(rp[:, 0], rp[:, 1], "o", ms=3, label="medium on block")
    ax2.plot(r, h.p0 * np.sqrt(np.clip(1 - (r / h.a) ** 2, 0.0, None)), "k--", label=f"Hertz, F = {rows[-1]['F']:.3g}")
    ax2.set(xlabel="radius r", ylabel="pressure p", xlim=(0.0, 2 * h.a))
    ax2.legend(fontsize=8)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    save_png(fig, path, dpi=90)


def main(argv: typing.Sequence[str] | None = None) -> int:
    """Parse ``argv`` (default ``sys.argv[1:]``), build, solve and compare with Hertz; the exit code."""
    args = common.parse_args(make_parser(), argv)
    problem, observers = build(args)
    cells = "octree block, tetrahedra" if args.block == "octree" else "tetrahedra"
    title = (f"hertz3d: {'SFVEM' if args.method == 'vem' else 'P2'} on {cells}, h = {args.h:g}, gamma = {args.gamma:g}, {args.regularization} "
             f"alpha_r = {args.alpha_r:g}, indent {args.indent:g}")
    code = common.run(problem, args, observers)
    pressure = problem.contact_pressure()          # the last converged state (collective)
    if problem.comm.rank == 0:
        block = block_body(pressure)
        rows = hertz_rows(read_summary(args.out), block, args.gap, args.stiffness)
        xy, p = block_top_nodes(pressure, block)
        rp = radial_profile(xy, p)
        with open(args.out / "pressure.csv", "w", newline="") as f:
            csv.writer(f).writerows([["r", "p"], *rp.tolist()])
        last = last_state_radii(xy, p, *block_top_forces(pressure, block), rows[-1] if rows else None)
        write_table(rows, last, args.out / "hertz3d.md", title)
        (args.out / "hertz3d.json").write_text(json.dumps({"rows": rows, "last": last}, indent=1))
        if rows:
            plot(rp, rows, args.stiffness, args.out / "hertz3d.png", title)
            r = rows[-1]
            print(f"final: load {r['load']:.4g}, F {r['F']:.5g}, delta {r['delta']:.4f} (Hertz {r['delta_H']:.4f}), "
                  f"a_zone {r['a_zone']:.4f}, a_p {r['a_p']:.4f}, a_fit {last['a_fit']:.4f}, a_m {last['a_m']:.4f}, "
                  f"a_F {last['a_F']:.4f} "
                  f"(Hertz {r['a_H']:.4f}; {last['a_m_H']:.4f} on the same nodes), "
                  f"p_max {r['p_max']:.4g}, p0_fit {last['p0_fit']:.4g} (Hertz {r['p0_H']:.4g}), gap {r['gap']:.2e}",
                  flush=True)
        else:
            print("final: no contact reached", flush=True)
    return code


if __name__ == "__main__":
    sys.exit(common.exit_code(main))
