"""The package layout's import rules: library and apps apart, policy loading without training code."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import run_module

PACKAGE = Path(__file__).resolve().parents[1] / "formation_rl"
TRAINING_APPS = {"formation_rl.apps.train", "formation_rl.apps.tune"}
# the entry points documented before the apps moved (python -m formation_rl.<old>) -> the app each runs
OLD_ENTRY_POINTS = {"train": "train", "evaluate": "evaluate", "rollout": "demo", "visualize": "render",
                    "report": "report", "diagnose": "diagnose", "ceiling": "ceiling", "tune": "tune"}
SHIMS = {f"formation_rl.{old}" for old in OLD_ENTRY_POINTS}


def _module(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path) -> set[str]:
    """Every module an ``import`` or ``from ... import`` in the file names (lazy imports in functions too)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.add(node.module)
            out |= {f"{node.module}.{a.name}" for a in node.names}  # from formation_rl.apps import report
    return out


MODULES = {_module(p): _imports(p) for p in sorted(PACKAGE.rglob("*.py"))}


def _under(name: str, package: str) -> bool:
    return name == package or name.startswith(package + ".")


@pytest.mark.parametrize("module", sorted(MODULES))
def test_import_rules(module):
    imports = MODULES[module]
    training = sorted(i for i in imports if _under(i, "formation_rl.training"))
    if module in SHIMS:  # a shim imports nothing of ours: it runs its app's module as __main__
        app = f"formation_rl.apps.{OLD_ENTRY_POINTS[module.split('.')[-1]]}"
        assert imports <= {"runpy", "runpy.run_module"}, imports
        assert f'runpy.run_module("{app}", run_name="__main__"' in (PACKAGE / f"{module.split('.')[-1]}.py").read_text()
        return
    if not _under(module, "formation_rl.training") and module not in TRAINING_APPS:
        assert not training, f"{module} imports {training}: only the train and tune apps may"
    apps = sorted(i for i in imports if _under(i, "formation_rl.apps"))
    if _under(module, "formation_rl.apps"):  # the shared helpers of apps/cli.py, and itself (tune's workers)
        others = [i for i in apps if not (_under(i, "formation_rl.apps.cli") or _under(i, module))]
        assert not others, f"{module} imports another app: {others}"
    else:
        assert not apps, f"library module {module} imports an app: {apps}"


@pytest.mark.integration
def test_loading_a_policy_loads_no_training_code():
    code = ("import sys, formation_rl; formation_rl.load_policy('apf'); formation_rl.load_policy("
            f"{str(PACKAGE.parent / 'pretrained' / 'per_matd3_fast.pt')!r}); import formation_rl.evaluation; "
            "print(sorted(m for m in sys.modules if m.startswith(('formation_rl.training', 'formation_rl.apps'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip() == "[]"


@pytest.mark.integration
@pytest.mark.parametrize("old", sorted(OLD_ENTRY_POINTS))
def test_old_entry_points_run_their_app(old):
    """python -m formation_rl.<old> composes the same config as the app it now lives in, Hydra's included
    (job name, run directory, log file: the same outputs), and refuses a bad key with the app's own error."""
    shim, app = run_module(f"formation_rl.{old}", "--cfg", "all"), run_module(
        f"formation_rl.apps.{OLD_ENTRY_POINTS[old]}", "--cfg", "all")
    assert shim.returncode == 0 and app.returncode == 0, (shim.stderr + app.stderr)[-2000:]
    assert shim.stdout == app.stdout and shim.stdout.strip()
    shim, app = run_module(f"formation_rl.{old}", "nosuchkey=1"), run_module(
        f"formation_rl.apps.{OLD_ENTRY_POINTS[old]}", "nosuchkey=1")
    assert shim.returncode == app.returncode != 0 and shim.stderr == app.stderr and shim.stderr.strip()
