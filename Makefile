# mjx_skills: every target creates the environment first if it is missing.
PY      ?= python3
VENV    := .venv
BIN     := $(VENV)/bin
STAMP   := $(VENV)/.stamp-setup
TASK    ?= pick_move
METHOD  ?=
EPOCHS  ?= 100
# A Fetch task trains with the skills built on Fetch (`--preset fetch`, their library);
# FetchPush, whose fingers are blocked, with the push library and the learner tuned there
# (`--preset fetch_push`).
FETCH   := $(filter fetch_%,$(TASK))
PUSH    := $(filter fetch_push,$(TASK))
ROBOT   ?= $(if $(FETCH),fetch,baxter)
SKILL_LIBRARY ?= $(if $(PUSH),SL_fetch_push,$(if $(filter fetch,$(ROBOT)),SL1_fetch))
LIBRARY := experiments/skill_library$(if $(PUSH),_SL_fetch_push,$(if $(FETCH),_fetch))
PRESET  ?= $(if $(PUSH),fetch_push,$(if $(FETCH),fetch))
SEEDS   ?= 1
OUT     ?= runs
ARGS    ?=

.PHONY: setup train resume plot skills sweep report bench bench-peer test test-fast lint results notebook clean

setup: $(STAMP)

$(STAMP): pyproject.toml
	test -d $(VENV) || $(PY) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	PYTHONWARNINGS=ignore $(BIN)/pip install --quiet -e '.[dev,notebook,ray]'
	touch $(STAMP)

# The CLI's default method unless METHOD=... (DDPG+HER+SL; with a Fetch preset DDPG+HER+SL+Fast,
# train.PRESET_METHODS); a library method builds the skill library first if there is none (on
# Fetch for a Fetch task: make train TASK=fetch_pick_and_place).
train: setup
	@if [ "$(METHOD)" != ddpg_her ] && [ ! -f $(LIBRARY)/manifest.json ]; then $(MAKE) skills ROBOT=$(ROBOT) SKILL_LIBRARY=$(SKILL_LIBRARY); fi
	$(BIN)/python -m mjx_skills.train $(METHOD) $(if $(PRESET),--preset $(PRESET)) --task $(TASK) --epochs $(EPOCHS) --seeds $(SEEDS) --out $(OUT) $(ARGS)

# Go on with an interrupted (or finished, with ARGS="--epochs N") run: make resume RUN=runs/...
resume: setup
	@test -n "$(RUN)" || { echo "make resume RUN=RUN_DIR (the run directory train printed)"; exit 2; }
	$(BIN)/python -m mjx_skills.train --resume $(RUN) $(ARGS)

# A run's learning curve (eval success over env steps): make plot RUN=runs/... -> RUN/curve.png
plot: setup
	@test -n "$(RUN)" || { echo "make plot RUN=RUN_DIR"; exit 2; }
	$(BIN)/python -m mjx_skills.plot $(RUN) $(ARGS)

# Train transit / grasp / transfer, collect their data, fit their models.
# ROBOT=fetch builds the same skills on Fetch into experiments/skill_library_fetch;
# ROBOT=fetch SKILL_LIBRARY=SL_fetch_push the push library into experiments/skill_library_SL_fetch_push.
skills: setup
	$(BIN)/python -m mjx_skills.build_library --robot $(ROBOT) $(if $(SKILL_LIBRARY),--library $(SKILL_LIBRARY)) $(ARGS)

# The thesis's experiments: make sweep ARGS="--experiment fig6_3" (see --list).
sweep: setup
	$(BIN)/python -m mjx_skills.sweep $(ARGS)

# docs/results.md, its figures and the README's table from the stored cells (the study, study/).
report: setup
	$(BIN)/python -m study.report $(ARGS)

bench: setup
	$(BIN)/python benchmarks/physics.py
	$(BIN)/python benchmarks/train_throughput.py

# Ours against Stable-Baselines3 (installs the bench extra: torch CPU, SB3).
bench-peer: setup
	$(BIN)/pip install --quiet -e '.[bench]'
	MJX_SKILLS_CACHE_DIR=off $(BIN)/python benchmarks/peer_sb3.py --tasks transit --sb3-epochs 80 --seeds 3

# The whole suite, learning tests included (what CI runs).
test: setup
	$(BIN)/python -m pytest -q tests

# Skips the long learning tests (marked slow).
test-fast: setup
	$(BIN)/python -m pytest -q -m "not slow" tests

lint: setup
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

# Execute experiments/analysis.ipynb headless: analysis.executed.ipynb + experiments/figures/*.png.
# The sweeps' CSV/JSONL the notebook reads, made from the stored cells (seconds each; nothing
# trains): derived files, not committed (experiments/results/cells/ is the record).
results: setup
	for e in fig6_3 fig6_4 fig6_5; do $(BIN)/python -m mjx_skills.sweep --experiment $$e --overwrite --no-progress || exit 1; done

notebook: results
	$(BIN)/python experiments/run_notebook.py

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache build *.egg-info
