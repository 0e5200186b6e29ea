"""The C compiler of the package's compiles (dolfinx_sfvem/discretizations/c_compiler.py): clang
while the package compiles FFCx 0.5's code, the user's CC kept, the environment restored."""
import os

import pytest

from dolfinx_sfvem.discretizations import c_compiler
from dolfinx_sfvem.discretizations.compile_lock import compiling


@pytest.fixture
def with_clang(monkeypatch):
    """A clang on PATH (a stand-in path; nothing is compiled here), FFCx 0.5's code and no CC."""
    monkeypatch.setattr(c_compiler, "clang", lambda: "/opt/bin/clang-17")
    monkeypatch.setattr(c_compiler, "STRAIGHT_LINE_KERNELS", True)
    monkeypatch.delenv("CC", raising=False)


def test_clang_while_the_package_compiles_then_the_environment_as_it_was(with_clang):
    with compiling():
        assert os.environ["CC"] == "/opt/bin/clang-17"
        with compiling():                              # nested compiles keep it
            assert os.environ["CC"] == "/opt/bin/clang-17"
        assert os.environ["CC"] == "/opt/bin/clang-17"
    assert "CC" not in os.environ


def test_the_users_cc_wins(with_clang, monkeypatch):
    monkeypatch.setenv("CC", "gcc")
    with compiling():
        assert os.environ["CC"] == "gcc"
    assert os.environ["CC"] == "gcc"


def test_an_empty_cc_is_unset_and_restored(with_clang, monkeypatch):
    monkeypatch.setenv("CC", "")
    with compiling():
        assert os.environ["CC"] == "/opt/bin/clang-17"
    assert os.environ["CC"] == ""


def test_without_clang_nothing_changes(monkeypatch):
    monkeypatch.setattr(c_compiler, "clang", lambda: None)
    monkeypatch.delenv("CC", raising=False)
    with compiling():
        assert "CC" not in os.environ


def test_loops_of_later_ffcx_stay_with_the_default(with_clang, monkeypatch):
    monkeypatch.setattr(c_compiler, "STRAIGHT_LINE_KERNELS", False)
    with compiling():
        assert "CC" not in os.environ


def test_restored_when_the_compile_fails(with_clang):
    with pytest.raises(RuntimeError), compiling():
        raise RuntimeError("a failed compile")
    assert "CC" not in os.environ


def test_clang_is_found_on_path(tmp_path, monkeypatch):
    fake = tmp_path / "clang-15"
    fake.write_text("#!/bin/sh\n")
    fake.chmod(0o755)
    monkeypatch.setenv("PATH", str(tmp_path))
    c_compiler.clang.cache_clear()
    try:
        assert c_compiler.clang() == str(fake)
    finally:
        c_compiler.clang.cache_clear()
