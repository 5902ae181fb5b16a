"""A posture term for training: generated poses held near the real poses of their action.

Per action, the Gaussian of ``training/pose_prior.py`` (the same ``prior_of``: mean, principal axes, inverse
standard deviations of the real poses in the model's normalized used dims, the root's dims left out, frames from
``pose_prior.START_FRAME`` of each training sequence). A generated frame ``y`` of action ``a`` has the standardized
deviation ``m = sqrt(mean_k (z_k * inv_std_ak)^2)`` with ``z = C_a (y - mu_a)`` (about 1 on average for real poses,
exactly what the closed-loop prior measures), and the term is the mean over rows and frames of ``relu(m - r)^2``:
zero while every frame lies within ``r`` of its action's real poses. Where the closed-loop prior clips a frame back
after it drifted, this term teaches the model not to drift (``train_intention.py --posture-weight``).
"""

from __future__ import annotations

import numpy as np
import torch

from .pose_prior import START_FRAME, prior_of


class PostureGaussian:
    """Per action ``a``: ``mean [A, O]``, ``components [A, O, O]``, ``inv_std [A, O]`` (float tensors) of
    ``sequences[a]``, a list of normalized model frames ``[T, O]`` (those shorter than ``START_FRAME`` add none; an
    action without frames gets the pooled Gaussian of all the others)."""

    def __init__(self, sequences: list[list[np.ndarray]], dims_used: list[int]):
        per_action = []
        for seqs in sequences:
            frames = [np.asarray(s, dtype=np.float64)[START_FRAME:] for s in seqs]
            frames = [f for f in frames if len(f)]
            per_action.append(np.concatenate(frames, axis=0) if frames else None)
        known = [f for f in per_action if f is not None]
        if not known:
            raise ValueError("no real frames to fit the posture term to")
        pooled = np.concatenate(known, axis=0)
        fits = [prior_of(f if f is not None else pooled, dims_used) for f in per_action]
        self.mean = torch.tensor(np.stack([f[0] for f in fits]), dtype=torch.float32)
        self.components = torch.tensor(np.stack([f[1] for f in fits]), dtype=torch.float32)
        self.inv_std = torch.tensor(np.stack([f[2] for f in fits]), dtype=torch.float32)

    def deviation(self, frames: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """``m [B, T]`` of normalized frames ``[B, T, O]`` of actions ``[B]`` (long)."""
        mean, comps, inv = (t.to(frames.device, frames.dtype) for t in (self.mean, self.components, self.inv_std))
        z = torch.einsum("bko,bto->btk", comps[actions], frames - mean[actions][:, None, :])
        axes = (inv > 0).sum(-1).clamp(min=1).to(frames.dtype)[actions][:, None]
        return torch.sqrt(((z * inv[actions][:, None, :]) ** 2).sum(-1) / axes + 1e-12)


def posture_loss(frames: torch.Tensor, actions: torch.Tensor, gaussian: PostureGaussian, radius: float) -> torch.Tensor:
    """Mean over rows and frames of ``relu(m - radius)^2`` (module docs)."""
    return (torch.relu(gaussian.deviation(frames, actions) - radius) ** 2).mean()
