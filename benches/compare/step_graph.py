"""One closed-loop generation step of a training/models.py model as a standalone module, for
ONNX export and PyTorch eager timing.

The step does the same work as one `BatchGenerator::step` of the Rust engine: derivative features
of the current normalized frame (repeat-first history of the last 3 frames), the recurrent step
(GRU-d: every layer; VGRU-d: the body GRU reading the guide ``p_t``), the decoder, the optional
residual and un-normalization to full frames. VGRU-d: the body reads a guide computed earlier
(an input here), and the step also takes one step of the plan GRU, because the Rust engine
computes the next plan block ahead, one plan step per body step (its constant input projection
``plan_gi``, the action one-hot through ``W_ih``, is computed once per block, an input here too).

Inputs:  ``x [B, O]`` (normalized frame), ``history [B, 3, O]`` (x_{t-1}, x_{t-2}, x_{t-3}),
         ``h`` (GRU-d ``[L, B, H]``; VGRU-d ``[B, H]``), VGRU-d also ``guide [B, P]``,
         ``plan_gi [B, 3P]`` and ``plan_h [B, P]``.
Outputs: ``y [B, O]`` (normalized prediction, fed back as the next ``x``), ``full [B, F]``,
         ``history' [B, 3, O]``, ``h'``, VGRU-d also ``plan_h' [B, P]``.
"""

from __future__ import annotations

import os
import statistics
import sys
import time

import torch
from torch import nn
from torch.nn import functional as F

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
if REPO not in sys.path:
    sys.path.insert(0, REPO)

from training.export_fixtures import H36M_DIMS_USED  # noqa: E402
from training.features import _differences  # noqa: E402
from training.models import GRUD, VGRUD, MotionModel, build_model, make_config  # noqa: E402


def paper_model(architecture: str, seed: int = 42) -> MotionModel:
    """A paper-size model (H3.6M frames, 512 units) with the training init, in eval mode."""
    torch.manual_seed(seed)
    model = build_model(make_config(architecture, H36M_DIMS_USED))
    # Non-trivial normalization so un-normalization is real work (as with trained weights).
    frames = model.frame_dims
    model.norm.set_stats(0.1 * torch.randn(frames), 0.5 + torch.rand(frames))
    return model.eval()


class ClosedLoopStep(nn.Module):
    """One closed-loop step of ``model`` (see the module doc)."""

    def __init__(self, model: MotionModel):
        super().__init__()
        if model.derivative_order != 3:
            raise ValueError("the step graph assumes derivative order 3 (the paper's)")
        self.model = model
        self.is_vgru = isinstance(model, VGRUD)
        if not self.is_vgru and not isinstance(model, GRUD):
            raise ValueError(f"unsupported model {type(model).__name__}")
        self.register_buffer("mean_used", model.norm.mean[model.dims_used].clone())
        self.register_buffer("std_used", model.norm.std[model.dims_used].clone())
        self.register_buffer("dims_used", torch.tensor(model.dims_used, dtype=torch.long))

    def forward(self, x, history, h, guide=None, plan_gi=None, plan_h=None):
        m = self.model
        features = _differences([x, history[:, 0], history[:, 1], history[:, 2]], 3)
        if self.is_vgru:
            body = m.body
            gi = F.linear(features, body.weight_ih, body.bias_ih) + F.linear(guide, body.weight_ph)
            new_h = body.step(gi, h)
            top = new_h
        else:
            layers = []
            inp = features
            for k, cell in enumerate(m.rnn):
                hk = cell.step(cell.input_gates(inp), h[k])
                layers.append(hk)
                inp = hk
            new_h = torch.stack(layers, dim=0)
            top = inp
        y = m._decode(top, x)
        # Full frame: dropped dims at their mean, used dims un-normalized.
        full = m.norm.mean.expand(x.shape[0], -1).index_copy(1, self.dims_used, y * self.std_used + self.mean_used)
        new_history = torch.cat([x.unsqueeze(1), history[:, :2]], dim=1)
        if self.is_vgru:
            return y, full, new_history, new_h, m.plan.cell.step(plan_gi, plan_h)
        return y, full, new_history, new_h

    def initial_inputs(self, batch: int, seed: int = 0) -> dict[str, torch.Tensor]:
        """Inputs of a first step: a small random frame, its history, zero state, a random guide."""
        g = torch.Generator().manual_seed(seed)
        m = self.model
        o, hdim = m.output_size, m.hidden_size
        x = 0.1 * torch.randn(batch, o, generator=g)
        inputs = {"x": x, "history": x.unsqueeze(1).expand(-1, 3, -1).contiguous()}
        if self.is_vgru:
            inputs["h"] = torch.zeros(batch, hdim)
            inputs["guide"] = torch.tanh(torch.randn(batch, m.plan_size, generator=g))
            onehot = torch.nn.functional.one_hot(torch.zeros(batch, dtype=torch.long), m.plan.num_actions)
            with torch.no_grad():
                inputs["plan_gi"] = m.plan.cell.input_gates(onehot.to(x.dtype)).contiguous()
            inputs["plan_h"] = torch.tanh(torch.randn(batch, m.plan_size, generator=g))
        else:
            inputs["h"] = torch.zeros(len(m.rnn), batch, hdim)
        return inputs


