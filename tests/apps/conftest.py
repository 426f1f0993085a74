"""Fixtures shared by the app tests."""

import pytest
from helpers import tiny

from formation_rl.training.trainer import Trainer


@pytest.fixture(scope="package")  # one tiny training for tests/apps (test_evaluate.py and test_render.py)
def trained(tmp_path_factory):
    run = tmp_path_factory.mktemp("run")
    Trainer(tiny("per_matd3", frames=800), run).train()
    return run
