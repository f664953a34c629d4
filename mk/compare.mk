# Issue 21 "Must show": this tree's products against an older checkout's (BASE=DIR, e.g. a detached
# worktree of the last landed commit), on the small config of every paper chain. Each tree simulates its
# own raw products (results/compare/{base,new}/raw_*.h5); then both trees process the SAME raw products
# (base's) through every later stage, each tree feeding its own intermediate products on. `sarproc compare`
# tabulates them (results/compare/table.md). Heavy: waits for heavy.lock. Usage: make compare-products BASE=DIR
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
	env PYTHONPATH=$(CURDIR) $(abspath $(SARPROC)) compare $(CMP)/base $(CMP)/new > $(CMP)/table.md
	cat $(CMP)/table.md

# Issue 21, full size: each reproduction's chain (reproduce-000-exp1, -000-exp2, -004, -gotcha, the scene
# chain of -003, the CLI products of -002's Table 1) in both trees, into $(CMPF)/{base,new}/CHAIN/. Same
# scheme as above: the base tree simulates (imports) the raw products, the new tree processes a copy of
# them (its own simulate goes to simulated/, beside links to base's raw in base/CHAIN/simulated/), each
# tree running its own configs and reproduce script. One `flock /tmp/heavy.lock nice` per chain (both
# trees), so other heavy jobs interleave; wall time and peak RSS per chain in $(CMPF)/times.txt. Then
# `sarproc compare` tabulates products, reports and the scripts' Markdown tables
# ($(CMPF)/table.md). Usage: make compare-reproductions BASE=DIR [CMPF_CHAINS="000-exp1 004"] [VENV=...]
CMPF := results/compare-full
CMPF_CHAINS ?= 000-exp1 000-exp2 004 gotcha 003 002

.PHONY: compare-reproductions compare-reproductions-table
compare-reproductions:
	@test -n "$(BASE)" || { echo "usage: make compare-reproductions BASE=<checkout of the older commit>"; exit 2; }
	mkdir -p $(CMPF)
	for c in $(CMPF_CHAINS); do \
	  flock /tmp/heavy.lock nice $(MAKE) --no-print-directory cmpf-pair C=$$c BASE=$(abspath $(BASE)); done
	$(MAKE) --no-print-directory compare-reproductions-table

# One chain in both trees under one hold of the lock: wall time and peak RSS of each in times.txt.
.PHONY: cmpf-pair
cmpf-pair:
	for role in base new; do \
	  tree=$$([ $$role = base ] && echo $(BASE) || echo $(CURDIR)); \
	  /usr/bin/time -a -o $(CMPF)/times.txt -f "$(C) $$role: %e s wall, %M KB peak RSS (largest process)" \
	    $(MAKE) --no-print-directory cmpf-$(C) ROLE=$$role T=$$tree O=$(CMPF)/$$role/$(C) R=$(CURDIR)/$(CMPF)/base/$(C) \
	    > $(CMPF)/$(C)-$$role.log 2>&1 || echo "$(C) $$role: FAILED ($(CMPF)/$(C)-$$role.log)" | tee -a $(CMPF)/times.txt; \
	done

compare-reproductions-table:
	env PYTHONPATH=$(CURDIR) $(abspath $(SARPROC)) compare $(CMPF)/base $(CMPF)/new > $(CMPF)/table.md
	cat $(CMPF)/table.md

# Inside one chain: ROLE (base|new), T (the tree), O (its output folder), R (base's output folder).
CMPF_S = env PYTHONPATH=$(T) $(abspath $(SARPROC))
CMPF_P = env PYTHONPATH=$(T) $(abspath $(PY))
# $(call cmpf_raw,SCENE_YAML,NAME): base simulates O/NAME (linked from O/simulated/NAME); new links base's
# R/NAME to O/NAME and simulates its own into O/simulated/NAME.
define cmpf_raw
	mkdir -p $(O)/simulated
	$(if $(filter new,$(ROLE)),ln -f $(R)/$(2) $(O)/$(2),$(CMPF_S) simulate $(1) -o $(O)/$(2) --overwrite --no-progress)
	$(if $(filter new,$(ROLE)),$(CMPF_S) simulate $(1) -o $(O)/simulated/$(2) --overwrite --no-progress,ln -sf ../$(2) $(O)/simulated/$(2))
endef

