"""Does a follower's critic prefer flying faster? For a run's last checkpoint (actors and twin critics), on 100
validation episodes flown by its actors, steps 20-59: each follower's Q (the min of the twins) with its own action
replaced, against Q of the action it took, the others' actions unchanged; mean difference and share of states where
the replacement scores higher.

    python docs/results/probe_assembly_2m/critic_probe.py RUN_DIR [overrides the run was trained with ...]

e.g. ``... outputs/train/per_matd3/hindsight_2m_velfv1_seed0 recipe=hindsight precision=bf16_targets``.
"""
import sys
import tempfile

import torch

from formation_rl.apps.tune import train_config
from formation_rl.evaluation.evaluate import evaluate_policy
from formation_rl.training.trainer import Trainer

if len(sys.argv) < 2:
    sys.exit("usage: python docs/results/probe_assembly_2m/critic_probe.py RUN_DIR [overrides ...]")
torch.set_num_threads(1)
trainer = Trainer(train_config(["eval_episodes=100", *sys.argv[2:]]), tempfile.mkdtemp())
trainer.load_checkpoint(sys.argv[1] + "/checkpoints/last.pt")
qnet, params = trainer.algo.loss.qvalue_network, trainer.algo.loss.qvalue_network_params  # public attributes
flown = evaluate_policy(trainer.actor, trainer.cfg.env, 100, seed=trainer.cfg.eval_seed, progress=False,
                        metrics=lambda r, _: {"obs": r["agents", "observation"][:, 20:60],
                                              "act": r["agents", "action"][:, 20:60],
                                              "vel": r["state", "velocities"][:, 20:60]})
obs, act, vel = (flown[k].flatten(0, 1) for k in ("obs", "act", "vel"))  # steps 20-59 of every episode


def q(action):
    values = []
    for k in range(params.shape[0]):
        with params[k].to_module(qnet):
            values.append(qnet.module(obs, action))
    return torch.stack(values).min(0).values.squeeze(-1)  # [B, N]


with torch.no_grad():
    base = q(act)
    heading = vel[:, 0] / vel[:, 0].norm(dim=-1, keepdim=True).clamp_min(1e-6)
    full = heading / heading.abs().amax(-1, keepdim=True).clamp_min(1e-6)  # full force along the leader's heading
    print(f"{sys.argv[1]}: followers' speed {vel[:, 1:].norm(dim=-1).mean():.2f} m/s, leader's "
          f"{vel[:, 0].norm(dim=-1).mean():.2f} (steps 20-59)\n"
          "| follower's action replaced by | follower 1 | 2 | 3 | 4 |\n|---|---|---|---|---|")
    for name, alt in (("full force along the leader's heading", full), ("zero force", torch.zeros_like(full)),
                      ("full force against the leader's heading", -full)):
        cells = []
        for i in range(1, act.shape[1]):
            changed = act.clone()
            changed[:, i] = alt
            d = q(changed)[:, i] - base[:, i]
            cells.append(f"dQ {d.mean():+.2f}, higher in {100 * (d > 0).float().mean():.0f}%")
        print(f"| {name} | " + " | ".join(cells) + " |")
