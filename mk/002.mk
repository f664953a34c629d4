# Paper 002 (Nie 2016): polar format with varied gate, sub-aperture de-aliasing, two-step PFA (`pfa2`).
CONFIG002 ?= configs/nie2016.yaml
GOTCHA_DIR ?= ../shared/data/gotcha

.PHONY: reproduce-002 reproduce-002-small reproduce-gotcha

# Every step through the CLI, each under scripts/timed.py (times/STEP.txt: wall seconds, peak RSS in kB):
# simulate -> pfa2 plain (the config with pfa2.method plain; with CORRECTED=1 also plain with
# correct_distortion) -> pfa2 two-step (the config) -> evaluate each image (report_*.json). The script
# only reads those products and reports and tabulates and plots them (summary.md, fig_M.png,
# quality_vs_distance.png). $(call run002,CONFIG,DIR,CORRECTED)
PLAIN002 = sed -E 's/^( *)method: two_step *$$/\1method: plain/; s/\{ *method: two_step/{method: plain/'
CORR002 = sed -E 's/^( *)method: two_step *$$/\1method: plain\n\1correct_distortion: true/; s/\{ *method: two_step/{method: plain, correct_distortion: true/'
TIME002 = $(PY) scripts/timed.py $(2)/times/$(1).txt --
define run002
	rm -rf $(2)/times && mkdir -p $(2)/times
	$(call TIME002,simulate,$(2)) $(SARPROC) simulate $(1) -o $(2)/raw.h5 --overwrite --no-progress
	$(PLAIN002) $(1) > $(2)/config_plain.yaml
	$(call TIME002,pfa2_plain,$(2)) $(SARPROC) pfa2 $(2)/raw.h5 --config $(2)/config_plain.yaml -o $(2)/image_pfa.h5 --overwrite --no-progress
	$(if $(3),$(CORR002) $(1) > $(2)/config_plain_corrected.yaml)
	$(if $(3),$(call TIME002,pfa2_plain_corrected,$(2)) $(SARPROC) pfa2 $(2)/raw.h5 --config $(2)/config_plain_corrected.yaml -o $(2)/image_pfa_corrected.h5 --overwrite --no-progress)
	$(call TIME002,pfa2_two_step,$(2)) $(SARPROC) pfa2 $(2)/raw.h5 --config $(1) -o $(2)/image_pfa2.h5 --overwrite --no-progress
	set -e; for m in pfa pfa2 $(if $(3),pfa_corrected); do \
	  $(call TIME002,evaluate_$$m,$(2)) $(SARPROC) evaluate $(2)/image_$$m.h5 -o $(2)/report_$$m.json --overwrite > $(2)/report_$$m.md; \
	done
	$(PY) scripts/reproduce_002.py --config $(1) --out $(2) $(if $(3),--corrected-plain)
endef

# Full Table 1 scene (heavy: about 11k pulses x 17k samples; serialised with other heavy runs).
reproduce-002: $(STAMP)
	flock /tmp/heavy.lock nice $(MAKE) --no-print-directory run-002 CONFIG=$(CONFIG002) OUT=results/002

# The reduced scene of the tests (seconds).
reproduce-002-small: $(STAMP)
	$(MAKE) --no-print-directory run-002 CONFIG=configs/nie2016_small.yaml OUT=results/002-small CORRECTED=1

.PHONY: run-002
run-002:
	$(call run002,$(CONFIG),$(OUT),$(CORRECTED))

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
