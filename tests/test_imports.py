"""The package's modules import each other without a circle.

The graph has an edge A -> B when A's source imports B anywhere: in its module body (also inside
``if``/``try`` blocks and class bodies), under ``if TYPE_CHECKING:``, and inside functions (a lazy
import ties the modules together as much as one at the top: it only delays the circle). The
``__init__`` of a parent package, which every submodule import runs first, is not counted.

The test modules do not import each other (nor conftest.py, whose fixtures pytest hands to the
tests) and do not edit ``sys.path`` (demos/, bench/ and docs/_ext/ are importable through
pytest's ``pythonpath`` option in pyproject.toml).
"""
import ast
import pathlib

import dolfinx_sfvem

PACKAGE = pathlib.Path(dolfinx_sfvem.__file__).parent
TESTS = pathlib.Path(__file__).resolve().parent


def _imports(tree: ast.Module):
    """Every import statement of a module: at the top, in blocks, classes and functions."""
    return (node for node in ast.walk(tree) if isinstance(node, (ast.Import, ast.ImportFrom)))


def import_graph(root: pathlib.Path) -> dict[str, set[str]]:
    """Module name -> the package modules its source imports (anywhere), for the package in
    directory ``root``."""
    files = {}
    for path in root.rglob("*.py"):
        parts = list(path.relative_to(root.parent).with_suffix("").parts)
        files[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    graph = {}
    for name, path in files.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        targets = set()
        for node in _imports(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                targets.update(alias.name for alias in node.names)
                continue
            base = package.split(".")[:len(package.split(".")) - node.level + 1] if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            for alias in node.names:
                submodule = f"{module}.{alias.name}"
                targets.add(submodule if submodule in files else module)
        graph[name] = {t for t in targets if t in files and t != name}
    return graph


def find_circle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import circle [a, b, ..., a] of the graph, or None."""
    state: dict[str, int] = {}               # 1: on the current path, 2: done
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for target in sorted(graph[node]):
            if state.get(target) == 1:
                return path[path.index(target):] + [target]
            if target not in state and (circle := visit(target)):
                return circle
        state[node] = 2
        path.pop()
        return None

    for node in sorted(graph):
        if node not in state and (circle := visit(node)):
            return circle
    return None


def test_the_checker_finds_a_circle(tmp_path):
    """A package whose module a imports b (relative, in a function-free body) and b imports a
    (absolute, inside a try block): one circle; c's TYPE_CHECKING import counts, and so does d's
    import inside a function, which closes a second circle with a."""
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("from . import a\n")
    (pkg / "a.py").write_text("from .b import f\n")
    (pkg / "b.py").write_text("try:\n    import pkg.a\nexcept ImportError:\n    pass\n")
    (pkg / "c.py").write_text("import typing\nif typing.TYPE_CHECKING:\n    from .a import f\n")
    (pkg / "d.py").write_text("class D:\n    def g(self):\n        from . import c\n")
    graph = import_graph(pkg)
    assert graph == {"pkg": {"pkg.a"}, "pkg.a": {"pkg.b"}, "pkg.b": {"pkg.a"}, "pkg.c": {"pkg.a"},
                     "pkg.d": {"pkg.c"}}
    assert find_circle(graph) == ["pkg.a", "pkg.b", "pkg.a"]
    assert find_circle({**graph, "pkg.b": set()}) is None
    assert find_circle({**graph, "pkg.b": set(), "pkg.a": {"pkg.d"}}) == ["pkg.a", "pkg.d", "pkg.c", "pkg.a"]


def test_no_import_circle_in_the_package():
    graph = import_graph(PACKAGE)
    assert {"dolfinx_sfvem.mesh.polygon_mesh", "dolfinx_sfvem.mesh.refine", "dolfinx_sfvem.meshing.dual"} <= set(graph)
    assert "dolfinx_sfvem.mesh.refine" in graph["dolfinx_sfvem.mesh.polygon_mesh"]
    circle = find_circle(graph)
    assert circle is None, "import circle: " + " -> ".join(circle)


def forbidden_in_tests(source: str, test_modules: set[str]) -> list[str]:
    """What a test module must not do, anywhere in its ``source``: import one of ``test_modules``,
    conftest or the tests directory, or touch ``sys.path``; one "line N: ..." per finding."""
    problems = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            modules = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            modules = [node.module or ""]
            if node.module == "sys" and any(alias.name == "path" for alias in node.names):
                problems.append(f"line {node.lineno}: sys.path")
        else:
            modules = []
        problems += [f"line {node.lineno}: imports {m}" for m in modules
                     if m.split(".")[0] in test_modules | {"conftest", "tests"}]
        if (isinstance(node, ast.Attribute) and node.attr == "path" and isinstance(node.value, ast.Name)
                and node.value.id == "sys"):
            problems.append(f"line {node.lineno}: sys.path")
    return sorted(problems, key=lambda problem: int(problem.split(":")[0][5:]))


def test_the_test_module_checker_finds_imports_and_path_edits():
    bad = ("import numpy, test_b\nfrom test_c.d import x\nimport sys\nsys.path.insert(0, 'demos')\n"
           "def f():\n    from conftest import y\n    from sys import path\n")
    assert forbidden_in_tests(bad, {"test_b", "test_c"}) == [
        "line 1: imports test_b", "line 2: imports test_c.d", "line 4: sys.path", "line 6: imports conftest",
        "line 7: sys.path"]
    assert forbidden_in_tests("import sys\nimport testing_tools\nfrom dolfinx_sfvem import meshes\n"
                                "run = [sys.executable]\n", {"test_b"}) == []


def test_test_modules_neither_import_each_other_nor_edit_sys_path():
    modules = sorted(TESTS.glob("test_*.py")) + [TESTS / "conftest.py"]
    assert len(modules) > 30 and (TESTS / "test_imports.py") in modules
    names = {path.stem for path in modules}
    problems = {path.name: found for path in modules if (found := forbidden_in_tests(path.read_text(), names))}
    assert not problems, problems
