from pathlib import Path

import pytest
import torch

TESTS = Path(__file__).resolve().parent
# integration tests (`make test-integration`): commands in subprocesses, kill -9, the wheel, the Makefile,
# the benchmarks' scripts and the shipped policies; single tests elsewhere carry @pytest.mark.integration
INTEGRATION = ("apps/", "test_faults.py", "test_wheel.py", "test_makefile.py", "test_benchmark.py",
               "evaluation/test_pretrained.py")


def pytest_collection_modifyitems(items):
    for item in items:
        if item.path.resolve().relative_to(TESTS).as_posix().startswith(INTEGRATION):
            item.add_marker(pytest.mark.integration)


@pytest.fixture(autouse=True)
def _seed():
    torch.manual_seed(0)
