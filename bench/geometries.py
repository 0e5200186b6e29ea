"""The benchmark geometries: mesh sizes and load path (no heavy imports: the driver reads them).

Mesh sizes h of the solid; the medium is quads of size h. SFVEM unknowns (polygons):

- ``cbox``: quick 0.1, 0.07, 0.05 -> 1258 (103) ... 3002 (264);
  full 0.025, 0.0125, 0.007 -> about 11000, 39686 (3793), 118254 (11542);
- ``box``: quick 0.1, 0.07, 0.05 -> ... 5658 (496);
  full 0.04, 0.02, 0.01 -> 9042 (812), 31638 (2968), 117682 (11370).
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Geometry:
    """One benchmark geometry.

    Attributes
    ----------
    name
        Key used on the command line and in results.json.
    sizes_quick, sizes_full
        Solid mesh sizes h (descending: the unknowns grow along the tuple).
    uy, steps
        Load path: u_y at the load point reached in ``steps`` equal load steps.
    """
    name: str
    sizes_quick: tuple[float, ...]
    sizes_full: tuple[float, ...]
    uy: float
    steps: int

    def sizes(self, quick: bool) -> tuple[float, ...]:
        return self.sizes_quick if quick else self.sizes_full


GEOMETRIES: dict[str, Geometry] = {
    "cbox": Geometry("cbox", (0.1, 0.07, 0.05), (0.025, 0.0125, 0.007), uy=-0.15, steps=4),
    "box": Geometry("box", (0.1, 0.07, 0.05), (0.04, 0.02, 0.01), uy=-0.1, steps=4),
}
