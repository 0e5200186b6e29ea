# Two commands do all the set-up on a fresh Debian 12 machine:
#   make demo   install what is missing, then run the main demo
#   make test   install what is missing, then run the tests (serial, then MPI on 2 ranks) on
#               Debian's DOLFINx 0.5.2 and build the documentation site (make docs), then run the
#               tests again on DOLFINx 0.11 (the dolfinx-solver-real wheel from PyPI) in a second
#               venv, if the machine has a Python >= 3.12
#   make docs   the documentation site (Sphinx, from Debian's packages) in out/docs; fails on warnings
SHELL := /bin/bash
DEBS := python3-dolfinx python3-petsc4py python3-mpi4py python3-gmsh python3-numba \
        python3-scipy python3-matplotlib python3-pytest python3-sympy python3-venv openmpi-bin
# clang compiles the generated C of the 3D forms some 15 times faster than gcc, to code as fast
# (dolfinx_sfvem/discretizations/c_compiler.py)
DEBS += clang
# offscreen OpenGL for the 3D pictures (VTK's EGL window on Mesa, dolfinx_sfvem/output/pictures3d.py)
DEBS += libegl1 libegl-mesa0 libgl1-mesa-dri
# the 3D contact geometry (libigl) and pictures (PyVista, VTK) from PyPI, into the Debian venv; the
# same pins as the `3d` extra of pyproject.toml (the DOLFINx 0.11 venv)
PIP3D := libigl==2.6.3 pyvista==0.49.1 vtk==9.7.2
# the documentation site: Sphinx 5.3, MyST (the pages are Markdown) and the furo theme
DOCS_DEBS := python3-sphinx python3-myst-parser furo
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
# the second stack: its own venv (no system packages) on a Python >= 3.12
VENV011 := .venv-dolfinx011
PY011 := $(VENV011)/bin/python
STAMP011 := $(VENV011)/.installed
# the first Python >= 3.12 that runs: python3.1N on PATH (a pyenv shim fails unless its version
# is selected, and is then skipped), else one of pyenv's installed versions; empty if none
PYTHON312 = $(shell for p in $$(command -v python3.12 python3.13 python3.14) \
                      $$(ls -d "$$(pyenv root 2>/dev/null)"/versions/3.1[2-9]*/bin/python3 2>/dev/null); do \
                      "$$p" -c 'import sys; assert sys.version_info >= (3, 12)' 2>/dev/null && { echo "$$p"; break; }; \
                    done)
NP ?= 2
OUT ?= out
export OMP_NUM_THREADS := 1

