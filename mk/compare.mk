# Issue 21 "Must show": this tree's products against an older checkout's (BASE=DIR, e.g. a detached
# worktree of the last landed commit), on the small config of every paper chain. Each tree simulates its
# own raw products (results/compare/{base,new}/raw_*.h5); then both trees process the SAME raw products
# (base's) through every later stage, each tree feeding its own intermediate products on. The script only
# tabulates (results/compare/table.md). Heavy: waits for heavy.lock. Usage: make compare-products BASE=DIR
# (with the shared venv of a worktree: add VENV=/path/to/.venv).
CMP := results/compare
CMP_SCENES := demo an2012_exp1_small nie2016_small xu_small du2010_wide_swath bp_squint30

# $(call cmp_tree,SOURCE_TREE,OUT_DIR): every chain of one tree into OUT_DIR, from $(CMP)/base's raw products.
define cmp_tree
	mkdir -p $(2)
	set -e; S="env PYTHONPATH=$(1) $(abspath $(SARPROC))"; R=$(CMP)/base; O=$(2); \
	for s in $(CMP_SCENES); do $$S simulate configs/$$s.yaml -o $$O/raw_$$s.h5 --overwrite --no-progress; done; \
	$$S backproject $$R/raw_demo.h5 --config configs/demo.yaml -o $$O/demo_image.h5 --overwrite --no-progress; \
	$$S evaluate $$O/demo_image.h5 -o $$O/demo_report.json --expect configs/demo_expect.yaml --overwrite > /dev/null; \
	c=configs/an2012_exp1_small.yaml; \
	$$S preprocess $$R/raw_an2012_exp1_small.h5 --config $$c -o $$O/000_pre.h5 --overwrite --no-progress; \
	$$S coarse-focus $$O/000_pre.h5 --config $$c -o $$O/000_coarse.h5 --overwrite --no-progress; \
	$$S fine-focus $$O/000_coarse.h5 --config $$c -o $$O/000_image.h5 --overwrite --no-progress; \
	$$S evaluate $$O/000_image.h5 -o $$O/000_report.json --config $$c --overwrite > /dev/null; \
	c=configs/nie2016_small.yaml; \
	$$S pfa2 $$R/raw_nie2016_small.h5 --config $$c -o $$O/002_two_step_image.h5 --overwrite --no-progress; \
	$$S pfa2 $$R/raw_nie2016_small.h5 --config configs/pfa2_plain.yaml -o $$O/002_plain_image.h5 --overwrite --no-progress; \
	for m in two_step plain; do \
	  $$S evaluate $$O/002_$${m}_image.h5 -o $$O/002_$${m}_report.json --config $$c --overwrite > /dev/null; done; \
	c=configs/xu_small.yaml; \
	$$S reconstruct $$R/raw_xu_small.h5 --config $$c -o $$O/003_reconstructed.h5 --overwrite --no-progress; \
	$$S backproject $$O/003_reconstructed.h5 --config $$c -o $$O/003_image.h5 --overwrite --no-progress; \
	$$S evaluate $$O/003_image.h5 -o $$O/003_report.json --config $$c --overwrite > /dev/null; \
	c=configs/du2010_wide_swath.yaml; \
	$$S array3d $$R/raw_du2010_wide_swath.h5 --config $$c -o $$O/004_cube.h5 --overwrite --no-progress; \
	$$S evaluate $$O/004_cube.h5 -o $$O/004_report.json --config $$c --overwrite > /dev/null; \
	c=configs/bp_squint30.yaml; \
	$$S backproject $$R/raw_bp_squint30.h5 --config $$c -o $$O/squint30_image.h5 --overwrite --no-progress; \
	$$S evaluate $$O/squint30_image.h5 -o $$O/squint30_report.json --expect configs/bp_expect.yaml --overwrite > /dev/null; \
	$$S export-sicd $$O/demo_image.h5 -o $$O/demo_image.nitf --overwrite; \
	$$S export-cphd $$R/raw_demo.h5 -o $$O/demo_raw.cphd --overwrite
endef

.PHONY: compare-products
compare-products:
	@test -n "$(BASE)" || { echo "usage: make compare-products BASE=<checkout of the older commit>"; exit 2; }
	flock /tmp/heavy.lock nice $(MAKE) --no-print-directory compare-products-run BASE=$(abspath $(BASE))

.PHONY: compare-products-run
compare-products-run:
	$(call cmp_tree,$(BASE),$(CMP)/base)
	$(call cmp_tree,$(CURDIR),$(CMP)/new)
	PYTHONPATH=$(CURDIR) $(PY) scripts/compare_products.py $(CMP)/base $(CMP)/new > $(CMP)/table.md
	cat $(CMP)/table.md
