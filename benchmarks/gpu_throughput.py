"""Training throughput on a GPU: eager gradient steps against CUDA-graphed ones (``cudagraphs=true``).

    python benchmarks/gpu_throughput.py [--frames 300000] [--json FILE]

Per algorithm, two real :class:`~formation_rl.training.trainer.Trainer` runs at the paper's settings (one
gradient step of batch 1024 per 100 frames, 64 env copies, ``device=cuda``), one with the eager
update and one replaying it from CUDA graphs, in this one process: frames/s, gradient steps/s,
the split of the wall time, and the ratio graphed / eager. Needs CUDA.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import tempfile
import time
from pathlib import Path

import torch

from formation_rl.training.trainer import Trainer

sys.path.insert(0, str(Path(__file__).resolve().parent))
from train_throughput import make_config  # noqa: E402

PAPER = dict(num_envs=64, steps_per_batch=25, eval_episodes=100, progress=False, device="cuda")


def measure(algo: str, cudagraphs: bool, frames: int) -> dict:
    cfg = make_config(algo, total_frames=frames, eval_interval=10 * frames, checkpoint_interval=10 * frames,
                      cudagraphs=cudagraphs, **PAPER)  # the algorithm's conf/algo/*.yaml
    with tempfile.TemporaryDirectory() as tmp:
        trainer = Trainer(cfg, tmp)
        start = time.perf_counter()
        trainer.train()
        torch.cuda.synchronize()
        seconds = time.perf_counter() - start
        trained = trainer.timings.total() - trainer.timings.seconds["evaluation"] - trainer.timings.seconds["setup"]
        return {"frames_per_s": frames / trained, "grad_steps_per_s": trainer.algo.critic_steps / trained,
                "wall_s": seconds, "split": trainer.timings.summary()}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=300_000, help="frames per run (default 300,000)")
    parser.add_argument("--algos", default="per_matd3,matd3,maddpg", help="comma-separated (default: all three)")
    parser.add_argument("--json", default=None, help="also write the results to this JSON file")
    args = parser.parse_args(argv)
    if not torch.cuda.is_available():
        print("error: CUDA is not available: this benchmark needs a GPU", file=sys.stderr)
        return 2
    logging.getLogger("torchrl").setLevel(logging.WARNING)
    results = {"device": torch.cuda.get_device_name(), "torch": torch.__version__, "frames": args.frames}
    for algo in args.algos.split(","):
        eager, graphed = measure(algo, False, args.frames), measure(algo, True, args.frames)
        results[algo] = {"eager": eager, "cudagraphs": graphed,
                         "speedup": graphed["frames_per_s"] / eager["frames_per_s"]}
        for name, r in (("eager", eager), ("cudagraphs", graphed)):
            print(f"{algo:>9} {name:>10}: {r['frames_per_s']:7,.0f} frames/s, {r['grad_steps_per_s']:5.1f} "
                  f"gradient steps/s ({r['split']})")
        print(f"{algo:>9} cudagraphs / eager: {results[algo]['speedup']:.2f}x", flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
