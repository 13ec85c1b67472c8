# Two entry points (see README):
#   make paper   create .venv from environment.lock, install wsmap, run `dvc repro`
#   make test    create .venv from environment.lock, install wsmap, run the tests on two workers
#                (CI runs this; tests/conftest.py says how the work is split)
#   make docs    the documentation site (mkdocs build --strict) into site/ (CI runs this after the tests)
#   make lab     JupyterLab on notebooks/
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: env paper test smoke bench docs lab lock clean-env

# the compiled lane kernel is built by the editable install: a change to its sources reinstalls
$(STAMP): environment.lock pyproject.toml CMakeLists.txt $(wildcard src/wsmap/kinematics/_lanes/*)
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet -r environment.lock
	$(BIN)/python -m pip install --quiet --no-deps --no-build-isolation -e .
	$(BIN)/python -m ipykernel install --sys-prefix --name python3 >/dev/null
	touch $(STAMP)

env: $(STAMP)

paper: $(STAMP)
	PATH="$(CURDIR)/$(BIN):$$PATH" dvc repro

test: $(STAMP)
	$(BIN)/python -m pytest -q -n 2 --dist loadgroup --durations=20

# only the papermill smoke runs of the notebooks (tests marked `smoke`; `-m "not smoke"` for the rest)
smoke: $(STAMP)
	$(BIN)/python -m pytest -q -m smoke

# The documentation site (mkdocs.yml; the API reference from the docstrings) into site/; warnings are errors
docs: $(STAMP)
	$(BIN)/mkdocs build --strict
	@echo "site/index.html"

# JupyterLab on the notebooks: opened by hand, a notebook writes into scratch/<notebook>/ (git-ignored),
# not over the committed figures/, tables/, results/ and models/ (wsmap.paths.notebook_outputs)
lab: $(STAMP)
	$(BIN)/jupyter lab --notebook-dir=notebooks

# Speed measurements (minutes; never part of the tests). JSON results land in bench/.
bench: $(STAMP)
	mkdir -p bench
	OMP_NUM_THREADS=1 $(BIN)/python benchmarks/maps/bench_classical.py --json bench/classical.json
	OMP_NUM_THREADS=1 $(BIN)/python benchmarks/paper/bench_datasets.py --load | tee bench/datasets.txt
	$(BIN)/python benchmarks/learn/bench_models.py --threads 2 --json bench/models.json

# Regenerate environment.lock from requirements.in (needs pip-tools in the venv).
lock:
	$(BIN)/python -m pip install --quiet pip-tools
	$(BIN)/pip-compile --quiet --strip-extras --allow-unsafe --no-emit-find-links --no-emit-index-url -o environment.lock requirements.in

clean-env:
	rm -rf $(VENV)
