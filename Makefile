# Two commands do all the set-up on a fresh Debian 12 machine:
#   make demo   install what is missing, then run the main demo
#   make test   install what is missing, then run the tests (serial, then MPI on 2 ranks)
SHELL := /bin/bash
DEBS := python3-dolfinx python3-petsc4py python3-mpi4py python3-gmsh python3-numba \
        python3-scipy python3-matplotlib python3-pytest python3-venv openmpi-bin
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
NP ?= 2
MPIRUN := mpirun -n $(NP) $(if $(filter 0,$(shell id -u)),--allow-run-as-root) --oversubscribe
OUT ?= out
export OMP_NUM_THREADS := 1

.PHONY: install demo test test-serial test-mpi bench results meshes clean

install: $(STAMP)

$(STAMP): pyproject.toml
	@missing=$$(for p in $(DEBS); do dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  echo "Installing Debian packages:" $$missing; \
	  SUDO=$$([ "$$(id -u)" = 0 ] || echo sudo); \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq $$missing; \
	fi
	[ -x $(PY) ] || /usr/bin/python3 -m venv --system-site-packages $(VENV)
	$(PY) -m pip install -q --no-deps --no-build-isolation -e .
	touch $(STAMP)

demo: $(STAMP)
	$(MPIRUN) $(PY) demos/cbox.py --method vem --uy -0.5 --steps 25 --out $(OUT)/cbox

test: test-serial test-mpi

test-serial: $(STAMP)
	$(PY) -m pytest -q -x tests

test-mpi: $(STAMP)
	$(MPIRUN) $(PY) -m pytest -q -m mpi -p no:cacheprovider tests

# SFVEM vs P2 FEM up to 1.2e5 unknowns (about 25 min); the summary is kept in bench/results.{json,md}
bench: $(STAMP)
	$(PY) bench/run.py --out $(OUT)/bench
	cp $(OUT)/bench/results.json $(OUT)/bench/results.md bench/

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
