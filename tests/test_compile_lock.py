"""The compile lock (dolfinx_sfvem/discretizations/compile_lock.py): FFCx's JIT entry points run under an exclusive
``flock`` of their cache directory while the package compiles, on every rank, and are FFCx's own
again afterwards; a compile interrupted by Ctrl-C leaves no ``.c`` file that later runs would wait
for. (Processes started together: tests/test_concurrent_starts.py.)"""
import fcntl
import os
import time

import ffcx.codegeneration.jit
import pytest

from dolfinx_sfvem.discretizations import compile_lock


def locked_by_another(cache_dir) -> bool:
    """Whether the cache directory's lock is held (by any open file description but this one)."""
    with open(cache_dir / compile_lock.LOCK_NAME, "a") as f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return True
        fcntl.flock(f, fcntl.LOCK_UN)
        return False


def test_ffcx_compiles_hold_the_lock_of_their_cache_directory(tmp_path, monkeypatch):
    seen = []

    def compile_forms(forms, options=None, cache_dir=None, **kwargs):
        seen.append(locked_by_another(tmp_path) if cache_dir is not None else None)
        return "compiled"
    monkeypatch.setattr(ffcx.codegeneration.jit, "compile_forms", compile_forms)
    with compile_lock.compiling():
        with compile_lock.compiling():          # re-entrant
            assert ffcx.codegeneration.jit.compile_forms(["form"], cache_dir=tmp_path) == "compiled"
        assert ffcx.codegeneration.jit.compile_forms(["form"]) == "compiled"       # no cache: no lock
    assert seen == [True, None]
    assert ffcx.codegeneration.jit.compile_forms is compile_forms and not locked_by_another(tmp_path)


def test_an_interrupted_compile_leaves_no_c_file_to_wait_for(tmp_path):
    """The ``.c`` file made during the interrupted compile is set aside as ``.c.failed`` (FFCx's
    name for a failed compile); finished modules and older files stay."""
    old, done = tmp_path / "libffcx_forms_old.c", tmp_path / "libffcx_forms_done.c"
    old.write_text("")
    os.utime(old, (time.time() - 60, time.time() - 60))
    with pytest.raises(KeyboardInterrupt):
        with compile_lock.compiler_lock(tmp_path):
            done.write_text("")
            (tmp_path / "libffcx_forms_done.c.cached").write_text("")
            (tmp_path / "libffcx_forms_new.c").write_text("")
            raise KeyboardInterrupt
    assert sorted(p.name for p in tmp_path.glob("libffcx_*")) == [
        "libffcx_forms_done.c", "libffcx_forms_done.c.cached", "libffcx_forms_new.c.failed", "libffcx_forms_old.c"]
    assert not locked_by_another(tmp_path)
