# The two set-up commands of the README:
#   make run    -> create .venv (Python >= 3.12), install, run the default pipeline
#   make test   -> create .venv, install with test extras (+ system packages for the
#                  SLURM and browser tests when run as root), run the whole test suite
# Both install the exact versions of requirements.lock (regenerate: `make lock`), then the
# package itself without resolving anything else, so that a rerun months later on a new
# machine gets the same libraries (and so the same result bytes).
SHELL := /bin/bash
VENV  ?= .venv
PY     = $(VENV)/bin/python
CORES ?= all
# test processes of `make test` (pytest-xdist; a test file stays in one process, so that
# its module fixtures, e.g. the SLURM cluster, start once; the files with the most slow
# tests are handed out first, tests/conftest.py)
TEST_WORKERS ?= 2

.PHONY: run test test-fast venv lint lock bench clean

$(VENV)/.installed: pyproject.toml requirements.lock scripts/find-python.sh
	@PY312=$$(bash scripts/find-python.sh) && echo "using $$PY312" && \
	  ( [ -x $(PY) ] || $$PY312 -m venv $(VENV) ) && \
	  $(PY) -m pip install -q --upgrade pip && \
	  $(PY) -m pip install -q -r requirements.lock && \
	  $(PY) -m pip install -q --no-deps -e '.[test]' && touch $@

# requirements.lock from a clean venv (pip freeze); commit it with the pyproject change.
lock:
	bash scripts/lock.sh

venv: $(VENV)/.installed

run: venv
	$(VENV)/bin/flidar-uq run --cores $(CORES)

test: venv
	bash scripts/system-deps.sh
	$(VENV)/bin/lint-imports --no-cache
	$(VENV)/bin/python -m pytest -m "slow or not slow" -p no:cacheprovider \
	  -n $(TEST_WORKERS) --dist loadfile --no-loadscope-reorder --durations=25

test-fast: venv
	$(VENV)/bin/python -m pytest

lint: venv
	$(VENV)/bin/ruff check src tests benchmarks workflow/scripts
	$(VENV)/bin/snakemake --lint

clean:
	rm -rf results/* .snakemake
