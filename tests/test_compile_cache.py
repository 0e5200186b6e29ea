"""FFCx module names of the FEM's forms (dolfinx_sfvem/discretizations/fem.py): a second run with
another grid, another gamma and another hash seed finds the first run's modules in the cache.

Each run is a fresh process on the same, first empty, cache directory: the first compiles every
form, the second must compile nothing. (Under DOLFINx 0.5.2 the residual's and tangent's names
used to depend on whether the process had compiled the energy form or found it in the cache:
docs/notes/2026-12-07-compile-time.md.)
"""
import json
import os
import subprocess
import sys

import pytest

from dolfinx_sfvem.discretizations.c_compiler import jit_c_compiler

#: a solid and a huhu medium side by side on P2 triangles of an n x 2n grid: cheap to compile
BUILD = """
import json, sys
import numpy as np
import dolfinx_sfvem as sf
from dolfinx_sfvem.discretizations.fem import LagrangeDiscretization

n, gamma = int(sys.argv[1]), float(sys.argv[2])
x, y = np.meshgrid(np.linspace(0.0, 2.0, 2 * n + 1), np.linspace(0.0, 1.0, n + 1))
corner = np.arange((n + 1) * (2 * n + 1)).reshape(n + 1, 2 * n + 1)[:-1, :-1].ravel()
a, b, c, d = corner, corner + 1, corner + 2 * n + 2, corner + 2 * n + 1
triangles = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
tags = np.where(np.tile(corner % (2 * n + 1) < n, 2), 1, 2)
mesh = sf.PolygonMesh(np.column_stack([x.ravel(), y.ravel()]), triangles, tags)
materials = {1: sf.Hyperelastic(K=2.0, mu=0.7),
             2: sf.ThirdMedium(mu=0.3, gamma=gamma, alpha_r=1.0, K=0.2, regularization="huhu")}
disc = LagrangeDiscretization.from_polygon_mesh(mesh, materials, fem_mesh=mesh, verbose=False)
print(json.dumps(disc.module_names()))
"""


def build(cache, seed: int, n: int, gamma: float) -> dict[str, str]:
    """The module names of a fresh process's discretization (cache directory ``cache``)."""
    env = dict(os.environ, PYTHONHASHSEED=str(seed), XDG_CACHE_HOME=str(cache), OMP_NUM_THREADS="1")
    done = subprocess.run([sys.executable, "-c", BUILD, str(n), str(gamma)], env=env, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


def c_files(cache) -> set[str]:
    return {path.name for path in cache.rglob("*.c")}


@pytest.fixture(scope="module")
def first_run(tmp_path_factory):
    """A first run on an empty cache: (cache directory, module names, the .c files there)."""
    cache = tmp_path_factory.mktemp("cache")
    names = build(cache, seed=0, n=2, gamma=1e-5)
    return cache, names, c_files(cache)


def test_a_second_run_with_another_grid_gamma_and_hash_seed_finds_the_forms(first_run):
    cache, first, compiled = first_run
    assert set(first) == {"energy", "residual", "tangent"}
    assert {f"{name}.c" for name in first.values()} <= compiled
    second = build(cache, seed=1, n=3, gamma=2e-6)
    assert second == first
    assert c_files(cache) == compiled            # nothing compiled again


@pytest.mark.skipif(jit_c_compiler() is None,
                    reason="FFCx writes loops (gcc is faster there), no clang on PATH (the Makefile installs "
                           "it), or CC set by the user")
def test_the_forms_are_built_by_clang(first_run):
    """clang leaves its version in the .comment section of what it compiles; gcc-built modules
    carry only GCC's."""
    cache, names, _ = first_run
    for name in names.values():
        (library,) = [path for path in cache.rglob(f"{name}*.so")]
        assert b"clang version" in library.read_bytes(), name
