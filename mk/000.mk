# Paper 000 (An et al. 2012): squint spotlight two-step imaging. See scripts/reproduce_000.py, scripts/accuracy_000.py.
.PHONY: reproduce-000-exp1 reproduce-000-exp2

reproduce-000-exp1: $(STAMP)
	$(PY) scripts/reproduce_000.py exp1 --out results/000-exp1

reproduce-000-exp2: $(STAMP)
	$(PY) scripts/reproduce_000.py exp2 --out results/000-exp2

# accuracy-000 is a sweep: mk/sweeps.mk.
