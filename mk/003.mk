# Paper 003 (Xu et al.): azimuth multichannel squint SAR, moving targets. Outputs under results/003*/.
# Every processing step runs through the command line: the scene A, B, C chain (simulate, reconstruct,
# backproject, evaluate --expect configs/xu_scene_expect.yaml: A, B, C at theory where they appear, B's
# and C's velocity and relocation errors), its azimuth strips (configs/xu_strip.yaml) and five sweeps
# (configs/sweeps/reproduce_003_*.yaml, hard_cases_003.yaml); the scripts only tabulate and plot them.
.PHONY: reproduce-003

R003 := results/003
SWEEP003 := --scheduler serial

reproduce-003: $(STAMP)
	mkdir -p $(R003)
	$(SARPROC) simulate configs/xu_scene.yaml -o $(R003)/raw_mc.h5 --overwrite --no-progress
	$(SARPROC) reconstruct $(R003)/raw_mc.h5 -o $(R003)/raw_conventional.h5 --config configs/xu_conventional.yaml --overwrite --no-progress
	$(SARPROC) reconstruct $(R003)/raw_mc.h5 -o $(R003)/raw_modified.h5 --config configs/xu_scene.yaml --overwrite --no-progress
	for m in conventional modified; do \
	  $(SARPROC) backproject $(R003)/raw_$$m.h5 -o $(R003)/image_$$m.h5 --config configs/xu_scene.yaml --overwrite --no-progress || exit 1; \
	  for t in A B C; do \
	    $(SARPROC) backproject $(R003)/raw_$$m.h5 -o $(R003)/strip_$${m}_$$t.h5 --config configs/xu_strip.yaml --targets $$t --overwrite --no-progress && \
	    $(SARPROC) evaluate $(R003)/strip_$${m}_$$t.h5 -o $(R003)/strip_$${m}_$$t.json --config configs/xu_strip.yaml --targets $$t --overwrite > /dev/null || exit 1; \
	  done; \
	done
	$(SARPROC) evaluate $(R003)/image_modified.h5 -o $(R003)/report_modified.json --config configs/xu_scene.yaml --expect configs/xu_scene_expect.yaml --overwrite > $(R003)/report_modified.md
	$(SARPROC) evaluate $(R003)/image_conventional.h5 -o $(R003)/report_conventional.json --config configs/xu_scene.yaml --overwrite > $(R003)/report_conventional.md
	$(SARPROC) sweep configs/sweeps/reproduce_003_cases.yaml -o $(R003)/sweep-cases $(SWEEP003)
	$(SARPROC) sweep configs/sweeps/reproduce_003_given.yaml -o $(R003)/sweep-given $(SWEEP003)
	$(SARPROC) sweep configs/sweeps/reproduce_003_speeds.yaml -o $(R003)/sweep-speeds $(SWEEP003)
	$(SARPROC) sweep configs/sweeps/reproduce_003_clutter.yaml -o $(R003)/sweep-clutter $(SWEEP003)
	$(SARPROC) sweep configs/sweeps/hard_cases_003.yaml -o $(R003)/sweep-hard $(SWEEP003)
	$(PY) scripts/reproduce_003.py --results $(R003)
	$(PY) scripts/hard_cases_003.py --results $(R003)
	$(DROP003)

