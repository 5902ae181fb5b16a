"""NPSS on N x T x D sequences (default 2,000 x 100 x 99): motion-metrics (Rust) vs numpy.

Three numpy implementations of metrics.md's definition are timed against ``motion-cli bench
--npss`` (the Rust `Npss::score`, files loaded outside the clock) on the same .npy files:

- ``numpy-vectorized``: one FFT over the time axis of the whole array, then array arithmetic;
- ``numpy-loop``: one FFT per (sequence, dim) in Python loops, in the style of the published code
  (which stores the DFT in a real array, hence ``Re(DFT)²``: it is compared with our
  ``npss-reference``; its weighted average is taken once at the end);
- both spectra (``|DFT|²``, the paper's, and ``Re(DFT)²``) for the vectorized version.

The values must agree to 1e-9 (relative); the table shows median seconds and the ratios.

What is timed: the same computation on both sides, from arrays in memory to the score. Ours is
``Npss::score`` inside ``motion-cli bench --npss`` (the two .npy files are read before its clock
starts, as numpy's arrays are already loaded; the finiteness check of the inputs is inside the
clock), at ``--threads`` rayon threads and at 1 (numpy's FFT is single-threaded, so the 1-thread
ratio compares one core with one core). The end-to-end ``motion-cli score --metric npss`` wall time
(process start-up, reading two .npy files and the three time windows as well) is reported for
information.

Run from the repository root (release binary built first):

    cargo build --release -p motion-cli
    crates/motion-py/build.sh          # the Python bindings, for the in-process ``python-motion`` rows
    crates/motion-py/.venv/bin/python benches/compare/compare_metrics.py [--reps 5] [--loop-sequences 200]

``python-motion``: the same Rust ``Npss::score`` called in-process through the Python bindings
(``motion.npss`` on the numpy arrays, no copy, GIL released) — what a researcher's evaluation loop
pays, against the vectorized numpy code on the same arrays in the same run.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

try:  # the Python bindings (crates/motion-py), when this interpreter has them
    import motion
except ImportError:
    motion = None

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


def npss_vectorized(gt: np.ndarray, pred: np.ndarray, real_part: bool = False) -> float:
    """metrics.md NPSS over ``[N, T, D]`` with numpy array operations."""

    def spectrum(x):
        c = np.fft.fft(x, axis=1)
        return c.real**2 if real_part else c.real**2 + c.imag**2

    gp, pp = spectrum(gt), spectrum(pred)
    g_total = gp.sum(axis=1, keepdims=True)
    p_total = pp.sum(axis=1, keepdims=True)
    g_cdf = np.cumsum(np.divide(gp, g_total, out=np.zeros_like(gp), where=g_total > 0), axis=1)
    p_cdf = np.cumsum(np.divide(pp, p_total, out=np.zeros_like(pp), where=p_total > 0), axis=1)
    emd = np.abs(p_cdf - g_cdf).sum(axis=1)  # [N, D]
    weights = g_total[:, 0, :]
    return float((weights * emd).sum() / weights.sum())


def npss_loop(gt: np.ndarray, pred: np.ndarray) -> float:
    """Per (sequence, dim) loop like the published code, with its ``Re(DFT)²`` power."""
    n, t, d = gt.shape
    gt_coeffs = np.zeros(gt.shape)
    pred_coeffs = np.zeros(pred.shape)
    gt_power = np.zeros((n, d))
    emd = np.zeros((n, d))
    for s in range(n):
        for j in range(d):
            # Assigning the complex DFT into a real array keeps the real part (the quirk).
            gt_coeffs[s, :, j] = np.fft.fft(gt[s, :, j]).real
            pred_coeffs[s, :, j] = np.fft.fft(pred[s, :, j]).real
            gt_power[s, j] = np.square(gt_coeffs[s, :, j]).sum()
            pred_power = np.square(pred_coeffs[s, :, j]).sum()
            gt_norm = np.square(gt_coeffs[s, :, j]) / gt_power[s, j]
            pred_norm = np.square(pred_coeffs[s, :, j]) / pred_power
            emd[s, j] = np.linalg.norm(np.cumsum(pred_norm) - np.cumsum(gt_norm), ord=1)
    return float(np.average(emd, weights=gt_power))


def synthetic(n: int, t: int, d: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Smooth motion-like curves (random walks plus sines) and a perturbed prediction."""
    rng = np.random.default_rng(seed)
    time_axis = np.arange(t)[None, :, None]
    freq = rng.uniform(0.02, 0.3, size=(n, 1, d))
    phase = rng.uniform(0, 2 * np.pi, size=(n, 1, d))
    gt = np.sin(2 * np.pi * freq * time_axis + phase) + 0.05 * np.cumsum(rng.standard_normal((n, t, d)), axis=1)
    pred = gt + 0.1 * np.cumsum(rng.standard_normal((n, t, d)), axis=1) / np.sqrt(t)
    return gt, pred


def timed(fn, reps: int) -> tuple[float, float]:
    """(value, median seconds) of ``reps`` calls."""
    times, value = [], None
    for _ in range(reps):
        start = time.perf_counter()
        value = fn()
        times.append(time.perf_counter() - start)
    return value, statistics.median(times)


