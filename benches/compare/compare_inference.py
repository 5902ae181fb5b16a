"""Closed-loop generation step: motion-cli (Rust) vs ONNX Runtime vs PyTorch eager, same weights.

For each architecture (GRU-d 2x512, VGRU-d 512) the script builds a paper-size model with the
training init (or loads ``--model FILE``), saves it with ``training.export.save_weights`` (the file
``motion-cli bench --model`` times), exports one closed-loop step to ONNX (step_graph.py: inputs
frame + derivative history + state [+ guide], outputs next frame + full frame + new history + new
state), checks ONNX Runtime against PyTorch (1e-5), then times the three engines in one run,
alternating their order every repetition. ONNX Runtime and PyTorch are also timed with one
thread: on a shared 2-core machine their second thread often waits for a busy core, and the ratio
columns compare each engine at its better thread count (ours too: RAYON_NUM_THREADS=1). Each repetition times ``--steps`` closed-loop steps one
by one (outputs fed back as inputs) and keeps the median step; the table shows the median over
repetitions.

`--simd avx512,avx2,portable` also times ours on each SIMD path; `--ort-avx2` adds ONNX Runtime
held to its AVX2 kernels (ort_avx2.py), against which the `avx2` path is then compared.

Run from the repository root (release binary built first):

    cargo build --release -p motion-cli
    training/.venv/bin/python benches/compare/compare_inference.py [--threads 2] [--reps 7]
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
import onnxruntime as ort
import torch

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ort_avx2 import Worker, make_avx2_copy  # noqa: E402
from paired import paired_ratio  # noqa: E402
from step_graph import (  # noqa: E402
    REPO,
    ClosedLoopStep,
    export_onnx,
    fed_back,
    median_step_us,
    paper_model,
    run_closed_loop,
    session_for,
)

from training.export import load_weights, save_weights  # noqa: E402

ARCHES = ("gru-d", "vgru-d")
SETTLE_S = 0.2  # idle seconds before each timed repetition
DTYPES = {"float32": torch.float32, "float16": torch.float16, "bfloat16": torch.bfloat16}


def step_matrices(model) -> list[str]:
    """State-dict names of the weight matrices one closed-loop step multiplies by (VGRU-d: with the
    plan GRU's recurrent matrix, one plan step per body step; its input projection is once per
    block)."""
    names = []
    for name, tensor in model.state_dict().items():
        if tensor.dim() != 2:
            continue
        if name.startswith(("rnn.", "body.", "decoder.")) or name == "plan.cell.weight_hh":
            names.append(name)
    return names


def step_cost(model, weights: str) -> tuple[int, int]:
    """(FLOPs, bytes of weight matrices read) of one character-step, bytes in the file's dtype."""
    from safetensors import safe_open

    flops = 0
    nbytes = 0
    with safe_open(weights, framework="pt") as f:
        for name in step_matrices(model):
            t = f.get_tensor(name)
            flops += 2 * t.numel()
            nbytes += t.numel() * t.element_size()
    return flops, nbytes


def torch_runner(step: ClosedLoopStep, inputs: dict[str, torch.Tensor], threads: int):
    """A closure that times PyTorch eager (no_grad) with ``threads`` intra-op threads."""

    def one(state):
        with torch.no_grad():
            return fed_back(state, step(**state))

    def run(steps: int) -> float:
        torch.set_num_threads(threads)
        for _ in range(3):  # warm-up
            one(inputs)
        return median_step_us(one, dict(inputs), steps)

    return run


def ort_runner(session: ort.InferenceSession, inputs: dict[str, np.ndarray]):
    """A closure that times ONNX Runtime, outputs fed back as numpy inputs."""

    def run(steps: int) -> float:
        return run_closed_loop(lambda state: session.run(None, state), inputs, steps)

    return run


def ort_avx2_runner(worker: Worker, onnx_path: str, threads: int, feeds_npz: str):
    """A closure that times ONNX Runtime held to AVX2 (``ort_avx2``), in its worker process."""

    def run(steps: int) -> float:
        return worker.time(onnx_path, threads, feeds_npz, steps)

    return run


def best_on(med: dict[str, float], path: str) -> float:
    """Ours on one SIMD path: the default step, or the opt-in row split where it was timed."""
    return min(v for n, v in med.items() if n in (f"simd-{path}", f"simd-{path}-split"))


