"""The physics, the path-following, the output and the problem use only declared members of a discretization.

A discretization is a :class:`~dolfinx_sfvem.discretizations.discretization.Discretization`, and in
3D also a :class:`~dolfinx_sfvem.discretizations.load_host.LoadHost` for the loads on faces and
the enclosed volume. Walking the source with ``ast``, every attribute read or call on a
discretization object in those modules must name a member one of the two declares; and every
concrete discretization must define every member declared for it, the load hosts' methods with
the protocol's signatures.

A discretization object in the source is ``disc`` or any ``<expression>.disc`` (``self.disc``,
``problem.disc``, ``self.equilibrium.disc``), a parameter annotated with ``Discretization`` or
``LoadHost``, or a name assigned one of these; ``getattr(disc, "name", ...)`` and
``hasattr(disc, "name")`` with a literal name count as a use of ``name``.
"""
import ast
import inspect
import pathlib
import textwrap

import numpy as np
import pytest
import ufl
from petsc4py import PETSc

import dolfinx_sfvem as sf
from dolfinx_sfvem.discretizations.compile_lock import compiled_form
from dolfinx_sfvem.discretizations.discretization import Discretization
from dolfinx_sfvem.discretizations.fem import LagrangeDiscretization
from dolfinx_sfvem.discretizations.load_host import LoadHost
from dolfinx_sfvem.discretizations.vem import SFVEMDiscretization
from dolfinx_sfvem.discretizations.vem3d import PolyhedralDiscretization
from dolfinx_sfvem.mesh.cell_mesh import CellMesh

PACKAGE = pathlib.Path(sf.__file__).parent
#: the modules whose uses of a discretization are checked
USERS = sorted([*(PACKAGE / "physics").glob("*.py"), *(PACKAGE / "path_following").glob("*.py"),
                *(PACKAGE / "output").glob("*.py"), PACKAGE / "problem.py"])
#: the discretization classes a problem builds, and whether each is a load host
CONCRETE = {SFVEMDiscretization: False, LagrangeDiscretization: True, PolyhedralDiscretization: True}
CONTRACTS = ("Discretization", "LoadHost")


def members(cls: type) -> set[str]:
    """The public names a class or protocol declares: annotated attributes, methods and
    properties, its own and its package bases' (not ``object``'s, ``abc.ABC``'s or
    ``typing.Protocol``'s)."""
    names = set()
    for base in cls.__mro__:
        if base.__module__.startswith("dolfinx_sfvem"):
            names.update(vars(base).get("__annotations__", {}))
            names.update(vars(base))
    return {name for name in names if not name.startswith("_")}


def declared() -> set[str]:
    """Every member of the contract: :class:`Discretization`'s and :class:`LoadHost`'s."""
    return members(Discretization) | members(LoadHost)


def _is_disc(node: ast.AST, aliases: set[str]) -> bool:
    return (isinstance(node, ast.Name) and node.id in aliases) or (isinstance(node, ast.Attribute)
                                                                   and node.attr == "disc")


def discretization_uses(source: str) -> list[tuple[int, str]]:
    """(line, member) of every attribute of a discretization object used in ``source`` (module
    docstring)."""
    tree = ast.parse(source)
    aliases = {"disc"}
    for node in ast.walk(tree):
        if isinstance(node, ast.arg) and node.annotation is not None and \
                any(name in ast.unparse(node.annotation) for name in CONTRACTS):
            aliases.add(node.arg)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)) and node.value is not None and _is_disc(node.value, {"disc"}):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            aliases.update(t.id for t in targets if isinstance(t, ast.Name))
    uses = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and _is_disc(node.value, aliases):
            uses.append((node.lineno, node.attr))
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ("getattr", "hasattr") \
                and len(node.args) >= 2 and _is_disc(node.args[0], aliases) and isinstance(node.args[1], ast.Constant):
            uses.append((node.lineno, node.args[1].value))
    return sorted(uses)


def undeclared_uses(paths: list[pathlib.Path]) -> list[str]:
    """``path:line: disc.<name>`` for every use of a member the contract does not declare."""
    known = declared()
    return [f"{path.name}:{line}: disc.{name}" for path in paths
            for line, name in discretization_uses(path.read_text()) if name not in known]


def test_the_walk_finds_the_uses():
    source = textwrap.dedent('''
        def f(disc, problem, other: Discretization, host: "LoadHost", x):
            disc.comm
            self.disc.gdim
            problem.disc.create_vector()
            other.x_nodes[0]
            host.to_host(x)
            d = problem.disc
            d.n_owned_nodes
            getattr(self.disc, "face_centre_keys", None)
            x.comm, problem.mesh, self.equilibrium.disc.constraints
        ''')
    assert [name for _, name in discretization_uses(source)] == [
        "comm", "gdim", "create_vector", "x_nodes", "to_host", "n_owned_nodes", "face_centre_keys", "constraints"]


