"""curve.csv of a run: every eval/* scalar per frames, over all its tb event files (a resume adds one)."""
import csv, glob, os, sys
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator
run, out = sys.argv[1], sys.argv[2]
rows = {}
for f in sorted(glob.glob(os.path.join(run, "tb", "events*"))):
    ea = EventAccumulator(f, size_guidance={"scalars": 0}); ea.Reload()
    for k in ea.Tags()["scalars"]:
        if k.startswith("eval/"):
            for e in ea.Scalars(k):
                rows.setdefault(e.step, {})[k[5:]] = e.value
keys = sorted({k for r in rows.values() for k in r})
with open(out, "w", newline="") as fh:
    w = csv.writer(fh); w.writerow(["frames"] + keys)
    for s in sorted(rows):
        w.writerow([s] + [f"{rows[s][k]:.4g}" if k in rows[s] else "" for k in keys])
print(out, len(rows), "rows")
