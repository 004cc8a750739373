# bouncebayes: everything starts from a fresh virtual environment in .venv
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: install demo test test-slow bench lint clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	# compile the numerical kernels once (numba caches them on disk): the first run is then
	# as fast as any later one
	$(BIN)/bouncebayes warmup
	touch $(STAMP)

install: $(STAMP)

## Run the main job on the bundled demo data
demo: $(STAMP)
	$(BIN)/bouncebayes demo --out demo-output

## Install and run the test suite (slow statistical studies excluded)
test: $(STAMP)
	$(BIN)/python -m pytest

## The slow statistical studies (simulation-based calibration etc.)
test-slow: $(STAMP)
	$(BIN)/python -m pytest -m slow

## Static checks: ruff (pyflakes, bugbear, pydocstyle) and mypy on src/
lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks
	$(BIN)/mypy

## Speed benchmarks (not part of the tests)
bench: $(STAMP)
	$(BIN)/python benchmarks/forward.py

clean:
	rm -rf $(VENV) demo-output .pytest_cache
