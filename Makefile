# sarproc: the two set-up commands (README) and the reproduction / benchmark targets.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
SARPROC := $(VENV)/bin/sarproc
STAMP := $(VENV)/.installed
TEST_STAMP := $(VENV)/.installed-test

.PHONY: demo test lint venv clean bench bench-venv

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e .
	touch $@

$(TEST_STAMP): $(STAMP) pyproject.toml
	$(PY) -m pip install --quiet -e '.[test]'
	touch $@

venv: $(STAMP)

demo: $(STAMP)
	mkdir -p results/demo
	$(SARPROC) simulate configs/demo.yaml -o results/demo/raw.h5 --overwrite
	$(SARPROC) backproject results/demo/raw.h5 --config configs/demo.yaml -o results/demo/image.h5 --overwrite
	$(SARPROC) evaluate results/demo/image.h5 -o results/demo/report.json --overwrite --plot results/demo --expect configs/demo_expect.yaml

# Static checks (issue 21), a few seconds warm: lint and format with ruff, types with mypy (settings in pyproject.toml;
# mypy caches under .mypy_cache). `make test` runs them before pytest.
lint: $(TEST_STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(VENV)/bin/mypy

# --durations: the slowest tests in the log, to keep CI (2 cores) inside its budget.
test: lint
	$(PY) -m pytest -q --durations=25

# Stage timings interleaved in one run, beside FastSAR (installed only in the bench venv .venv-bench,
# never a runtime dependency); results/bench/latest.json (+ a timestamped copy). Heavy: waits for heavy.lock.
BENCH_VENV := .venv-bench
$(BENCH_VENV)/.installed:
	$(PYTHON) -m venv $(BENCH_VENV)
	$(BENCH_VENV)/bin/pip install --quiet 'fastsar==0.1.8' numpy scipy
	touch $@

bench-venv: $(BENCH_VENV)/.installed

bench: $(STAMP) $(BENCH_VENV)/.installed
	flock /tmp/heavy.lock nice $(PY) scripts/bench.py --fastsar-python $(BENCH_VENV)/bin/python

# Exact and factorised backprojection against FastSAR's formers, calls interleaved (docs/performance.md).
.PHONY: bench-ffbp
bench-ffbp: $(STAMP) $(BENCH_VENV)/.installed
	flock /tmp/heavy.lock nice $(PY) scripts/bench.py ffbp --sizes 512 1024 2048 --fastsar-python $(BENCH_VENV)/bin/python

# Every stage's plan (sarproc STAGE ... --dry-run) against its measured peak RSS and wall time, for every
# shipped config (configs/*.yaml, sweeps excluded): the table in docs/plans.md. Heavy: waits for heavy.lock.
.PHONY: plan-accuracy
plan-accuracy: $(STAMP)
	flock /tmp/heavy.lock nice $(PY) scripts/plan_accuracy.py --out results/plan-accuracy --markdown docs/plans.md

clean:
	rm -rf results build *.egg-info

# The JSON Schema of the YAML files (sarproc schema, each command's --help key list), regenerated from the
# parameter declarations; tests/cli/test_docs.py fails until it is after a parameter changes.
.PHONY: schema
schema: $(STAMP)
	$(PY) -m sarproc.cli.schema

# Paper-specific targets live in mk/*.mk, one file per paper.
-include mk/*.mk

# simulate -> backproject -> evaluate --expect for each scene: $(call bp_check,DIR,SCENES,EXPECT) with EXPECT
# a file name in which % stands for the scene (configs/bp_<scene>.yaml holds scene and processing).
define bp_check
	mkdir -p $(1)
	for s in $(2); do \
	  $(SARPROC) simulate configs/bp_$$s.yaml -o $(1)/raw_$$s.h5 --overwrite && \
	  $(SARPROC) backproject $(1)/raw_$$s.h5 --config configs/bp_$$s.yaml -o $(1)/image_$$s.h5 --overwrite && \
	  $(SARPROC) evaluate $(1)/image_$$s.h5 -o $(1)/report_$$s.json --overwrite --expect $(subst %,$${s},$(3)) \
	    || exit 1; \
	done
endef

# The backprojection reference against theory on the two test scenes (issue 2), via the CLI.
.PHONY: check-backprojection
check-backprojection: $(STAMP)
	$(call bp_check,results/bp,stripmap squint30,configs/bp_expect.yaml)

# Each target's own theory (issue 20): a stripmap beam-edge scene (fully lit, partly lit, side-lobe-lit targets;
# simulate warns about the last two) and a Hamming-windowed spotlight, each judged against its own theory.
.PHONY: check-theory
check-theory: $(STAMP)
	$(call bp_check,results/theory,beam_edge hamming,configs/bp_%_expect.yaml)

# What backproject's default range upsampling (x16; x8 before session 24) does to every measurement of the
# shipped backprojection scenes, against the float64 reference engine on x32 pulses: results/range-upsample/.
.PHONY: range-upsample
range-upsample: $(STAMP)
	$(PY) scripts/range_upsample_effect.py --out results/range-upsample

# accuracy-backprojection (the reference's own knobs: time vs quality) is a sweep: mk/sweeps.mk, as are
# accuracy-000, -002, -003 and -004.

# Signals at random moments of real `sarproc simulate` runs of a ~100 MB product (issue 18): every
# delivery ends 128+N with nothing left, or 0 with the complete output. Heavy: waits for heavy.lock.
.PHONY: signal-soak
signal-soak: $(STAMP)
	flock /tmp/heavy.lock nice $(PY) scripts/signal_soak.py --runs 90 --out results/soak

# An image bigger than --max-memory (8192^2 complex64, 512 MiB, within 384M), written block by block by
# `sarproc backproject`, once in this process and once on a local Dask cluster: wall time, peak memory
# per process and per worker, the two images compared (results/tiled/table.md). Heavy: waits for heavy.lock.
.PHONY: backproject-tiled
backproject-tiled: $(TEST_STAMP)  # the Dask run needs dask.distributed (test extra)
	flock /tmp/heavy.lock nice $(PY) scripts/tiled_backproject.py --scene configs/demo.yaml --pixels 8192 \
		--max-memory 384M --out results/tiled

# False-target figures with and without the residual (issue 20): every paper image found under results/
# (run the reproduce targets first), guard window vs residual, floors and evaluate times; BEFORE=DIR (an
# older checkout) adds that code's residual floor beside this one's.
.PHONY: residual-floors residual-ghosts residual-scenes evaluate-campaign
residual-floors: $(STAMP)
	flock /tmp/heavy.lock nice $(PY) scripts/residual_floors.py $$(ls results/demo/image.h5 results/bp/image_*.h5 \
		results/000-exp2/*image*.h5 results/002-small/*image*.h5 results/003/image_*.h5 results/004/*.h5 2>/dev/null \
		| grep -v raw) $(if $(BEFORE),--before $(BEFORE)) --out results/residual_floors.md

# Residual floors of the paper scenes' clean images simulated with each waveform (continuous: the aliasing
# pedestal; band_limited: without it), stage and evaluate times beside them.
residual-scenes: $(STAMP)
	flock /tmp/heavy.lock nice $(PY) scripts/residual_scenes.py --waveform continuous \
		--out results/residual_scenes_continuous.md
	flock /tmp/heavy.lock nice $(PY) scripts/residual_scenes.py --waveform band_limited \
		--out results/residual_scenes_band_limited.md

# Ghosts at -40/-45/-50 dB left out of the truth table, found on the residual of real processed images:
# bp_squint30 and the demo by backprojection, the small paper-002 scene by plain polar format.
residual-ghosts: $(STAMP)
	flock /tmp/heavy.lock nice $(PY) scripts/residual_ghosts.py --scene configs/bp_squint30.yaml --ghost 12,20 \
		--out results/residual_ghosts_squint30.md
	flock /tmp/heavy.lock nice $(PY) scripts/residual_ghosts.py --scene configs/demo.yaml --ghost 30,35 \
		--out results/residual_ghosts_demo.md
	flock /tmp/heavy.lock nice $(PY) scripts/residual_ghosts.py --scene configs/demo.yaml --ghost 30,35 \
		--waveform band_limited --out results/residual_ghosts_demo_band_limited.md
	flock /tmp/heavy.lock nice $(PY) scripts/residual_ghosts.py --scene configs/nie2016_small.yaml --ghost 40,40 \
		--process pfa2 --process-config configs/pfa2_plain.yaml --out results/residual_ghosts_002_plain.md

# evaluate on scenes nobody tuned (issue 20): SCENES random squinted stripmap scenes (truth near and beyond the beam
# edge, close pairs, ghosts left out of the truth at -40..-50 dB, sinc/gaussian/rect beams, Hamming or none,
# noise or none) through simulate / backproject / evaluate; tables and a summary in results/evaluate-campaign/.
SCENES ?= 30
SEED ?= 1
evaluate-campaign: $(STAMP)
	flock /tmp/heavy.lock nice $(PY) scripts/evaluate_campaign.py --scenes $(SCENES) --seed $(SEED) \
		--out results/evaluate-campaign
