"""The benchmark's analytic FLOP count, checked against a count by hand on a tiny network."""

import importlib.util
from pathlib import Path

spec = importlib.util.spec_from_file_location("train_throughput",
                                              Path(__file__).resolve().parents[1] / "benchmarks/train_throughput.py")
bench = importlib.util.module_from_spec(spec)
spec.loader.exec_module(bench)


def test_step_flops_by_hand():
    # N=2 robots, obs 3, hidden [4], batch 1: actor 3*4 + 4*2 = 20 MACs; critic input 2*(3+2) = 10,
    # critic 10*4 + 4*1 = 44 MACs of which 4 above the first layer; actor above the first layer 8
    critic_step = 2 * (20 + 1 * 44 * 3 + 1 * 4)  # target actors, target critic, critic, its backward
    actor_step = 2 * (20 + 44 + 4 + 20 + 8)  # actors, critic 1 forward and back to a, actors' backward
    assert bench.step_flops(2, 3, [4], 1, critics=1, delay=1) == 2 * (critic_step + actor_step)
    twin = 2 * (20 + 2 * 44 * 3 + 2 * 4)
    assert bench.step_flops(2, 3, [4], 8, critics=2, delay=2) == 2 * 8 * (twin + actor_step / 2)


def test_target_share_and_bf16_floor_by_hand():
    critic_step = 2 * (20 + 1 * 44 * 3 + 1 * 4)  # the network of test_step_flops_by_hand
    actor_step = 2 * (20 + 44 + 4 + 20 + 8)
    target = 2 * (20 + 44)  # MACs: target actors and target critic forward, both robots
    share = bench.target_share(2, 3, [4], critics=1, delay=1)
    assert abs(share - target / (critic_step + actor_step)) < 1e-12
    assert bench.bf16_floor(share, 100.0, 200.0) == share + (1 - share) / 2
    assert bench.bf16_floor(0.0, 100.0, 400.0) == 0.25


def test_matmul_rate_in_each_precision():
    import torch

    assert bench.matmul_rate(repeats=1) > 0
    assert bench.matmul_rate(repeats=1, dtype=torch.bfloat16) > 0
