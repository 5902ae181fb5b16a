"""What the long-horizon training options and checkpoint choices share (issue 15): the joint-speed and
acceleration terms of a closed loop, and the 12 s speed ratio of the S5 validation windows.

Used by ``train`` (``--speed-weight``, ``--choose long``), ``train_dae`` and ``train_intention``. The speed ratio
of an action is the mean absolute frame-to-frame change of the joint angles (exp-map dims 6.., un-normalized)
over predicted frames ``LONG_WINDOW`` of a ``LONG_HORIZON``-frame closed loop, divided by the ground truth's
over the validation window's frames: the training-side counterpart of ``motion-cli eval``'s ``speed_ratio``.
"""

from __future__ import annotations

import numpy as np
import torch

from .features import DerivativeHistory
from .root_drift import drift_penalty

LONG_HORIZON = 300  # 12 s at 25 Hz: the closed-loop length of the long checkpoint choices
LONG_WINDOW = (200, 300)  # predicted frames 8-12 s
ELIGIBLE_RATIO = 0.5  # the target: every window's speed ratio >= 0.5

SPEED_FLOOR = 1e-3  # radians per frame added to both speeds: sequences that stand still do not dominate
ACCEL_FLOOR = 1e-4  # radians per frame² added to both accelerations, likewise
HINGE_BAND = (0.8, 1.5)  # the hinge form: no penalty while prediction / truth is inside this band
MOTION_LOSS = ["log"]  # the form of the speed and acceleration terms (a trainer sets it from --motion-loss)


def ratio_loss(pred: torch.Tensor, truth: torch.Tensor, kind: str) -> torch.Tensor:
    """Per-sequence penalty of a predicted motion magnitude against the truth's, averaged: ``log`` is the squared
    log ratio; ``hinge`` is the squared shortfall below ``HINGE_BAND[0]`` plus the squared excess over
    ``HINGE_BAND[1]``, both as fractions of the truth (a gradient bounded by ~2 / truth, zero inside the band)."""
    if kind == "log":
        return ((pred.log() - truth.log()) ** 2).mean()
    ratio = pred / truth
    low, high = HINGE_BAND
    return (torch.relu(low - ratio) ** 2 + torch.relu(ratio - high) ** 2).mean()


def _joint_scale(model, device):
    joints = torch.tensor([d >= 6 for d in model.dims_used], device=device)
    return joints, model.norm.std[model.norm.dims_used][joints]


def speed_loss(model, pred: torch.Tensor, truth: torch.Tensor) -> torch.Tensor:
    """Penalty (``MOTION_LOSS[0]`` form) of the mean absolute frame-to-frame change of the joint angles (not the
    root's 6 dims) of ``pred`` against ``truth`` ``[B, T, O]`` (normalized), per sequence, in radians: the
    training counterpart of the speed ratio. It penalises a prediction that slows to a stop (the squared-error
    optimum far from the seed) as much as one that moves too fast."""
    joints, scale = _joint_scale(model, pred.device)

    def speed(x):
        return (x[:, 1:, joints] - x[:, :-1, joints]).abs().mul(scale).mean(dim=(1, 2)) + SPEED_FLOOR

    return ratio_loss(speed(pred), speed(truth), MOTION_LOSS[0])


def accel_loss(model, pred: torch.Tensor, truth: torch.Tensor) -> torch.Tensor:
    """As ``speed_loss`` for the mean absolute second difference of the joint angles: matching it too keeps the
    speed term from being met by jitter (fast, rough motion has a far larger acceleration than real motion)."""
    joints, scale = _joint_scale(model, pred.device)

    def accel(x):
        x = x[..., joints]
        return (x[:, 2:] - 2 * x[:, 1:-1] + x[:, :-2]).abs().mul(scale).mean(dim=(1, 2)) + ACCEL_FLOOR

    return ratio_loss(accel(pred), accel(truth), MOTION_LOSS[0])


ROOT_SPEED_FLOOR = 1.0  # mm per source frame added to both root speeds: standing sequences do not dominate


def root_speed_loss(model, pred: torch.Tensor, truth: torch.Tensor) -> torch.Tensor:
    """As ``speed_loss`` for the root's translation: the mean length of the per-frame root translation (dims 0..2,
    a delta in mm per source frame, root-local; un-normalized) of ``pred`` against ``truth`` ``[B, T, O]``
    (normalized) per sequence. The joint-angle terms leave the root out, and a closed loop that keeps its legs
    walking while the body stops (the root's speed falls to a tenth by 8-12 s) meets them; NDMS and any viewer see
    the root's motion in every joint's velocity."""
    used = model.norm.dims_used[:3]
    if used.tolist() != [0, 1, 2]:
        raise ValueError(f"the model's first used dims are {used.tolist()}, not the root translation's 0..2")
    std, mean = model.norm.std[used], model.norm.mean[used]

    def speed(x):
        return (x[..., :3] * std + mean).norm(dim=-1).mean(dim=1) + ROOT_SPEED_FLOOR

    return ratio_loss(speed(pred), speed(truth), MOTION_LOSS[0])


