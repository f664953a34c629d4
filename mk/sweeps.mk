# Sweeps on Dask (issue 14): sarproc sweep, see docs/sweeps.md.
DIST_STAMP := $(VENV)/.installed-distributed

$(DIST_STAMP): $(STAMP) pyproject.toml
	$(PY) -m pip install --quiet -e '.[distributed]'
	touch $@

.PHONY: accuracy-backprojection sweep-backprojection
# The backprojection reference's knobs (engine x range upsampling x interpolation, 18 settings on the
# 2 reference scenes): a 36-task sweep on a local Dask cluster, then scripts/accuracy_backprojection.py
# for what a sweep row cannot hold, the deviation of every image from the finest one (read
# off the sweep's images); its times are the sweep's per-task focus times (best, median and spread of 3 interleaved runs, product I/O included).
accuracy-backprojection: $(DIST_STAMP)
	$(SARPROC) sweep configs/sweeps/backprojection.yaml -o results/bp-accuracy/sweep
	$(PY) scripts/accuracy_backprojection.py --from-sweep results/bp-accuracy/sweep --out results/bp-accuracy

# The sweep alone (its table and plot in results/sweep-backprojection/).
sweep-backprojection: $(DIST_STAMP)
	$(SARPROC) sweep configs/sweeps/backprojection.yaml

.PHONY: accuracy-000 sweep-000
# Paper 000's accuracy knobs: a 32-task sweep (2 scenes x 16 settings, squint_lrwc frame), then the hard
# cases (squint 60 deg, 800 km, the Stolt limit, alpha near 1/2, window edge, PRF limits: refusals and special
# scenes that are no grid of one scene) as the 11-task sweep configs/sweeps/hard_cases_000.yaml, tabulated by
# scripts/accuracy_000.py.
accuracy-000: $(DIST_STAMP)
	$(SARPROC) sweep configs/sweeps/accuracy_000.yaml -o results/000-accuracy/sweep
	$(SARPROC) sweep configs/sweeps/hard_cases_000.yaml -o results/000-accuracy/hard-cases
	$(PY) scripts/accuracy_000.py --from-sweep results/000-accuracy/hard-cases --out results/000-accuracy

sweep-000: $(DIST_STAMP)
	$(SARPROC) sweep configs/sweeps/accuracy_000.yaml

.PHONY: accuracy-002 sweep-002
# Paper 002's pfa2 knobs on the reduced Table 1 scene: a 12-task sweep (sub-image sizes at full
# precision), then scripts/accuracy_002.py's table from the sweep's images (a per-target score against
# each target's own theory, sarproc.quality.summary.tolerance_score, the false-target level and the
# Pareto front: no sweep columns); times are the
# sweep's focus times: best, median, spread of 3 interleaved runs (repeats: 3), faster only beyond the spread.
accuracy-002: $(DIST_STAMP)
	$(SARPROC) sweep configs/sweeps/accuracy_002.yaml -o results/002-accuracy/sweep
	$(PY) scripts/accuracy_002.py --from-sweep results/002-accuracy/sweep --out results/002-accuracy

sweep-002: $(DIST_STAMP)
	$(SARPROC) sweep configs/sweeps/accuracy_002.yaml

