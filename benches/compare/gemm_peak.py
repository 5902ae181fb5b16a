"""The large-batch products of a closed-loop step (batch 256) in our AVX-512 panel GEMM, in
``matrixmultiply`` and in ONNX Runtime's MatMul (constant weight, which it pre-packs at session
creation, like ours at load) and PyTorch ``mm``, in one run, plus the core's f32 peak measured in
the same run (AVX-512 FMAs on registers only).

Ours and matrixmultiply come from the criterion group ``gemm/`` (benches/motion/gemm.rs, mean time
per call). ONNX Runtime and PyTorch are timed the same way here: mean over about one second of
calls. The machine is shared (a training run holds a core), so the script alternates engines over
several rounds and keeps each row's best round.

    training/.venv/bin/python benches/compare/gemm_peak.py [--rounds 3] [--bench-binary PATH]
"""

from __future__ import annotations

import argparse
import re
import subprocess
import time
from pathlib import Path

import numpy as np

BATCH = 256
SHAPES = [(216, 1536), (512, 1536), (512, 1024), (512, 512), (512, 54), (1024, 1536)]
REPO = Path(__file__).resolve().parents[2]
UNITS = {"elem/s": 1e-9, "Kelem/s": 1e-6, "Melem/s": 1e-3, "Gelem/s": 1.0}


def criterion_round(binary: str | None) -> dict[str, float]:
    """GFLOP/s of every ``gemm/`` criterion benchmark (criterion's middle throughput estimate)."""
    if binary:
        cmd = [binary, "--bench", "gemm/"]
    else:
        cmd = ["cargo", "bench", "-q", "--bench", "motion", "--", "gemm/"]
    out = subprocess.run(cmd, cwd=REPO, check=True, capture_output=True, text=True).stdout
    results: dict[str, float] = {}
    name = None
    for line in out.splitlines():
        if line.startswith("gemm/"):
            name = line.split()[0]
        found = re.search(r"thrpt:\s+\[\S+ \S+ (\S+) (\S+) ", line)
        if found and name:
            results[name] = float(found.group(1)) * UNITS[found.group(2)]
            name = None
    return results


def mean_gflops(call, flop: float, seconds: float = 1.0) -> float:
    """Mean throughput of ``call`` over about ``seconds`` (after a short warm-up)."""
    for _ in range(3):
        call()
    calls, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        call()
        calls += 1
    return flop * calls / (time.perf_counter() - start) / 1e9


def onnx_matmul(inputs: int, outputs: int, threads: int, w: np.ndarray):
    """An ONNX Runtime session computing ``X @ Wᵀ`` with ``Wᵀ`` a constant initializer."""
    import onnx
    import onnxruntime as ort
    from onnx import TensorProto, helper, numpy_helper

    graph = helper.make_graph(
        [helper.make_node("MatMul", ["x", "wt"], ["y"])],
        "gemm",
        [helper.make_tensor_value_info("x", TensorProto.FLOAT, [BATCH, inputs])],
        [helper.make_tensor_value_info("y", TensorProto.FLOAT, [BATCH, outputs])],
        [numpy_helper.from_array(np.ascontiguousarray(w.T), "wt")],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8  # readable by every onnxruntime the venv may hold
    options = ort.SessionOptions()
    options.intra_op_num_threads = threads
    options.inter_op_num_threads = 1
    return ort.InferenceSession(
        model.SerializeToString(), options, providers=["CPUExecutionProvider"]
    )


def python_round(threads: list[int]) -> dict[str, float]:
    import torch

    rng = np.random.default_rng(0)
    results: dict[str, float] = {}
    for inputs, outputs in SHAPES:
        x = rng.uniform(-1, 1, (BATCH, inputs)).astype(np.float32)
        w = rng.uniform(-1, 1, (outputs, inputs)).astype(np.float32)
        flop = 2.0 * BATCH * inputs * outputs
        shape = f"{inputs}x{outputs}"
        for t in threads:
            session = onnx_matmul(inputs, outputs, t, w)
            results[f"onnxruntime/t{t}/{shape}"] = mean_gflops(
                lambda: session.run(None, {"x": x}), flop
            )
            torch.set_num_threads(t)
            xt, wt = torch.from_numpy(x), torch.from_numpy(w)
            with torch.no_grad():
                results[f"torch_mm/t{t}/{shape}"] = mean_gflops(lambda: torch.mm(xt, wt.T), flop)
    return results


def print_table(best: dict[str, float], peak: float, threads: list[int], label: str) -> None:
    engines = [
        "panels_avx512",
        "onnxruntime",
        "torch_mm",
        "matrixmultiply_transposed",
        "matrixmultiply_pytorch_layout",
    ]
    print(f"\nf32 peak, register-only AVX-512 FMAs ({label}): {peak:.0f} GFLOP/s per core")
    print(
        f"batch {BATCH}, GFLOP/s ({label} of criterion-style means); "
        "in parentheses: fraction of that peak x threads\n"
    )
    header = ["shape"] + [f"{e} t{t}" for t in threads for e in engines]
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for inputs, outputs in SHAPES:
        shape = f"{inputs}x{outputs}"
        cells = [shape]
        for t in threads:
            for e in engines:
                v = best.get(f"{e}/t{t}/{shape}")
                cells.append("" if v is None else f"{v:.0f} ({v / (peak * t):.0%})")
        print("| " + " | ".join(cells) + " |", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--threads", default="1,2")
    parser.add_argument(
        "--bench-binary", help="a built criterion binary (target/release/deps/motion-*) to run"
    )
    args = parser.parse_args()
    threads = [int(t) for t in args.threads.split(",")]
    best: dict[str, float] = {}
    peak_best = 0.0
    for r in range(args.rounds):
        ours = criterion_round(args.bench_binary)
        theirs = python_round(threads)
        for name, value in list(ours.items()) + list(theirs.items()):
            key = name.removeprefix("gemm/batch256/")
            best[key] = max(best.get(key, 0.0), value)
        peak_best = max(peak_best, ours.get("gemm/peak/fma_registers", 0.0))
        print_table(best, peak_best, threads, f"best of {r + 1} rounds")


if __name__ == "__main__":
    main()
