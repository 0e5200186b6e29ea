"""The P2 FEM's rates on the thick sphere (bench/thick_sphere_rates.py, its two coarsest meshes in
the linear regime against Lamé): curved (degree-2) tetrahedra converge at order 3 in L2 and 2 in
H1, straight-sided ones at order 2 in L2, the flat faces' geometric error (issue 44 item 5)."""
from __future__ import annotations

import math

import pytest
import thick_sphere_rates as bench

H = (0.4, 0.2)


def observed(rows: list[dict], key: str) -> float:
    """The order of rows[key] between the two meshes in their h."""
    return math.log(rows[0][key] / rows[1][key]) / math.log(rows[0]["h"] / rows[1]["h"])


@pytest.fixture(scope="module")
def runs() -> dict[int, list[dict]]:
    return {order: [bench.run("lame", order, h) for h in H] for order in (1, 2)}


def test_curved_tetrahedra_converge_at_order_3_in_L2_and_2_in_H1(runs):
    curved = runs[2]
    assert curved[1]["cells"] > 3 * curved[0]["cells"]
    assert observed(curved, "L2") > 2.6
    assert observed(curved, "H1") > 1.6
    assert curved[1]["L2"] < 1.5e-3 and curved[1]["H1"] < 3e-2


def test_straight_tetrahedra_are_held_at_order_2_by_the_flat_faces(runs):
    straight, curved = runs[1], runs[2]
    assert [r["cells"] for r in straight] == [r["cells"] for r in curved]      # the same meshes, flat or curved
    assert 1.6 < observed(straight, "L2") < 2.4
    assert all(s["L2"] > 8 * c["L2"] for s, c in zip(straight, curved))
    assert all(s["u_r_mean"] < -1e-2 for s in straight)                       # the thinner, smaller shell
