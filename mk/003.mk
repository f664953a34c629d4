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
