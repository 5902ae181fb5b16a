"""What this machine can reach on one core, to put the step timings in proportion:

- f32 GEMM throughput: PyTorch's single-thread ``mm`` of 1024 x 1024 matrices (a practical peak;
  the theoretical FMA peak is cores x GHz x FMA units x lanes x 2);
- read bandwidth from cache and memory: BLAS ``sdot`` of an f32 vector with itself, for the size
  of the GRU-d 2x512 weights (10.9 MB, fits the L3) and for 256 MB (memory).

Also prints the FLOPs and weight bytes of one closed-loop step of the paper-size models.

    training/.venv/bin/python benches/compare/machine_peak.py
"""

from __future__ import annotations

import time

import numpy as np
import torch

O, I, H = 54, 54 * 4, 512  # used dims, derivative features (order 3), units


def step_cost() -> dict[str, tuple[int, int]]:
    """(multiply-adds, weight floats read) per character-step of the paper-size models."""
    gru = 3 * H * I + 3 * H * H  # layer 0: W_ih, W_hh
    gru += 2 * 3 * H * H  # layer 1: W_ih, W_hh
    vgru = 3 * H * I + 3 * H * H + 3 * H * H  # body: W_ih, W_hh, V (guide)
    decoder = O * H
    return {"gru-d 2x512": (gru + decoder,) * 2, "vgru-d 512": (vgru + decoder,) * 2}


def best_seconds(fn, reps: int) -> float:
    times = []
    for _ in range(reps):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    torch.set_num_threads(1)
    n = 1024
    a, b = torch.randn(n, n), torch.randn(n, n)
    t = best_seconds(lambda: torch.mm(a, b), 15)
    print(f"torch.mm {n}^3 f32, 1 thread: {2 * n**3 / t / 1e9:.0f} GFLOP/s (best of 15)")
    for label, mb in (("cache (10.9 MB)", 10.9), ("memory (256 MB)", 256)):
        v = np.random.default_rng(0).standard_normal(int(mb * 1e6 / 4)).astype(np.float32)
        t = best_seconds(lambda: np.dot(v, v), 20)
        print(f"read bandwidth, {label}: {v.nbytes / t / 1e9:.0f} GB/s (sdot, best of 20)")
    for name, (macs, floats) in step_cost().items():
        print(f"{name}: {2 * macs / 1e6:.2f} MFLOP and {4 * floats / 1e6:.2f} MB of f32 weights per character-step")


if __name__ == "__main__":
    main()
