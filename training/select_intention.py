"""Choosing an intention checkpoint and its noise scale on the S5 *validation* windows (issue 20, session 18).

The rule, fixed before any test window is scored:
1. among the given checkpoints (their weight averages), the highest validation NDMS 2.0-4.0 s at noise scale 1;
2. for that checkpoint, among the noise scales (``--scales``), the highest validation NDMS 2.0-4.0 s of those whose
   8-12 s speed ratio (``long_horizon.speed_ratios``, the windows of ``train_intention.validate``) is at least
   ``MIN_SPEED_RATIO`` on every action that has test windows (``EVALUABLE``): the issue's "keeps moving" target.

Validation NDMS: for each action, the 4 windows of ``data.validation_windows`` (disjoint from the test windows), each
seed repeated ``--samples`` times with ``z = s · N(0, I)`` (seeded), 100 frames generated, and every word (the last 7
seed frames prepended, as ``motion-cli eval``) scored against the nearest word of the action's S5 files: exactly the
numbers of ``motion-cli score --metric ndms`` (``word_realism`` builds the words as it does, and the search here is
exact in f64), averaged per 0.4 s bin, then over actions; the reported number is the mean of the bins 2.0 … 4.0 s.

    python -m training.select_intention training/runs/RUN/best.pt training/runs/RUN/last.pt --scales 1,0.75,0.5,0.25
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import torch

from . import data as h36m
from . import word_realism as wr
from .long_horizon import LONG_HORIZON, speed_ratios
from .models import IntentionModel
from .train import Validator
from .train_intention import VAL_NOISE_SEED, load_checkpoint

MIN_SPEED_RATIO = 0.5
WORDS_PER_BIN = 10  # 0.4 s at 25 Hz
NDMS_BINS = slice(4, 10)  # 2.0 ... 4.0 s
NDMS_NOISE_SEED = 7
EVALUABLE = tuple(a for a in h36m.ACTIONS if a not in ("directions", "discussion", "sittingdown", "waiting"))


def load_model(path: Path) -> IntentionModel:
    """The weight average (or the weights) of an intention checkpoint, in eval mode; ValueError naming the file."""
    state = load_checkpoint(path)
    if state.get("config", {}).get("architecture") != "intention":
        raise ValueError(f"{path}: not an intention checkpoint")
    model = IntentionModel(state["config"])
    model.load_state_dict(state["ema"] if state.get("ema") is not None else state["model"])
    return model.eval()


@torch.no_grad()
def validation_ndms(model: IntentionModel, windows, databases: dict[str, torch.Tensor], samples: int,
                    scale: float) -> dict[str, np.ndarray]:
    """Per action: NDMS per 0.4 s bin of ``samples`` forecasts of each of its windows (module doc); ``databases``
    holds each action's S5 words (``word_realism.words`` of its files, stride 1, f64)."""
    out = {}
    prefix = wr.KAPPA - 1
    for action, bank in databases.items():
        full = np.stack([w.frames for w in windows if w.action == action])
        seed = torch.from_numpy(np.repeat(full[:, : h36m.SEED_FRAMES], samples, 0))
        z = scale * torch.randn(len(seed), model.noise_dims, generator=torch.Generator().manual_seed(NDMS_NOISE_SEED))
        pred = model.norm.unnormalize(model.closed_loop(model.norm.normalize(seed.float()), 100, eps=z)).double()
        joined = torch.cat([seed[:, -prefix - 1 :], pred], 1)  # the root integrates from one frame before the words
        q = wr.words(wr.world_positions(joined))[:, 1:]  # [forecasts, 100, D]: word k ends at forecast frame k
        flat = q.flatten(0, 1)
        d2 = (bank * bank).sum(-1)[None] - 2.0 * flat @ bank.T
        scores = wr.similarity(flat, bank[d2.argmin(-1)]).view(q.shape[0], q.shape[1]).mean(0)
        out[action] = scores.view(-1, WORDS_PER_BIN).mean(-1).numpy()
    return out


def s5_databases(dataset_dir, actions) -> dict[str, torch.Tensor]:
    """Each action's S5 words (stride 1, f64); actions without an S5 file are left out."""
    out = {}
    for a in actions:
        seqs = [h36m.downsample(h36m.read_sequence(p)) for k in (1, 2)
                if (p := h36m.sequence_path(dataset_dir, 5, a, k)) is not None]
        if seqs:
            out[a] = torch.cat([wr.words(wr.world_positions(torch.from_numpy(s)[None]))[0] for s in seqs])
    return out


@torch.no_grad()
def validation_speed(model: IntentionModel, validator: Validator, scale: float) -> dict[str, float]:
    """8-12 s speed ratio per validation action, ``train_intention.validate``'s windows and draws times ``scale``."""
    n = validator.seed_norm.shape[0]
    z = scale * torch.randn(n, model.noise_dims, generator=torch.Generator().manual_seed(VAL_NOISE_SEED))
    pred = model.norm.unnormalize(model.closed_loop(validator.seed_norm, LONG_HORIZON, eps=z)).double().numpy()
    return speed_ratios(pred, validator)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("checkpoints", type=Path, nargs="+")
    p.add_argument("--scales", default="1", help="noise scales of step 2, comma-separated (default: 1)")
    p.add_argument("--samples", type=int, default=5, help="samples per validation window (default 5)")
    p.add_argument("--data-dir", type=Path, default=None)
    args = p.parse_args(argv)
    try:
        scales = [float(s) for s in args.scales.split(",")]
        if args.samples < 1 or any(not 0 <= s <= 100 for s in scales):
            raise ValueError("--samples must be >= 1 and every scale in [0, 100]")
        models = {path: load_model(path) for path in args.checkpoints}
        windows = h36m.validation_windows(args.data_dir, h36m.ACTIONS, 4)
        databases = s5_databases(args.data_dir or h36m.default_dataset_dir(), [a for a in h36m.ACTIONS
                                                                             if any(w.action == a for w in windows)])
    except (OSError, ValueError, KeyError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2

    def ndms(model, scale):
        per_action = validation_ndms(model, windows, databases, args.samples, scale)
        return float(np.mean([b[NDMS_BINS].mean() for b in per_action.values()]))

    first = {path: ndms(m, 1.0) for path, m in models.items()}
    for path, v in first.items():
        print(f"step 1: {path}: validation NDMS 2.0-4.0 s {v:.4f} (noise scale 1)")
    chosen = max(first, key=first.get)
    model = models[chosen]
    first_model = next(iter(models.values()))
    stats = h36m.NormStats(mean=first_model.norm.mean.double().numpy(), std=first_model.norm.std.double().numpy(),
                           dims_used=first_model.norm.dims_used.numpy())
    validator = Validator(windows, stats, list(h36m.ACTIONS))
    best = None
    for s in scales:
        v = first[chosen] if s == 1.0 else ndms(model, s)
        ratios = validation_speed(model, validator, s)
        low = min((r, a) for a, r in ratios.items() if a in EVALUABLE)
        eligible = low[0] >= MIN_SPEED_RATIO
        print(f"step 2: scale {s}: validation NDMS 2.0-4.0 s {v:.4f}; 8-12 s speed ratio min {low[0]:.2f} ({low[1]})"
              f"{'' if eligible else ' (not eligible)'}")
        if eligible and (best is None or v > best[1]):
            best = (s, v)
    if best is None:
        print(f"chosen: {chosen} — no scale keeps every evaluable action's speed ratio >= {MIN_SPEED_RATIO}")
        return 1
    print(f"chosen: {chosen}, noise scale {best[0]} (validation NDMS 2.0-4.0 s {best[1]:.4f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
