# Paper 004 (Du 2010): linear-array down-looking 3D SAR. Outputs under results/004*/.
.PHONY: reproduce-004

reproduce-004: $(STAMP)
	mkdir -p results/004
	$(SARPROC) simulate configs/du2010.yaml -o results/004/raw.h5 --overwrite --no-progress
	$(SARPROC) array3d results/004/raw.h5 -o results/004/cube.h5 --config configs/du2010.yaml --overwrite --no-progress \
		--channel-image 14 --channel-output results/004/image_channel14.h5
	$(SARPROC) evaluate results/004/cube.h5 -o results/004/report_cube.json --overwrite --plot results/004/plots_cube > results/004/report_cube.md
	$(SARPROC) evaluate results/004/image_channel14.h5 -o results/004/report_channel14.json --overwrite > results/004/report_channel14.md
	$(PY) scripts/reproduce_004.py --results results/004 --config configs/du2010.yaml

# accuracy-004 is a sweep: mk/sweeps.mk.
