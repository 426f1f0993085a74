"""Compare runs: the paper's Figures 6-9 and Table 1 from TensorBoard events and final evaluations.

    python -m formation_rl.apps.report runs=[RUN_OR_SWEEP_DIR,...] [by=algo.name] [out=DIR] [smooth=0.9]

Each run directory (Hydra's, with ``.hydra/config.yaml`` and ``tb/``) is grouped by a config key;
curves are the mean over the group's seeds with a shaded min-max spread, smoothed; Table 1 takes
each run's final evaluation (the ``make eval`` of its checkpoint when present: ``outputs/eval/<run>``
given among the runs, or ``checkpoints/metrics.json``; else the training run's ``metrics.json``)
and reports mean ± 95% CI across seeds beside the paper's numbers.

A directory written by ``make eval ... ARGS="out=DIR"`` (a ``metrics.json`` that records its evaluation) counts
as a run without curves: it enters Table 1, grouped by the same keys (``algo.name``, ``env.reward.variant``, ...
read from what it records), and no figure. So the table can be rebuilt from the ``metrics.json`` files kept in
``docs/results`` after the training runs' TensorBoard directories are gone.
"""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import hydra
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402
import yaml  # noqa: E402
from hydra.core.config_store import ConfigStore  # noqa: E402
from omegaconf import DictConfig, OmegaConf  # noqa: E402

from formation_rl.apps.cli import CONF, as_list, one_line_errors  # noqa: E402
from formation_rl.evaluation.evaluate import mean_ci  # noqa: E402

# the paper's Table 1 (CBRO %, UDBLT m, RFSE m)
PAPER = {"maddpg": (3.72, 0.15, 2.28), "matd3": (4.29, 0.05, 1.09), "per_matd3": (2.37, 0.08, 0.36)}
TABLE_METRICS = ("episode_reward", "CBRS", "CBRO", "UDBLT", "RFSE", "success")
FIGURES = {  # file: (title, [(tag, label)], y label)
    "fig6_episode_reward.png": ("Episode reward (Fig. 6)", [("train/episode_reward", None)], "episode reward"),
    "fig7_collisions.png": ("Collision rates (Fig. 7)", [("train/CBRS", "CBRS"), ("train/CBRO", "CBRO")], "% of steps"),
    "fig8_udblt.png": ("Leader-to-goal distance at the last step (Fig. 8)", [("train/UDBLT", None)], "UDBLT (m)"),
    "fig9_rfse.png": ("Formation error (Fig. 9)", [("train/RFSE", None)], "RFSE (m)"),
}

# time to quality: the first periodic evaluation meeting every bound (metric, "<=" or ">=", value)
THRESHOLDS = {
    "UDBLT <= 0.08 m": [("UDBLT", "<=", 0.08)],
    "success >= 10%": [("success", ">=", 0.10)],
    "paper PER-MATD3 row + 90% success": [("CBRO", "<=", 2.37), ("UDBLT", "<=", 0.08), ("RFSE", "<=", 0.36),
                                          ("success", ">=", 0.90)],
}


@dataclass
class ReportConfig:
    runs: Any = None  # run directories, directories holding them (a sweep) or kept evaluations; one or a list
    by: str = "algo.name"  # the config key runs are grouped by
    out: str | None = None  # where figures and tables go (default: the first of `runs`)
    smooth: float = 0.8  # TensorBoard's EMA weight for the curves, in [0, 1)


ConfigStore.instance().store(name="report_schema", node=ReportConfig)


@dataclass
class Run:
    path: Path
    config: dict
    scalars: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)  # tag -> (episodes, values)
    evals: list[tuple[float, float, dict[str, float]]] = field(default_factory=list)  # (frames, seconds, eval/*)
    final: dict[str, float] | None = None


def find_runs(paths: list[str]) -> list[Path]:
    """Run directories under ``paths`` (a run dir holds ``.hydra/config.yaml`` and ``tb/``)."""
    runs: list[Path] = []
    for p in map(Path, paths):
        if not p.exists():
            raise ValueError(f"runs = {str(p)!r} is invalid: no such directory")
        if (p / ".hydra").is_dir() or _evaluation(p) is not None:
            candidates = [p]
        else:
            candidates = sorted({c.parent.parent for c in p.rglob(".hydra/config.yaml")}
                                | {m.parent for m in p.rglob("metrics.json") if _evaluation(m.parent) is not None})
        runs += [c for c in candidates if (c / "tb").is_dir() or _evaluation(c) is not None]
    # an evaluation inside a training run (its checkpoints/metrics.json) is that run's final, not a run of its own
    trained = [r for r in runs if (r / ".hydra").is_dir()]
    runs = [r for r in runs if (r / ".hydra").is_dir() or not any(t in r.parents for t in trained)]
    if not runs:
        raise ValueError(f"runs = {paths} is invalid: no training run (a directory with .hydra/config.yaml and tb/) "
                         "and no evaluation (a metrics.json written by make eval) under them")
    return list(dict.fromkeys(runs))


