"""bench/peer3d.py's readings of a run and its variants of the peer's demo, from texts made up here (no solve)."""
from __future__ import annotations

import json
import pathlib
import subprocess
import sys

import pytest

import peer3d as bench

BENCH = pathlib.Path(bench.__file__).resolve().parent

#: the lines of a dolfiny demo that the bench reads (PETSc 3.25's converged-reason lines carry the prefix)
PEER_OUTPUT = """Mesh: 7840 cells, 9225 nodes
Load step 1, u_z: -0.100, u_y: 0.025
  0 SNES Function norm 1.0e+00
Nonlinear cbox_W_3D solve converged due to CONVERGED_FNORM_ABS iterations 7
Load step 2, u_z: -0.200, u_y: 0.050
Nonlinear cbox_W_3D solve converged due to CONVERGED_FNORM_RELATIVE iterations 9
Load step 3, u_z: -0.300, u_y: 0.075
Nonlinear cbox_W_3D solve did not converge due to DIVERGED_MAX_IT iterations 25
Solver failed to converge, aborting.
"""


def test_the_peers_load_is_its_last_converged_step_and_every_iteration_counts():
    assert bench.parse_peer(PEER_OUTPUT, 20) == (2 / 20, 7 + 9 + 25, "DIVERGED_MAX_IT")
    assert bench.parse_peer("", 60) == (0.0, 0, "")


def test_our_time_to_the_peers_load_includes_the_failed_attempts_before():
    steps = [{"wall_time_s": 1.0, "converged": True, "load": 0.5},
             {"wall_time_s": 2.0, "converged": False, "load": 1.0},
             {"wall_time_s": 3.0, "converged": True, "load": 0.9},
             {"wall_time_s": 4.0, "converged": True, "load": 1.0}]
    assert bench.wall_time_to(steps, 0.85) == 6.0
    assert bench.wall_time_to(steps, 1.0) == 10.0
    assert bench.wall_time_to(steps[:2], 0.85) is None


def test_each_run_is_measured_alone(tmp_path):
    """A small run after a large one reports its own peak memory and CPU time, not the larger
    run's (the usage of all children together would). Measured from a fresh interpreter: a child's
    peak counts the pages it shares with its parent until it execs, so the parent must be small."""
    script = (f"import json, pathlib, sys; sys.path.insert(0, {str(BENCH)!r}); import peer3d\n"
              "large = peer3d.run_measured([sys.executable, '-c', \"x = b'1' * (800 * 2**20); print('done')\"], "
              "pathlib.Path('.'))\n"
              "small = peer3d.run_measured([sys.executable, '-c', \"print('small')\"], pathlib.Path('.'))\n"
              "print(json.dumps([[p.returncode, p.stdout, cpu, memory] for p, cpu, memory in (large, small)]))")
    out = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, capture_output=True, text=True, check=True)
    (code_large, out_large, cpu_large, memory_large), (code_small, out_small, cpu_small, memory_small) = \
        json.loads(out.stdout.splitlines()[-1])
    assert code_large == code_small == 0 and out_large == "done\n" and out_small == "small\n"
    assert memory_large - memory_small > 0.5, (memory_large, memory_small)   # most of the 0.78 GiB
    assert 0 < cpu_small < cpu_large + 1.0


#: the lines of the peer's demos that its variants change, and one they keep
PEER_DEMO = '''metadata = {"quadrature_degree": 1} # one quadrature point
V = fem.functionspace(mesh, ("Lagrange", 1, (tdim,))) # displacement
P = fem.functionspace(third_medium_mesh, ("Lagrange", 1, (3,)))
bcs = [bc_bottom, bc_x_symm]
ofile = VTXWriter(comm, f"{name}/{name}.bp", [u, tm_func])
'''


def test_a_peer_variant_changes_the_element_the_rule_and_the_auxiliary_field():
    as_is = bench.peer_variant(PEER_DEMO, bench.PeerVariant())
    assert as_is == PEER_DEMO and bench.PeerVariant().label == ""
    variant = bench.PeerVariant(degree=2, quadrature_degree=4, no_aux=True)
    changed = bench.peer_variant(PEER_DEMO, variant).splitlines()
    assert changed[0].startswith('metadata = {"quadrature_degree": 4}')
    assert changed[1].startswith('V = fem.functionspace(mesh, ("Lagrange", 2, (tdim,)))')
    assert changed[2] == PEER_DEMO.splitlines()[2]                            # p stays P1
    assert changed[3] == "bcs = [bc_bottom, bc_x_symm]" and "dirichletbc(np.zeros(3)" in changed[4]
    assert "VTXWriter" not in changed[5] and "NoOutput" in changed[5]
    assert variant.label == "P2/Q2, quadrature degree 4, p = 0"


def test_a_peer_variant_refuses_a_demo_it_does_not_recognise():
    with pytest.raises(ValueError, match="0 matches"):
        bench.peer_variant(PEER_DEMO.replace("Lagrange", "CG"), bench.PeerVariant(degree=2))
