"""The paired ratios compare_inference.py reports (paired.py; no engines run here)."""
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from paired import paired_ratio  # noqa: E402


def test_paired_ratio_pairs_each_repetition_and_takes_the_better_variant():
    # Repetition 2 is a busy minute for everyone; per-rep ratios 0.5, 0.5, 0.46 (median 0.5),
    # the split variant winning in repetition 2 only.
    times = {
        "simd-avx2": [10.0, 40.0, 12.0],
        "simd-avx2-split": [20.0, 30.0, 50.0],
        "onnxruntime-avx2": [20.0, 60.0, 26.0],
        "onnxruntime-avx2-1t": [25.0, 80.0, 30.0],
    }
    got = paired_ratio(times, ("simd-avx2", "simd-avx2-split"), ("onnxruntime-avx2", "onnxruntime-avx2-1t"))
    assert got == 0.5
    # The ratio of medians of the same numbers is 12 / 26: the pairing is what this measures.
    mine = [min(a, b) for a, b in zip(times["simd-avx2"], times["simd-avx2-split"])]
    assert statistics.median(mine) / statistics.median(times["onnxruntime-avx2"]) == 12.0 / 26.0


def test_paired_ratio_ignores_variants_that_were_not_timed():
    times = {"simd-portable": [3.0, 6.0, 9.0], "simd-avx2": [1.0, 2.0, 4.0]}
    assert paired_ratio(times, ("simd-portable", "simd-portable-split"), ("simd-avx2",)) == 3.0
