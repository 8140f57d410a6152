# inertest: `make demo` sets up the core and runs the main job; `make test` installs every
# extra and the test tools, then runs the tests. Either may run first.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
CORE := $(VENV)/.installed-core
FULL := $(VENV)/.installed-test

.PHONY: demo test lint bench clean

$(BIN)/python:
	@echo "[setup 1/2] creating $(VENV) with $(PYTHON) ..."
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --upgrade pip

# What the demo and `inertest fit` use: numpy, scipy, pyarrow, numba, matplotlib, SQLAlchemy.
$(CORE): pyproject.toml | $(BIN)/python
	@echo "[setup 2/2] installing inertest (core: about 770 MB; pip lists each package as it goes) ..."
	$(BIN)/python -m pip install -e .
	touch $(CORE)
	@echo "$(VENV) ready"

# Every extra (ROS, PX4, TDMS, HDF5, PostgreSQL, scikit-learn, sympy, pandas) and the test tools.
$(FULL): pyproject.toml | $(BIN)/python
	@echo "[setup] installing inertest with every extra and the test tools ..."
	$(BIN)/python -m pip install -e '.[test]'
	touch $(FULL) $(CORE)
	@echo "$(VENV) ready for the tests"

demo: $(CORE)
	@echo "running the example campaign (one line per test as it starts) ..."
	$(BIN)/inertest demo

lint: $(FULL)
	$(BIN)/ruff check src tests benchmarks examples
	$(BIN)/lint-imports
	$(BIN)/mypy

# Test processes (pytest-xdist): two, one a core of the CI machine; `make test TEST_WORKERS=8`
# on a bigger one. tests/conftest.py keeps the tests that share a resource on one worker.
TEST_WORKERS ?= 2

test: lint
	# One BLAS thread: the tests' matrices are small, and threads fight over the cores.
	OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 \
	PYTHONWARNINGS=error MPLBACKEND=Agg $(BIN)/python -m pytest -q \
	  -n $(TEST_WORKERS)

bench: $(FULL)
	$(BIN)/python benchmarks/run.py

clean:
	rm -rf $(VENV) inertest-report .pytest_cache build src/*.egg-info