def _evaluation(path: Path) -> dict | None:
    """The record of ``make eval`` in ``path/metrics.json`` (what was evaluated, on which world), if any."""
    if (path / ".hydra").is_dir() or not (path / "metrics.json").is_file():
        return None
    try:
        record = json.loads((path / "metrics.json").read_text()).get("eval")
    except (ValueError, AttributeError):
        return None
    return record if isinstance(record, dict) and "algo" in record and "env" in record else None


def load_run(path: Path) -> Run:
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    record = _evaluation(path)
    if record is not None:  # an evaluation directory: a final, no curves
        final = json.loads((path / "metrics.json").read_text())
        config = {"algo": {"name": record["algo"]}, "env": record["env"], "ckpt": record.get("ckpt")}
        return Run(path, config, final={k: v for k, v in final.items() if isinstance(v, (int, float))})
    config = yaml.safe_load((path / ".hydra" / "config.yaml").read_text())
    run = Run(path, config)
    elapsed = 0.0  # training seconds before this events file (a resumed run writes one file per session)
    # one evaluation per (frames, events file, repeat): a run may evaluate twice at one frame count
    # (e.g. a run that evaluated twice at frame 0), a resumed session may redo one
    evals: dict[tuple[float, int, int], tuple[float, dict[str, float]]] = {}
    for file_index, events in enumerate(sorted((path / "tb").glob("events*"))):
        ea = EventAccumulator(str(events), size_guidance={"scalars": 0})
        ea.Reload()
        tags = ea.Tags()["scalars"]
        walls = [e.wall_time for t in tags for e in ea.Scalars(t)]
        if not walls:
            continue
        start = min(walls)
        for tag in (t for t in tags if t.startswith("eval/")):
            repeats: dict[int, int] = {}
            for e in ea.Scalars(tag):
                k = repeats[e.step] = repeats.get(e.step, -1) + 1
                key = (float(e.step), file_index, k)
                seconds, metrics = evals.setdefault(key, (elapsed + e.wall_time - start, {}))
                metrics[tag[len("eval/"):]] = e.value
        elapsed += max(walls) - start
        episodes = _series(ea, "perf/episodes") if "perf/episodes" in tags else None
        for tag in tags:
            frames, values = _series(ea, tag)
            x = np.interp(frames, *episodes) if episodes is not None and tag.startswith("train/") else frames
            if tag in run.scalars:  # a resumed run: append
                x0, v0 = run.scalars[tag]
                x, values = np.concatenate([x0, x]), np.concatenate([v0, values])
            run.scalars[tag] = (x, values)
    run.evals = [(key[0], seconds, metrics) for key, (seconds, metrics) in sorted(evals.items())]
    for candidate in (path / "checkpoints" / "metrics.json", path / "metrics.json"):
        if candidate.is_file():
            run.final = {k: v for k, v in json.loads(candidate.read_text()).items() if isinstance(v, (int, float))}
            break
    return run


def attach_evaluations(runs: list[Run]) -> list[Run]:
    """An evaluation of a training run's checkpoint (``make eval`` writes ``outputs/eval/<run>``, recording the
    checkpoint it read) is that run's final, not a run of its own."""
    trained = {r.path.resolve(): r for r in runs if (r.path / ".hydra").is_dir()}
    kept = []
    for r in runs:
        ckpt = r.config.get("ckpt") if r.path.resolve() not in trained else None
        owner = next((trained[p] for p in Path(ckpt).resolve().parents if p in trained), None) if ckpt else None
        if owner is None:
            kept.append(r)
        else:
            owner.final = r.final
    return kept


def _series(ea, tag: str) -> tuple[np.ndarray, np.ndarray]:
    events = ea.Scalars(tag)
    return np.array([e.step for e in events], float), np.array([e.value for e in events], float)


def group_key(run: Run, by: str) -> str:
    node = run.config
    for part in by.split("."):
        if not isinstance(node, dict) or part not in node:
            raise ValueError(f"by = {by!r} is invalid: run {run.path} has no config key {by!r}")
        node = node[part]
    # a name stands for itself (per_matd3, hybrid); a number or a flag needs its key (batch_size=256)
    return node if isinstance(node, str) else f"{by.rsplit('.', 1)[-1]}={node}"


