# Standard formats through sarkit (issue 14): docs/formats.md.
FORMATS_STAMP := $(VENV)/.installed-formats

$(FORMATS_STAMP): $(STAMP) pyproject.toml
	$(PY) -m pip install --quiet -e '.[formats]'
	touch $@

.PHONY: formats-demo formats-gotcha formats-readers
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

# SICD for every reader (issue 18): the demo image, a plain pfa2 image (configs/nie2016_small.yaml with
# configs/pfa2_plain.yaml) and a backprojected Gotcha image, each as SICD 1.4.0 and 1.3.0, through sarkit's
# sicdcheck and sarpy's validity check (sarpy: the test extra): results/formats/readers/sicd_readers.md.
READERS := results/formats/readers
formats-readers: demo $(FORMATS_STAMP) $(TEST_STAMP)
	mkdir -p $(READERS)
	$(SARPROC) simulate configs/nie2016_small.yaml -o $(READERS)/nie2016_small_raw.h5 --overwrite
	$(SARPROC) pfa2 $(READERS)/nie2016_small_raw.h5 --config configs/pfa2_plain.yaml -o $(READERS)/nie2016_small_plain.h5 --overwrite
	$(SARPROC) import-gotcha $(GOTCHA_DIR) -o $(READERS)/gotcha_raw.h5 --overwrite
	$(SARPROC) backproject $(READERS)/gotcha_raw.h5 --config configs/gotcha.yaml -o $(READERS)/gotcha_bp.h5 --overwrite
	$(PY) scripts/sicd_readers.py --out $(READERS) demo=results/demo/image.h5 \
	  nie2016_small_plain=$(READERS)/nie2016_small_plain.h5 gotcha_bp=$(READERS)/gotcha_bp.h5
