"""ONNX Runtime's floor for one closed-loop step: only the step's matrix products, nothing else.

The weight matrices one character-step multiplies by (``compare_inference.step_matrices``: the
recurrent layers, the decoder, VGRU-d's plan recurrence) become one ONNX graph of independent
``MatMul`` nodes (``x_k [batch, in_k] @ W_kᵀ``, constant f32 weights that ORT pre-packs), timed
like ``compare_inference.py`` times a step (median of ``--steps`` calls, best thread count). No
features, gates, un-normalization or feedback: any ORT graph of the step takes at least this long,
so ours at or under it is at or under any ORT implementation of the same step.

    training/.venv/bin/python benches/compare/ort_products.py --model weights/vgru_d_multi.safetensors --batch 1,16
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import numpy as np
import onnxruntime as ort
from onnx import TensorProto, helper, numpy_helper
from safetensors import safe_open

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from compare_inference import step_matrices  # noqa: E402

from training.export import load_weights  # noqa: E402


def products_graph(weights: str) -> tuple[bytes, dict[str, int]]:
    """The serialized graph and each input's width."""
    model = load_weights(weights)
    nodes, inputs, outputs, inits, widths = [], [], [], [], {}
    with safe_open(weights, framework="np") as f:
        for k, name in enumerate(step_matrices(model)):
            w = f.get_tensor(name).astype(np.float32)  # [out, in]
            inits.append(numpy_helper.from_array(np.ascontiguousarray(w.T), f"w{k}"))
            nodes.append(helper.make_node("MatMul", [f"x{k}", f"w{k}"], [f"y{k}"]))
            inputs.append(helper.make_tensor_value_info(f"x{k}", TensorProto.FLOAT, ["batch", w.shape[1]]))
            outputs.append(helper.make_tensor_value_info(f"y{k}", TensorProto.FLOAT, ["batch", w.shape[0]]))
            widths[f"x{k}"] = w.shape[1]
    graph = helper.make_graph(nodes, "step_products", inputs, outputs, inits)
    onnx_model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)], ir_version=9)
    return onnx_model.SerializeToString(), widths


def time_products(blob: bytes, widths: dict[str, int], batch: int, threads: int, steps: int) -> float:
    options = ort.SessionOptions()
    options.intra_op_num_threads = threads
    options.inter_op_num_threads = 1
    options.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
    session = ort.InferenceSession(blob, options, providers=["CPUExecutionProvider"])
    rng = np.random.default_rng(0)
    feeds = {n: rng.standard_normal((batch, w)).astype(np.float32) for n, w in widths.items()}
    for _ in range(20):
        session.run(None, feeds)
    times = []
    for _ in range(steps):
        t = time.perf_counter()
        session.run(None, feeds)
        times.append(time.perf_counter() - t)
    return statistics.median(times) * 1e6


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--model", required=True, help="weights file")
    p.add_argument("--batch", default="1,16")
    p.add_argument("--steps", type=int, default=2000)
    p.add_argument("--reps", type=int, default=3)
    args = p.parse_args()
    blob, widths = products_graph(args.model)
    for batch in (int(b) for b in args.batch.split(",")):
        best = {t: min(time_products(blob, widths, batch, t, args.steps) for _ in range(args.reps)) for t in (1, 2)}
        print(f"{os.path.basename(args.model)} batch {batch}: ORT products only {best[1]:.1f} µs (1 thread), "
              f"{best[2]:.1f} µs (2 threads); {len(widths)} MatMuls")
    return 0


if __name__ == "__main__":
    sys.exit(main())