def smooth(values: np.ndarray, weight: float) -> np.ndarray:
    """TensorBoard's exponential moving average."""
    out, last = np.empty_like(values), values[0] if len(values) else 0.0
    for i, v in enumerate(values):
        last = weight * last + (1 - weight) * v
        out[i] = last
    return out


def plot_figures(groups: dict[str, list[Run]], out: Path, weight: float) -> list[Path]:
    written = []
    for name, (title, series, ylabel) in FIGURES.items():
        fig, axes = plt.subplots(1, len(series), figsize=(6 * len(series), 4), dpi=100, squeeze=False)
        drawn = False
        for ax, (tag, label) in zip(axes[0], series, strict=True):
            for g, runs in groups.items():
                curves = [r.scalars[tag] for r in runs if tag in r.scalars and len(r.scalars[tag][0])]
                if not curves:
                    continue
                grid = np.linspace(0, min(c[0][-1] for c in curves), 200)
                ys = np.stack([np.interp(grid, c[0], smooth(c[1], weight)) for c in curves])
                line, = ax.plot(grid, ys.mean(0), label=f"{g} ({len(curves)} seed{'s' * (len(curves) > 1)})")
                ax.fill_between(grid, ys.min(0), ys.max(0), color=line.get_color(), alpha=0.2)
                drawn = True
            ax.set_xlabel("episodes")
            ax.set_ylabel(label or ylabel)
            ax.grid(alpha=0.3)
            if ax.get_legend_handles_labels()[0]:
                ax.legend(fontsize=8)
        fig.suptitle(title)
        fig.tight_layout()
        if drawn:
            fig.savefig(out / name)
            written.append(out / name)
        plt.close(fig)
    return written


def table(groups: dict[str, list[Run]]) -> list[dict]:
    rows = []
    for g, runs in groups.items():
        finals = [r.final for r in runs if r.final]
        row = {"group": g, "seeds": len(finals)}
        for m in TABLE_METRICS:
            mean, ci = mean_ci(torch.tensor([f[m] for f in finals if m in f], dtype=torch.float64))
            row[m], row[f"{m}_ci95"] = mean, ci
        paper = PAPER.get(g)
        row.update(paper_CBRO=paper[0] if paper else None, paper_UDBLT=paper[1] if paper else None,
                   paper_RFSE=paper[2] if paper else None)
        rows.append(row)
    return rows


def write_table(rows: list[dict], out: Path) -> tuple[Path, Path]:
    with (out / "table1.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    lines = ["| group | seeds | episode reward | CBRS (%) | CBRO (%) | UDBLT (m) | RFSE (m) | success "
             "| paper CBRO (%) | paper UDBLT (m) | paper RFSE (m) |", "|---" * 11 + "|"]

    def cell(r, m):
        if np.isnan(r[m]):
            return "n/a"
        return f"{r[m]:.3g}" + ("" if np.isnan(r[f"{m}_ci95"]) else f" ± {r[f'{m}_ci95']:.2g}")

    for r in rows:
        paper = [("" if r[k] is None else f"{r[k]}") for k in ("paper_CBRO", "paper_UDBLT", "paper_RFSE")]
        lines.append("| " + " | ".join([r["group"], str(r["seeds"]), *[cell(r, m) for m in TABLE_METRICS], *paper])
                     + " |")
    md = out / "table1.md"
    md.write_text("\n".join(lines) + "\n\nmean ± 95% CI across seeds of each run's final evaluation.\n")
    return md, out / "table1.csv"


def time_to_quality(run: Run) -> dict[str, tuple[float, float] | None]:
    """Per threshold, (frames, seconds) of the first periodic evaluation meeting it, or None."""
    out: dict[str, tuple[float, float] | None] = {}
    for name, bounds in THRESHOLDS.items():
        out[name] = next(((frames, seconds) for frames, seconds, m in run.evals
                          if all(k in m and (m[k] <= v if op == "<=" else m[k] >= v) for k, op, v in bounds)), None)
    return out


