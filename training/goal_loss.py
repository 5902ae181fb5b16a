"""The training loss of ``goal-gru`` (``training/locomotion.py``, on H3.6M or on any rig's takes): a window's seed
teacher-forced with one control, then a closed loop reading each frame's own control."""

from __future__ import annotations

import torch

from .models import GoalGRU


def seed_controls(controls: torch.Tensor, seed: int) -> torch.Tensor:
    """The controls a run reads: the last seed frame's over the whole seed, then each frame's own."""
    out = controls.clone()
    out[:, :seed] = controls[:, seed - 1 : seed]
    return out


def window_loss(model: GoalGRU, frames: torch.Tensor, controls: torch.Tensor, seed: int, feed_noise: float):
    """Mean squared error of the teacher-forced seed outputs and of the closed loop after them."""
    horizon = frames.shape[1] - seed - 1
    seed_out, generated = model.closed_loop(
        frames[:, :seed], horizon + 1, action=seed_controls(controls, seed), return_seed_outputs=True,
        feed_noise=feed_noise,
    )
    truth_seed = frames[:, 1 : seed + 1]
    truth_gen = frames[:, seed : seed + horizon + 1]
    return ((seed_out - truth_seed) ** 2).mean(), ((generated - truth_gen) ** 2).mean()