# Each sweep task's reconstructed raw product (~77 MB x 72 tasks) and each sweep's simulated raw products
# (~70 MB x 32), read only by the scripts above, are deleted once tabulated (results/003 was 5.7 GB with
# them); KEEP_INTERMEDIATES=1 keeps them (a rerun then resumes without simulating and reconstructing again).
KEEP_INTERMEDIATES ?=
DROP003 = $(if $(KEEP_INTERMEDIATES),,rm -f $(R003)/sweep-*/tasks/*/reconstruct.h5 $(R003)/sweep-*/tasks/*/reconstruct.h5.done.json $(R003)/sweep-*/raw/*.h5 $(R003)/sweep-*/raw/*.h5.done.json)

# accuracy-003 is a sweep: mk/sweeps.mk.

# Issue 19: traffic through clutter (configs/xu_traffic.yaml), every step through the command line; the
# two-mover case (configs/xu_two_movers.yaml) and the static targets well above the clutter
# (configs/xu_traffic_static.yaml: a chip around each, modified against conventional reconstruction) beside
# it. traffic_003.py only tabulates and plots the products: results/003-traffic/detections.md, traffic.png.
.PHONY: reproduce-003-traffic
reproduce-003-traffic: $(STAMP)
	mkdir -p results/003-traffic/two_movers
	$(SARPROC) simulate configs/xu_traffic.yaml -o results/003-traffic/raw_mc.h5 --overwrite --no-progress
	$(SARPROC) reconstruct results/003-traffic/raw_mc.h5 -o results/003-traffic/raw.h5 --config configs/xu_traffic.yaml --overwrite --no-progress
	$(SARPROC) reconstruct results/003-traffic/raw_mc.h5 -o results/003-traffic/raw_conventional.h5 --config configs/xu_conventional.yaml --overwrite --no-progress
	$(SARPROC) backproject results/003-traffic/raw.h5 -o results/003-traffic/image.h5 --config configs/xu_traffic.yaml --overwrite --no-progress
	$(SARPROC) backproject results/003-traffic/raw_conventional.h5 -o results/003-traffic/image_conventional.h5 --config configs/xu_traffic.yaml --overwrite --no-progress
	$(SARPROC) evaluate results/003-traffic/image.h5 -o results/003-traffic/report.json --config configs/xu_traffic.yaml --overwrite --no-progress > results/003-traffic/report.md
	$(SARPROC) evaluate results/003-traffic/image_conventional.h5 -o results/003-traffic/report_conventional.json --config configs/xu_traffic.yaml --overwrite --no-progress > results/003-traffic/report_conventional.md
	$(SARPROC) simulate configs/xu_two_movers.yaml -o results/003-traffic/two_movers/raw_mc.h5 --overwrite --no-progress
	$(SARPROC) reconstruct results/003-traffic/two_movers/raw_mc.h5 -o results/003-traffic/two_movers/raw.h5 --config configs/xu_two_movers.yaml --overwrite --no-progress
	mkdir -p results/003-traffic/static
	$(SARPROC) simulate configs/xu_traffic_static.yaml -o results/003-traffic/static/raw_mc.h5 --overwrite --no-progress
	$(SARPROC) reconstruct results/003-traffic/static/raw_mc.h5 -o results/003-traffic/static/raw_modified.h5 --config configs/xu_traffic_static.yaml --overwrite --no-progress
	$(SARPROC) reconstruct results/003-traffic/static/raw_mc.h5 -o results/003-traffic/static/raw_conventional.h5 --config configs/xu_conventional.yaml --overwrite --no-progress
	for m in modified conventional; do for s in S1 S2 S3 S4; do \
	  $(SARPROC) backproject results/003-traffic/static/raw_$$m.h5 -o results/003-traffic/static/chip_$${m}_$$s.h5 --config configs/xu_traffic_static.yaml --targets $$s --overwrite --no-progress && \
	  $(SARPROC) evaluate results/003-traffic/static/chip_$${m}_$$s.h5 -o results/003-traffic/static/chip_$${m}_$$s.json --config configs/xu_traffic_static.yaml --targets $$s --overwrite --no-progress > /dev/null || exit 1; \
	done; done
	$(PY) scripts/traffic_003.py --results results/003-traffic

# Issue 19: where mover detection breaks, against SNR and spacing (range cells, Doppler): CLI runs on a
# reduced scene, tabulated by the script (results/003-movers/limits.md).
.PHONY: movers-003-limits
movers-003-limits: $(STAMP)
	$(PY) scripts/movers_limits_003.py --results results/003-movers

# Issue 19: are the moving_targets table's 1-sigma velocity uncertainties true? A small Monte-Carlo of clutter
# seeds and mover velocities on reduced scenes (about 7 min; results/003-movers/sigma_calibration.md).
.PHONY: movers-003-sigma
movers-003-sigma: $(STAMP)
	flock /tmp/heavy.lock nice $(PY) scripts/movers_sigma_003.py --results results/003-movers

# Issue 19: moving targets on scenes nobody tuned: N random reduced scenes (movers, static points, beam, squint,
# clutter, noise drawn from SEED), simulate and reconstruct through the CLI, tabulated against the truth
# (results/mover-campaign/campaign.md; about 1 min of one core per scene).
.PHONY: mover-campaign
CAMPAIGN_N ?= 30
CAMPAIGN_SEED ?= 1
mover-campaign: $(STAMP)
	nice $(PY) scripts/mover_campaign.py --n $(CAMPAIGN_N) --seed $(CAMPAIGN_SEED) --results results/mover-campaign