def write_time_to_quality(groups: dict[str, list[Run]], out: Path) -> Path:
    lines = ["| group | run | " + " | ".join(THRESHOLDS) + " | last evaluation |", "|---" * (len(THRESHOLDS) + 3) + "|"]
    for g, runs in groups.items():
        for r in (r for r in runs if r.scalars):  # training runs; an evaluation directory has no periodic evaluation
            reached = time_to_quality(r)
            cells = ["not reached" if hit is None else f"{hit[0]:,.0f} frames, {hit[1] / 60:.1f} min"
                     for hit in reached.values()]
            last = (f"{r.evals[-1][0]:,.0f} frames, {r.evals[-1][1] / 60:.1f} min" if r.evals else "none")
            lines.append(f"| {g} | {r.path.name} | " + " | ".join(cells) + f" | {last} |")
    md = out / "time_to_quality.md"
    md.write_text("\n".join(lines) + "\n\nFrames and training wall time (seconds since the run's first TensorBoard "
                  "event, summed over resumed sessions) at the first periodic evaluation (`eval/*`) that met every "
                  "bound of the column.\n")
    return md


def plot_time_to_quality(groups: dict[str, list[Run]], out: Path) -> Path | None:
    """The periodic evaluation of every run against training wall time, with the paper's PER-MATD3 bounds."""
    panels = [("UDBLT", "UDBLT (m)", 0.08, True), ("CBRS", "CBRS (%)", None, False),
              ("CBRO", "CBRO (%)", 2.37, False), ("RFSE", "RFSE (m)", 0.36, True), ("success", "success", 0.9, False)]
    runs = [(g, r) for g, rs in groups.items() for r in rs if r.evals]
    if not runs:
        return None
    fig, axes = plt.subplots(1, len(panels), figsize=(4 * len(panels), 3.6), dpi=100)
    for ax, (metric, label, bound, log) in zip(axes, panels, strict=True):
        for g, r in runs:
            pts = [(seconds / 60, m[metric]) for _, seconds, m in r.evals if metric in m]
            if pts:
                ax.plot(*zip(*pts, strict=True), marker=".", label=f"{g}: {r.path.name}")
        if bound is not None:
            ax.axhline(bound, color="k", ls="--", lw=0.8)
        if log:
            ax.set_yscale("log")
        ax.set_xlabel("training wall time (min)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle("Periodic evaluation against wall time (dashed: the paper's PER-MATD3 row, 90% success)")
    fig.tight_layout()
    fig.savefig(out / "time_to_quality.png")
    plt.close(fig)
    return out / "time_to_quality.png"


def run(cfg: ReportConfig) -> list[Path]:
    """Figures, Table 1 and the time-to-quality table of ``cfg.runs``; the files written (tables last)."""
    paths = as_list(cfg.runs)
    if not paths:
        raise ValueError(f"runs = {cfg.runs!r} is invalid: must be run directories or directories holding them "
                         "(make compare RUNS=...)")
    if not 0 <= cfg.smooth < 1:
        raise ValueError(f"smooth = {cfg.smooth} is invalid: must be in [0, 1)")
    runs = attach_evaluations([load_run(p) for p in find_runs(paths)])
    sizes = {r.config.get("env", {}).get("num_robots") for r in runs}
    if len(sizes) > 1 and cfg.by != "env.num_robots":
        raise ValueError(f"runs mix team sizes {sorted(sizes)}: compare one N at a time (or by=env.num_robots)")
    groups: dict[str, list[Run]] = {}
    for r in runs:
        groups.setdefault(group_key(r, cfg.by), []).append(r)
    out = Path(cfg.out or paths[0])
    try:
        out.mkdir(parents=True, exist_ok=True)
        trained = [r for r in runs if (r.path / ".hydra").is_dir()]
        figs = plot_figures(groups, out, cfg.smooth) if trained else []
        if trained and not figs:
            raise ValueError(f"runs = {paths} is invalid: none of {len(trained)} training run(s) has train/* curves "
                             "in tb/ (formation_rl runs?)")
        tables = list(write_table(table(groups), out))
        if trained:
            tables.append(write_time_to_quality(groups, out))
        figs += [f for f in [plot_time_to_quality(groups, out)] if f is not None]
    except OSError as err:
        reason = err.strerror or err
        raise ValueError(f"out = {str(out)!r} is invalid: cannot write the report there: {reason}") from None
    return [*figs, *tables]


@hydra.main(config_path=str(CONF), config_name="report", version_base=None)
@one_line_errors
def main(cfg: DictConfig) -> None:
    written = run(OmegaConf.to_object(cfg))
    for md in (p for p in written if p.suffix == ".md"):
        print(md.read_text())
    print("wrote " + ", ".join(map(str, written)))


if __name__ == "__main__":
    from formation_rl.apps.cli import check_overrides

    check_overrides(ReportConfig, ())
    main()
