"""her_vs_baseline.png: validation success, leader at goal and RFSE over training, the 51.9% setup with and
without hindsight goals (algo.her=1), seeds 0 and 1, from each results folder's curve.csv."""
import csv
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

results = Path(__file__).resolve().parents[1]
arms = {"algo.her=0 (the 51.9% setup)": ("per_matd3_paper_relative_r5_followers_50_bf16_targets_seed{}", "tab:gray"),
        "algo.her=1": ("per_matd3_paper_relative_r5_followers_50_her_bf16_targets_seed{}", "tab:blue")}
fig, axes = plt.subplots(1, 3, figsize=(12, 3.4))
for label, (folder, color) in arms.items():
    for seed, ls in ((0, "-"), (1, "--")):
        rows = sorted(csv.DictReader(open(results / folder.format(seed) / "curve.csv")), key=lambda r: int(r["frames"]))
        x = [int(r["frames"]) / 1e6 for r in rows]
        for ax, key in zip(axes, ("success", "at_goal", "RFSE")):
            ax.plot(x, [float(r[key]) for r in rows], color=color, ls=ls, label=f"{label}, seed {seed}")
for ax, name in zip(axes, ("validation success", "leader at goal", "RFSE (m)")):
    ax.set(xlabel="frames (millions)", ylabel=name)
axes[2].set_ylim(0, 20)
fig.legend(*axes[0].get_legend_handles_labels(), loc="lower center", ncol=4, fontsize=8)
fig.tight_layout(rect=(0, 0.1, 1, 1))
fig.savefig(Path(__file__).parent / "her_vs_baseline.png", dpi=100)
