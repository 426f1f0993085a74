"""Validation (the run's own evaluations) against held-out test (make eval on each copied policy), per evaluation."""
import csv, json, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
D, E = sys.argv[1], sys.argv[2]  # results folder prefix, snapshot eval folder
fig, axes = plt.subplots(1, 2, figsize=(11, 3.8))
for s, ls in ((0, "-"), (1, "--")):
    curve = {int(r["frames"]): r for r in csv.DictReader(open(f"{D}_seed{s}/curve.csv"))}
    rows = []
    for f in sorted(curve):
        try:
            m = json.load(open(f"{E}/seed{s}/{f}/metrics.json"))
        except FileNotFoundError:
            continue
        c = curve[f]
        rows.append([f, float(c["success"]), m["success"], float(c["at_goal"]), m["at_goal"], float(c["RFSE"]), m["RFSE"]])
    with open(f"{D}_seed{s}/snapshots_heldout.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["frames", "validation_success", "heldout_success", "validation_at_goal", "heldout_at_goal",
                    "validation_RFSE", "heldout_RFSE"])
        w.writerows([[r[0]] + [f"{v:.4g}" for v in r[1:]] for r in rows])
    x = [r[0] / 1e6 for r in rows]
    axes[0].plot(x, [r[1] for r in rows], "C0" + ls, marker="o", ms=3, label=f"validation, seed {s}")
    axes[0].plot(x, [r[2] for r in rows], "C1" + ls, marker="o", ms=3, label=f"held-out test, seed {s}")
    axes[1].plot(x, [r[5] for r in rows], "C0" + ls, marker="o", ms=3, label=f"validation, seed {s}")
    axes[1].plot(x, [r[6] for r in rows], "C1" + ls, marker="o", ms=3, label=f"held-out test, seed {s}")
axes[0].set(xlabel="frames (M)", ylabel="success", title="success per evaluation (1,000 episodes each)")
axes[1].set(xlabel="frames (M)", ylabel="RFSE (m)", title="formation error per evaluation")
axes[1].axhline(3.0, color="gray", lw=0.8, ls=":"); axes[1].text(1.6, 3.05, "pretrained/per_matd3.pt", fontsize=7, color="gray")
axes[0].legend(fontsize=7); fig.tight_layout()
fig.savefig(f"{D}_seed0/validation_vs_heldout.png", dpi=110)
