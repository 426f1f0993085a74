"""Probe driver: trains as apps.train does (compose API) and keeps, beside the run, exponential moving averages
of the trained actors' parameters (per actor step, decays from argv EMA=0.997,0.999); after every validation
evaluation of the deployed actors it evaluates the trained actors and each average on the same episodes
(RUN_DIR/actor_evals.jsonl) and keeps each average's best validation policy (RUN_DIR/ema_<decay>_best/policy.pt,
success then RFSE, the trainer's rule) and its final one (ema_<decay>_final/policy.pt), loadable as policy files."""
import contextlib, json, sys
from pathlib import Path
import torch
from hydra import compose, initialize_config_dir
from torchrl.envs.utils import ExplorationType, set_exploration_type
from formation_rl.apps.cli import CONF
from formation_rl.envs.metrics import episode_metrics, summarize
from formation_rl.training.config import register
from formation_rl.training.trainer import Trainer, to_train_config, _better

register()
run_dir, args = Path(sys.argv[1]), sys.argv[2:]
decays = [0.997, 0.999]
overrides = []
for a in args:
    if a.startswith("EMA="):
        decays = [float(x) for x in a[4:].split(",")]
    else:
        overrides.append(a)
with initialize_config_dir(str(CONF), version_base=None):
    cfg = compose("config", overrides=overrides)
run_dir.mkdir(parents=True, exist_ok=False)
(run_dir / "overrides.json").write_text(json.dumps(overrides + [f"EMA={decays}"]))
trainer = Trainer(to_train_config(cfg), run_dir)
print("precision", trainer.cfg.precision, flush=True)
log = open(run_dir / "actor_evals.jsonl", "a")
params = trainer.algo.loss.actor_network_params
emas = {d: params.detach().clone() for d in decays}
best = {d: None for d in decays}
update = trainer.algo.update

def update_with_ema(batch):
    before = trainer.algo.actor_steps
    out = update(batch)
    if trainer.algo.actor_steps != before:
        with torch.no_grad():
            for d, e in emas.items():
                e.lerp_(params.detach(), 1.0 - d)
    return out
trainer.algo.update = update_with_ema

def state_of(ema):
    with ema.to_module(trainer.actor):
        return {k: v.detach().clone() for k, v in trainer.actor.state_dict().items()}

@torch.no_grad()
def run_eval(ema=None):
    """The validation episodes with the trained actors, or with ``ema``'s parameters swapped in."""
    t = trainer
    t.eval_env.set_seed(t.cfg.eval_seed)
    swap = contextlib.nullcontext() if ema is None else ema.to_module(t.actor)
    with set_exploration_type(ExplorationType.DETERMINISTIC), swap:
        ro = t.eval_env.rollout(t.cfg.env.max_steps, t.actor, break_when_any_done=False)
    return summarize(episode_metrics(ro, t.cfg.env.goal_radius))

def hook(frames, deployed):
    rec = {"frames": frames, "actor": run_eval(), "deployed": deployed}
    for d, e in emas.items():
        m = run_eval(e)
        rec[f"ema_{d}"] = m
        if frames > 0 and _better(m, best[d]):
            best[d] = {"frames": frames, "success": m["success"], "RFSE": m["RFSE"]}
            (run_dir / f"ema_{d}_best").mkdir(exist_ok=True)
            torch.save({**trainer.policy_state(), "actor": state_of(e), "validation": best[d]},
                       run_dir / f"ema_{d}_best" / "policy.pt")
    log.write(json.dumps(rec) + "\n"); log.flush()

trainer.on_evaluate.append(hook)
metrics = trainer.train()
for d, e in emas.items():
    (run_dir / f"ema_{d}_final").mkdir(exist_ok=True)
    torch.save({**trainer.policy_state(), "actor": state_of(e)}, run_dir / f"ema_{d}_final" / "policy.pt")
(run_dir / "metrics.json").write_text(json.dumps(metrics, indent=2))
print("final", json.dumps(metrics), "best", json.dumps(trainer.best), "ema_best", json.dumps(best),
      "wall", trainer.timings.total(), flush=True)
