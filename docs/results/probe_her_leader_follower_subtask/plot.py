"""her_ab.png: success and the leader's final distance over training, with and without hindsight goals."""
import csv
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

here = Path(sys.argv[1] if len(sys.argv) > 1 else Path(__file__).parent)
fig, axes = plt.subplots(1, 2, figsize=(9, 3.4))
for run in sorted(here.glob("her*_seed*")):
    rows = list(csv.DictReader(open(run / "curve.csv")))
    x = [int(r["frames"]) / 1000 for r in rows]
    style = dict(color="tab:blue" if run.name.startswith("her1") else "tab:gray",
                 ls="-" if run.name.endswith("seed0") else "--", label=run.name)
    axes[0].plot(x, [float(r["success"]) for r in rows], **style)
    axes[1].plot(x, [float(r["UDBLT"]) for r in rows], **style)
axes[0].set(xlabel="frames (thousands)", ylabel="validation success")
axes[1].set(xlabel="frames (thousands)", ylabel="UDBLT (m)", yscale="log")
axes[1].axhline(0.05, color="k", lw=0.5)
axes[0].legend(fontsize=8)
fig.tight_layout()
fig.savefig(here / "her_ab.png", dpi=110)