def ours_runner(cli: str, weights: str, batch: int, threads: int, extra: tuple[str, ...] = ()):
    """A closure that times ``motion-cli bench --model WEIGHTS`` (its median µs per step)."""
    env = dict(os.environ, RAYON_NUM_THREADS=str(threads))

    def run(steps: int) -> float:
        out = subprocess.run(
            [cli, "bench", "--model", weights, "--batch", str(batch), "--steps", str(steps), "--json", *extra],
            check=True,
            capture_output=True,
            text=True,
            env=env,
        ).stdout
        return json.loads(out)["results"][0]["us_per_step"]

    return run


def parity(step: ClosedLoopStep, session: ort.InferenceSession, batch: int) -> float:
    """Max |ORT - PyTorch| over all outputs of 5 chained steps."""
    state = step.initial_inputs(batch, seed=1)
    worst = 0.0
    for _ in range(5):
        with torch.no_grad():
            ref = step(**state)
        got = session.run(None, {k: v.numpy() for k, v in state.items()})
        worst = max(worst, max(float(np.abs(r.numpy() - g).max()) for r, g in zip(ref, got)))
        state = fed_back(state, ref)
    return worst


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", action="append", default=[], help="weights file(s) to use instead of random ones")
    parser.add_argument("--arch", default="gru-d,vgru-d", help="random models to build (comma-separated)")
    parser.add_argument("--batch", default="1,256", help="batch sizes (comma-separated)")
    parser.add_argument("--threads", type=int, default=2, help="intra-op threads (ORT, torch, rayon)")
    parser.add_argument("--reps", type=int, default=5, help="repetitions per engine (alternating)")
    parser.add_argument("--steps", type=int, default=300, help="timed steps per repetition at batch 1")
    parser.add_argument("--large-steps", type=int, default=30, help="timed steps per repetition at batch >= 64")
    parser.add_argument("--cli", default=os.path.join(REPO, "target", "release", "motion-cli"))
    parser.add_argument(
        "--dtype",
        choices=sorted(DTYPES),
        default="float32",
        help="dtype the random models' weights are saved in (ORT and PyTorch get the same values as f32)",
    )
    parser.add_argument(
        "--baseline-cli",
        help="also time this motion-cli build (e.g. an older commit) in the same run, as `baseline`",
    )
    parser.add_argument(
        "--simd",
        default="",
        help="also time ours on each of these SIMD paths (comma-separated: avx512, avx2, neon, portable; "
        "`motion-cli bench --simd`), each against ORT in the same run",
    )
    parser.add_argument(
        "--ort-avx2",
        action="store_true",
        help="also time ONNX Runtime held to its AVX2 kernels (ort_avx2.py: a patched private copy, run in "
        "a worker process); the `avx2` path's ratio is then taken against it, every other against stock ORT",
    )
    parser.add_argument("--json", help="also write the results to this JSON file")
    args = parser.parse_args()
    simd_paths = [p for p in args.simd.split(",") if p]

    if not os.path.exists(args.cli):
        print(f"error: {args.cli} not found; run `cargo build --release -p motion-cli` first", file=sys.stderr)
        return 2
    torch.set_num_threads(args.threads)
    batches = [int(b) for b in args.batch.split(",")]

    rows = []
    with tempfile.TemporaryDirectory(prefix="motion-compare-") as tmp:
        worker = Worker(make_avx2_copy(os.path.join(tmp, "ort-avx2"))) if args.ort_avx2 else None
        models = []
        for path in args.model:
            models.append((load_weights(path), path))
        if not args.model:
            for arch in args.arch.split(","):
                model = paper_model(arch)
                path = os.path.join(tmp, f"{arch}.safetensors")
                save_weights(model, path, {"data": "random", "iterations": 0, "seed": 42}, dtype=DTYPES[args.dtype])
                if args.dtype != "float32":
                    # The stored (rounded) values, upcast to f32, for ONNX Runtime and PyTorch.
                    model = load_weights(path)
                models.append((model, path))
        if args.dtype != "float32" and not args.model:
            print(
                f"weights stored as {args.dtype}: ours keeps them {args.dtype}; ONNX Runtime and PyTorch "
                "compute with the same values upcast to f32 (identical numbers in every engine)"
            )
        for model, weights in models:
            arch = model.config["architecture"]
            step = ClosedLoopStep(model).eval()
            onnx_path = os.path.join(tmp, f"{arch}.onnx")
            export_onnx(step, onnx_path, batch=2)
            sessions = {n: session_for(onnx_path, n) for n in {args.threads, 1}}
            flops, weight_bytes = step_cost(model, weights)
            print(
                f"{arch} {model.hidden_size}: {flops / 1e6:.2f} MFLOP and {weight_bytes / 1e6:.2f} MB of weight "
                f"matrices per character-step ({os.path.basename(weights)})",
                flush=True,
            )
            for batch in batches:
                err = parity(step, sessions[args.threads], batch)
                inputs = step.initial_inputs(batch)
                feeds = {k: v.numpy() for k, v in inputs.items()}
                engines = {
                    "ours": ours_runner(args.cli, weights, batch, args.threads),
                    "onnxruntime": ort_runner(sessions[args.threads], feeds),
                    "pytorch": torch_runner(step, inputs, args.threads),
                }
                if args.baseline_cli:
                    engines["baseline"] = ours_runner(args.baseline_cli, weights, batch, args.threads)
                if worker is not None:
                    feeds_npz = os.path.join(tmp, f"{arch}-{batch}.npz")
                    np.savez(feeds_npz, **feeds)
                    for n in sorted({args.threads, 1}, reverse=True):
                        name = "onnxruntime-avx2" + ("" if n == args.threads else "-1t")
                        engines[name] = ort_avx2_runner(worker, onnx_path, n, feeds_npz)
                if args.threads != 1 and batch <= 4:
                    # Opt-in: products split over threads by output rows (`bench --row-split`).
                    engines["split"] = ours_runner(args.cli, weights, batch, args.threads, ("--row-split",))
                for path in simd_paths:
                    engines[f"simd-{path}"] = ours_runner(args.cli, weights, batch, args.threads, ("--simd", path))
                    if args.threads != 1 and batch <= 4:
                        engines[f"simd-{path}-split"] = ours_runner(
                            args.cli, weights, batch, args.threads, ("--simd", path, "--row-split")
                        )
                if args.threads != 1:
                    engines["ours-1t"] = ours_runner(args.cli, weights, batch, 1)
                    if args.baseline_cli:
                        engines["baseline-1t"] = ours_runner(args.baseline_cli, weights, batch, 1)
                    engines["onnxruntime-1t"] = ort_runner(sessions[1], feeds)
                    engines["pytorch-1t"] = torch_runner(step, inputs, 1)
                steps = args.steps if batch < 64 else args.large_steps
                times = {name: [] for name in engines}
                order = list(engines)
                for rep in range(args.reps):
                    k = rep % len(order)
                    for name in order[k:] + order[:k]:
                        # ORT's and torch's pool threads spin for a while after a call; let them
                        # stop so they do not take the next engine's second core.
                        time.sleep(SETTLE_S)
                        times[name].append(engines[name](steps))
                med = {name: statistics.median(t) for name, t in times.items()}
                # Each engine at its better thread count on this (shared) machine.
                best_ours = min(v for n, v in med.items() if n.startswith("ours"))
                best_ort = min(v for n, v in med.items() if n.startswith("onnxruntime") and "avx2" not in n)
                best_ort_avx2 = min((v for n, v in med.items() if n.startswith("onnxruntime-avx2")), default=None)
                # Which ORT each path is compared with (held to AVX2 for `avx2` when timed).
                stock = ("onnxruntime", "onnxruntime-1t")
                held = ("onnxruntime-avx2", "onnxruntime-avx2-1t")
                ort_names = {p: held if p == "avx2" and best_ort_avx2 else stock for p in simd_paths}
                ort_for = {p: min(med[n] for n in ort_names[p] if n in med) for p in simd_paths}
                best_torch = min(v for n, v in med.items() if n.startswith("pytorch"))
                best_base = min((v for n, v in med.items() if n.startswith("baseline")), default=float("nan"))
                row = {
                    "arch": arch,
                    "hidden": model.hidden_size,
                    "batch": batch,
                    "us_per_step": med,
                    "char_steps_per_s": {n: batch * 1e6 / t for n, t in med.items()},
                    "ours_over_ort": best_ours / best_ort,
                    "pytorch_over_ours": best_torch / best_ours,
                    "split_over_ort": med.get("split", float("nan")) / best_ort,
                    "pytorch_over_split": best_torch / med.get("split", float("nan")),
                    "baseline_over_ort": best_base / best_ort,
                    "ours_over_ort_by_simd": {p: best_on(med, p) / ort_for[p] for p in simd_paths},
                    # The same ratios paired within each repetition (`paired_ratio`), and the
                    # portable path over the AVX2 one: the figures the README's tables quote.
                    "ours_over_ort_by_simd_paired": {
                        p: paired_ratio(times, (f"simd-{p}", f"simd-{p}-split"), ort_names[p])
                        for p in simd_paths
                    },
                    "portable_over_avx2_paired": (
                        paired_ratio(times, ("simd-portable", "simd-portable-split"), ("simd-avx2", "simd-avx2-split"))
                        if {"portable", "avx2"} <= set(simd_paths)
                        else None
                    ),
                    "ort_avx2_over_ort": best_ort_avx2 / best_ort if best_ort_avx2 else None,
                    "ort_vs_pytorch_max_abs": err,
                    "flops_per_char_step": flops,
                    "weight_bytes_per_step": weight_bytes,
                    # Batch 1 reads every weight once per step; larger batches read them once
                    # for all rows.
                    "ours_weight_gb_per_s": weight_bytes / best_ours / 1e3,
                    "ours_gflop_per_s": batch * flops / best_ours / 1e3,
                    "all_reps_us": times,
                }
                rows.append(row)
                print_row(row, header=len(rows) == 1)
                if simd_paths:
                    print(
                        "    per SIMD path, ours µs (ours/ORT; at batch <= 4 the better of the default step and "
                        "--row-split): "
                        + "  ".join(
                            f"{p} {med[f'simd-{p}']:.1f}"
                            + (f" split {med[f'simd-{p}-split']:.1f}" if f"simd-{p}-split" in med else "")
                            + f" ({row['ours_over_ort_by_simd'][p]:.2f}x,"
                            + f" paired {row['ours_over_ort_by_simd_paired'][p]:.2f}x)"
                            for p in simd_paths
                        )
                        + (
                            f"  portable/avx2 paired {row['portable_over_avx2_paired']:.2f}x"
                            if row["portable_over_avx2_paired"] is not None
                            else ""
                        ),
                        flush=True,
                    )
                if best_ort_avx2:
                    print(
                        f"    ONNX Runtime held to AVX2: {best_ort_avx2:.1f} µs ({row['ort_avx2_over_ort']:.2f}x stock ORT)"
                        + ("; the avx2 ratio above is against it" if "avx2" in simd_paths else ""),
                        flush=True,
                    )
        if worker is not None:
            print(f"ONNX Runtime held to AVX2 was imported from {worker.package}")
            worker.close()
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"threads": args.threads, "reps": args.reps, "dtype": args.dtype, "results": rows}, f, indent=1)
    return 0


