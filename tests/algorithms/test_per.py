"""PER-MATD3 (paper §3.3): priorities (max |delta| + eps)^alpha, normalised IS weights, alpha = 0 uniform."""

import torch

from formation_rl.algorithms import MATD3
from formation_rl.algorithms.config import AlgoConfig
from formation_rl.models import make_actor, make_critic
from formation_rl.training.replay import make_replay_buffer

from .conftest import D, N, make_batch


def setup(alpha=0.6, beta=0.5, size=64):
    cfg = AlgoConfig(name="per_matd3", batch_size=16, buffer_size=size, alpha=alpha, beta=beta, priority_eps=1e-6)
    buffer = make_replay_buffer(cfg)
    data = make_batch(size)
    data["next", "agents", "reward"] *= torch.linspace(0.1, 3.0, size).view(size, 1, 1)  # spread the errors
    buffer.extend(data)
    algo = MATD3(make_actor(N, D, (16, 16)), make_critic(N, D, (16, 16)), cfg)
    return cfg, buffer, algo


def tree_priorities(buffer, index):
    return torch.tensor([buffer.sampler._sum_tree[int(i)] for i in index])


def test_priorities_after_a_critic_step_and_normalised_weights():
    cfg, buffer, algo = setup()
    for _ in range(3):  # make the stored priorities differ from their initial max
        b = buffer.sample()
        algo.update(b)
        buffer.update_tensordict_priority(b)
    batch = buffer.sample()
    index = batch["index"]
    stored = torch.tensor([buffer.sampler._sum_tree[i] for i in range(len(buffer))])
    # eq. 20: w = (N P(k))^-beta / max w = (p_k / p_min)^-beta, p the stored (|delta| + eps)^alpha
    expected_w = (tree_priorities(buffer, index) / stored.min()) ** -cfg.beta
    torch.testing.assert_close(batch["priority_weight"].float(), expected_w.float(), atol=1e-5, rtol=1e-4)
    assert batch["priority_weight"].max() <= 1.0 + 1e-6

    algo.update(batch)
    buffer.update_tensordict_priority(batch)
    delta = batch["td_error"]  # [B, N], max over the twin critics already
    assert delta.shape == (16, N)
    expected_p = (delta.amax(-1) + cfg.priority_eps) ** cfg.alpha  # eq. 17, max over robots
    last = {int(i): p for i, p in zip(index, expected_p, strict=True)}  # a transition drawn twice: last write wins
    expected = torch.stack([last[int(i)] for i in index])
    torch.testing.assert_close(tree_priorities(buffer, index).float(), expected.float(), atol=1e-5, rtol=1e-4)


def test_alpha_zero_is_uniform():
    cfg, buffer, algo = setup(alpha=0.0)
    for _ in range(3):
        b = buffer.sample()
        algo.update(b)
        buffer.update_tensordict_priority(b)
    stored = torch.tensor([buffer.sampler._sum_tree[i] for i in range(len(buffer))])
    assert torch.allclose(stored, torch.ones_like(stored))
    assert torch.allclose(buffer.sample()["priority_weight"].float(), torch.ones(16))
    counts = torch.bincount(torch.cat([buffer.sample()["index"] for _ in range(400)]), minlength=64).float()
    assert counts.min() > 0.5 * counts.mean() and counts.max() < 1.5 * counts.mean()  # 6400 draws, ~100 each
