# Sweeps on Dask (issue 14): sarproc sweep, see docs/sweeps.md.
DIST_STAMP := $(VENV)/.installed-distributed

$(DIST_STAMP): $(STAMP) pyproject.toml
	$(PY) -m pip install --quiet -e '.[distributed]'
	touch $@

.PHONY: sweep-backprojection
# The backprojection knobs (make accuracy-backprojection) as an 18-task sweep on a local Dask cluster.
sweep-backprojection: $(DIST_STAMP)
	$(SARPROC) sweep configs/sweeps/backprojection.yaml

.PHONY: sweep-000
# Paper 000's accuracy knobs (make accuracy-000) as a 32-task sweep on a local Dask cluster.
sweep-000: $(DIST_STAMP)
	$(SARPROC) sweep configs/sweeps/accuracy_000.yaml

.PHONY: sweep-002 sweep-004
# Paper 002's pfa2 knobs (make accuracy-002) as a 12-task sweep; paper 004's array3d knobs as a 19-task sweep.
sweep-002: $(DIST_STAMP)
	$(SARPROC) sweep configs/sweeps/accuracy_002.yaml

sweep-004: $(DIST_STAMP)
	$(SARPROC) sweep configs/sweeps/accuracy_004.yaml