.PHONY: accuracy-004 sweep-004 sweep-004-wide
# Paper 004's array3d knobs: the script's 19 settings as a 152-task sweep (the paper scene for the time and
# the cube, each of its 7 targets simulated and focused alone for the quality, as scripts/accuracy_004.py
# scores them) and its 7 wide-swath settings as a 7-task sweep, the hard cases (the 6-task sweep
# configs/sweeps/hard_cases_004.yaml: its refusal is a row, not a failure) and the reference cubes (the 5-task
# sweep configs/sweeps/accuracy_004_reference.yaml: float64, sinc 32, one per scene and elevation padding),
# then accuracy_004.py --from-sweep, which only reads: the script's tables from the sweeps' products (each
# cube's deviation from its reference cube, worst quality over the single-target tasks) and the hard cases.
# Against the script's own run: deviations identical, quality columns within 1.5e-7 (relative): Dask
# workers run BLAS single-threaded (OMP_NUM_THREADS=1), which rounds array3d's complex64 elevation
# matmul differently by one float32 ulp; the script run with OMP_NUM_THREADS=1 gives the sweep's cubes
# bit for bit (docs/sweeps.md). Times are the sweep's.
accuracy-004: $(DIST_STAMP)
	$(SARPROC) sweep configs/sweeps/accuracy_004.yaml -o results/004-accuracy/sweep
	$(SARPROC) sweep configs/sweeps/accuracy_004_wide.yaml -o results/004-accuracy/sweep-wide
	$(SARPROC) sweep configs/sweeps/hard_cases_004.yaml -o results/004-accuracy/hard-cases
	$(SARPROC) sweep configs/sweeps/accuracy_004_reference.yaml -o results/004-accuracy/reference
	$(PY) scripts/accuracy_004.py --from-sweep results/004-accuracy/sweep --wide-sweep results/004-accuracy/sweep-wide \
		--hard-sweep results/004-accuracy/hard-cases --reference-sweep results/004-accuracy/reference \
		--results results/004-accuracy --config configs/du2010.yaml

sweep-004: $(DIST_STAMP)
	$(SARPROC) sweep configs/sweeps/accuracy_004.yaml

sweep-004-wide: $(DIST_STAMP)
	$(SARPROC) sweep configs/sweeps/accuracy_004_wide.yaml

.PHONY: accuracy-003 sweep-003
# Paper 003's reconstruct knobs on its single moving target T (v_r 10 m/s): the 5 velocity-search settings
# and 3 channel counts as an 8-task sweep timing reconstruct alone (no evaluate: its product is phase history),
# then the images sweep configs/sweeps/accuracy_003_images.yaml: the same 8 cases and 5 backprojection
# interpolation settings on the N = 3 reconstruct, each reconstructed and backprojected where T appears
# (quality) and on its false-target strip (MFTA), and evaluated (26 tasks). accuracy_003.py --from-sweep
# --images-sweep only tabulates: v_r error and search evaluations off the products' attributes, times the
# sweeps' (reconstruct: best of 3 interleaved; interpolation rows: the backproject step), quality and MFTA
# the images sweep's reports (docs/sweeps.md: the check against the former in-process table).
accuracy-003: $(DIST_STAMP)
	$(SARPROC) sweep configs/sweeps/accuracy_003.yaml -o results/003-accuracy/sweep
	$(SARPROC) sweep configs/sweeps/accuracy_003_images.yaml -o results/003-accuracy/images
	$(PY) scripts/accuracy_003.py --from-sweep results/003-accuracy/sweep --images-sweep results/003-accuracy/images \
		--results results/003-accuracy

sweep-003: $(DIST_STAMP)
	$(SARPROC) sweep configs/sweeps/accuracy_003.yaml

.PHONY: motion-002
# Issue 22: pfa2 on a curved track. The reduced Table 1 scene with platform_motion (15 settings: cross-track
# 0.1-5 m at periods 0.3-5 s, vertical, along-track velocity error up to 1 m/s, combinations) through plain
# PFA, two-step PFA and two-step with eq. (7)'s sub-images (45 tasks), backprojection of the same scenes
# (15 tasks), then scripts/motion_002.py: the table against the track-curvature bound (docs/pfa.md).
motion-002: $(STAMP)
	flock /tmp/heavy.lock nice $(SARPROC) sweep configs/sweeps/motion_002.yaml -o results/motion-002/pfa2 --scheduler serial
	flock /tmp/heavy.lock nice $(SARPROC) sweep configs/sweeps/motion_002_bp.yaml -o results/motion-002/bp --scheduler serial
	$(PY) scripts/motion_002.py --pfa-sweep results/motion-002/pfa2 --bp-sweep results/motion-002/bp --out results/motion-002
