"""Where a training run's wall time goes: cumulative seconds per section of the loop.

The trainer times each part of its loop (``with timings("update"): ...``) and the collection
policy's forward passes through module hooks; ``split()`` gives the shares that the end of
``make train``, TensorBoard (``perf/share_*``) and ``benchmarks/train_throughput.py`` report.
"""

from __future__ import annotations

import time
from collections import defaultdict
from contextlib import contextmanager

from torch import nn

# sections of one training loop iteration, in the order they run
SECTIONS = ("setup", "env", "policy", "buffer_extend", "buffer_sample", "update", "priority", "metrics", "logging",
            "evaluation", "checkpoint", "behaviour_cloning")


class Timings:
    def __init__(self) -> None:
        self.seconds: dict[str, float] = defaultdict(float)
        self._policy_start = 0.0

    @contextmanager
    def __call__(self, section: str):
        start = time.perf_counter()
        try:
            yield
        finally:
            self.seconds[section] += time.perf_counter() - start

    def add(self, section: str, seconds: float) -> None:
        self.seconds[section] += seconds

    def watch_policy(self, module: nn.Module) -> None:
        """Count ``module``'s forward passes (the collection policy, called inside the collector) as ``policy``."""

        def before(*_):
            self._policy_start = time.perf_counter()

        def after(*_):
            self.seconds["policy"] += time.perf_counter() - self._policy_start

        module.register_forward_pre_hook(before)
        module.register_forward_hook(after)

    def total(self) -> float:
        return sum(self.seconds.values())

    def split(self) -> dict[str, float]:
        """Share of the timed wall time per section, in :data:`SECTIONS` order (sections never entered omitted)."""
        total = max(self.total(), 1e-12)
        return {k: self.seconds[k] / total for k in SECTIONS if k in self.seconds}

    def summary(self) -> str:
        return ", ".join(f"{k} {100 * v:.1f}%" for k, v in self.split().items())
