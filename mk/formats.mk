# Standard formats through sarkit (issue 14): docs/formats.md.
FORMATS_STAMP := $(VENV)/.installed-formats

$(FORMATS_STAMP): $(STAMP) pyproject.toml
	$(PY) -m pip install --quiet -e '.[formats]'
	touch $@

.PHONY: formats-demo formats-gotcha
# The demo: image -> SICD (checked, pixels re-read), raw -> CPHD (checked) -> raw -> backprojected image.
formats-demo: demo $(FORMATS_STAMP)
	mkdir -p results/formats
	$(SARPROC) export-sicd results/demo/image.h5 -o results/formats/demo.nitf --overwrite --check-report results/formats/demo_sicd.json
	$(SARPROC) export-cphd results/demo/raw.h5 -o results/formats/demo.cphd --overwrite --check-report results/formats/demo_cphd.json
	$(SARPROC) import-cphd results/formats/demo.cphd -o results/formats/demo_from_cphd.h5 --overwrite
	$(SARPROC) backproject results/formats/demo_from_cphd.h5 --config configs/demo.yaml -o results/formats/demo_image_from_cphd.h5 --overwrite
	$(SARPROC) quicklook results/formats/demo_image_from_cphd.h5 -o results/formats/demo_image_from_cphd.png --overwrite

# The Gotcha images of make reproduce-gotcha (pfa2 and backprojection) as SICD, checked.
formats-gotcha: $(FORMATS_STAMP)
	test -f results/gotcha/image_pfa.h5 || $(MAKE) reproduce-gotcha
	mkdir -p results/formats
	$(SARPROC) export-sicd results/gotcha/image_pfa.h5 -o results/formats/gotcha_pfa.nitf --overwrite --check-report results/formats/gotcha_pfa_sicd.json
	$(SARPROC) export-sicd results/gotcha/image_bp.h5 -o results/formats/gotcha_bp.nitf --overwrite --check-report results/formats/gotcha_bp_sicd.json
