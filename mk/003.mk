# Paper 003 (Xu et al.): azimuth multichannel squint SAR, moving targets. Outputs under results/003*/.
.PHONY: reproduce-003

reproduce-003: $(STAMP)
	mkdir -p results/003
	$(SARPROC) simulate configs/xu_scene.yaml -o results/003/raw_mc.h5 --overwrite --no-progress
	$(SARPROC) reconstruct results/003/raw_mc.h5 -o results/003/raw_conventional.h5 --config configs/xu_conventional.yaml --overwrite --no-progress
	$(SARPROC) reconstruct results/003/raw_mc.h5 -o results/003/raw_modified.h5 --config configs/xu_scene.yaml --overwrite --no-progress
	$(PY) scripts/reproduce_003.py --results results/003 --config configs/xu_scene.yaml
	$(PY) scripts/hard_cases_003.py --results results/003 --config configs/xu_small.yaml
	$(SARPROC) evaluate results/003/image_modified.h5 -o results/003/report_modified.json --config configs/xu_scene.yaml --overwrite > results/003/report_modified.md
	$(SARPROC) evaluate results/003/image_conventional.h5 -o results/003/report_conventional.json --config configs/xu_scene.yaml --overwrite > results/003/report_conventional.md

# accuracy-003 is a sweep: mk/sweeps.mk.

# Issue 19: traffic through clutter (configs/xu_traffic.yaml), every step through the command line; the
# two-mover case (configs/xu_two_movers.yaml) beside it. traffic_003.py only tabulates and plots the
# products: results/003-traffic/detections.md and traffic.png.
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
	$(PY) scripts/traffic_003.py --results results/003-traffic

# Issue 19: where mover detection breaks, against SNR and spacing (range cells, Doppler): CLI runs on a
# reduced scene, tabulated by the script (results/003-movers/limits.md).
.PHONY: movers-003-limits
movers-003-limits: $(STAMP)
	$(PY) scripts/movers_limits_003.py --results results/003-movers