def test_an_undeclared_member_is_found(tmp_path):
    """The check fails on a module that uses ``disc.foo``."""
    module = tmp_path / "copy.py"
    module.write_text((PACKAGE / "physics" / "equilibrium.py").read_text()
                      + "\n\ndef bogus(disc):\n    return disc.foo\n")
    assert undeclared_uses([module]) == [f"copy.py:{len(module.read_text().splitlines())}: disc.foo"]


def test_the_modules_use_declared_members_only():
    assert len(USERS) > 30
    uses = {name for path in USERS for _, name in discretization_uses(path.read_text())}
    assert {"residual", "create_vector", "load_space", "add_host_matrix"} <= uses
    undeclared = undeclared_uses(USERS)
    assert not undeclared, "members of a discretization used but not declared by Discretization or LoadHost:\n" \
        + "\n".join(undeclared)


def _assigned_on_self(cls: type) -> set[str]:
    """Names a class or one of its package bases assigns as ``self.<name> = ...`` in a method."""
    names = set()
    for base in cls.__mro__:
        if base.__module__.startswith("dolfinx_sfvem"):
            for node in ast.walk(ast.parse(textwrap.dedent(inspect.getsource(base)))):
                targets = node.targets if isinstance(node, ast.Assign) else \
                    [node.target] if isinstance(node, ast.AnnAssign) else []
                for target in targets:
                    for t in target.elts if isinstance(target, ast.Tuple) else [target]:
                        if isinstance(t, ast.Attribute) and isinstance(t.value, ast.Name) and t.value.id == "self":
                            names.add(t.attr)
    return names


@pytest.mark.parametrize("cls", list(CONCRETE), ids=lambda cls: cls.__name__)
def test_every_discretization_defines_the_contract(cls):
    """No abstract method left; every declared attribute set (on the class or in a method as
    ``self.<name> = ...``); a load host has every :class:`LoadHost` member, its methods with the
    protocol's signatures."""
    assert not cls.__abstractmethods__
    wanted = members(Discretization) | (members(LoadHost) if CONCRETE[cls] else set())
    defined = {name for name in wanted if hasattr(cls, name)} | _assigned_on_self(cls)
    assert wanted <= defined, f"{cls.__name__} lacks {sorted(wanted - defined)}"
    if CONCRETE[cls]:
        for name in ("to_host", "add_from_host", "add_host_matrix", "nodes_of_host"):
            assert inspect.signature(getattr(cls, name)) == inspect.signature(getattr(LoadHost, name)), name
        assert isinstance(inspect.getattr_static(cls, "load_space"), property)


def test_the_two_contracts_do_not_overlap():
    """One meaning per name: a member is declared by one of them."""
    assert not members(Discretization) & members(LoadHost)


def dense(A: PETSc.Mat) -> np.ndarray:
    """The entries of A as an array (A itself unchanged: ``A.convert`` without a target converts A)."""
    copy = A.convert("dense", PETSc.Mat())
    values = copy.getDenseArray().copy()
    copy.destroy()
    return values


@pytest.mark.parametrize("method", ["fem", "vem"])
def test_a_load_host_scales_a_host_matrix(method, tiny3d):
    """add_host_matrix(A, form, scale) adds scale times what it adds with the default scale 1, to
    a tangent as the balance's tangent does."""
    points, cells = tiny3d.hex_grid(1)
    problem = sf.ContactProblem(CellMesh(points, cells, np.ones(len(cells)), "hexahedron"),
                                {1: sf.Hyperelastic(K=1.0, mu=0.5)}, method=method, verbose=False)
    disc = problem.disc
    W = disc.load_space
    form = compiled_form(ufl.inner(ufl.TrialFunction(W), ufl.TestFunction(W)) * ufl.ds(domain=disc.dolfinx_mesh))
    added = []
    for scale in ((), (-2.5,)):
        A = disc.create_matrix()
        disc.assemble_tangent(problem.x, A)
        tangent = dense(A)
        disc.add_host_matrix(A, form, *scale)
        A.assemble()
        added.append(dense(A) - tangent)
        A.destroy()
    assert np.abs(added[0]).max() > 0.0
    np.testing.assert_allclose(added[1], -2.5 * added[0], rtol=1e-12, atol=1e-12 * np.abs(added[0]).max())