def ours(cli: str, gt_path: str, pred_path: str, reps: int, threads: int) -> dict[str, tuple[float, float]]:
    """{metric: (value, median seconds)} from ``motion-cli bench --npss``."""
    env = dict(os.environ, RAYON_NUM_THREADS=str(threads))
    out = subprocess.run(
        [cli, "bench", "--npss", gt_path, pred_path, "--reps", str(reps), "--json"],
        check=True,
        capture_output=True,
        text=True,
        env=env,
    ).stdout
    return {r["metric"]: (r["value"], r["median_ms"] / 1e3) for r in json.loads(out)["npss"]}


def score_wall(cli: str, gt_path: str, pred_path: str) -> float:
    """Wall seconds of one ``motion-cli score --metric npss`` run (I/O and windows included)."""
    start = time.perf_counter()
    subprocess.run(
        [cli, "score", "--gt", gt_path, "--pred", pred_path, "--metric", "npss", "--input-space", "raw", "--json"],
        check=True,
        capture_output=True,
    )
    return time.perf_counter() - start


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--shape", default="2000,100,99", help="N,T,D")
    parser.add_argument("--reps", type=int, default=5)
    parser.add_argument("--threads", type=int, default=2, help="rayon threads of ours (numpy FFT is single-threaded)")
    parser.add_argument(
        "--loop-sequences", type=int, default=200, help="sequences the slow loop runs on (time scaled to N)"
    )
    parser.add_argument("--cli", default=os.path.join(REPO, "target", "release", "motion-cli"))
    parser.add_argument("--json", help="also write the results to this JSON file")
    args = parser.parse_args()
    if not os.path.exists(args.cli):
        print(f"error: {args.cli} not found; run `cargo build --release -p motion-cli` first", file=sys.stderr)
        return 2
    n, t, d = (int(v) for v in args.shape.split(","))
    gt, pred = synthetic(n, t, d, seed=7)

    with tempfile.TemporaryDirectory(prefix="motion-npss-") as tmp:
        gt_path, pred_path = os.path.join(tmp, "gt.npy"), os.path.join(tmp, "pred.npy")
        np.save(gt_path, gt)
        np.save(pred_path, pred)
        results: dict[str, dict[str, list]] = {}

        def record(name, value, seconds):
            results.setdefault(name, {"values": [], "seconds": []})
            results[name]["values"].append(value)
            results[name]["seconds"].append(seconds)

        # Alternate engines; each call is itself a median of `reps` evaluations.
        rounds = 3
        for _ in range(rounds):
            for metric, (value, sec) in ours(args.cli, gt_path, pred_path, args.reps, args.threads).items():
                record(f"ours {metric}", value, sec)
            if args.threads != 1:
                for metric, (value, sec) in ours(args.cli, gt_path, pred_path, args.reps, 1).items():
                    record(f"ours-1t {metric}", value, sec)
            if motion is not None:
                # The same Rust function in-process through the Python bindings (arrays viewed in
                # place, GIL released, rayon's default pool).
                record("python-motion npss", *timed(lambda: motion.npss(gt, pred), args.reps))
                record(
                    "python-motion npss-reference",
                    *timed(lambda: motion.npss(gt, pred, variant="reference"), args.reps),
                )
            record("numpy-vectorized npss", *timed(lambda: npss_vectorized(gt, pred), args.reps))
            record("numpy-vectorized npss-reference", *timed(lambda: npss_vectorized(gt, pred, True), args.reps))
        k = min(args.loop_sequences, n)
        value, sec = timed(lambda: npss_loop(gt[:k], pred[:k]), 1)
        results["numpy-loop npss-reference (subset)"] = {"values": [value], "seconds": [sec * n / k]}
        loop_check = npss_vectorized(gt[:k], pred[:k], True)
        wall = statistics.median(score_wall(args.cli, gt_path, pred_path) for _ in range(3))

    med = {name: statistics.median(r["seconds"]) for name, r in results.items()}
    val = {name: r["values"][-1] for name, r in results.items()}
    print(f"NPSS on {n} x {t} x {d} (float64); ours with {args.threads} threads unless -1t; median of {rounds} rounds")
    print(f"{'implementation':<36} {'value':>14} {'seconds':>10} {'this / ours':>12} {'this / ours-1t':>15}")
    for name in results:
        metric = name.split(" ")[1]
        base = med[f"ours {metric}"]
        base1 = med.get(f"ours-1t {metric}", base)
        print(f"{name:<36} {val[name]:>14.9f} {med[name]:>10.4f} {med[name] / base:>12.1f} {med[name] / base1:>15.1f}")
    print(f"loop (first {k} sequences) vs vectorized Re(DFT)²: |diff| = {abs(val['numpy-loop npss-reference (subset)'] - loop_check):.1e}")
    print(f"motion-cli score --metric npss end to end (2 x {gt.nbytes / 1e6:.0f} MB .npy read, + 3 windows): {wall:.2f} s")
    worst = 0.0
    for metric in ("npss", "npss-reference"):
        ref = val[f"numpy-vectorized {metric}"]
        worst = max(worst, abs(val[f"ours {metric}"] - ref) / abs(ref))
        if motion is not None:
            worst = max(worst, abs(val[f"python-motion {metric}"] - ref) / abs(ref))
    if motion is None:
        print("(no `motion` module in this interpreter: run with crates/motion-py/.venv/bin/python for the in-process path)")
    print(f"max relative difference ours vs numpy: {worst:.1e}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"shape": [n, t, d], "median_seconds": med, "values": val, "score_wall_s": wall}, f, indent=1)
    return 0 if worst < 1e-9 else 1


if __name__ == "__main__":
    sys.exit(main())
