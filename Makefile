# bouncebayes: everything starts from a fresh virtual environment in .venv
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: install demo test test-slow test-newest bench lint clean

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

## Install, run the static checks (ruff, mypy) and the test suite (slow studies excluded)
test: lint
	$(BIN)/python -m pytest

## The slow statistical studies (simulation-based calibration etc.)
test-slow: $(STAMP)
	$(BIN)/python -m pytest -m slow

## The inference tests against the newest ArviZ line (arviz-base/arviz-stats 1.x, which need
## Python >= 3.12); `make test` covers the lowest supported (0.8, the line on Python 3.11).
## PYTHON_NEWEST: a Python 3.12 interpreter (default: python3.12 on the PATH, else pyenv's)
PYTHON_NEWEST ?= $(shell for p in python3.12 $$HOME/.pyenv/versions/3.12*/bin/python3.12; do \
	$$p -c 1 >/dev/null 2>&1 && { echo $$p; break; }; done)
NEWEST := .venv-newest
test-newest:
	@if [ -n "$(PYTHON_NEWEST)" ] && $(PYTHON_NEWEST) -c 1 >/dev/null 2>&1; then \
		$(PYTHON_NEWEST) -m venv $(NEWEST) && \
		$(NEWEST)/bin/python -m pip install --quiet --upgrade pip && \
		$(NEWEST)/bin/python -m pip install --quiet --upgrade -e '.[test]' \
			'arviz-base>=1' 'arviz-stats[xarray]>=1' && \
		$(NEWEST)/bin/pip list 2>/dev/null | grep -i -E '^(arviz-base|arviz-stats|xarray|numpy) ' && \
		$(NEWEST)/bin/python -m pytest tests/test_inference.py tests/test_priors.py \
			tests/test_inference_adequacy.py tests/test_report.py \
			tests/test_inference_population.py; \
	else \
		echo "test-newest: no runnable Python 3.12 found. ArviZ 1.x (arviz-base and arviz-stats >= 1)"; \
		echo "needs Python >= 3.12, so the newest supported ArviZ cannot be tested with this"; \
		echo "machine's Python; 'make test' covers the lowest supported line (0.8). Install"; \
		echo "Python 3.12 or set PYTHON_NEWEST=/path/to/python3.12."; \
	fi

## Static checks: ruff (pyflakes, bugbear, pydocstyle) and mypy on src/
lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks
	$(BIN)/mypy

## Speed benchmarks (not part of the tests; the statistical and accuracy studies in
## benchmarks/ -- sbc, population_sbc, discrepancy, tracking_accuracy, tracking_campaign -- run alone)
bench: $(STAMP)
	@for b in benchmarks/[a-z]*.py; do \
		case $$b in benchmarks/speed_table.py|benchmarks/sbc.py|benchmarks/population_sbc.py|\
			benchmarks/discrepancy.py|benchmarks/tracking_accuracy.py|\
			benchmarks/tracking_campaign.py|benchmarks/tracking_codecs.py) continue;; esac; \
		echo "== $$b"; OPENBLAS_NUM_THREADS=1 $(BIN)/python $$b || exit 1; \
	done
	OPENBLAS_NUM_THREADS=1 $(BIN)/python benchmarks/forward.py --compliant
	$(BIN)/python benchmarks/speed_table.py

clean:
	rm -rf $(VENV) $(NEWEST) demo-output .pytest_cache
