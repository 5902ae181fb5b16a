"""MPJPE on the 256-window evaluation's sizes: motion-metrics (Rust, through the Python bindings)
vs a vectorized numpy implementation, and the whole `eval --protocol mpjpe` against the model's
inference alone.

1. Scoring. 11 actions x 256 windows x 25 frames of H3.6M exp-map frames (synthetic, fixed seed),
   prediction and ground truth: ``motion.mpjpe(gt, pred)`` (forward kinematics with dims 0..5
   zeroed, then the 32-joint mean per frame) against numpy doing the same with batched matrix
   products over all frames at once. Values must agree to 1e-9 mm. Also from positions
   (``input_space="positions"``), the error alone.
2. The evaluation. ``motion-cli eval --protocol mpjpe --windows 256`` of a model (wall time, data
   reading included) against ``motion-cli bench --model W --batch 256 --steps 25`` run once per
   action: the inference the evaluation cannot avoid. The target is a ratio of at most 2.

Run from the repository root (release binary and bindings built first):

    cargo build --release -p motion-cli && crates/motion-py/build.sh
    crates/motion-py/.venv/bin/python benches/compare/compare_mpjpe.py [--reps 5] [--model weights/vgru_d_multi.safetensors]

Medians of ``--reps`` repetitions, engines alternating; ratios within one run are what counts.
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
SKELETON = ROOT.parent / "shared" / "reference" / "h36m_skeleton.json"
sys.path.insert(0, str(ROOT))
from training.metrics_np import expmap2rotmat as rotmats  # noqa: E402  (numpy only)


def positions(frames: np.ndarray, joints: list[dict]) -> np.ndarray:
    """... x 99 exp-map frames -> ... x 32 x 3 (dims 0..5 zeroed, row-vector FK)."""
    lead = frames.shape[:-1]
    local = rotmats(frames.reshape(-1, 99)[:, 3:].reshape(-1, 32, 3))  # joint j: dims 3+3j..
    local[:, 0] = np.eye(3)  # the root's rotation: dims 3..5 zeroed
    world = np.empty_like(local)
    pos = np.empty(local.shape[:2] + (3,))
    for j in joints:
        i, p = j["index"], j["parent"]
        off = np.asarray(j["offset_mm"])
        if p < 0:
            world[:, i], pos[:, i] = local[:, i], off
        else:
            world[:, i] = local[:, i] @ world[:, p]
            pos[:, i] = np.einsum("k,nkl->nl", off, world[:, p]) + pos[:, p]
    return pos.reshape(lead + (32, 3))


def numpy_mpjpe(gt: np.ndarray, pred: np.ndarray, joints: list[dict]) -> np.ndarray:
    a, b = positions(gt, joints), positions(pred, joints)
    return np.linalg.norm(a - b, axis=-1).mean(axis=(0, 2))


def timed(fn, reps: int) -> tuple[float, object]:
    times, value = [], None
    for _ in range(reps):
        start = time.perf_counter()
        value = fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times), value


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--windows", type=int, default=11 * 256)
    ap.add_argument("--model", default="weights/vgru_d_multi.safetensors")
    ap.add_argument("--cli", default="target/release/motion-cli")
    ap.add_argument("--eval-reps", type=int, default=2)
    args = ap.parse_args()
    import motion

    joints = json.loads(SKELETON.read_text())["joints"]
    rng = np.random.default_rng(0)
    gt = rng.normal(scale=0.4, size=(args.windows, 25, 99))
    pred = gt + rng.normal(scale=0.05, size=gt.shape)
    rows = {}
    t_ours, v_ours = timed(lambda: motion.mpjpe(gt, pred), args.reps)
    t_np, v_np = timed(lambda: numpy_mpjpe(gt, pred, joints), args.reps)
    diff = float(np.max(np.abs(np.asarray(v_ours) - v_np)))
    if diff > 1e-9:
        print(f"values differ by {diff:.3e} mm", file=sys.stderr)
        return 1
    rows["exp-map -> MPJPE"] = (t_ours, t_np)
    pa, pb = positions(gt, joints), positions(pred, joints)
    t_ours_p, v_p = timed(lambda: motion.mpjpe(pa, pb, input_space="positions"), args.reps)
    t_np_p, v_np_p = timed(lambda: np.linalg.norm(pa - pb, axis=-1).mean(axis=(0, 2)), args.reps)
    assert np.max(np.abs(np.asarray(v_p) - v_np_p)) < 1e-9
    rows["positions -> MPJPE"] = (t_ours_p, t_np_p)

    print(f"MPJPE, {args.windows} windows x 25 frames (values agree to {diff:.1e} mm)")
    print(f"{'':24}{'ours (s)':>10}{'numpy (s)':>11}{'numpy / ours':>14}")
    for name, (o, n) in rows.items():
        print(f"{name:24}{o:>10.4f}{n:>11.4f}{n / o:>13.1f}x")

    if Path(args.model).is_file() and (ROOT.parent / "shared" / "data" / "h3.6m").is_dir():
        evals, infers = [], []
        for _ in range(args.eval_reps):
            start = time.perf_counter()
            subprocess.run([args.cli, "eval", "--protocol", "mpjpe", "--windows", "256", "--model", args.model, "--json"],
                           check=True, stdout=subprocess.DEVNULL)
            evals.append(time.perf_counter() - start)
            start = time.perf_counter()
            for _ in range(11):
                out = subprocess.run([args.cli, "bench", "--model", args.model, "--batch", "256", "--steps", "25"],
                                     check=True, capture_output=True, text=True).stdout
            infers.append(time.perf_counter() - start)
        e, i = statistics.median(evals), statistics.median(infers)
        print(f"\neval --protocol mpjpe --windows 256 ({args.model}): {e:.2f} s; the model alone "
              f"(11 x bench --batch 256 --steps 25, processes included): {i:.2f} s; ratio {e / i:.2f}")
        last = re.findall(r"[^\n]+", out)[-1:] or [""]
        print(f"  last bench line: {last[0]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