def speed_ratios(full_pred: np.ndarray, validator) -> dict[str, float]:
    """Per validation action: the speed ratio (module doc) of ``full_pred [N, >= LONG_WINDOW[1], F]``
    (un-normalized closed-loop frames of the validator's windows, in its order)."""
    lo, hi = LONG_WINDOW
    out = {}
    for a in validator.actions:
        idx = [i for i, wa in enumerate(validator.window_actions) if wa == a]
        p = np.abs(np.diff(full_pred[idx, lo - 1 : hi, 6:], axis=1)).mean()
        g = np.abs(np.diff(validator.gt_full[idx][:, :, 6:], axis=1)).mean()
        out[a] = float(p / g) if g > 0 else float("nan")
    return out


@torch.no_grad()
def long_closed_loop(model, validator, eps=None) -> np.ndarray:
    """The model's ``LONG_HORIZON``-frame closed loop from every validation seed, un-normalized ``[N, T, F]``
    (eval mode; ``eps`` the plan noise or ``z``, None for a model without one)."""
    was_training = model.training
    model.eval()
    try:
        acts = torch.tensor([model.actions.index(a) for a in validator.window_actions]) if model.actions else None
        pred = model.closed_loop(validator.seed_norm, LONG_HORIZON, acts, eps).double().numpy()
    finally:
        model.train(was_training)
    return validator.stats.unnormalize(pred)


def choice_key(val: dict) -> tuple:
    """Sort key of the long checkpoint choice (smaller is better): eligible (every action's 8-12 s ratio >=
    ``ELIGIBLE_RATIO``) first, then the lowest validation NPSS; else the highest smallest ratio."""
    smallest = min(val["long_speed"].values())
    if smallest >= ELIGIBLE_RATIO:
        return (0, val["npss_ref"])
    return (1, -smallest)


def long_motion_loss(model, frames: torch.Tensor, actions, seed: int, burn_in: int, length: int, eps=None,
                     feed_noise: float = 0.0, dropout: bool = True, drift_weight: float = 0.0) -> torch.Tensor:
    """The long-horizon term (truncated back-propagation through the closed loop), for any ``MotionModel``:
    after ``seed`` true frames the model runs ``burn_in`` frames on its own output without gradient, then
    ``length`` frames with it; ``speed_loss + accel_loss`` of those frames (with the last burn-in frame before
    them) against the truth's over the same frames ``frames[:, seed + burn_in : seed + burn_in + length + 1]``.
    Positions are not compared: ``burn_in`` frames in, the truth is one of many right answers. The steps are
    ``closed_loop``'s (the VGRU plan streams past its horizon); ``feed_noise`` as there (the frames with gradient
    only); ``dropout=False`` leaves out the input dropout (``train_dae``'s term). ``drift_weight > 0`` adds that
    times ``root_drift.drift_penalty`` of the ``length`` frames: the root integrated from the first seed frame over
    the seed and the burn-in (no gradient) and these frames, hip height and lean against the last seed frame's."""
    ctx = model._begin(frames.shape[0], seed + burn_in + length, actions, eps, frames, seed_len=seed)
    history = DerivativeHistory(model.derivative_order)
    with torch.no_grad():
        frame = model._teacher_force(ctx, history, frames[:, :seed], dropout)[:, -1:]
        burned = [frame]  # predicted frames seed .. seed + burn_in (the last is pred[:, 0] below)
        for k in range(burn_in):
            frame = model._feed_back(ctx, history, frame, seed + k, dropout=dropout)
            burned.append(frame)
    model._cut_graph(ctx, history)
    outputs = [frame.detach()]
    for k in range(length):
        outputs.append(model._feed_back(ctx, history, outputs[-1], seed + burn_in + k, feed_noise, dropout))
    pred = torch.cat(outputs, dim=1)
    truth = frames[:, seed + burn_in : seed + burn_in + length + 1]
    loss = speed_loss(model, pred, truth) + accel_loss(model, pred, truth)
    if drift_weight > 0:
        parts = [(torch.cat(burned, dim=1), False), (pred[:, 1:], True)]
        loss = loss + drift_weight * drift_penalty(model, frames[:, :seed], parts).to(loss.dtype)
    return loss
