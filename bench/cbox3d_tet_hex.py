"""P2 tetrahedra against Q2 hexahedra on the 3D C-box (issue 29 item 8): the corner's reaction.

The same grids (``--n``), each hexahedron split into 6 tetrahedra for P2 (the same unknowns), the
point contact's corner displacement scaled by ``--scale`` in one step, the Hu-Hu medium. Two
loadings: the corner point alone (as dolfiny; in 3D a point has no capacity, so its reaction
falls with the cells around it and two cell types need not agree) and the ``--load-patch`` square
of the top face at the corner (a finite reaction). Per grid and loading: the unknowns, both
reactions and their relative difference |R_tet − R_hex| / |R_hex|.

Usage: ``python bench/cbox3d_tet_hex.py [--grids 20,1,7 20,2,7 ...] [--scale 0.1] [--patch 0.1]
[--alpha-r A] [--loadings point patch]``; adds its cases to bench/cbox3d_tet_hex.json (a case run
again replaces its row) and writes the table of all of them to bench/cbox3d_tet_hex.md.
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


def reaction(n: tuple[int, int, int], cell: str, scale: float, patch: float | None,
             alpha_r: float | None = None) -> tuple[int, list[float]]:
    """(unknowns, the load's reaction) of one run of demos/cbox3d.py."""
    with tempfile.TemporaryDirectory() as out:
        argv = [sys.executable, str(ROOT / "demos" / "cbox3d.py"), "--n", *map(str, n), "--cell", cell,
                "--scale", str(scale), "--steps", "1", "--regularization", "huhu", "--quiet", "--out", out]
        if patch is not None:
            argv += ["--load-patch", str(patch)]
        if alpha_r is not None:
            argv += ["--alpha-r", str(alpha_r)]
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
    p.add_argument("--alpha-r", type=float, default=None,
                   help="the medium's regularization weight (default: the demo's); 0: the neo-Hookean medium alone")
    p.add_argument("--loadings", nargs="+", choices=("point", "patch"), default=["point", "patch"])
    args = p.parse_args()
    rows = []
    for grid in args.grids:
        n = tuple(int(k) for k in grid.split(","))
        for loading, patch in (("point", None), ("patch", args.patch)):
            if loading not in args.loadings:
                continue
            (dofs, hexa), (_, tet) = (reaction(n, cell, args.scale, patch, args.alpha_r)
                                      for cell in ("hexahedron", "tetrahedron"))
            difference = float(np.linalg.norm(np.subtract(tet, hexa)) / np.linalg.norm(hexa))
            rows.append({"grid": list(n), "loading": loading, "patch": patch, "alpha_r": args.alpha_r,
                         "scale": args.scale, "unknowns": dofs, "R_hex": hexa, "R_tet": tet, "difference": difference})
            print(f"{grid:>9} {loading:>5} {dofs:7d}  R_hex {hexa[1]:+.5e} {hexa[2]:+.5e}  "
                  f"R_tet {tet[1]:+.5e} {tet[2]:+.5e}  {100 * difference:5.2f} %", flush=True)
    store = pathlib.Path(__file__).resolve().parent / "cbox3d_tet_hex.json"
    rows = merged(json.loads(store.read_text())["rows"] if store.exists() else [], rows)
    store.write_text(json.dumps({"rows": rows}, indent=1))
    store.with_suffix(".md").write_text(markdown(rows))


def _key(row: dict) -> tuple:
    return tuple(row["grid"]), row["loading"], row.get("patch"), row.get("alpha_r"), row.get("scale")


def merged(old: list[dict], new: list[dict]) -> list[dict]:
    """The stored rows with this run's added, a row of the same case replaced."""
    keys = {_key(r) for r in new}
    return [r for r in old if _key(r) not in keys] + new


def markdown(rows: list[dict]) -> str:
    """The table of every stored case (alpha_r "-": the demo's default)."""
    lines = ["| grid | loading | alpha_r | unknowns | R_y hex | R_z hex | R_y tet | R_z tet | difference |",
             "|---" * 9 + "|"]
    lines += [f"| {' x '.join(map(str, r['grid']))} | {r['loading']}"
              f"{'' if r.get('patch') is None else ' ' + format(r['patch'], 'g')} | "
              f"{'-' if r.get('alpha_r') is None else format(r['alpha_r'], 'g')} | {r['unknowns']} | "
              f"{r['R_hex'][1]:.5e} | {r['R_hex'][2]:.5e} | {r['R_tet'][1]:.5e} | {r['R_tet'][2]:.5e} | "
              f"{100 * r['difference']:.2f} % |" for r in rows]
    return "\n".join(lines) + "\n"

if __name__ == "__main__":
    main()