def print_row(row: dict, header: bool) -> None:
    if header:
        print(
            f"{'model':<14} {'batch':>5} {'ours µs':>10} {'ours-1t µs':>10} {'ORT µs':>10} {'ORT-1t µs':>10} {'torch µs':>10} "
            f"{'torch-1t µs':>11} {'ours/ORT':>9} {'torch/ours':>10} {'best ours char-steps/s':>22} {'ORT-torch':>9} "
            f"{'ours GB/s':>9} {'ours GFLOP/s':>12} {'baseline µs':>11} {'baseline/ORT':>12} "
            f"{'split µs':>9} {'split/ORT':>9} {'torch/split':>11}"
        )
    t = dict(row["us_per_step"])
    for n in ("ours-1t", "onnxruntime-1t", "pytorch-1t", "split"):
        t.setdefault(n, float("nan"))
    name = f"{row['arch']} {row['hidden']}"
    print(
        f"{name:<14} {row['batch']:>5} {t['ours']:>10.1f} {t['ours-1t']:>10.1f} {t['onnxruntime']:>10.1f} {t['onnxruntime-1t']:>10.1f} "
        f"{t['pytorch']:>10.1f} {t['pytorch-1t']:>11.1f} "
        f"{row['ours_over_ort']:>9.2f} {row['pytorch_over_ours']:>10.2f} "
        f"{max(v for n, v in row['char_steps_per_s'].items() if n.startswith('ours')):>22.0f} "
        f"{row['ort_vs_pytorch_max_abs']:>9.1e} "
        f"{row['ours_weight_gb_per_s']:>9.1f} {row['ours_gflop_per_s']:>12.1f} "
        f"{min((v for n, v in t.items() if n.startswith('baseline')), default=float('nan')):>11.1f} "
        f"{row['baseline_over_ort']:>12.2f} "
        f"{t['split']:>9.1f} {row['split_over_ort']:>9.2f} {row['pytorch_over_split']:>11.2f}",
        flush=True,
    )


if __name__ == "__main__":
    sys.exit(main())
