"""formation_rl.compat: the private torch function it wraps still exists and still means what we use it for."""

import torch
from torch.func import vmap

from formation_rl.compat import is_batched_tensor


def test_is_batched_tensor_tells_vmapped_tensors_apart():
    seen = []
    vmap(lambda x: seen.append(is_batched_tensor(x)) or x)(torch.zeros(3, 2))
    assert seen == [True] and not is_batched_tensor(torch.zeros(2))


def test_no_private_torchrl_attribute_is_read():
    """TorchRL's private attributes are not read anywhere in the package (grep of the source)."""
    import re
    from pathlib import Path

    import formation_rl

    root = Path(formation_rl.__file__).parent
    hits = [f"{p.relative_to(root)}: {line.strip()}" for p in root.rglob("*.py") for line in p.read_text().splitlines()
            if re.search(r"\.loss\._|_AcceptedKeys|_cached_", line)]
    assert hits == []
