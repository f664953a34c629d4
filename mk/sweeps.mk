# Sweeps on Dask (issue 14): sarproc sweep, see docs/sweeps.md.
DIST_STAMP := $(VENV)/.installed-distributed

$(DIST_STAMP): $(STAMP) pyproject.toml
	$(PY) -m pip install --quiet -e '.[distributed]'
	touch $@

.PHONY: accuracy-backprojection sweep-backprojection
# The backprojection reference's knobs (engine x range upsampling x interpolation, the 15 settings of
# scripts/accuracy_backprojection.py on its 2 scenes): a 30-task sweep on a local Dask cluster, then a
# script step for what a sweep row cannot hold, the deviation of every image from the finest one (read
# off the sweep's images). Same table as the script's own run (quality columns equal to 1e-14,
# deviations identical); its times are the sweep's per-task focus times (one run, product I/O included).
accuracy-backprojection: $(DIST_STAMP)
	$(SARPROC) sweep configs/sweeps/backprojection.yaml -o results/bp-accuracy/sweep
	$(PY) scripts/accuracy_backprojection.py --from-sweep results/bp-accuracy/sweep --out results/bp-accuracy

# The sweep alone (its table and plot in results/sweep-backprojection/).
sweep-backprojection: $(DIST_STAMP)
	$(SARPROC) sweep configs/sweeps/backprojection.yaml

.PHONY: accuracy-000 sweep-000
# Paper 000's accuracy knobs: a 32-task sweep (2 scenes x 16 settings, squint_lrwc frame: the settings
# table of scripts/accuracy_000.py, quality columns equal to 1e-14), then the script's hard-case table
# (squint 60 deg, 800 km, the Stolt limit, alpha near 1/2, window edge, PRF limits: refusals and
# special scenes that are no grid of one scene) as a script step.
accuracy-000: $(DIST_STAMP)
	$(SARPROC) sweep configs/sweeps/accuracy_000.yaml -o results/000-accuracy/sweep
	$(PY) scripts/accuracy_000.py --hard-only --out results/000-accuracy

sweep-000: $(DIST_STAMP)
	$(SARPROC) sweep configs/sweeps/accuracy_000.yaml

.PHONY: accuracy-002 sweep-002 sweep-004
# Paper 002's pfa2 knobs on the reduced Table 1 scene: a 12-task sweep (the 12 settings of
# scripts/accuracy_002.py, sub-image sizes at full precision), then the script's table from the sweep's
# images (a per-target score against each target's own sub-image theory, the false-target level and the
# Pareto front: no sweep columns). Same numbers as the script's own run (identical); times are the
# sweep's focus times.
accuracy-002: $(DIST_STAMP)
	$(SARPROC) sweep configs/sweeps/accuracy_002.yaml -o results/002-accuracy/sweep
	cd scripts && ../$(PY) accuracy_002.py --from-sweep ../results/002-accuracy/sweep --out ../results/002-accuracy

sweep-002: $(DIST_STAMP)
	$(SARPROC) sweep configs/sweeps/accuracy_002.yaml

# Paper 004's array3d knobs as a 19-task sweep on the paper scene. Not yet the accuracy-004 target: its
# script scores every target simulated and focused alone (7 single-target scenes per setting) and the
# cube deviation from a float64 reference, so make accuracy-004 still runs the script.
sweep-004: $(DIST_STAMP)
	$(SARPROC) sweep configs/sweeps/accuracy_004.yaml
