"""Sphinx configuration of the documentation site (``make docs``: Debian 12's Sphinx 5.3, MyST 0.18, furo).

The pages are Markdown (MyST). The API reference, the demo gallery and the list of tools are
written into ``_generated/`` when the build starts (``_ext/sitegen.py``); nothing is executed
besides importing ``dolfinx_sfvem`` for autodoc.
"""
import pathlib
import sys

DOCS = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS / "_ext"))

import dolfinx_sfvem  # noqa: E402
import sitegen  # noqa: E402

project = "dolfinx-sfvem"
author = "the dolfinx-sfvem developers"
copyright = "the dolfinx-sfvem developers (MIT licence)"
release = version = dolfinx_sfvem.__version__

extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinx.ext.napoleon"]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
# results-notes.md and results-studies.md are sources of the generated results.md, not pages
exclude_patterns = ["_build", "_ext", "results-notes.md", "results-studies.md"]

myst_heading_anchors = 4
myst_enable_extensions = ["colon_fence", "deflist"]

autodoc_member_order = "bysource"
autodoc_typehints = "signature"
# the indicator type by its name (expanded, numpy.bool_ reads as a reStructuredText link target)
autodoc_type_aliases = {"Indicator": "dolfinx_sfvem.path_following.adaptivity.Indicator"}
napoleon_google_docstring = False
napoleon_numpy_docstring = True
napoleon_use_rtype = False
napoleon_use_ivar = True     # Attributes as fields: dataclass and NamedTuple fields are documented once

html_theme = "furo"
html_title = f"dolfinx-sfvem {release}"
html_static_path = []
html_show_sourcelink = False


def _write_generated_pages(app) -> None:
    """API reference, gallery and tools pages from ``dolfinx_sfvem.__all__`` and ``demos/``."""
    sitegen.write_pages(dolfinx_sfvem, DOCS / "_generated")


def setup(app):
    app.connect("builder-inited", _write_generated_pages)
