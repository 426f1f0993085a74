"""``device=cuda``: the environment, every algorithm, PER, checkpoints and policy loading on a GPU.

Skipped where CUDA is absent (CI); run on a GPU machine with ``pytest tests/test_cuda.py``.
"""

import pytest
import torch
from helpers import tiny
from torchrl.envs.utils import check_env_specs

import formation_rl
from formation_rl.envs import EnvConfig, FormationEnv
from formation_rl.envs.metrics import episode_metrics, summarize
from formation_rl.training.trainer import Trainer

pytestmark = pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA")


def test_env_specs_and_rollout_on_cuda():
    env = FormationEnv(num_envs=16, config=EnvConfig(), device="cuda", seed=0)
    check_env_specs(env)
    rollout = env.rollout(150, break_when_any_done=False)
    assert rollout.device.type == "cuda" and rollout.shape == (16, 150)
    assert rollout["next", "agents", "reward"].is_cuda and torch.isfinite(rollout["next", "agents", "reward"]).all()
    metrics = summarize(episode_metrics(rollout, env.config.goal_radius))
    assert all(torch.isfinite(torch.tensor(v)) for v in metrics.values())


def test_env_partial_reset_on_cuda():
    env = FormationEnv(num_envs=4, config=EnvConfig(), device="cuda", seed=0)
    td = env.reset()
    for _ in range(3):
        td = env.rand_step(td)["next"].exclude(("agents", "reward"))
    before = env.world_state()["positions"].clone()
    mask = torch.tensor([[True], [False], [True], [False]], device="cuda")
    after = env.reset(td.update({"_reset": mask}))["state", "positions"]
    assert torch.equal(after[1], before[1]) and torch.equal(after[3], before[3])
    assert not torch.equal(after[0], before[0])


def test_per_priorities_on_cuda():
    """eq. 17 on the GPU: after a critic step the sampled priorities are (max |delta| + eps)^alpha."""
    from algorithms.conftest import D, N, make_batch

    from formation_rl.algorithms import MATD3
    from formation_rl.algorithms.config import AlgoConfig
    from formation_rl.models import make_actor, make_critic
    from formation_rl.training.replay import make_replay_buffer

    cfg = AlgoConfig(name="per_matd3", batch_size=16, buffer_size=64, priority_eps=1e-6)
    buffer = make_replay_buffer(cfg, torch.device("cuda"))
    data = make_batch(64).to("cuda")
    data["next", "agents", "reward"] *= torch.linspace(0.1, 3.0, 64, device="cuda").view(64, 1, 1)
    buffer.extend(data)
    algo = MATD3(make_actor(N, D, (16, 16)).cuda(), make_critic(N, D, (16, 16)).cuda(), cfg)
    batch = buffer.sample()
    assert batch["agents", "observation"].is_cuda
    algo.update(batch)
    buffer.update_tensordict_priority(batch)
    expected = (batch["td_error"].amax(-1) + cfg.priority_eps) ** cfg.alpha
    last = {int(i): p for i, p in zip(batch["index"].tolist(), expected.cpu(), strict=True)}
    stored = torch.tensor([buffer.sampler._sum_tree[i] for i in last])
    torch.testing.assert_close(stored, torch.stack(list(last.values())).float(), atol=1e-5, rtol=1e-4)


@pytest.mark.parametrize("algo", ["maddpg", "matd3", "per_matd3"])
def test_tiny_run_on_cuda_resumes_and_loads_on_cpu(tmp_path, algo):
    cfg = tiny(algo, frames=1600, device="cuda")
    trainer = Trainer(cfg, tmp_path)
    metrics = trainer.train()
    assert trainer.algo.critic_steps == (1600 - 160) // 20
    assert all(p.is_cuda for p in trainer.algo.actor_params)
    assert set(metrics) >= {"episode_reward", "CBRO", "UDBLT", "success"}
    assert len(trainer.buffer) == 1600
    # resume on the GPU continues the counters
    again = Trainer(tiny(algo, frames=3200, device="cuda"), tmp_path)
    again.load_checkpoint("auto")
    assert again.frames == 1600
    again.train()
    assert again.frames == 3200
    # a policy trained on the GPU loads on the CPU and acts there
    policy = formation_rl.load_policy(tmp_path, device="cpu")
    obs = torch.zeros(2, cfg.env.num_robots, cfg.env.obs_dim)
    assert policy(obs).shape == (2, cfg.env.num_robots, 2)


@pytest.mark.parametrize("name", ["maddpg", "matd3", "per_matd3"])
def test_cudagraph_steps_match_eager_steps(name):
    """cudagraphs=true replays the same update: same batches, same parameters as the eager step
    (target-policy noise off, so both draw nothing random), the actor delay and PER weights included."""
    from algorithms.conftest import D, N, make_batch

    from formation_rl.algorithms import PRIORITY_KEY, WEIGHT_KEY, make_algorithm
    from formation_rl.algorithms.config import AlgoConfig
    from formation_rl.models import make_actor, make_critic

    cfg = AlgoConfig(name=name, policy_noise=0.0, num_critics=1 if name == "maddpg" else 2,
                     policy_delay=1 if name == "maddpg" else 2)
    algos = []
    for graphed in (False, True):
        torch.manual_seed(0)
        algo = make_algorithm(make_actor(N, D, (16, 16)).cuda(), make_critic(N, D, (16, 16)).cuda(), cfg)
        if graphed:
            algo.enable_cudagraphs()
        algos.append(algo)
    for i in range(9):  # 3 eager warm-up calls per graph, then capture and replays
        batch = make_batch(32).to("cuda")
        batch["next", "agents", "reward"] += i
        if name == "per_matd3":
            batch[WEIGHT_KEY] = torch.rand(32, device="cuda")
            batch["index"] = torch.arange(32)  # on the CPU, as CPU priority trees give it
        batches = [batch.clone(), batch.clone()]
        outs = [a.update(b) for a, b in zip(algos, batches, strict=True)]
        torch.testing.assert_close(outs[0]["loss_critic"], outs[1]["loss_critic"], rtol=1e-4, atol=1e-5)
        torch.testing.assert_close(batches[0][PRIORITY_KEY], batches[1][PRIORITY_KEY], rtol=1e-4, atol=1e-5)
    assert algos[1]._graphs and all(g.counter >= 3 for g in algos[1]._graphs.values())  # captured
    for eager, graphed in zip(algos[0].loss.parameters(), algos[1].loss.parameters(), strict=True):
        torch.testing.assert_close(eager, graphed, rtol=1e-4, atol=1e-5)
    assert algos[0].actor_steps == algos[1].actor_steps > 0


@pytest.mark.parametrize("algo", ["matd3", "per_matd3"])
def test_cudagraph_training_resumes_without_graphs(tmp_path, algo):
    cfg = tiny(algo, frames=3200, device="cuda")
    cfg.cudagraphs = True
    trainer = Trainer(cfg, tmp_path)
    metrics = trainer.train()
    assert trainer.algo.critic_steps == (3200 - 160) // 20 and set(metrics) >= {"CBRO", "success"}
    assert all(torch.isfinite(p).all() for p in trainer.algo.actor_params)
    again = Trainer(tiny(algo, frames=4800, device="cuda"), tmp_path)  # cudagraphs off: plain Adam again
    again.load_checkpoint("auto")
    again.train()
    assert again.frames == 4800