.PHONY: cmpf-000-exp1 cmpf-000-exp2 cmpf-004 cmpf-gotcha cmpf-003 cmpf-003-full cmpf-002
cmpf-000-exp1 cmpf-000-exp2: cmpf-000-%:
	mkdir -p $(O)/simulated
	$(CMPF_P) $(T)/scripts/reproduce_000.py $* --out $(O) $(if $(filter new,$(ROLE)),--raw-from $(R))
	$(if $(filter new,$(ROLE)),$(CMPF_S) simulate $(T)/configs/an2012_$*.yaml -o $(O)/simulated/raw.h5 --overwrite --no-progress,ln -sf ../raw.h5 $(O)/simulated/raw.h5)
	$(if $(filter exp1,$*),$(if $(filter new,$(ROLE)),$(CMPF_S) simulate $(R)/scene_prf1850.yaml -o $(O)/simulated/raw_prf1850.h5 --overwrite --no-progress,ln -sf ../raw_prf1850.h5 $(O)/simulated/raw_prf1850.h5))

# Trees whose reproduce_004.py tabulates the CLI's times/ and isolated-target sweep (mk/004.mk) get them
# too (a tree without configs/sweeps/reproduce_004_isolated.yaml runs its own timing and isolated targets);
# a tree whose mk/004.mk runs the channel overlap and the timed 3D backprojection (reproduce_004.py then reads
# times/backproject.txt) runs them here too (session 26: cmpf-004 failed without them).
cmpf-004:
	$(call cmpf_raw,$(T)/configs/du2010.yaml,raw.h5)
	rm -rf $(O)/times && mkdir -p $(O)/times
	$(PY) scripts/timed.py $(O)/times/simulate.txt -- \
		$(CMPF_S) simulate $(T)/configs/du2010.yaml -o $(O)/times/raw.h5 --overwrite --no-progress && rm $(O)/times/raw.h5
	$(PY) scripts/timed.py $(O)/times/array3d.txt -- $(CMPF_S) array3d $(O)/raw.h5 -o $(O)/cube.h5 --config $(T)/configs/du2010.yaml --overwrite --no-progress \
		--channel-image 14 --channel-output $(O)/image_channel14.h5 \
		$$(grep -q -- --channel-overlap $(T)/mk/004.mk && echo --channel-overlap)
	if grep -q times/backproject.txt $(T)/mk/004.mk; then \
	  $(PY) scripts/timed.py $(O)/times/backproject.txt -- $(CMPF_S) backproject $(O)/raw.h5 -o $(O)/bp_cube.h5 \
	    --config $(T)/configs/du2010.yaml --overwrite --no-progress && \
	  $(CMPF_S) evaluate $(O)/bp_cube.h5 -o $(O)/report_bp.json --overwrite > $(O)/report_bp.md; fi
	$(CMPF_S) evaluate $(O)/cube.h5 -o $(O)/report_cube.json --overwrite --plot $(O)/plots_cube > $(O)/report_cube.md
	$(CMPF_S) evaluate $(O)/image_channel14.h5 -o $(O)/report_channel14.json --overwrite > $(O)/report_channel14.md
	if [ -f $(T)/configs/sweeps/reproduce_004_isolated.yaml ]; then rm -rf $(O)/isolated && \
	  $(CMPF_S) sweep $(T)/configs/sweeps/reproduce_004_isolated.yaml -o $(O)/isolated --scheduler serial; fi
	$(CMPF_P) $(T)/scripts/reproduce_004.py --results $(O) --config $(T)/configs/du2010.yaml

cmpf-gotcha:
	mkdir -p $(O)/simulated
	$(if $(filter new,$(ROLE)),$(CMPF_S) import-gotcha $(GOTCHA_DIR) -o $(O)/simulated/raw.h5 --overwrite && ln -f $(R)/raw.h5 $(O)/raw.h5,$(CMPF_S) import-gotcha $(GOTCHA_DIR) -o $(O)/raw.h5 --overwrite && ln -sf ../raw.h5 $(O)/simulated/raw.h5)
	$(CMPF_S) pfa2 $(O)/raw.h5 --config $(T)/configs/gotcha.yaml -o $(O)/image_pfa.h5 --overwrite --no-progress
	$(CMPF_S) pfa2 $(O)/raw.h5 --config $(T)/configs/gotcha_two_step.yaml -o $(O)/image_pfa_two_step.h5 --overwrite --no-progress
	$(CMPF_S) backproject $(O)/raw.h5 --config $(T)/configs/gotcha.yaml -o $(O)/image_bp.h5 --overwrite --no-progress
	$(CMPF_P) $(T)/scripts/reproduce_gotcha.py --dir $(O)

