"""The package's docstrings and comments name only documents that exist, and no dated notes.

A reader follows a path such as ``docs/method.md`` or ``meshes/README.md`` from the source; every
such path (a word ending in ``.md``, or one starting with ``docs/``) names a file or folder of the
repository. The dated investigation notes (``docs/notes/``) keep the history; the source states
its contracts itself and points, where it explains a method at length, to a page of docs/.
"""
import pathlib
import re

import dolfinx_sfvem

PACKAGE = pathlib.Path(dolfinx_sfvem.__file__).parent
ROOT = PACKAGE.parent
#: a path to a Markdown file (with or without folders) or any path below docs/
DOC_PATH = re.compile(r"(?<![\w./-])((?:[\w.-]+/)*[\w.-]+\.md(?![\w/-])|docs/[\w./-]*[\w/-](?![\w-]))")


def doc_paths(source: str) -> list[tuple[int, str]]:
    """(line, path) of every document path named in ``source``."""
    return [(source.count("\n", 0, m.start()) + 1, m.group(1)) for m in DOC_PATH.finditer(source)]


def test_the_path_finder_reads_paths_in_prose():
    text = ('"""See docs/method.md §3 and docs/guide/loads.md.\n(POLY-INTERFACES.md, meshes/README.md)"""\n'
            "# docs/figures/cbox.png, docs/notes/, a.md5sum, x = 1.5")
    assert doc_paths(text) == [(1, "docs/method.md"), (1, "docs/guide/loads.md"), (2, "POLY-INTERFACES.md"),
                               (2, "meshes/README.md"), (3, "docs/figures/cbox.png"), (3, "docs/notes/")]


def test_every_document_named_in_the_package_exists():
    missing, named = [], 0
    for path in sorted(PACKAGE.rglob("*.py")):
        for line, doc in doc_paths(path.read_text()):
            named += 1
            if not (ROOT / doc).exists():
                missing.append(f"{path.relative_to(ROOT)}:{line}: {doc}")
    assert named > 20
    assert not missing, "\n".join(missing)


def test_the_package_names_no_dated_note():
    dated = [f"{path.relative_to(ROOT)}:{line}: {doc}" for path in sorted(PACKAGE.rglob("*.py"))
             for line, doc in doc_paths(path.read_text()) if doc.startswith("docs/notes")]
    assert not dated, "\n".join(dated)
