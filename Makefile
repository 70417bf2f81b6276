# The two commands a fresh clone needs: `make demo` and `make test`. Both build .venv when it is missing.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-stamp

.PHONY: demo test test-fast edge-check lint verify-results mutation sweep desync-grid bench soak calibrate labels weights trials thresholds lofo eval-models outside results overlap adapt-runs eval-generalization eval-paper clean

$(STAMP): pyproject.toml constraints.txt
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -c constraints.txt -e '.[dev,realsense,train,viewer,triggers,ros2,fleet]'
	# OrbbecSDK v2's wheel asks for numpy<2 and opencv-python; its module runs with what is installed.
	$(BIN)/python -m pip install --quiet --no-deps 'pyorbbecsdk2>=2.1'
	@touch $(STAMP)

demo: $(STAMP)
	$(BIN)/d2sr demo --out out/demo --overwrite

test: $(STAMP)
	$(BIN)/ruff check src tests bench tools lab docs/examples
	$(BIN)/python -m pytest

# Under a minute: no training, no subprocess CLI, no DDP (tests marked slow are left out).
test-fast: $(STAMP)
	$(BIN)/python -m pytest -m "not slow" -q

# pip install 'd2sr[edge]' into a fresh venv: no torch comes with it; run, detect and recover work (CI runs it).
edge-check:
	.ci/edge-check

lint: $(STAMP)
	$(BIN)/ruff check src tests bench tools lab docs/examples
	$(BIN)/ruff format --check src tests bench tools lab docs/examples
	$(BIN)/mypy

# Long jobs: their results are committed under docs/results/.
sweep: $(STAMP)
	$(BIN)/d2sr desync sweep --out docs/results/desync --overwrite

# The default controller against Algorithm 1 across deployment assumptions (about 10 min on 2 cores).
desync-grid: $(STAMP)
	$(BIN)/d2sr desync grid --out docs/results/desync/grid --overwrite

bench: $(STAMP)
	$(BIN)/python bench/timing_world.py --json docs/results/bench_timing.json --overwrite
	$(BIN)/python bench/simulate.py --json docs/results/bench_simulate.json --overwrite
	$(BIN)/python bench/models.py --json docs/results/bench_models.json --overwrite
	$(BIN)/python bench/pipeline.py --json docs/results/bench_pipeline.json --overwrite
	$(BIN)/python bench/quantize.py --json docs/results/quantize.json --overwrite
	$(BIN)/python bench/pass_profile.py --json docs/results/pass_profile.json --overwrite
	$(BIN)/python bench/rerun_overhead.py --json docs/results/bench_rerun.json --overwrite
	$(BIN)/python bench/fleet.py --json docs/results/bench_fleet.json --overwrite
	$(BIN)/python bench/stored_scene.py --json docs/results/bench_stored_scene.json --overwrite

# 100,000 closed-loop frames, resident memory sampled (about 5 min).
soak: $(STAMP)
	$(BIN)/python bench/soak.py --json docs/results/soak.json --overwrite

# These read ../shared/data (real captures that must never be copied into the repository).
DATA ?= ../shared/data
REAL ?= $(DATA)/l515
calibrate: $(STAMP)
	$(BIN)/d2sr calibrate --real $(REAL)/dev0 --real $(REAL)/dev1 --out docs/results/sim --overwrite
	$(BIN)/d2sr gallery --out docs/results/sim/gallery.png --overwrite

labels: $(STAMP)
	$(BIN)/d2sr eval labels --real $(REAL) --out docs/results/labels --sims 4 --overwrite

