"""Test helpers shared by the training tests: a synthetic dataset shaped like H3.6M, a run killed mid-iteration, a
model whose normalized frames are full frames."""

import numpy as np
import pytest
import torch

from training import data


def synthetic_dataset(seed=0, frames=400, scaling="standard"):
    """Smooth random walks shaped like H3.6M frames, two sequences per action: ``(TrainingSet, validation
    windows of 150 frames for the first 3 actions)``. ``scaling`` ``standard`` or ``min-max``, as
    ``data.load_training_set``."""
    rng = np.random.default_rng(seed)
    seqs = []
    for _ in range(2 * len(data.ACTIONS)):
        x = np.cumsum(rng.normal(scale=0.02, size=(frames, data.FRAME_DIMS)), axis=0)
        x[:, 10:20] = 0.5  # constant dims are dropped
        seqs.append(x)
    stats = data.minmax_stats(seqs) if scaling == "min-max" else data.normalization_stats(seqs)
    by_action = []
    for i, a in enumerate(data.ACTIONS):
        by_action.append([((1, a, k + 1), stats.normalize(seqs[2 * i + k][::2]).astype(np.float32)) for k in range(2)])
    ts = data.TrainingSet(actions=tuple(data.ACTIONS), stats=stats, by_action=by_action)
    wins = [
        data.ValidationWindow(action=a, subaction=1, start=0, frames=seqs[2 * i][:150].copy())
        for i, a in enumerate(data.ACTIONS[:3])
    ]
    return ts, wins


def run_interrupted(monkeypatch, module, name: str, calls: int, run) -> None:
    """Runs ``run()`` with ``module.name`` raising KeyboardInterrupt on its ``calls``-th call (a run killed in
    the middle of an iteration), then puts the real function back."""
    seen, real = [], getattr(module, name)

    def interrupted(*a, **k):
        seen.append(1)
        if len(seen) == calls:
            raise KeyboardInterrupt
        return real(*a, **k)

    monkeypatch.setattr(module, name, interrupted)
    with pytest.raises(KeyboardInterrupt):
        run()
    monkeypatch.setattr(module, name, real)


class FullFrames:
    """Stands in for a model whose normalized frames are the full 99-dim H3.6M frames (``model.norm`` only)."""

    class norm:  # noqa: N801 (mirrors model.norm)
        dims_used = torch.arange(99)
        mean = torch.zeros(99, dtype=torch.float64)
        std = torch.ones(99, dtype=torch.float64)

        @staticmethod
        def unnormalize(x):
            return x
