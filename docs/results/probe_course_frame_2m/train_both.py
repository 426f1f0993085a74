"""Probe driver (the runs of this folder): `python train_both.py RUN_DIR override...` trains as apps.train does (compose API, same config) and,
after every validation evaluation of the deployed actors (algo.deploy), evaluates the trained actors too
(the same episodes), logging them to RUN_DIR/actor_evals.jsonl; metrics.json as apps.train writes it."""
import json, sys
from pathlib import Path
import torch
from hydra import compose, initialize_config_dir
from torchrl.envs.utils import ExplorationType, set_exploration_type
from formation_rl.apps.cli import CONF
from formation_rl.envs.metrics import episode_metrics, summarize
from formation_rl.training.config import register
from formation_rl.training.trainer import Trainer, to_train_config

register()
run_dir, overrides = Path(sys.argv[1]), sys.argv[2:]
with initialize_config_dir(str(CONF), version_base=None):
    cfg = compose("config", overrides=overrides)
run_dir.mkdir(parents=True, exist_ok=False)
(run_dir / "overrides.json").write_text(json.dumps(overrides))
trainer = Trainer(to_train_config(cfg), run_dir)
print("precision", trainer.cfg.precision, flush=True)
log = open(run_dir / "actor_evals.jsonl", "a")

@torch.no_grad()
def actor_eval(frames, deployed):
    t = trainer
    t.eval_env.set_seed(t.cfg.eval_seed)
    with set_exploration_type(ExplorationType.DETERMINISTIC):
        ro = t.eval_env.rollout(t.cfg.env.max_steps, t.actor, break_when_any_done=False)
    m = summarize(episode_metrics(ro, t.cfg.env.goal_radius))
    log.write(json.dumps({"frames": frames, "actor": m, "deployed": deployed}) + "\n"); log.flush()

trainer.on_evaluate.append(actor_eval)
metrics = trainer.train()
(run_dir / "metrics.json").write_text(json.dumps(metrics, indent=2))
print("final", json.dumps(metrics), "best", json.dumps(trainer.best), "wall", trainer.timings.total(), flush=True)
