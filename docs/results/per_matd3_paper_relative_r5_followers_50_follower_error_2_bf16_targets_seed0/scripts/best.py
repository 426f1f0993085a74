"""Pick the snapshot (copied policy.pt) of the best validation evaluation: success, then lower RFSE."""
import glob, os, sys
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator
run = sys.argv[1]
ev = {}
for f in sorted(glob.glob(os.path.join(run, "tb", "events*"))):
    ea = EventAccumulator(f, size_guidance={"scalars": 0}); ea.Reload()
    for k in ("eval/success", "eval/RFSE"):
        for e in ea.Scalars(k):
            ev.setdefault(e.step, {"wall": e.wall_time})[k] = e.value
snaps = []
for p in sorted(glob.glob(os.path.join(run, "snapshots", "policy_*.pt"))):
    m = int(p.rsplit("_", 1)[1][:-3])
    before = [s for s in ev if ev[s]["wall"] <= m + 1]
    step = max(before, key=lambda s: ev[s]["wall"])
    snaps.append((ev[step]["eval/success"], -ev[step]["eval/RFSE"], step, p))
best = max(snaps)
for s in sorted(snaps, key=lambda x: x[2]):
    print(s[2], round(s[0], 3), round(-s[1], 3), os.path.basename(s[3]), "<- best" if s is best else "")
print("BEST", best[3], best[2])
