"""The documentation site's generated pages (docs/_ext/sitegen.py) and the README's links."""
import pathlib
import re
import types

import sitegen

import dolfinx_sfvem

ROOT = pathlib.Path(__file__).resolve().parents[1]


def test_api_page_documents_every_public_name():
    page = sitegen.api_page(dolfinx_sfvem)
    assert set(dolfinx_sfvem.__all__) <= sitegen.documented_names(page)


def test_a_name_in_no_group_still_gets_an_entry():
    package = types.ModuleType("dolfinx_sfvem")
    package.__all__ = ["ContactProblem", "brand_new"]
    package.ContactProblem, package.brand_new = dolfinx_sfvem.ContactProblem, lambda: None
    page = sitegen.api_page(package)
    assert "Other names" in page and {"ContactProblem", "brand_new"} <= sitegen.documented_names(page)


def test_readme_links_point_at_files():
    links = re.findall(r"\]\(((?!https?:)[^)#]+)", (ROOT / "README.md").read_text())
    assert links and [link for link in links if not (ROOT / link).exists()] == []
