"""`python target_actor.py RUN...`: each run's final trained actors (checkpoints/policy.pt) against the target actors
its last.pt holds (TD3's Polyak average, tau 0.01 per actor step), both on the 200 validation episodes (seed
1,000,000,007, one thread); writes the two policy files under /work/exp/tgt/<run>/ (any scratch folder) and prints
one JSON line per run (target_actor.txt). The session-22 runs' configs carry env.reward.follower_area (removed since):
dropped before loading, at 0 it changed nothing."""
import sys, json, torch
from pathlib import Path
from formation_rl.evaluation.policy import load_policy
from formation_rl.evaluation.evaluate import evaluate_policy
torch.set_num_threads(int(__import__("os").environ.get("NT", "1")))
for run in sys.argv[1:]:
    run = Path(run)
    pol = torch.load(run / "checkpoints/policy.pt", weights_only=False)
    last = torch.load(run / "checkpoints/last.pt", weights_only=False)
    loss = last["algo"]["loss"]
    tgt = {k.replace("target_actor_network_params.", ""): v for k, v in loss.items() if k.startswith("target_actor_network_params.")}
    assert set(tgt) == set(pol["actor"]), (set(tgt), set(pol["actor"]))
    out = Path("/work/exp/tgt") / run.name; out.mkdir(parents=True, exist_ok=True)
    torch.save({**pol, "actor": tgt}, out / "policy.pt")
    for key in ("follower_area",):
        pol["env"]["reward"].pop(key, None)
    torch.save(pol, out / "actor.pt")
    torch.save({**pol, "actor": tgt}, out / "policy.pt")
    row = {}
    for name, p in (("actor", out / "actor.pt"), ("target", out / "policy.pt")):
        policy = load_policy(p)
        per = evaluate_policy(policy.module, policy.env_config, 200, 200, 1000000007, "cpu", progress=False)
        row[name] = {k: round(float(per[k].float().mean()), 4) for k in ("success", "RFSE", "at_goal", "no_robot_collision", "no_obstacle_collision")}
    print(run.name, json.dumps(row), flush=True)
