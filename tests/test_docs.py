"""The documentation site's generated pages (docs/_ext/sitegen.py) and the README's links."""
import pathlib
import re
import types

import pytest

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


def test_user_energy_example_of_the_guide_solves():
    """The Mooney-Rivlin ``UserEnergy`` of docs/guide/materials.md, as written there, drives a
    pressurized quarter cylinder to its load; at small strain it is neo-Hookean with
    mu = 2 (c1 + c2), so its bore's area change is the exact one of that solid to the mesh's error."""
    import numpy as np
    import dolfinx_sfvem as sf
    from dolfinx_sfvem import exact

    text = (ROOT / "docs" / "guide" / "materials.md").read_text()
    block = next(b for b in re.findall(r"```python\n(.*?)```", text, re.S) if "UserEnergy" in b)
    namespace = {"sf": sf}
    exec(block, namespace)
    cylinder = sf.meshes.thick_cylinder(a=1.0, b=2.0, h=0.2)
    problem = sf.ContactProblem(cylinder.mesh, {"solid": namespace["solid"]}, verbose=False)
    problem.fix(lambda x: np.isclose(x[0], 0.0), components="x", name="symmetry_x")
    problem.fix(lambda x: np.isclose(x[1], 0.0), components="y", name="symmetry_y")
    p = 1e-4
    problem.pressure(lambda x: np.hypot(*x) < 1.001, p=p, name="inside")
    result = problem.solve(steps=1)
    c1, c2, K = 0.1, 0.05, 2.0
    mu = 2 * (c1 + c2)
    expected = exact.pressurized_cylinder(1.0, 2.0, K=K, mu=mu, p=p).cavity_area_change / 4
    assert result.converged
    assert abs(result.steps[-1]["loads"]["inside"]["displacement"] / expected - 1) < 2e-3      # the mesh's own error: 2.6e-4


def test_three_d_example_of_the_guide_solves():
    """The 3D block of docs/guide/three-d.md, as written there: its end face's mean displacement
    is that of the exact uniaxial stress state P_11 = 0.1 of the neo-Hookean solid (Eq. 2 in 3D,
    solved here with numpy; Q2 holds the homogeneous state exactly)."""
    import numpy as np
    import scipy.optimize

    text = (ROOT / "docs" / "guide" / "three-d.md").read_text()
    block = next(b for b in re.findall(r"```python\n(.*?)```", text, re.S) if "create_box" in b)
    namespace = {}
    exec(block, namespace)
    K, mu = 5 / 3, 5 / 14

    def P(F):
        J = np.linalg.det(F)
        inv_T = np.linalg.inv(F).T
        return K * np.log(J) * inv_T + mu * J ** (-2 / 3) * (F - np.trace(F.T @ F) / 3 * inv_T)

    stretch, _ = scipy.optimize.fsolve(lambda v: [P(np.diag([v[0], v[1], v[1]]))[0, 0] - 0.1,
                                                  P(np.diag([v[0], v[1], v[1]]))[1, 1]], [1.0, 1.0], xtol=1e-14)
    assert namespace["result"].converged
    assert namespace["stretch"] == pytest.approx(stretch - 1, rel=1e-9)


def test_every_demo_with_a_figure_shows_it_in_the_gallery(tmp_path):
    """A demo's pictures are found whether named <demo>.png or <demo>-*.png (the snap-through page
    once showed "(no pictures yet)" beside docs/figures/snap-through.png)."""
    for file in ("new-demo.png", "new-demo-curves.png", "new-demo-extra.txt", "new-demos-x.png"):
        (tmp_path / file).write_bytes(b"")
    assert [file for file, _ in sitegen.figures_of("new_demo", tmp_path)] == ["new-demo.png", "new-demo-curves.png"]
    demos, _ = sitegen.demo_names()
    for name in demos:
        stem = name.replace("_", "-")
        if list(sitegen.FIGURES.glob(stem + ".png")) or list(sitegen.FIGURES.glob(stem + "-*.png")):
            assert sitegen.figures_of(name), f"demos/{name}.py has pictures in docs/figures but none on its page"
    assert "snap_through" in {name for name in demos if sitegen.figures_of(name)}
