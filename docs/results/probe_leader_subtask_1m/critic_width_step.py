"""The whole task's PER-MATD3 gradient step (N=5, batch 1024, fp32) with the recipe's critics (128 wide, the leader's
layer-normalised) and with 256-wide ones (`model.critic_hidden=[256,256]`), alternated in one process:
``python docs/results/probe_leader_subtask_1m/critic_width_step.py [THREADS]``; prints the medians and their ratio."""

import statistics
import sys
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "benchmarks"))
import train_throughput as tt  # noqa: E402

from formation_rl.models import make_critic  # noqa: E402



def critics(width: int):
    """``grad_step``'s critic factory with ``width``-wide layers, the leader's layer-normalised (the recipe's)."""
    return lambda n, d, hidden: make_critic(n, d, (width, width), layer_norm=(0,))


torch.set_num_threads(int(sys.argv[1]) if len(sys.argv) > 1 else 1)
times: dict[int, list[float]] = {128: [], 256: []}
for _ in range(3):
    for width in times:
        tt.make_critic = critics(width)
        times[width].append(tt.grad_step("per_matd3", steps=12)["ms"])
med = {w: statistics.median(v) for w, v in times.items()}
print(f"{torch.get_num_threads()} threads: 128-wide critics {med[128]:.1f} ms, 256-wide {med[256]:.1f} ms, "
      f"ratio {med[256] / med[128]:.2f}")
