"""Write the study's summary.md (the tune app's own summary) and trials.json (every trial: state, score, parameters,
intermediate scores, final validation metrics) beside this file, from outputs/tune/hindsight.db or a given file:

    python docs/results/tune_hindsight_2026-12-03/export.py [outputs/tune/hindsight.db]
"""

import json
import shutil
import sys
from pathlib import Path

import optuna

from formation_rl.apps.tune import summary

HERE = Path(__file__).parent


def main(db: Path) -> None:
    study = optuna.load_study(study_name="hindsight", storage=f"sqlite:///{db.resolve()}")
    (HERE / "summary.md").write_text(summary(study))
    rows = []
    for t in study.trials:
        final = {}
        run = Path(t.user_attrs.get("run_dir", "-")) / "metrics.json"
        if run.exists():
            final = json.loads(run.read_text())
        rows.append({"number": t.number, "state": t.state.name, "score": t.value, "params": t.params,
                     "intermediate": {str(k): v for k, v in sorted(t.intermediate_values.items())},
                     "final_metrics": final or {k: v for k, v in t.user_attrs.items() if isinstance(v, float)},
                     "added_from": t.user_attrs.get("added_from")})
    (HERE / "trials.json").write_text(json.dumps(rows, indent=1))
    if db.resolve() != (HERE / "hindsight.db").resolve():
        shutil.copy(db, HERE / "hindsight.db")
    print(f"wrote {HERE}/summary.md, trials.json, hindsight.db ({len(rows)} trials)")


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "outputs/tune/hindsight.db"))