# $(call mpi,PYTHON,ARGS): PYTHON ARGS on $(NP) ranks, started by the launcher of PYTHON's MPI with
# the flags it needs (Open MPI: --oversubscribe, as root --allow-run-as-root; MPICH: none), see
# dolfinx_sfvem/mpi_launcher.py
mpi = launcher="$$($(1) dolfinx_sfvem/mpi_launcher.py -n $(NP))" && $$launcher $(1) $(2)
# $(call apt-install,PACKAGES): apt-get install those of the Debian PACKAGES that are missing
# (sudo when not root)
apt-install = missing=$$(for p in $(1); do dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  echo "Installing Debian packages:" $$missing; \
	  SUDO=$$([ "$$(id -u)" = 0 ] || echo sudo); \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq $$missing; \
	fi
# $(call serial-tests,PYTHON) and $(call mpi-tests,PYTHON): the whole suite, the tests marked mpi
serial-tests = $(1) -m pytest -q -x tests
mpi-tests = $(call mpi,$(1),-m pytest -q -m mpi -p no:cacheprovider tests)

.PHONY: install install-dolfinx011 demo demo-dolfinx011 test test-serial test-mpi test-dolfinx011 \
        test-dolfinx011-run docs bench peer3d results meshes clean

install: $(STAMP)

$(STAMP): pyproject.toml
	@$(call apt-install,$(DEBS))
	[ -x $(PY) ] || /usr/bin/python3 -m venv --system-site-packages $(VENV)
	$(PY) -m pip install -q --no-deps --no-build-isolation -e .
	$(PY) -m pip install -q $(PIP3D)
	touch $(STAMP)

# DOLFINx 0.11: a venv with the dolfinx-solver-real wheel (third-party, alpha) and the package
install-dolfinx011: $(STAMP011)

$(STAMP011): pyproject.toml
	@[ -n "$(PYTHON312)" ] || { echo "install-dolfinx011: no Python >= 3.12 found (see PYTHON312 above)"; exit 1; }
	[ -x $(PY011) ] || $(PYTHON312) -m venv $(VENV011)
	$(PY011) -m pip install -q -e ".[wheel,test,3d]"
	touch $(STAMP011)

DEMO := demos/cbox.py --method vem --uy -0.5 --steps 25 --out $(OUT)/cbox

demo: $(STAMP)
	$(call mpi,$(PY),$(DEMO))

# the same demo on DOLFINx 0.11 (out/cbox-dolfinx011)
demo-dolfinx011: $(STAMP011)
	$(call mpi,$(PY011),$(DEMO)-dolfinx011)

test: test-serial test-mpi docs test-dolfinx011

test-serial: $(STAMP)
	$(call serial-tests,$(PY))

test-mpi: $(STAMP)
	$(call mpi-tests,$(PY))

# the whole suite again on DOLFINx 0.11; one line and nothing else without a Python >= 3.12
test-dolfinx011:
	@if [ -z "$(PYTHON312)" ]; then \
	  echo "test-dolfinx011: skipped, no Python >= 3.12 on this machine (the DOLFINx 0.11 wheel needs one)"; \
	else \
	  $(MAKE) --no-print-directory test-dolfinx011-run; \
	fi

test-dolfinx011-run: $(STAMP011)
	$(call serial-tests,$(PY011))
	$(call mpi-tests,$(PY011))

# the documentation site (docs/conf.py) in $(OUT)/docs, index.html its start page: read from scratch
# every time (-E), so that a warning is never hidden by an earlier build, and any warning fails it
# (-W, all of them reported: --keep-going). Runs no demo and no notebook: seconds.
docs: $(STAMP)
	@$(call apt-install,$(DOCS_DEBS))
	$(PY) -m sphinx -b html -E -q -W --keep-going docs $(OUT)/docs
	@echo "documentation: $(OUT)/docs/index.html"

# SFVEM vs P2 FEM up to 1.2e5 unknowns (about 25 min), kept in bench/results.{json,md}; then the
# load paths of the four paper examples, SFVEM and FEM (about 15 min), kept in bench/loadpath.{json,md};
# then the time to an answer of equal accuracy (hours at 1 rank; restartable: the same command goes
# on), kept in bench/accuracy.{json,md}; then the 3D C-box by size, 9 k to 204 k unknowns, 1 and 2
# ranks, direct and iterative solver (about 1.5 h; restartable), kept in bench/cbox3d_sizes.{json,md}
bench: $(STAMP)
	$(PY) bench/run.py --out $(OUT)/bench
	cp $(OUT)/bench/results.json $(OUT)/bench/results.md bench/
	$(PY) bench/loadpath.py --out $(OUT)/loadpath --results bench
	$(PY) bench/accuracy.py --out $(OUT)/accuracy --results bench
	$(PY) bench/cbox3d_sizes.py --out $(OUT)/cbox3d_sizes --results bench

# our 3D benchmarks beside dolfiny's own demos (bench/peer3d.py; about 1.5 h on an idle machine):
# DOLFINY_DEMOS=<a dolfiny checkout>/demo/tmc/3D (its pull request 4) runs the peer too, in the
# DOLFINx 0.11 venv with dolfiny installed beside the wheel (no dependencies of its own but IPython)
peer3d: $(STAMP)
	@if [ -n "$(DOLFINY_DEMOS)" ]; then \
	  $(MAKE) --no-print-directory $(STAMP011) && $(PY011) -m pip install -q --no-deps dolfiny==0.10.0 && \
	  $(PY011) -m pip install -q ipython && \
	  $(PY) bench/peer3d.py --dolfiny $(DOLFINY_DEMOS) --dolfiny-python $(CURDIR)/$(PY011); \
	else \
	  $(PY) bench/peer3d.py; \
	fi

# the paper's examples with SFVEM and FEM on $(NP) and 1 ranks, then docs/results.md (hours;
# restartable), then the mesh refinement study, docs/refinement.md (about 1.5 h; restartable).
# RESULTS_OPTS / REFINEMENT_OPTS go to each (--quick checks the pipelines in minutes).
results: $(STAMP)
	rc=0; $(PY) demos/results.py --np $(NP) --out $(OUT) $(RESULTS_OPTS) || rc=$$?; \
	$(PY) demos/refinement.py --np $(NP) --out $(OUT) $(REFINEMENT_OPTS) || rc=$$?; exit $$rc

# the demo meshes at their default sizes, with summary.md (meshes/README.md)
meshes: $(STAMP)
	$(PY) meshes/generate.py

clean:
	rm -rf $(OUT) .pytest_cache
