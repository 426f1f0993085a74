# formation_rl: one-command jobs. `make help` lists them.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
ARGS ?=
ALGO ?= per_matd3
RECIPE ?= hindsight
RUNS ?= outputs
CKPT ?=
JOBS ?= $(shell nproc)
SWEEP ?= outputs/sweep

STUDY ?= recipe
# "a b" -> [a,b]: a space-separated CKPT or RUNS as one Hydra list
empty :=
comma := ,
hydra_list = [$(subst $(empty) $(empty),$(comma),$(strip $(1)))]

.PHONY: tune help setup train train-paper train-fast eval diagnose ceiling render sweep compare tensorboard demo test test-integration test-slow bench-env bench bench-gpu lint clean

help:  ## list the targets
	@grep -E '^[a-z-]+:.*## ' $(MAKEFILE_LIST) | awk -F':.*## ' '{printf "  make %-10s %s\n", $$1, $$2}'

$(PY): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[dev]'
	@touch $(PY)

setup: $(PY)  ## create .venv and install the package with its dev tools

train: $(PY)  ## train ALGO with RECIPE (hindsight: our from-scratch PER-MATD3 recipe, ~10-37 min by CPU host; paper: the paper's setup, 3 min); ARGS = Hydra overrides
	$(PY) -m formation_rl.apps.train algo=$(ALGO) recipe=$(RECIPE) $(ARGS)

train-paper: $(PY)  ## train ALGO on the paper's budget (9M frames, 90,000 gradient steps)
	$(PY) -m formation_rl.apps.train algo=$(ALGO) budget=paper $(ARGS)

train-fast: $(PY)  ## our quickest recipe (~10 min): actors correcting the classical controller, PER-MATD3 anchored to it
	$(PY) -m formation_rl.apps.train algo=$(ALGO) budget=fast $(ARGS)

eval: $(PY)  ## evaluate CKPT (policy.pt, last.pt or run dir) on 1,000 held-out episodes; ARGS = overrides
	$(PY) -m formation_rl.apps.evaluate ckpt=$(CKPT) $(ARGS)

diagnose: $(PY)  ## why CKPT's episodes fail (several: CKPT="a b"): success split into its parts, first collisions
	$(PY) -m formation_rl.apps.diagnose 'ckpt=$(call hydra_list,$(CKPT))' $(ARGS)

ceiling: $(PY)  ## what the 0.2 m obstacle sensing range allows a reactive team: apf gains searched per range (~10 min)
	$(PY) -m formation_rl.apps.ceiling $(ARGS)

render: $(PY)  ## one held-out episode of CKPT as a GIF and a Figure-10 PNG
	$(PY) -m formation_rl.apps.render ckpt=$(CKPT) $(ARGS)

sweep: $(PY)  ## algo x seed multirun (JOBS parallel jobs) into SWEEP; ARGS e.g. "total_frames=20000"
	SWEEP_JOBS=$(JOBS) $(PY) -m formation_rl.apps.train -m hydra/launcher=local hydra.sweep.dir=$(SWEEP) \
		algo=maddpg,matd3,per_matd3 seed=0,1,2 threads=1 progress=false $(ARGS)

tune: $(PY)  ## Optuna study of the training recipe (SQLite in outputs/tune/, resumable; ARGS e.g. "trials=40 workers=2")
	$(PY) -m formation_rl.apps.tune study=$(STUDY) $(ARGS)

compare: $(PY)  ## Figures 6-9 and Table 1 from RUNS (run dirs or a sweep dir); ARGS e.g. "by=env.reward.variant"
	$(PY) -m formation_rl.apps.report 'runs=$(call hydra_list,$(RUNS))' $(ARGS)

tensorboard: $(PY)  ## serve TensorBoard over RUNS (default outputs/); ARGS e.g. "--port 6007 --bind_all"
	$(VENV)/bin/tensorboard --logdir $(RUNS) $(ARGS)

demo: $(PY)  ## roll 64 copies for one episode, print metrics (docs/reference.md), write a GIF (ARGS = Hydra overrides)
	$(PY) -m formation_rl.apps.demo $(ARGS)

test: $(PY)  ## the unit tests (in-process, a few minutes)
	$(PY) -m pytest -q -m "not slow and not integration"

test-integration: $(PY)  ## the integration tests: commands in subprocesses, kill -9, the wheel, the shipped policies
	$(PY) -m pytest -q -m "integration and not slow"

test-slow: $(PY)  ## the long checks marked slow (10^6 random steps ...)
	$(PY) -m pytest -q -m slow

bench-env: $(PY)  ## environment throughput, frames/s for B in {1, 64, 1024, 4096}
	$(PY) benchmarks/env_throughput.py --json benchmarks/env_throughput.json $(ARGS)

bench: $(PY)  ## training throughput: gradient step vs matmul rate, end-to-end split, scaling in N and B (~6-10 min by machine)
	$(PY) benchmarks/train_throughput.py --json benchmarks/train_throughput.json $(ARGS)

bench-gpu: $(PY)  ## on a CUDA machine: eager vs cudagraphs=true training frames/s per algorithm (~6 min)
	$(PY) benchmarks/gpu_throughput.py --frames 200000 --json benchmarks/gpu_throughput.json $(ARGS)

lint: $(PY)  ## ruff
	$(VENV)/bin/ruff check formation_rl tests benchmarks

clean:  ## remove caches (keeps outputs/ and .venv)
	rm -rf .pytest_cache .ruff_cache build dist *.egg-info