# Shipped weights: trained on generated data only (never on ../shared/data), then exported to ONNX.
# Each run resumes from runs/<model>/checkpoint.pt if interrupted.
SHIP := src/d2sr/models/weights
weights: $(STAMP)
	$(BIN)/d2sr train detector --config configs/detector.toml --out runs/detector
	$(BIN)/d2sr train detector --config configs/detector-temporal.toml --out runs/detector-temporal
	$(BIN)/d2sr train detector --config configs/paper-detector.toml --out runs/paper-detector
	# Starting points shipped earlier: runs/<model>-<version>/ from the commit that shipped them.
	for m in unet8-0.2.0:a496b2f unet16-0.2.0:a496b2f unet32-0.2.0:5263f3f unet16-0.4.0:ebe0a54; do \
	  d=$${m%:*}; n=$${d%-*}; mkdir -p runs/$$d; test -f runs/$$d/$$n.safetensors || \
	  git show $${m#*:}:src/d2sr/models/weights/$$n.safetensors > runs/$$d/$$n.safetensors; done
	$(BIN)/d2sr train recovery --config configs/unet8-stage1.toml --out runs/unet8-stage1
	$(BIN)/d2sr train recovery --config configs/unet8-stage2.toml --out runs/unet8-stage2
	$(BIN)/d2sr train recovery --config configs/unet8.toml --out runs/unet8
	$(BIN)/d2sr train recovery --config configs/unet8-temporal.toml --out runs/unet8-temporal
	# The shipped unet8 (since 2026-11-26): runs/unet8 trained on with depth-shell patterns (data version 6).
	$(BIN)/d2sr train recovery --config configs/unet8-shell.toml --out runs/unet8-shell
	# unet8-fast (issue 78): one pass, from the shipped unet8 and distilled from its two passes.
	$(BIN)/d2sr train recovery --config configs/unet8-fast.toml --out runs/unet8-fast
	# The shipped unet16 (since 2026-11-26): that unet8 widened to unet16 (models.widen), trained on.
	$(BIN)/d2sr train recovery --config configs/unet16-wide.toml --out runs/unet16-wide
	# The shipped unet32 (since 2026-11-26): that unet8 widened four times, trained on (lab/notes/decisions.md).
	$(BIN)/d2sr train recovery --config configs/unet32-wide.toml --out runs/unet32-wide
	mkdir -p $(SHIP)
	# Only the models whose shipped weights come from this data version are copied. The shipped detector and
	# paper-detector were trained on data version 3 by the same configs (code of b0d36d6 and ebe0a54); on
	# version 4 the detector flags 16-19% of the clean L515 frames and the Azure Kinect frames (CHANGELOG
	# 0.6.0, 0.7.0): those runs stay in runs/ to compare with, as does lab/trials/unet16.toml's.
	for m in unet8-shell/unet8 unet16-wide/unet16 unet32-wide/unet32 unet8-temporal/unet8-temporal \
	  unet8-fast/unet8-fast; do \
	  cp runs/$$m.safetensors runs/$$m.card.json runs/$$m.md $(SHIP)/; done
	$(BIN)/d2sr export --out $(SHIP) --overwrite

# Trials that did not ship (lab/trials/; each one's rule, written before it ran, and its outcome are in
# lab/notes/trials.md): the older unet16 and unet32 lines and the shipped
# models one more cycle on data versions 5 and 6, unet8-temporal also gated as auto uses it. They start
# from `make weights`'s runs.
trials: $(STAMP)
	test -f runs/unet8-temporal/unet8-temporal.safetensors -a -f runs/unet16-0.4.0/unet16.safetensors || \
	  { echo "make trials: run make weights first (it trains and extracts their starting points)"; exit 2; }
	$(BIN)/d2sr train recovery --config lab/trials/unet8-v6.toml --out runs/unet8-v6
	$(BIN)/d2sr train recovery --config lab/trials/unet8-temporal-v6.toml --out runs/unet8-temporal-v6
	$(BIN)/d2sr train recovery --config lab/trials/unet16-v5.toml --out runs/unet16-v5
	$(BIN)/d2sr train recovery --config lab/trials/unet16-v6.toml --out runs/unet16-v6
	$(BIN)/d2sr train recovery --config lab/trials/unet16-v6-stage2.toml --out runs/unet16-v6-stage2
	$(BIN)/d2sr train recovery --config lab/trials/unet8-temporal-gated.toml --out runs/unet8-temporal-gated
	$(BIN)/d2sr train recovery --config lab/trials/unet8-temporal-gated-stage2.toml --out runs/unet8-temporal-gated-stage2
	$(BIN)/d2sr train recovery --config lab/trials/unet8-missweight.toml --out runs/unet8-missweight
	$(BIN)/d2sr train recovery --config lab/trials/unet8-warp.toml --out runs/unet8-warp
	$(BIN)/d2sr train recovery --config lab/trials/unet8-stack.toml --out runs/unet8-stack
	$(BIN)/d2sr train recovery --config lab/trials/unet8-mirror.toml --out runs/unet8-mirror
	$(BIN)/d2sr train detector --config lab/trials/detector-clean-previous.toml --out runs/detector-clean-previous
	$(BIN)/d2sr train recovery --config lab/trials/unet16.toml --out runs/unet16
	$(BIN)/d2sr train recovery --config lab/trials/unet32.toml --out runs/unet32
	$(BIN)/d2sr train recovery --config lab/trials/unet32-stage2.toml --out runs/unet32-stage2
	$(BIN)/d2sr train recovery --config lab/trials/unet32-stage3.toml --out runs/unet32-stage3
	$(BIN)/d2sr train recovery --config lab/trials/unet32-stage4.toml --out runs/unet32-stage4

# The shipped recovery models' mask thresholds chosen again by today's rule (0.9.0: for the repair recover
# writes, two passes, under the 10% guard), without retraining; then `make eval-models results` refreshes the cards.
# Not unet16: at the logit the rule picks (0, was 1.25) it changed 4.7% of clean pixels on the real L515 set
# (bar 2%; at 1.25: 2.3%), so it keeps its old one (CHANGELOG 0.9.0).
thresholds: $(STAMP)
	for m in unet8 unet8-temporal; do \
	  $(BIN)/d2sr threshold $(SHIP)/$$m.safetensors --out runs/$$m-threshold --overwrite || exit 1; \
	  cp runs/$$m-threshold/$$m.safetensors runs/$$m-threshold/$$m.card.json runs/$$m-threshold/$$m.md \
	    runs/$$m-threshold/$$m*.onnx $(SHIP)/; done

# Metrics of the shipped models on frames they never trained on (generated test set, real L515 with
# simulated interference, the simulated moving robot); `make results` then writes them into the cards.
eval-models: $(STAMP)
	$(BIN)/d2sr eval detector --real $(REAL) --out docs/results/detector --overwrite
	$(BIN)/d2sr eval recovery --real $(REAL) --out docs/results/recovery --limit 60 --overwrite

# The README's results table and the models' cards, written from docs/results (`--check` says where they
# disagree; the tests run it). Repository tooling: not part of the installed package.
results: $(STAMP)
	$(BIN)/python tools/results.py

# The committed results cheap enough to re-make here (about a minute each), re-made in a temporary folder and
# compared figure by figure with the committed files (tools/verify_results.py; CI runs it).
verify-results: $(STAMP)
	$(BIN)/python tools/verify_results.py --data $(DATA)

# Mutation testing (issue 81; not in CI, 1-2 hours on 2 cores): mutmut changes atomic/, contract/repair.py
# and scene/stored.py one mutant at a time ([tool.mutmut] in pyproject.toml) and lists the mutants no test
# caught in out/mutation.txt (mutmut results: survived, and "no tests" for code only the suite's kill tests
# reach).
mutation: $(STAMP)
	$(BIN)/pip install -q "mutmut==3.8.1" -c constraints.txt
	$(BIN)/mutmut run --max-children 2 || true
	mkdir -p out
	$(BIN)/mutmut results > out/mutation.txt
	@grep -c "survived" out/mutation.txt || true

# Leave-one-family-out: a detector trained without each interference family (runs/lofo/no-<family>),
# then false alarms on every real clean frame in ../shared/data and each family on real L515 frames.
# The same for the recovery model (runs/lofo-recovery/no-<family>), beside one run of the same recipe on
# every family (runs/lofo-recovery/all) to compare with.
FAMILIES := band streak bar blob speckle region grating physical
lofo: $(STAMP)
	for f in $(FAMILIES); do \
	  $(BIN)/d2sr train detector --config configs/detector-lofo.toml --leave-out $$f --out runs/lofo/no-$$f || exit 1; done
	test -f runs/unet8-0.2.0/unet8.safetensors || \
	  (mkdir -p runs/unet8-0.2.0 && git show a496b2f:src/d2sr/models/weights/unet8.safetensors > runs/unet8-0.2.0/unet8.safetensors)
	$(BIN)/d2sr train recovery --config configs/unet8-lofo.toml --out runs/lofo-recovery/all
	for f in $(FAMILIES); do \
	  $(BIN)/d2sr train recovery --config configs/unet8-lofo.toml --leave-out $$f --out runs/lofo-recovery/no-$$f || exit 1; done

# Every outside set of bench/outside (real L515 frames, interference the generator does not make) with
# recover's default and each shipped recovery model; then the summary across sets (about 12 min on 2 cores).
SETS := a b c d e f g h i
OUTSIDE := docs/results/outside
outside: $(STAMP)
	mkdir -p $(OUTSIDE)
	for s in $(SETS); do for m in auto unet8 unet16 unet32 unet8-fast; do \
	  $(BIN)/python -m bench.outside --data $(DATA) --set $$s --model $$m --json $(OUTSIDE)/$$s-$$m.json \
	    --overwrite > /dev/null || exit 1; done; done
	$(BIN)/python -m lab.outside_summary --json docs/results/outside_sets.json \
	  --plot docs/results/outside_sets.png --overwrite

# Issue 45's calibration overlap: the simulator fitted to one L515 view at a time, a detector and unet8 (two
# stages) trained from scratch on each fit's data (configs/overlap/), each judged on the view its fit never
# saw and on the one it did (lab/calibration_overlap.py). About 5 h on 2 cores; training resumes from
# runs/overlap/.
VIEWS := dev0 dev1
overlap: $(STAMP)
	for v in $(VIEWS); do \
	  test -f docs/results/overlap/fit-$$v/calibration.json || \
	    $(BIN)/d2sr calibrate --real $(REAL)/$$v --out docs/results/overlap/fit-$$v || exit 1; \
	  $(BIN)/d2sr train detector --config configs/overlap/detector-$$v.toml --out runs/overlap/detector-$$v || exit 1; \
	  for r in unet8-stage1 unet8; do \
	    $(BIN)/d2sr train recovery --config configs/overlap/$$r-$$v.toml --out runs/overlap/$$r-$$v || exit 1; done; done
	$(BIN)/python -m lab.calibration_overlap --real $(REAL) --runs runs/overlap \
	  --json docs/results/overlap/overlap.json --overwrite

# d2sr adapt's bar on the D435 with interference hidden in its later frames, three runs (each must meet it;
# adapt is deterministic at one thread count, so they should agree): about 10 min each on 2 cores.
adapt-runs: $(STAMP)
	mkdir -p docs/results/adapt
	for r in 1 2 3; do $(BIN)/python -m bench.outside --data $(DATA) --adapt \
	  --json docs/results/adapt/run-$$r.json --overwrite > /dev/null || exit 1; done

eval-generalization: $(STAMP)
	$(BIN)/d2sr eval generalization --data $(DATA) --lofo runs/lofo --lofo-recovery runs/lofo-recovery \
	  --out docs/results/generalization --overwrite

# The paper's evaluation side by side with its numbers, one report (docs/results/paper/report.md).
eval-paper: $(STAMP)
	$(BIN)/d2sr eval paper --real $(REAL) --out docs/results/paper --overwrite

clean:
	rm -rf $(VENV) out .pytest_cache .ruff_cache