# reproduce-003's scene chain (A, B, C: images, strips, reports). cmpf-003-full adds its five sweeps (72
# tasks of the full scene in each tree, each tree simulating its own raw products) and the two scripts
# that tabulate them (summary.md, hard_cases.md); not in the default chains: hours on two cores.
cmpf-003-full: cmpf-003
	set -e; for s in cases given speeds clutter; do \
	  $(CMPF_S) sweep $(T)/configs/sweeps/reproduce_003_$$s.yaml -o $(O)/sweep-$$s --scheduler serial; done
	$(CMPF_S) sweep $(T)/configs/sweeps/hard_cases_003.yaml -o $(O)/sweep-hard --scheduler serial
	$(CMPF_P) $(T)/scripts/reproduce_003.py --results $(O)
	$(CMPF_P) $(T)/scripts/hard_cases_003.py --results $(O)
	rm -f $(O)/sweep-*/tasks/*/reconstruct.h5 $(O)/sweep-*/raw/*.h5

cmpf-003:
	$(call cmpf_raw,$(T)/configs/xu_scene.yaml,raw_mc.h5)
	$(CMPF_S) reconstruct $(O)/raw_mc.h5 -o $(O)/raw_conventional.h5 --config $(T)/configs/xu_conventional.yaml --overwrite --no-progress
	$(CMPF_S) reconstruct $(O)/raw_mc.h5 -o $(O)/raw_modified.h5 --config $(T)/configs/xu_scene.yaml --overwrite --no-progress
	set -e; for m in conventional modified; do \
	  $(CMPF_S) backproject $(O)/raw_$$m.h5 -o $(O)/image_$$m.h5 --config $(T)/configs/xu_scene.yaml --overwrite --no-progress; \
	  for t in A B C; do \
	    $(CMPF_S) backproject $(O)/raw_$$m.h5 -o $(O)/strip_$${m}_$$t.h5 --config $(T)/configs/xu_strip.yaml --targets $$t --overwrite --no-progress; \
	    $(CMPF_S) evaluate $(O)/strip_$${m}_$$t.h5 -o $(O)/strip_$${m}_$$t.json --config $(T)/configs/xu_strip.yaml --targets $$t --overwrite > /dev/null; \
	  done; \
	done
	$(CMPF_S) evaluate $(O)/image_modified.h5 -o $(O)/report_modified.json --config $(T)/configs/xu_scene.yaml --expect $(T)/configs/xu_scene_expect.yaml --overwrite > $(O)/report_modified.md
	$(CMPF_S) evaluate $(O)/image_conventional.h5 -o $(O)/report_conventional.json --config $(T)/configs/xu_scene.yaml --overwrite > $(O)/report_conventional.md

# reproduce-002's Table 1 products through the CLI (the steps mk/002.mk runs before reproduce_002.py
# tabulates evaluate's numbers): plain (the config with pfa2.method plain) and two-step PFA, evaluated; the
# new tree's simulate last. Peak ~11 GB (pfa2 on 13660 x 17287 samples, docs/pfa.md).
cmpf-002:
	mkdir -p $(O)/simulated
	$(if $(filter new,$(ROLE)),ln -f $(R)/raw.h5 $(O)/raw.h5,$(CMPF_S) simulate $(T)/$(CONFIG002) -o $(O)/raw.h5 --overwrite --no-progress && ln -sf ../raw.h5 $(O)/simulated/raw.h5)
	sed 's/method: two_step/method: plain/' $(T)/$(CONFIG002) > $(O)/config_plain.yaml
	$(CMPF_S) pfa2 $(O)/raw.h5 --config $(O)/config_plain.yaml -o $(O)/image_pfa.h5 --overwrite --no-progress
	$(CMPF_S) evaluate $(O)/image_pfa.h5 -o $(O)/report_pfa.json --config $(T)/$(CONFIG002) --overwrite > /dev/null
	$(CMPF_S) pfa2 $(O)/raw.h5 --config $(T)/$(CONFIG002) -o $(O)/image_pfa2.h5 --overwrite --no-progress
	$(CMPF_S) evaluate $(O)/image_pfa2.h5 -o $(O)/report_pfa2.json --config $(T)/$(CONFIG002) --overwrite > /dev/null
	$(if $(filter new,$(ROLE)),$(CMPF_S) simulate $(T)/$(CONFIG002) -o $(O)/simulated/raw.h5 --overwrite --no-progress)
