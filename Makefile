# The two commands a fresh clone needs: `make demo` and `make test`. Both build .venv when it is missing.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-stamp

.PHONY: demo test lint sweep bench clean

$(STAMP): pyproject.toml constraints.txt
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -c constraints.txt -e '.[dev,realsense]'
	@touch $(STAMP)

demo: $(STAMP)
	$(BIN)/d2sr demo --out out/demo

test: $(STAMP)
	$(BIN)/ruff check src tests bench
	$(BIN)/python -m pytest

lint: $(STAMP)
	$(BIN)/ruff check src tests bench
	$(BIN)/ruff format --check src tests bench

# Long jobs: their results are committed under docs/results/.
sweep: $(STAMP)
	$(BIN)/d2sr desync sweep --out docs/results/desync

bench: $(STAMP)
	$(BIN)/python bench/timing_world.py --json docs/results/bench_timing.json

clean:
	rm -rf $(VENV) out .pytest_cache .ruff_cache
