"""The user-mesh demo (demos/user_mesh3d.py): a gmsh order-2 model of an O-ring between plates,
read by name, on a coarse mesh in a short run into contact: the curved mesh read with its regions
and surfaces, equilibrium of the plate's force, the bodies kept apart, the pictures written."""
from __future__ import annotations

import pytest

import user_mesh3d
from dolfinx_sfvem.output.run_summary import read_summary

#: coarse mesh, the plates' gap (0.1) closed through the medium and the ring squeezed by 0.01 in 3 steps
COARSE = ["--h", "0.2", "--section-cells", "3", "--steps", "3", "--squeeze", "0.01", "--quiet"]


def test_the_model_is_read_curved_with_its_names(tmp_path):
    args = user_mesh3d.common.parse_args(user_mesh3d.make_parser(), [*COARSE, "--out", str(tmp_path)])
    mesh = user_mesh3d.read_mesh(args)
    assert mesh.cell_type == "tetrahedron" and mesh.geometry_degree == 2
    assert mesh.region_names == user_mesh3d.REGIONS
    assert set(mesh.boundary_names) == set(user_mesh3d.SURFACES)
    # the ring's volume: half a quarter torus, pi r^2 / 2 x pi R0 / 2, to the curved cells' accuracy
    ring = mesh.volumes[mesh.tags == user_mesh3d.REGIONS["oring"]].sum()
    exact = user_mesh3d.math.pi ** 2 * user_mesh3d.R_SECTION ** 2 * user_mesh3d.R0 / 4
    assert ring == pytest.approx(exact, rel=2e-3)


def test_coarse_run_into_contact(tmp_path):
    code = user_mesh3d.common.exit_code(user_mesh3d.main, [*COARSE, "--out", str(tmp_path)])
    assert code == 0
    for name in ("summary.json", "load_path.csv", "curves.png", "final-deformed.png", "final-clip.png",
                 "final-pressure.png"):
        assert (tmp_path / name).is_file(), name
    summary = read_summary(tmp_path)
    last = summary.final_step
    assert last.load == pytest.approx(1.0)
    force = -last.reaction["press"][2]
    assert force > 0.0
    assert sum(r[2] for r in last.reaction.values()) == pytest.approx(0.0, abs=1e-6 * force)
    gaps = [s.gap["value"] for s in summary.converged_steps if s.gap]
    assert gaps and min(gaps) > 0.0 and gaps[-1] < 0.05        # closed from 0.1, the bodies apart
