"""formation_rl.training.checkpoint and ``Trainer.state_dict``: atomic files, resume, the state round trip."""

import io

import pytest
import torch
from helpers import scalars, tiny

from formation_rl import load_policy
from formation_rl.evaluation.policy import output_dir, policy_path
from formation_rl.models import bf16_supported
from formation_rl.training.checkpoint import (
    BEST_POLICY,
    CHECKPOINT,
    atomic_save,
    load_checkpoint_file,
    resolve_checkpoint,
)
from formation_rl.training.trainer import Trainer


def test_atomic_save_keeps_the_previous_file_when_a_write_fails(tmp_path, monkeypatch):
    path = tmp_path / "checkpoints" / "last.pt"
    atomic_save({"frames": 1}, path)

    def disk_full(obj, f):
        f.write_bytes(b"half a checkpoint")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(torch, "save", disk_full)
    with pytest.raises(ValueError, match=r"^cannot write .*last.pt: No space left on device; the previous file there "
                                         r"is unchanged$"):
        atomic_save({"frames": 2}, path)
    monkeypatch.undo()
    assert torch.load(path)["frames"] == 1


def test_resolve_checkpoint_reads_auto_a_run_directory_or_a_file(tmp_path):
    (tmp_path / "checkpoints").mkdir()
    (tmp_path / CHECKPOINT).touch()
    assert resolve_checkpoint("auto", tmp_path) == tmp_path / CHECKPOINT
    assert resolve_checkpoint(tmp_path, tmp_path / "elsewhere") == tmp_path / CHECKPOINT
    assert resolve_checkpoint(tmp_path / CHECKPOINT, tmp_path / "elsewhere") == tmp_path / CHECKPOINT
    with pytest.raises(ValueError, match=r"^resume = 'auto' is invalid: no checkpoint at .*other/checkpoints/last.pt$"):
        resolve_checkpoint("auto", tmp_path / "other")


@pytest.mark.parametrize("precision", [
    "fp32", pytest.param("bf16_targets", marks=pytest.mark.skipif(not bf16_supported("cpu"), reason="no bf16 CPU"))])
def test_state_dict_round_trip_gives_the_same_next_update(tmp_path, precision):
    """Trainer.state_dict -> bytes -> a fresh Trainer's load_state_dict: the next gradient steps (PER sampling,
    target-policy noise, twin targets, Adam moments, the actor delay) and the priorities they write are the
    ones the original trainer computes, in either precision (weights and optimiser state stay fp32)."""
    first = Trainer(tiny("per_matd3", frames=800, save_buffer=True, precision=precision), tmp_path / "a")
    first.train()
    saved = io.BytesIO()
    torch.save(first.state_dict(), saved)  # what save_checkpoint writes to last.pt
    steps = [first._gradient_step() for _ in range(2)]  # one critic-only step, one with the actors (policy_delay 2)
    fresh = Trainer(tiny("per_matd3", frames=800, save_buffer=True, seed=7, precision=precision),
                    tmp_path / "b")  # other initial weights
    saved.seek(0)
    fresh.load_state_dict(torch.load(saved, weights_only=False))
    assert (fresh.frames, fresh.episodes, fresh.algo.critic_steps) == (800, first.episodes, first.algo.critic_steps - 2)
    again = [fresh._gradient_step() for _ in range(2)]
    assert "loss_actor" in steps[1] and "loss_actor" not in steps[0]
    for a, b in zip(steps, again, strict=True):
        assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a), (a, b)
    for a, b in zip(first.algo.loss.state_dict().values(), fresh.algo.loss.state_dict().values(), strict=True):
        assert torch.equal(a, b)  # actors, critics and their targets
    size = len(first.buffer)
    assert torch.equal(first.buffer.sampler._sum_tree[torch.arange(size)],
                       fresh.buffer.sampler._sum_tree[torch.arange(size)])
    assert torch.equal(first.noise.sigma, fresh.noise.sigma)  # the annealed exploration noise
    assert torch.equal(first.env.rng_state(), fresh.env.rng_state())  # the training scenarios drawn next


def test_resume_continues_counters_and_state(tmp_path):
    first = Trainer(tiny("matd3", frames=1600), tmp_path)
    first.train()
    steps, actor = first.algo.critic_steps, [p.detach().clone() for p in first.algo.actor_params]
    second = Trainer(tiny("matd3", frames=3200), tmp_path)
    second.load_checkpoint("auto")
    assert (second.frames, second.episodes, second.algo.critic_steps) == (1600, first.episodes, steps)
    assert all(torch.equal(a, b) for a, b in zip(actor, second.algo.actor_params, strict=True))
    assert second.algo.actor_optim.state_dict()["state"]  # Adam moments came back
    second.train()
    assert second.frames == 3200 and second.algo.critic_steps > steps
    tags = scalars(tmp_path)
    assert max(s for s, _ in tags["eval/success"]) == 3200


