import pytest
import torch
from tensordict import TensorDict

N, D = 3, 4 + 2 * 2 + 3 * 1 + 1  # 3 robots, 1 obstacle


def make_batch(b: int = 8, terminated=None) -> TensorDict:
    """A hand-built batch of transitions with the keys the losses read."""
    g = torch.Generator().manual_seed(1)
    term = torch.zeros(b, 1, 1, dtype=torch.bool) if terminated is None else terminated
    return TensorDict(
        {
            ("agents", "observation"): torch.randn(b, N, D, generator=g),
            ("agents", "action"): torch.rand(b, N, 2, generator=g) * 2 - 1,
            ("next", "agents", "observation"): torch.randn(b, N, D, generator=g),
            ("next", "agents", "reward"): torch.randn(b, N, 1, generator=g),
            ("next", "agents", "done"): term.expand(b, N, 1).clone(),
            ("next", "agents", "terminated"): term.expand(b, N, 1).clone(),
        },
        [b],
    )


@pytest.fixture
def batch():
    return make_batch()