def export_onnx(step: ClosedLoopStep, path: str, batch: int) -> None:
    """Export ``step`` with a dynamic batch axis to ``path`` (legacy TorchScript exporter)."""
    inputs = step.initial_inputs(batch)
    names = list(inputs)
    batch_axis = {"x": 0, "history": 0, "h": 0 if step.is_vgru else 1, "guide": 0, "plan_gi": 0, "plan_h": 0}
    dynamic = {name: {batch_axis[name]: "batch"} for name in names}
    outputs = ["y", "full", "history_out", "h_out"] + (["plan_h_out"] if step.is_vgru else [])
    dynamic.update({"y": {0: "batch"}, "full": {0: "batch"}, "history_out": {0: "batch"}, "plan_h_out": {0: "batch"}})
    dynamic["h_out"] = {batch_axis["h"]: "batch"}
    with torch.no_grad():
        torch.onnx.export(
            step,
            tuple(inputs[n] for n in names),
            path,
            input_names=names,
            output_names=outputs,
            dynamic_axes=dynamic,
            opset_version=17,
            dynamo=False,
        )


def fed_back(state: dict, outputs) -> dict:
    """The next step's inputs: ``state`` with the step's outputs in place (frame, history, state,
    and the VGRU-d plan GRU's state)."""
    nxt = dict(state, x=outputs[0], history=outputs[2], h=outputs[3])
    if len(outputs) > 4:
        nxt["plan_h"] = outputs[4]
    return nxt


def median_step_us(step_fn, state: dict, steps: int) -> float:
    """Runs ``steps`` closed-loop steps from ``state`` (``step_fn`` maps inputs to the next
    inputs); median µs per step."""
    times = []
    for _ in range(steps):
        start = time.perf_counter()
        state = step_fn(state)
        times.append((time.perf_counter() - start) * 1e6)
    return statistics.median(times)


def run_closed_loop(call, inputs: dict, steps: int) -> float:
    """Median µs per step of ``call`` (inputs -> the step's outputs, e.g. ``session.run(None, .)``)
    in a closed loop from ``inputs``, outputs fed back; two untimed steps first."""

    def one(state):
        return fed_back(state, call(state))

    one(inputs)
    one(inputs)
    return median_step_us(one, dict(inputs), steps)


def session_for(onnx_path: str, threads: int):
    """An ONNX Runtime CPU session with ``threads`` intra-op threads and every graph optimization."""
    import onnxruntime as ort

    options = ort.SessionOptions()
    options.intra_op_num_threads = threads
    options.inter_op_num_threads = 1
    options.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
    return ort.InferenceSession(onnx_path, options, providers=["CPUExecutionProvider"])
