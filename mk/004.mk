# Paper 004 (Du 2010): linear-array down-looking 3D SAR. Outputs under results/004*/.
# Every processing step runs through the CLI: simulate, array3d and backproject (each under scripts/timed.py:
# times/STEP.txt, wall seconds and peak RSS in kB). array3d writes the cube, receiver 14's image before elevation
# compression (--channel-image) and, in the cube's attribute channel_overlap, the Fig. 5 overlap over all 28
# receivers (--channel-overlap); backproject in frame elevation (configs/du2010.yaml, section backproject:) is the
# exact 3D reference of the cube. evaluate measures the cube, receiver 14's image and the BP cube;
# Table 3's isolated targets are a sweep (configs/sweeps/reproduce_004_isolated.yaml). scripts/reproduce_004.py
# only reads these products and reports, tabulates and plots.
.PHONY: reproduce-004

reproduce-004: $(STAMP)
	rm -rf results/004/times && mkdir -p results/004/times
	$(PY) scripts/timed.py results/004/times/simulate.txt -- \
		$(SARPROC) simulate configs/du2010.yaml -o results/004/raw.h5 --overwrite --no-progress
	$(PY) scripts/timed.py results/004/times/array3d.txt -- \
		$(SARPROC) array3d results/004/raw.h5 -o results/004/cube.h5 --config configs/du2010.yaml --overwrite --no-progress \
		--channel-image 14 --channel-output results/004/image_channel14.h5 --channel-overlap
	$(PY) scripts/timed.py results/004/times/backproject.txt -- \
		$(SARPROC) backproject results/004/raw.h5 -o results/004/bp_cube.h5 --config configs/du2010.yaml \
		--overwrite --no-progress
	$(SARPROC) evaluate results/004/cube.h5 -o results/004/report_cube.json --overwrite --plot results/004/plots_cube > results/004/report_cube.md
	$(SARPROC) evaluate results/004/image_channel14.h5 -o results/004/report_channel14.json --overwrite > results/004/report_channel14.md
	$(SARPROC) evaluate results/004/bp_cube.h5 -o results/004/report_bp.json --overwrite > results/004/report_bp.md
	rm -rf results/004/isolated
	$(SARPROC) sweep configs/sweeps/reproduce_004_isolated.yaml -o results/004/isolated --scheduler serial
	$(PY) scripts/reproduce_004.py --results results/004 --config configs/du2010.yaml

# accuracy-004 is a sweep: mk/sweeps.mk.
