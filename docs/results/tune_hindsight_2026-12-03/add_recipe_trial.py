"""Add recipe=hindsight itself to the study as a finished trial, from its seed-0 run, so that the study ranks the
recipe against its neighbours without training it again (that run is deterministic: two fresh clones reproduced
its final validation to the last digit). Run before the study's first worker:

    python docs/results/tune_hindsight_2026-12-03/add_recipe_trial.py outputs/train/per_matd3/hindsight_2m_seed0
"""

import json
import sys
from pathlib import Path

import optuna
from omegaconf import OmegaConf

from formation_rl.apps.tune import TuneConfig, load_study, score

HERE = Path(__file__).parent
RECIPE = {"env.reward.follower_error": 2.0, "env.reward.obstacle_collision": -20.0, "env.reward.goal": 10.0,
          "env.reward.scale": 1.0, "algo.gamma": 0.95, "algo.lr_critic": 1e-3, "algo.exploration_sigma": 0.3}


def distribution(spec):
    if spec["type"] == "categorical":
        return optuna.distributions.CategoricalDistribution(list(spec["choices"]))
    kind = optuna.distributions.FloatDistribution if spec["type"] == "float" else optuna.distributions.IntDistribution
    return kind(spec["low"], spec["high"], log=spec.get("log", False))


def main(run: Path) -> None:
    raw = OmegaConf.load(HERE / "tune_hindsight.yaml")
    cfg = OmegaConf.to_object(OmegaConf.merge(OmegaConf.structured(TuneConfig),
                                              {k: v for k, v in raw.items() if k not in ("defaults", "hydra")}))
    study = load_study(cfg)
    if any(t.user_attrs.get("added_from") for t in study.trials):
        sys.exit("the recipe's trial is already in the study")
    sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "tests"))
    from helpers import scalars  # TensorBoard scalars of a run, as the tests read them

    s = {k: dict(v) for k, v in scalars(run).items()}
    keys = ("success", "at_goal", "UDBLT", "RFSE")
    steps = sorted(s["eval/success"])
    curve = {step: score({k: s[f"eval/{k}"][step] for k in keys}) for step in steps if step > 0}
    final = json.loads((run / "metrics.json").read_text())
    attrs = {k: final[k] for k in ("success", "at_goal", "RFSE", "CBRO", "CBRS", "UDBLT")}
    trial = optuna.trial.create_trial(
        params=RECIPE, distributions={k: distribution(cfg.space[k]) for k in RECIPE}, value=score(final),
        intermediate_values={step: v for step, v in curve.items() if step < max(steps)},
        user_attrs={**attrs, "run_dir": str(run), "added_from": str(run), "overrides": ["recipe=hindsight", "seed=0"]})
    study.add_trial(trial)
    print(f"added trial {len(study.trials) - 1}: score {score(final):.4f}, curve {curve}")


if __name__ == "__main__":
    main(Path(sys.argv[1]))
