# Paper 002 (Nie 2016): polar format with varied gate, sub-aperture de-aliasing, two-step PFA (`pfa2`).
CONFIG002 ?= configs/nie2016.yaml
GOTCHA_DIR ?= ../shared/data/gotcha

.PHONY: reproduce-002 reproduce-002-small reproduce-gotcha

# Full Table 1 scene (heavy: about 11k pulses x 17k samples; serialised with other heavy runs).
reproduce-002: $(STAMP)
	mkdir -p results/002
	flock /tmp/heavy.lock nice $(PY) scripts/reproduce_002.py --config $(CONFIG002) --out results/002

# The reduced scene of the tests (seconds).
reproduce-002-small: $(STAMP)
	mkdir -p results/002-small
	$(PY) scripts/reproduce_002.py --config configs/nie2016_small.yaml --out results/002-small --corrected-plain

reproduce-gotcha: $(STAMP)
	mkdir -p results/gotcha
	$(SARPROC) import-gotcha $(GOTCHA_DIR) -o results/gotcha/raw.h5 --overwrite
	$(SARPROC) pfa2 results/gotcha/raw.h5 --config configs/gotcha.yaml -o results/gotcha/image_pfa.h5 --overwrite
	$(SARPROC) pfa2 results/gotcha/raw.h5 --config configs/gotcha_two_step.yaml -o results/gotcha/image_pfa_two_step.h5 --overwrite
	$(SARPROC) backproject results/gotcha/raw.h5 --config configs/gotcha.yaml -o results/gotcha/image_bp.h5 --overwrite
	$(PY) scripts/reproduce_gotcha.py --dir results/gotcha
	$(SARPROC) quicklook results/gotcha/image_bp.h5 -o results/gotcha/quicklook_bp.png --overwrite --dynamic-range 45
	$(SARPROC) quicklook results/gotcha/image_pfa.h5 -o results/gotcha/quicklook_pfa.png --overwrite --dynamic-range 45

# accuracy-002 is a sweep: mk/sweeps.mk.