def test_resume_with_the_saved_replay_buffer(tmp_path):
    """save_buffer=true: the transitions and their priorities come back from last.pt; a checkpoint without them
    starts an empty buffer, and a run that asked for them is told."""
    def cfg(frames, save=True):
        c = tiny("per_matd3", frames=frames, save_buffer=save)
        c.algo.buffer_size = 4000
        return c

    first = Trainer(cfg(1600), tmp_path)
    first.train()
    stored, size = first.buffer[:].clone(), len(first.buffer)
    priorities = first.buffer.sampler._sum_tree[torch.arange(size)]  # the sum tree's leaves: (|delta| + eps)^alpha
    assert load_checkpoint_file(tmp_path / CHECKPOINT)["buffer"] is not None
    second = Trainer(cfg(3200), tmp_path)
    second.load_checkpoint("auto")
    assert len(second.buffer) == size == 1600
    assert torch.equal(second.buffer[:]["agents", "observation"], stored["agents", "observation"])
    assert torch.equal(second.buffer.sampler._sum_tree[torch.arange(size)], priorities) and priorities.max() > 0
    second.train()
    assert len(second.buffer) == 3200
    # a checkpoint saved without the buffer
    second.cfg.save_buffer = False
    second.save_checkpoint()
    assert load_checkpoint_file(tmp_path / CHECKPOINT)["buffer"] is None
    with pytest.warns(UserWarning, match="holds no replay buffer .* the buffer starts empty and refills"):
        Trainer(cfg(4800), tmp_path).load_checkpoint("auto")
    third = Trainer(cfg(4800, save=False), tmp_path)
    third.load_checkpoint("auto")
    assert len(third.buffer) == 0 and third.frames == 3200


def test_resume_rejects_another_team(tmp_path):
    Trainer(tiny("matd3", frames=800), tmp_path).train()
    other = tiny("matd3", frames=1600)
    other.env.num_robots = 4
    with pytest.raises(ValueError, match=r"^resume: env.num_robots = 4 but the checkpoint has 3; they must match "
                                         r"\(.*last.pt\)$"):
        Trainer(other, tmp_path).load_checkpoint("auto")
    own = tiny("matd3", frames=1600)
    own.model.leader_critic = "own"  # another critic layout
    with pytest.raises(ValueError, match=r"^resume: model.leader_critic = 'own' but the checkpoint has 'joint'"):
        Trainer(own, tmp_path).load_checkpoint("auto")
    wide = tiny("matd3", frames=1600)
    wide.model.critic_hidden = [64, 64]  # wider critics than the checkpoint's (its model.hidden, [32, 32])
    with pytest.raises(ValueError, match=r"^resume: model.critic_hidden = \[64, 64\] but the checkpoint has "
                                         r"\[32, 32\]"):
        Trainer(wide, tmp_path).load_checkpoint("auto")
    same = tiny("matd3", frames=1600)
    same.model.critic_hidden = [32, 32]  # the checkpoint's critics, named explicitly
    Trainer(same, tmp_path).load_checkpoint("auto")
    (tmp_path / CHECKPOINT).write_bytes(b"not a checkpoint")
    with pytest.raises(ValueError, match=r"^checkpoint \S*last.pt cannot be read \(\w+\): it is truncated or corrupt$"):
        Trainer(tiny("matd3", frames=1600), tmp_path).load_checkpoint("auto")


def test_best_policy_holds_the_best_validation_and_survives_a_resume(tmp_path):
    """checkpoints/best_policy.pt: the actors of the evaluation with the highest validation success, then the
    lowest RFSE (frame 0 excluded); load_policy and make eval read it as itself, and a resume keeps the record."""
    first = Trainer(tiny("matd3", frames=3200), tmp_path)
    first.train()
    tags = scalars(tmp_path)
    evals = {s: (v, -r) for (s, v), (_, r) in zip(tags["eval/success"], tags["eval/RFSE"], strict=True) if s > 0}
    frames = max(evals, key=evals.get)
    best = load_checkpoint_file(tmp_path / BEST_POLICY)
    assert best["validation"]["frames"] == frames == first.best["frames"]
    assert best["validation"]["RFSE"] == pytest.approx(-evals[frames][1])
    assert policy_path(tmp_path / BEST_POLICY) == tmp_path / BEST_POLICY  # not the policy.pt beside it
    assert output_dir("eval", tmp_path / BEST_POLICY).name == tmp_path.name + "_best"
    loaded = load_policy(tmp_path / BEST_POLICY)
    for a, b in zip(loaded.actor.state_dict().values(), best["actor"].values(), strict=True):
        assert torch.equal(a, b)
    second = Trainer(tiny("matd3", frames=4800), tmp_path)
    second.load_checkpoint("auto")
    assert second.best == first.best
