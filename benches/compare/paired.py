"""Ratios of two engines' timings paired within each repetition (used by compare_inference.py).

No third-party imports, so the test runs in any venv."""
from __future__ import annotations

import statistics


def paired_ratio(times: dict[str, list[float]], num: tuple[str, ...], den: tuple[str, ...]) -> float:
    """Median over repetitions of (best of ``num`` / best of ``den``) within each repetition.

    The engines of one repetition run back to back, so a slow minute of a shared host slows both
    sides of its ratio; the ratio of medians can pair one engine's quiet minute with the other's
    busy one (on the 2-core VMs we measure on a cell moved by up to 40 % between runs that way).
    """
    def best(names: tuple[str, ...], rep: int) -> float:
        return min(times[n][rep] for n in names if n in times)

    reps = len(next(iter(times.values())))
    return statistics.median(best(num, r) / best(den, r) for r in range(reps))
