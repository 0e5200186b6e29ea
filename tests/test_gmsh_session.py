"""gmsh_session: opens a session only when none is open, and asks gmsh nothing before it is open."""
from __future__ import annotations

import sys
import types

import pytest

from dolfinx_sfvem.meshing import gmsh_io


class FakeGmsh(types.ModuleType):
    """gmsh 4.8's API as far as gmsh_session uses it: no isInitialized, and every call before
    initialize is an error (the real one may exit the process)."""

    def __init__(self, models: list[str] | None = None):
        super().__init__("gmsh")
        self.calls: list[str] = []
        self.open = models is not None
        self.models = models if models is not None else []
        self.current = self.models[-1] if self.models else ""
        self.entities: list[tuple[int, int]] = []
        self.terminal = 1.0
        self.model = types.SimpleNamespace(list=self._list, getCurrent=lambda: self._call("getCurrent", self.current),
                                           getEntities=lambda: self._call("getEntities", self.entities),
                                           add=self._add, remove=self._remove, setCurrent=self._set_current)
        self.option = types.SimpleNamespace(getNumber=lambda name: self._call("getNumber", self.terminal),
                                            setNumber=self._set_number)

    def _call(self, name, value=None):
        self.calls.append(name)
        if not self.open:
            raise AssertionError(f"gmsh.{name} called before gmsh.initialize")
        return value

    def initialize(self, readConfigFiles=True):
        self.calls.append("initialize")
        if not self.open:
            self.open, self.models, self.current = True, [""], ""

    def finalize(self):
        self._call("finalize")
        self.open, self.models = False, []

    def _list(self):
        return self._call("list", list(self.models))

    def _add(self, name):
        self._call("add")
        self.models.append(name)
        self.current = name

    def _remove(self):
        self._call("remove")
        self.models.remove(self.current)
        self.current = self.models[-1] if self.models else ""

    def _set_current(self, name):
        self.current = self._call("setCurrent", name)

    def _set_number(self, name, value):
        self._call("setNumber")
        self.terminal = value


@pytest.fixture
def fake_gmsh(monkeypatch):
    def install(models=None):
        fake = FakeGmsh(models)
        monkeypatch.setitem(sys.modules, "gmsh", fake)
        return fake
    return install


def test_a_fresh_session_is_opened_before_anything_is_asked_and_finalised(fake_gmsh):
    fake = fake_gmsh()
    with gmsh_io.gmsh_session() as gmsh:
        assert gmsh is fake and fake.open
        with gmsh_io.gmsh_session():                  # nested: a model in the open session
            assert fake.models == ["", "dolfinx_sfvem"]
        assert fake.models == [""] and fake.terminal == 0
    assert fake.calls[0] == "initialize" and fake.calls.count("initialize") == 1
    assert not fake.open and gmsh_io._sessions_opened == 0


def test_the_callers_session_is_left_open_with_its_model_and_terminal(fake_gmsh):
    fake = fake_gmsh(models=["", "mine"])
    with gmsh_io.gmsh_session():
        assert fake.current == "dolfinx_sfvem" and fake.terminal == 0
    assert fake.open and fake.models == ["", "mine"] and fake.current == "mine" and fake.terminal == 1


def test_a_failure_inside_still_finalises_and_resets_the_count(fake_gmsh):
    fake = fake_gmsh()
    with pytest.raises(RuntimeError, match="inside"):
        with gmsh_io.gmsh_session():
            raise RuntimeError("inside")
    assert not fake.open and gmsh_io._sessions_opened == 0
    with gmsh_io.gmsh_session():                      # the next one opens its own again
        assert fake.open
    assert fake.calls.count("initialize") == 2
