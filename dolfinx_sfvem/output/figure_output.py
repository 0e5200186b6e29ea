"""PNG output of matplotlib figures, written atomically."""
from __future__ import annotations

import os
import pathlib
import typing


def save_png(fig, path: str | os.PathLike, **savefig_options: typing.Any) -> None:
    """Write ``fig`` to ``path`` through a temporary file in the same directory (a reader never
    sees a half-written PNG) and close it; ``savefig_options`` go to ``fig.savefig``."""
    import matplotlib.pyplot as plt

    path = pathlib.Path(path)
    tmp = path.with_name(f".{path.name}.tmp.png")
    fig.savefig(tmp, **savefig_options)
    plt.close(fig)
    os.replace(tmp, path)
