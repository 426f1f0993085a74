"""The one place that reads a private attribute of another package; ``tests/test_compat.py`` fails loudly
when a torch release moves it.

- ``torch._C._functorch.is_batchedtensor``: whether a tensor is a vmap-batched one. Under vmap (TorchRL's
  twin critics) such a tensor reports ``requires_grad=False`` whatever lies beneath; the critic needs to
  know to keep its own-action gradient path (:func:`formation_rl.models.networks._may_need_grad`).
  torch has no public equivalent (torch.func exposes none as of 2.15).
"""

from __future__ import annotations

import torch


def is_batched_tensor(t: torch.Tensor) -> bool:
    return torch._C._functorch.is_batchedtensor(t)
