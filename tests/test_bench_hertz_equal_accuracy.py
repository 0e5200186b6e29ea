"""bench/hertz_equal_accuracy.py: a case's record from a made-up demo output (no solve), and its row."""
from __future__ import annotations

import json
import subprocess

import hertz_equal_accuracy as bench


def test_record_and_row_from_the_demo_outputs(tmp_path, monkeypatch):
    """run_case reads unknowns and Newton iterations from summary.json (failed attempts apart) and
    the errors from hertz3d.json (the radii a_m, a_F, a_fit); the row shows them as ratios to Hertz."""
    popen = subprocess.Popen

    def fake_demo(command, **_):
        out = tmp_path / "octree-0.2-0.1"
        out.mkdir()
        steps = [{"newton_iterations": 3, "converged": True, "gap": {"value": 0.05}},
                 {"newton_iterations": 60, "converged": False, "gap": {"value": -0.1}},
                 {"newton_iterations": 12, "converged": True, "gap": {"value": -1e-4}}]
        (out / "summary.json").write_text(json.dumps({"dofs": 38463, "message": "", "converged": True,
                                                       "steps": steps}))
        row = {"load": 1.0, "F": 0.015, "p_max": 0.2, "p0_H": 0.16, "a_H": 0.2, "a_zone": 0.22, "gap": 9e-5}
        last = {"a_fit": 0.19, "p0_fit": 0.164, "a_m": 0.201, "a_m_H": 0.2002, "a_F": 0.2028}
        (out / "hertz3d.json").write_text(json.dumps({"rows": [row], "last": last}))
        return popen(["true"])

    monkeypatch.setattr(bench.subprocess, "Popen", fake_demo)
    record = bench.run_case("octree-0.2-0.1", tmp_path)
    assert (record["dofs"], record["newton"], record["newton_failed"], record["exit_status"]) == (38463, 15, 60, 0)
    assert record["p_ratio"] == 1.25 and abs(record["a_m_ratio"] - 1.005) < 1e-12
    assert abs(record["a_F_ratio"] - 1.014) < 1e-12 and abs(record["p0_fit_ratio"] - 1.025) < 1e-12 and abs(record["a_fit_ratio"] - 0.95) < 1e-12
    row = bench.table([record]).splitlines()[-1]
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[:4] == ["octree-0.2-0.1", "38,463", "1", "15 (60)"]
    assert cells[6:14] == ["1.250", "1.005 (1.001)", "1.014", "1.025", "0.950", "1.100", "9.00e-05", "-1.00e-04"]
