"""The make targets pass their variables on: CKPT, RUNS and ARGS as the commands read them."""

import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.skipif(shutil.which("make") is None, reason="no make")


def command(target: str, *variables: str) -> str:
    """The line ``make -n`` prints for ``target``'s own command."""
    # --no-print-directory: under another make (`make test`) make -n also prints "Leaving directory ..."
    out = subprocess.run(["make", "--no-print-directory", "-n", target, *variables], cwd=ROOT, capture_output=True,
                         text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    return out.stdout.strip().splitlines()[-1]


def test_make_tensorboard_passes_args():
    """`make tensorboard ARGS="--port 6100"` ignored ARGS."""
    assert command("tensorboard", "RUNS=outputs/train", "ARGS=--port 6100").endswith(
        "/bin/tensorboard --logdir outputs/train --port 6100")


@pytest.mark.parametrize("target, variables, expected", [
    ("diagnose", ["CKPT=apf"], "-m formation_rl.apps.diagnose 'ckpt=[apf]'"),
    ("diagnose", ["CKPT= apf  outputs/train/run ", "ARGS=episodes=100"],
     "-m formation_rl.apps.diagnose 'ckpt=[apf,outputs/train/run]' episodes=100"),
    ("compare", [], "-m formation_rl.apps.report 'runs=[outputs]'"),
    ("compare", ["RUNS=outputs/sweep docs/results", "ARGS=by=env.reward.variant"],
     "-m formation_rl.apps.report 'runs=[outputs/sweep,docs/results]' by=env.reward.variant"),
    ("ceiling", ["ARGS=trials=10 ranges=[0.2,0.4]"], "-m formation_rl.apps.ceiling trials=10 ranges=[0.2,0.4]"),
    ("train", [], "-m formation_rl.apps.train algo=per_matd3 recipe=hindsight"),  # the README's first command
    ("train", ["RECIPE=paper", "ARGS=seed=1"], "-m formation_rl.apps.train algo=per_matd3 recipe=paper seed=1"),
])
def test_make_passes_ckpt_and_runs_as_one_hydra_list(target, variables, expected):
    assert command(target, *variables).endswith(expected)
