"""P2 tetrahedra against Q2 hexahedra on the 3D C-box (issue 29 item 8): the corner's reaction.

The same grids (``--n``), each hexahedron split into 6 tetrahedra for P2 (the same unknowns), the
point contact's corner displacement scaled by ``--scale`` in one step, the Hu-Hu medium. Two
loadings: the corner point alone (as dolfiny; in 3D a point has no capacity, so its reaction
falls with the cells around it and two cell types need not agree) and the ``--load-patch`` square
of the top face at the corner (a finite reaction). Per grid and loading: the unknowns, both
reactions and their relative difference |R_tet − R_hex| / |R_hex|.

Usage: ``python bench/cbox3d_tet_hex.py [--grids 20,1,7 20,2,7 ...] [--scale 0.1] [--patch 0.1]``;
writes bench/cbox3d_tet_hex.json and bench/cbox3d_tet_hex.md.
"""
from __future__ import annotations

import argparse
import json
import pathlib
import subprocess
import sys
import tempfile

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from dolfinx_sfvem.mpi_launcher import job_environment  # noqa: E402


def reaction(n: tuple[int, int, int], cell: str, scale: float, patch: float | None) -> tuple[int, list[float]]:
    """(unknowns, the load's reaction) of one run of demos/cbox3d.py."""
    with tempfile.TemporaryDirectory() as out:
        argv = [sys.executable, str(ROOT / "demos" / "cbox3d.py"), "--n", *map(str, n), "--cell", cell,
                "--scale", str(scale), "--steps", "1", "--regularization", "huhu", "--quiet", "--out", out]
        if patch is not None:
            argv += ["--load-patch", str(patch)]
        proc = subprocess.run(argv, capture_output=True, text=True, env=job_environment())
        if proc.returncode != 0:
            raise RuntimeError(f"{' '.join(argv)} failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}")
        summary = json.loads((pathlib.Path(out) / "summary.json").read_text())
        return int(summary["dofs"]), summary["steps"][-1]["reaction"]["load"]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--grids", nargs="+", default=["20,1,7", "20,2,7", "40,2,14", "40,4,14"])
    p.add_argument("--scale", type=float, default=0.1)
    p.add_argument("--patch", type=float, default=0.1)
    args = p.parse_args()
    rows = []
    for grid in args.grids:
        n = tuple(int(k) for k in grid.split(","))
        for loading, patch in (("point", None), ("patch", args.patch)):
            (dofs, hexa), (_, tet) = (reaction(n, cell, args.scale, patch) for cell in ("hexahedron", "tetrahedron"))
            difference = float(np.linalg.norm(np.subtract(tet, hexa)) / np.linalg.norm(hexa))
            rows.append({"grid": list(n), "loading": loading, "unknowns": dofs, "R_hex": hexa, "R_tet": tet,
                         "difference": difference})
            print(f"{grid:>9} {loading:>5} {dofs:7d}  R_hex {hexa[1]:+.5e} {hexa[2]:+.5e}  "
                  f"R_tet {tet[1]:+.5e} {tet[2]:+.5e}  {100 * difference:5.2f} %", flush=True)
    here = pathlib.Path(__file__).resolve().parent
    (here / "cbox3d_tet_hex.json").write_text(json.dumps({"scale": args.scale, "patch": args.patch, "rows": rows},
                                                         indent=1))
    lines = ["| grid | loading | unknowns | R_y hex | R_z hex | R_y tet | R_z tet | difference |", "|---" * 8 + "|"]
    lines += [f"| {' x '.join(map(str, r['grid']))} | {r['loading']} | {r['unknowns']} | {r['R_hex'][1]:.5e} | "
              f"{r['R_hex'][2]:.5e} | {r['R_tet'][1]:.5e} | {r['R_tet'][2]:.5e} | {100 * r['difference']:.2f} % |"
              for r in rows]
    (here / "cbox3d_tet_hex.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
