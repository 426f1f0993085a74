"""Evaluation: loading a trained policy (or the classical controller), the protocol of reference.md on held-out
episodes, and the failure metrics. Imports no training code (:mod:`formation_rl.training`)."""

from formation_rl.evaluation.evaluate import EVAL_SEED, evaluate_policy, mean_ci
from formation_rl.evaluation.policy import Policy, load_policy

__all__ = ["EVAL_SEED", "Policy", "evaluate_policy", "load_policy", "mean_ci"]
