"""Shared command-line behaviour of the Hydra entry points: one-line errors, before any compute."""

from __future__ import annotations

import functools
import shutil
import sys
from collections.abc import Callable
from pathlib import Path

from formation_rl.utils import check_device

__all__ = ["CONF", "as_list", "check_device", "check_overrides", "one_line_errors", "remove_unused_run_dir"]

CONF = Path(__file__).resolve().parent.parent / "conf"  # the Hydra configs, package data (pyproject.toml)


def as_list(value) -> list[str]:
    """One value or a list of them, as given on the command line (``ckpt=apf``, ``ckpt=[apf,run]``), as strings."""
    if value is None:
        return []
    return [str(v) for v in value] if isinstance(value, list | tuple) else [str(value)]


def one_line_errors(main: Callable) -> Callable:
    """Print a ``ValueError`` (bad config or input) as ``error: ...`` on stderr and exit with 2.

    A Hydra run directory the call leaves empty is removed (eval and render write elsewhere), and so is
    a refused call's, which holds only ``.hydra/``."""

    @functools.wraps(main)
    def wrapper(*args, **kwargs):
        try:
            out = main(*args, **kwargs)
        except ValueError as err:
            remove_unused_run_dir(refused=True)
            print(f"error: {err}", file=sys.stderr)
            sys.exit(2)
        remove_unused_run_dir(refused=False)
        return out

    return wrapper


def remove_unused_run_dir(refused: bool) -> None:
    """Remove this Hydra job's run directory if it holds nothing but empty logs (and, for a ``refused`` call,
    the composed config in ``.hydra/``), then its parents left empty, up to the working directory."""
    from hydra.core.hydra_config import HydraConfig

    if not HydraConfig.initialized():
        return
    run, cwd = Path(HydraConfig.get().runtime.output_dir).resolve(), Path.cwd().resolve()
    if run == cwd or run in cwd.parents:
        return
    for f in run.rglob("*"):
        unused = f.is_dir() or (f.suffix == ".log" and f.stat().st_size == 0) or (
            refused and ".hydra" in f.relative_to(run).parts)
        if not unused:
            return
    shutil.rmtree(run, ignore_errors=True)
    for parent in run.parents:
        if parent == cwd or cwd not in parent.parents:
            break
        try:
            parent.rmdir()  # only if empty
        except OSError:
            break


def check_overrides(schema: type, groups: tuple[str, ...], argv: list[str] | None = None) -> None:
    """Check command-line overrides against the config groups and the typed schema, the way Hydra
    would, but fail with one line: ``error: <key> = <value> is invalid: ...`` and exit code 2.

    Hydra's own messages for these cases span several lines; everything else is left to Hydra.
    """
    from hydra.core.override_parser.overrides_parser import OverridesParser
    from omegaconf import OmegaConf
    from omegaconf.errors import OmegaConfBaseException

    argv = sys.argv[1:] if argv is None else argv
    args = [a for a in argv if "=" in a and not a.startswith("-")]
    try:
        overrides = OverridesParser.create().parse_overrides(args)
    except Exception:  # noqa: BLE001  (malformed: Hydra reports it)
        return
    base = OmegaConf.structured(schema)
    for o in overrides:
        key = o.key_or_group
        if key.startswith("hydra") or o.is_delete() or o.is_add() or o.is_force_add():
            continue
        values = list(o.sweep_string_iterator()) if o.is_sweep_override() else [o.value()]
        try:
            if key in groups:
                options = sorted(p.stem for p in (CONF / key).glob("*.yaml"))
                for v in values:
                    if str(v) not in options:
                        raise ValueError(f"{key} = {v!r} is invalid: must be one of {', '.join(options)}")
                continue
            for v in values:
                try:
                    cfg = base.copy()
                    OmegaConf.update(cfg, key, v, merge=True)
                    # OmegaConf turns 3, 0 or "yes" into a bool field's True/False; only true/false are meant
                    if isinstance(OmegaConf.select(cfg, key), bool) and not isinstance(v, bool):
                        raise ValueError(f"{key} = {v!r} is invalid: must be true or false")
                except OmegaConfBaseException as err:
                    parent, _, leaf = key.rpartition(".")
                    node = OmegaConf.select(base, parent) if parent else base
                    if node is None or not hasattr(node, "keys") or leaf not in node:
                        allowed = ", ".join(sorted(map(str, node.keys()))) if hasattr(node, "keys") else "none"
                        raise ValueError(f"{key}: unknown key; allowed here: {allowed}") from None
                    reason = str(err).splitlines()[0]
                    raise ValueError(f"{key} = {v!r} is invalid: {reason}") from None
        except ValueError as err:
            print(f"error: {err}", file=sys.stderr)
            sys.exit(2)
