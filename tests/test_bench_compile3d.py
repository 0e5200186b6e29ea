"""bench/compile3d.py's table and ratios, from records made up here (no compile)."""
from __future__ import annotations

import pytest

import compile3d as bench


def record(stack: str, cell: str, compiler: str, setup: float, compiler_cpu: float, tangent: float,
           norm: float) -> dict:
    return {"stack": stack, "cell": cell, "grid": "20x4x7", "unknowns": 16605, "compiler": compiler,
            "setup_cpu_s": setup, "compiler_cpu_s": compiler_cpu, "tangent_cpu_s": tangent, "tangent_norm": norm,
            "python": "/usr/bin/python3"}


RECORDS = [record("0.5.2", "hexahedron", "gcc", 5.0, 235.0, 0.60, 145.3),
           record("0.5.2", "hexahedron", "/usr/bin/clang", 5.0, 19.0, 0.66, 145.3 * (1 + 1e-15)),
           record("0.5.2", "tetrahedron", "gcc", 4.0, 150.0, 0.70, 164.7),
           record("0.11.0", "hexahedron", "/usr/bin/clang-14", 11.0, 93.0, 4.0, 145.3)]


def test_ratios_pair_each_stack_and_cells_gcc_with_its_clang():
    (row,) = bench.ratios(RECORDS)            # the tetrahedra lack clang, 0.11 lacks gcc
    assert (row["stack"], row["cell"]) == ("0.5.2", "hexahedron")
    assert row["compile"] == pytest.approx(24.0 / 240.0)
    assert row["tangent"] == pytest.approx(1.1)
    assert row["norm_difference"] == pytest.approx(1e-15, rel=0.2)


def test_the_table_has_every_case_and_the_ratio():
    text = bench.markdown(RECORDS, "2 cores, x86_64")
    assert text.count("| 0.5.2 | hexahedron | 20x4x7 | 16605 |") == 2
    assert "| 0.11.0 | hexahedron | 20x4x7 | 16605 | /usr/bin/clang-14 | 11.0 + 93.0 | 4.000 |" in text
    assert "| 0.5.2 | hexahedron | 20x4x7 | 0.10 | 1.10 |" in text
