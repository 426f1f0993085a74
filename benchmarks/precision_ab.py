"""Learning A/B of ``precision=fp32`` against ``precision=bf16`` (and ``bf16_targets``): the same recipe, several
seeds each.

Reads finished run directories (TensorBoard events and ``metrics.json``), writes beside ``--out``:

- ``precision_ab.md``: the final evaluation per precision, mean ± 95% CI across seeds, per-seed values
  (``success_last3``: the mean success of each run's last three evaluations);
- ``precision_ab.png``: the critics' Q-value and TD-error curves and the evaluation success, per
  precision (thin lines: seeds, thick: their mean).

    python benchmarks/precision_ab.py --fp32 RUN... --bf16 RUN... [--bf16-targets RUN...]
        [--fp32-hand-written RUN...] --out DIR
"""

from __future__ import annotations

import argparse
import glob
import json
import sys
from pathlib import Path

import torch

from formation_rl.evaluation.evaluate import mean_ci

METRICS = ("success", "success_last3", "at_goal", "UDBLT", "RFSE", "CBRS", "CBRO", "episode_reward")
CURVES = (("algo/q_value", "critic Q-value (batch mean)"), ("algo/td_error", "|TD error| (batch mean)"),
          ("eval/success", "evaluation success"))


def scalars(run: Path) -> dict[str, tuple[list[int], list[float]]]:
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    events = glob.glob(str(run / "tb" / "**" / "events*"), recursive=True)
    if not events:
        sys.exit(f"--runs: {run} has no TensorBoard events (tb/); pass finished run directories")
    acc = EventAccumulator(events[0], size_guidance={"scalars": 0})
    acc.Reload()
    out = {}
    for tag, _ in CURVES:
        if tag in acc.Tags()["scalars"]:
            ev = acc.Scalars(tag)
            out[tag] = ([e.step for e in ev], [e.value for e in ev])
    return out


def final(run: Path) -> dict[str, float]:
    path = run / "metrics.json"
    if not path.exists():
        sys.exit(f"--runs: {run} has no metrics.json; pass finished run directories")
    m = json.loads(path.read_text())
    m = m.get("final", m)
    out = {k: float(m[k]) for k in METRICS if k in m}
    # the final success swings with the 5 cm goal radius: also the mean of the last three evaluations
    curve = scalars(run).get("eval/success")
    if curve:
        out["success_last3"] = sum(curve[1][-3:]) / len(curve[1][-3:])
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--fp32", nargs="+", type=Path, required=True)
    p.add_argument("--bf16", nargs="+", type=Path, default=[])
    p.add_argument("--bf16-targets", nargs="+", type=Path, default=[])
    p.add_argument("--fp32-hand-written", nargs="+", type=Path, default=[],
                   help="fp32 runs made through the bf16 paths' hand-written layers (PerRobotMLP.hand_written=True, a"
                        " one-line patch): tells bf16 rounding from the layers' other summation order")
    p.add_argument("--out", type=Path, required=True)
    args = p.parse_args()
    arms = (("fp32", args.fp32), ("bf16", args.bf16), ("bf16_targets", args.bf16_targets),
            ("fp32_hand_written", args.fp32_hand_written))
    groups = {g: r for g, r in arms if r}
    if len(groups) < 2:
        p.error("--bf16, --bf16-targets or --fp32-hand-written: at least one arm to set beside --fp32")
    args.out.mkdir(parents=True, exist_ok=True)

    lines = ["| metric | " + " | ".join(f"{g} (mean ± 95% CI, n={len(r)})" for g, r in groups.items())
             + "".join(f" | per seed {g}" for g in groups) + " |", "|---|" + "---|" * (2 * len(groups))]
    finals = {g: [final(r) for r in runs] for g, runs in groups.items()}
    for k in METRICS:
        cells, seeds = [], []
        for g in groups:
            vals = torch.tensor([f[k] for f in finals[g] if k in f], dtype=torch.float64)
            m, h = mean_ci(vals)
            cells.append(f"{m:.3g} ± {h:.2g}")
            seeds.append(", ".join(f"{v:.3g}" for v in vals.tolist()))
        lines.append(f"| {k} | " + " | ".join(cells) + " | " + " | ".join(seeds) + " |")
    (args.out / "precision_ab.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(CURVES), figsize=(5 * len(CURVES), 3.6))
    for (tag, title), ax in zip(CURVES, axes, strict=True):
        for g, color in zip(groups, ("tab:blue", "tab:orange", "tab:green", "tab:red"), strict=False):
            curves = [scalars(r).get(tag) for r in groups[g]]
            curves = [c for c in curves if c]
            for x, y in curves:
                ax.plot(x, y, color=color, alpha=0.3, lw=0.8)
            n = min(len(c[0]) for c in curves) if curves else 0
            if n:
                mean = torch.tensor([c[1][:n] for c in curves]).mean(0)
                ax.plot(curves[0][0][:n], mean, color=color, lw=2, label=g)
        ax.set_title(title)
        ax.set_xlabel("frames")
        ax.legend()
    fig.tight_layout()
    fig.savefig(args.out / "precision_ab.png", dpi=110)
    print(f"wrote {args.out / 'precision_ab.md'} and {args.out / 'precision_ab.png'}")


if __name__ == "__main__":
    main()
