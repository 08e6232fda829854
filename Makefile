# Fresh machine: `make run` (set up + main job) or `make test` (set up + tests).
# Set-up is idempotent: system packages are installed only when missing, the venv is
# (re)installed only when pyproject.toml or this file changed.
PYTHON ?= python3
VENV := .venv
STAMP := $(VENV)/.vpro-installed
VPRO := $(VENV)/bin/vpro
HF_LIBERO := hf-libero==0.1.4

.PHONY: setup run test test-slow system-packages clean-venv

setup: system-packages $(STAMP)

system-packages:
	@bash scripts/install-system-packages.sh

$(STAMP): pyproject.toml Makefile
	@test -x $(VENV)/bin/python || $(PYTHON) -m venv $(VENV)
	$(VENV)/bin/pip install --quiet --upgrade pip wheel setuptools
	$(VENV)/bin/pip install --quiet -e '.[test,plots]'
	# LIBERO's simulation code without its training stack (torch, wandb, transformers).
	$(VENV)/bin/pip install --quiet --no-deps $(HF_LIBERO)
	# robosuite's own recommended step (scripts/setup_macros.py, which prompts): a private macros
	# file equal to the defaults, so robosuite stops warning on every import.
	$(VENV)/bin/python scripts/robosuite_private_macros.py
	@touch $(STAMP)

# The main job: rebuild the catalog in memory and check it byte for byte against the
# committed catalog.json, regenerate docs/taxonomy.md, and render one base task headless.
run: setup
	$(VPRO) catalog verify
	$(VPRO) taxonomy --doc docs/taxonomy.md
	$(VPRO) env libero_spatial-00 --snapshot out/snapshots/libero_spatial-00.png

test: setup
	$(VENV)/bin/python -m pytest

test-slow: setup
	$(VENV)/bin/python -m pytest -m slow

clean-venv:
	rm -rf $(VENV)
