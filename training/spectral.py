"""A differentiable NPSS (reference variant) for training: the evaluation's metric as an auxiliary loss.

Gopalakrishnan et al. 2019 (CVPR), section 5, defines NPSS as an evaluation metric; the published
numbers use the reference code's variant (power = Re(DFT)^2, ../shared/reference/metrics.md). Squared error on
the closed loop pulls long predictions towards the conditional mean (a slowing, smoothed motion); this term scores
the spectrum of the whole predicted window instead. It mirrors `evaluate.npss(..., "reference")` on the Euler
angles of `evaluate.to_euler`, with two changes that keep gradients finite: the rotation angle is
sqrt(|r|^2 + tiny) and the pitch is clamped just inside +-pi/2 (the evaluation's exact gimbal-lock branches are
measure-zero cases).
"""

from __future__ import annotations

import torch

from .metrics_np import EXPMAP_EPS

_TINY = 1e-12


def expmap_to_euler(full: torch.Tensor) -> torch.Tensor:
    """Full exp-map frames ``[..., D]`` (D = 3 + 3k) -> Euler sequences ``[..., D]`` as `evaluate.to_euler`:
    every triple at dims 3.. converted (E1, E2, E3), dims 0..5 set to 0."""
    lead = full.shape[:-1]
    r = full[..., 3:].reshape(*lead, -1, 3)
    theta = torch.sqrt((r * r).sum(-1) + _TINY)
    k = r / (theta + EXPMAP_EPS).unsqueeze(-1)
    kx, ky, kz = k.unbind(-1)
    s, c = torch.sin(theta), 1.0 - torch.cos(theta)
    # Rodrigues R = I + s K + (1 - cos) K^2, only the five entries the Euler angles read
    r00 = 1.0 + c * (-(ky * ky) - kz * kz)
    r01 = -s * kz + c * (kx * ky)
    r02 = s * ky + c * (kx * kz)
    r12 = -s * kx + c * (ky * kz)
    r22 = 1.0 + c * (-(kx * kx) - ky * ky)
    e2 = -torch.asin(r02.clamp(-1.0 + 1e-6, 1.0 - 1e-6))
    e1 = torch.atan2(r12, r22)  # cos(e2) > 0 cancels from both arguments
    e3 = torch.atan2(r01, r00)
    eul = torch.stack([e1, e2, e3], -1).reshape(*lead, -1)
    out = torch.cat([torch.zeros(*lead, 3, dtype=full.dtype, device=full.device), eul], -1)
    mask = torch.ones(out.shape[-1], dtype=out.dtype, device=out.device)
    mask[:6] = 0.0
    return out * mask


def npss_reference(gt: torch.Tensor, pred: torch.Tensor) -> torch.Tensor:
    """NPSS, reference variant, over sequences ``[N, T, D]`` (time on dim 1), as `evaluate.npss(gt, pred,
    "reference")`: per sequence and dim, Re(DFT)^2 normalized to sum 1, earth mover's distance between the
    cumulative spectra, averaged with weights = the ground truth's total power. Differentiable in `pred`."""
    X = torch.fft.fft(gt, dim=1).real ** 2
    Y = torch.fft.fft(pred, dim=1).real ** 2
    sx = X.sum(1, keepdim=True)
    sy = Y.sum(1, keepdim=True)
    Xn = torch.where(sx > 0, X / sx.clamp_min(_TINY), torch.zeros_like(X))
    Yn = torch.where(sy > 0, Y / sy.clamp_min(_TINY), torch.zeros_like(Y))
    emd = (torch.cumsum(Yn, 1) - torch.cumsum(Xn, 1)).abs().sum(1)  # [N, D]
    w = sx[:, 0, :].detach()
    return (w * emd).sum() / w.sum().clamp_min(_TINY)


def spectral_loss(model, predicted: torch.Tensor, truth: torch.Tensor) -> torch.Tensor:
    """NPSS (reference variant) of normalized used-dim predictions ``[B, T, O]`` against the truth, computed on
    the Euler angles of their full frames (dropped dims at the training mean)."""
    full_pred = model.norm.unnormalize(predicted)
    with torch.no_grad():
        gt_euler = expmap_to_euler(model.norm.unnormalize(truth))
    return npss_reference(gt_euler, expmap_to_euler(full_pred))
