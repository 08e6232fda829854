# Fresh machine: `make run` (set up + main job) or `make test` (set up + tests).
# Set-up is idempotent: system packages are installed only when missing, the venv is
# (re)installed only when pyproject.toml or this file changed.
PYTHON ?= python3
VENV := .venv
STAMP := $(VENV)/.vpro-installed
VPRO := $(VENV)/bin/vpro
HF_LIBERO := hf-libero==0.1.4

.PHONY: setup run test test-slow lint wheel system-packages clean-venv

setup: system-packages $(STAMP)

system-packages:
	@bash scripts/install-system-packages.sh

$(STAMP): pyproject.toml Makefile
	@test -x $(VENV)/bin/python || $(PYTHON) -m venv $(VENV)
	$(VENV)/bin/pip install --quiet --upgrade pip wheel setuptools
	$(VENV)/bin/pip install --quiet -e '.[sim,ray,test,plots,lint,vla-eval]'
	# LIBERO's simulation code without its training stack (torch, wandb, transformers).
	$(VENV)/bin/pip install --quiet --no-deps $(HF_LIBERO)
	# robosuite's own recommended step (scripts/setup_macros.py, which prompts): a private macros
	# file equal to the defaults, so robosuite stops warning on every import.
	$(VENV)/bin/python scripts/robosuite_private_macros.py
	# LIBERO's config in the repository's .libero/ (never ~/.libero): `import vpro_assets` points
	# LIBERO at it, so users' own scripts importing LIBERO are not stopped by its prompt.
	$(VENV)/bin/python -c "from vpro_assets.libero.bridge import write_libero_config; write_libero_config()"
	@touch $(STAMP)

# The main job, end to end on a small scale (about 15 minutes on 2 cores): the catalog checked
# against a rebuild; a sample of scene cases built, checked against the committed hashes and
# validated; what a perturbation does and a task's scene variants as pictures; the scripted
# policy evaluated on a Normal baseline, observation cases and a scene case; the paper's tables.
RUN := out/run
# One scene case of each kind (the full set is `vpro build -j 2`, hours on 2 cores: docs/scenes.md).
SCENE_SAMPLE := --select libero_goal-03/task_precondition_variation/receptacle_openness-v1 \
	--select libero_goal-03/visual_state_ambiguity/object_pose-v1 \
	--select libero_goal-03/visual_state_ambiguity/receptacle_openness-v1 \
	--select libero_goal-03/task_relevant_distractors/familiar_position-v1 \
	--select libero_goal-03/task_relevant_distractors/trajectory_obstacle-v1 \
	--select libero_spatial-00/target_geometry_variation/taper-s1-v1 \
	--select libero_spatial-00/task_relevant_distractors/same_category-v1 \
	--select libero_spatial-00/task_relevant_distractors/same_color-v1
EVAL_SAMPLE := --select libero_spatial-00/normal --select libero_spatial-00/camera_staleness/wrist-delay2-v1 \
	--select libero_spatial-00/view_unavailability/third_person-constant-v1 \
	--select libero_spatial-00/target_object_masking/ratio50-always-v1 \
	--select libero_spatial-00/task_relevant_distractors/same_color-v1
run: setup
	$(VPRO) catalog verify
	$(VPRO) build --no-record -j 2 $(SCENE_SAMPLE)
	$(VPRO) catalog verify --artifacts
	$(VPRO) validate $(SCENE_SAMPLE)
	$(VPRO) preview libero_spatial-00/camera_staleness/wrist-delay2-v1 --out $(RUN)/preview-staleness.png
	$(VPRO) preview libero_goal-03 --out $(RUN)/gallery-libero_goal-03.png
	$(VPRO) eval --policy oracle $(EVAL_SAMPLE) --trials 2 --workers 2 --results $(RUN)/results.sqlite
	$(VPRO) report $(RUN)/results.sqlite --out $(RUN)/report
	@echo "main job done: pictures, results and report in $(RUN)/"

# ruff (lint and format check), mypy, and the import layers declared in pyproject.toml.
lint: setup
	$(VENV)/bin/ruff check vpro_assets generators tests scripts
	$(VENV)/bin/ruff format --check vpro_assets generators tests scripts
	$(VENV)/bin/mypy
	$(VENV)/bin/lint-imports

# Test files spread over both cores (pytest-xdist; a file stays on one worker, so its module
# fixtures, such as the fork environment, are made once). TEST_WORKERS=0 runs them in one process.
TEST_WORKERS ?= 2
test: setup
	$(VENV)/bin/python -m pytest -n $(TEST_WORKERS) --dist loadfile

test-slow: setup
	$(VENV)/bin/python -m pytest -m slow

# The toolkit as a wheel file (dist/ by default), for a fork's own environment: its base install
# needs only numpy, mujoco, opencv-python, scipy, pyyaml and tqdm, which LIBERO forks already have
# (docs/packs.md); the simulator pins and Ray are the extras `sim` and `ray`.
WHEEL_DIR ?= dist
wheel:
	$(PYTHON) -m pip wheel --quiet --no-deps --wheel-dir $(WHEEL_DIR) .

clean-venv:
	rm -rf $(VENV)
