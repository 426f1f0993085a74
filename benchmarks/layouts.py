"""Micro-benchmarks of the GEMM layouts behind the hand-written layers' two layout fixes (2026-12-02).

    python benchmarks/layouts.py [--threads 2] [--repeats 5]

At the critics' shapes (G = 10 groups: 5 robots x 2 twin critics, batch 1024, 128 wide), prints milliseconds
per call, median and range over ``--repeats`` timings of 50 calls each:

1. the second layer's ``baddbmm`` on the joint layer's output left as a strided view ``[B, G*H] -> [G, B, H]``
   against the same after ``.contiguous()``, in fp32 and bf16;
2. the Q layer (one output) as ``[G, B, H] @ [G, H, 1]`` against the same as rows ``[G, 1, H] @ [G, H, B]``.

A wide range on one line (a bimodal time) is glibc handing freed memory back to the OS and page-faulting
fresh outputs; run it again with ``MALLOC_MMAP_THRESHOLD_=4294967296 MALLOC_TRIM_THRESHOLD_=68719476736``
to see it go.
"""

from __future__ import annotations

import argparse
import statistics
import time

import torch

G, B, H, IN = 10, 1024, 128, 136


def _ms(f, calls: int = 50, repeats: int = 5) -> tuple[float, float, float]:
    times = []
    for _ in range(repeats):
        for _ in range(5):
            f()
        start = time.perf_counter()
        for _ in range(calls):
            f()
        times.append((time.perf_counter() - start) / calls * 1e3)
    return statistics.median(times), min(times), max(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--threads", type=int, default=None)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    if args.threads:
        torch.set_num_threads(args.threads)
    torch.manual_seed(0)
    rows = []
    for dtype in (torch.float32, torch.bfloat16):
        x, w1 = torch.randn(B, IN + 1, dtype=dtype), torch.randn(IN + 1, G * H, dtype=dtype)
        w2, b2 = torch.randn(G, H, H, dtype=dtype), torch.randn(G, 1, H, dtype=dtype)
        strided = torch.mm(x, w1).view(B, G, H).transpose(0, 1)
        name = str(dtype).removeprefix("torch.")
        rows.append((f"{name}: baddbmm on the strided view",
                     _ms(lambda b2=b2, s=strided, w2=w2: torch.baddbmm(b2, s, w2), repeats=args.repeats)))
        rows.append((f"{name}: baddbmm after .contiguous()",
                     _ms(lambda b2=b2, s=strided, w2=w2: torch.baddbmm(b2, s.contiguous(), w2), repeats=args.repeats)))
    h, w, b = torch.randn(G, B, H), torch.randn(G, H, 1), torch.randn(G, 1, 1)
    rows.append(("fp32 Q layer as [G, B, H] @ [G, H, 1]", _ms(lambda: torch.baddbmm(b, h, w), repeats=args.repeats)))
    rows.append(("fp32 Q layer as rows [G, 1, H] @ [G, H, B]", _ms(
        lambda: torch.baddbmm(b.transpose(1, 2), w.transpose(1, 2), h.transpose(1, 2)).transpose(1, 2),
        repeats=args.repeats)))
    print(f"# GEMM layouts, torch {torch.__version__}, {torch.get_num_threads()} threads\n")
    print("| call | ms (median) | ms (min - max) |\n|---|---:|---:|")
    for label, (med, lo, hi) in rows:
        print(f"| {label} | {med:.3f} | {lo:.3f} - {hi:.3f} |")


if __name__ == "__main__":
    main()
