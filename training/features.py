"""Model input features and normalization.

Gopalakrishnan et al., A Neural Temporal Model for Human Motion Prediction (CVPR 2019), section 3.3,
equation 5: backward differences with h = 1,
``∇ⁿ x_t = sum_{i=0..n} (-1)^i C(n, i) x_{t-i}``, appended to the frame: ``[x, ∇¹, ∇², ∇³]``.

Padding ``repeat-first``: frames before the first are copies of the first, so the first frame's
derivatives are 0. The Rust engine implements exactly this, in this summation order.
"""

from __future__ import annotations

import math

import torch

DERIVATIVE_PADDING = "repeat-first"
CONSTANT_STD = 1e-4


def _differences(frames: list[torch.Tensor], order: int) -> torch.Tensor:
    """``frames = [x_t, x_{t-1}, ..., x_{t-order}]`` -> ``[x_t, ∇¹, ..., ∇^order]`` on the last axis.

    Sums left to right over i = 0..n so batch and incremental paths give identical bits.
    """
    out = [frames[0]]
    for n in range(1, order + 1):
        acc = frames[0]
        for i in range(1, n + 1):
            coef = math.comb(n, i) * (-1) ** i
            acc = acc + coef * frames[i]
        out.append(acc)
    return torch.cat(out, dim=-1)


def derivative_features(x: torch.Tensor, order: int = 3) -> torch.Tensor:
    """Batch version: ``x [B, T, D] -> [B, T, D * (1 + order)]`` with repeat-first padding."""
    if order == 0:
        return x
    first = x[:, :1].expand(-1, order, -1)
    padded = torch.cat([first, x], dim=1)  # padded[:, order + t] = x_t
    steps = x.shape[1]
    frames = [padded[:, order - i : order - i + steps] for i in range(order + 1)]
    return _differences(frames, order)


class DerivativeHistory:
    """Incremental version for the closed loop: keeps the last ``order`` frames.

    ``push(x_t [B, D])`` returns the features of ``x_t``; the first push fills the history with
    copies of it (repeat-first). Differentiable (no in-place ops) so closed-loop training works.
    """

    def __init__(self, order: int = 3):
        self.order = order
        self.previous: list[torch.Tensor] = []  # [x_{t-1}, x_{t-2}, ..., x_{t-order}]

    def reset(self) -> None:
        """Forget the history; the next push is treated as a first frame."""
        self.previous = []

    def push(self, x: torch.Tensor) -> torch.Tensor:
        """Append ``x [B, D]`` and return its features ``[B, D * (1 + order)]``."""
        if self.order == 0:
            return x
        if not self.previous:
            self.previous = [x] * self.order
        features = _differences([x] + self.previous, self.order)
        self.previous = [x] + self.previous[:-1]
        return features


def compute_norm_stats(
    frames: torch.Tensor, constant_std: float = CONSTANT_STD
) -> tuple[torch.Tensor, torch.Tensor, list[int]]:
    """Mean, std (population, ddof 0) per dim of ``frames [N, F]``; dims with std < 1e-4 get std 1
    and are dropped (h36m.md). Returns ``(mean [F], std [F], dims_used)``."""
    frames = frames.double()
    mean = frames.mean(dim=0)
    std = frames.std(dim=0, unbiased=False)
    used = std >= constant_std
    std = torch.where(used, std, torch.ones_like(std))
    dims_used = [int(i) for i in torch.nonzero(used).flatten()]
    return mean.float(), std.float(), dims_used


def normalize(
    full: torch.Tensor, mean: torch.Tensor, std: torch.Tensor, dims_used: list[int] | torch.Tensor
) -> torch.Tensor:
    """Full frames ``[..., F]`` -> normalized used dims ``[..., O]``: ``(x - mean) / std``."""
    idx = torch.as_tensor(dims_used, dtype=torch.long, device=full.device)
    return (full.index_select(-1, idx) - mean[idx]) / std[idx]


def unnormalize(
    normalized: torch.Tensor, mean: torch.Tensor, std: torch.Tensor, dims_used: list[int] | torch.Tensor
) -> torch.Tensor:
    """Normalized used dims ``[..., O]`` -> full frames ``[..., F]``: ``x * std + mean``, dropped
    dims restored to the mean."""
    idx = torch.as_tensor(dims_used, dtype=torch.long, device=normalized.device)
    full = mean.to(normalized.dtype).expand(*normalized.shape[:-1], mean.shape[0]).clone()
    full[..., idx] = normalized * std[idx].to(normalized.dtype) + mean[idx].to(normalized.dtype)
    return full
