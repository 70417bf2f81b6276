# The two commands a fresh clone needs: `make demo` and `make test`. Both build .venv when it is missing.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-stamp

.PHONY: demo test lint sweep bench calibrate labels clean

$(STAMP): pyproject.toml constraints.txt
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -c constraints.txt -e '.[dev,realsense,train]'
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
	$(BIN)/python bench/simulate.py --json docs/results/bench_simulate.json

# These read ../shared/data (real captures that must never be copied into the repository).
REAL ?= ../shared/data/l515
calibrate: $(STAMP)
	$(BIN)/d2sr calibrate --real $(REAL)/dev0 --real $(REAL)/dev1 --out docs/results/sim
	$(BIN)/d2sr gallery --out docs/results/sim/gallery.png

labels: $(STAMP)
	$(BIN)/d2sr eval labels --real $(REAL) --out docs/results/labels --sims 4

clean:
	rm -rf $(VENV) out .pytest_cache .ruff_cache
