"""Tanke et al. 2021's motion words in torch, and a word-realism term built on them (issue 20).

NDMS (Tanke et al. 2021, section 4; ``../shared/reference/metrics.md``; ``motion_metrics::ndms``) cuts a forecast into
words of ``KAPPA`` = 8 frames of 12 joint positions, finds each word's nearest real word (Euclidean distance of the
normalized words) in a database of real motion of the same action, and scores the pair's frame-to-frame velocities:
``½(1 + cos) · min(|v|, |v'|) / max(|v|, |v'|)`` per joint and step. It measures whether short stretches of the
forecast move as real motion does *there*, not whether they follow the truth. Measured 2026-12-03 (S5 validation
windows, D = S5's sequences of the action, 2.0-4.0 s): real motion of the training subjects S1 and S6 scores 0.348,
the generator 0.27; the joint-angle speed, smoothness and root terms left that gap (weights/README.md).

``word_realism_loss`` is Tanke et al. 2021's plausibility measure (its eq. 10) used as a training signal, on training data
only: each generated word is matched to its nearest word of the *training* subjects' motion of the window's action
(``WordBank``; the search is not differentiated) and the loss is ``1 − NDMS`` of the pair, whose gradient pulls
the word's velocities toward those of the real motion nearest to it. The test subject S5 is never in the bank.

Words are built as ``motion-cli score`` / ``eval`` build them for 99-dim H3.6M frames
(``NdmsConfig::h36m_body_frame``): positions from forward kinematics with the integrated root (``root_drift``), axes
reordered so the vertical is last (x, z, y), then expressed in the rigid frame of the word's first frame (origin =
hip midpoint, x = left→right hip, vertical = hip→shoulder midpoint made orthogonal to x, y = vertical × x). A rigid
transform of the whole sequence changes nothing, so the root is integrated from the identity at any frame.
"""

from __future__ import annotations

import numpy as np
import torch

from .kinematics import body_positions, skeleton
from .root_drift import root_poses

KAPPA = 8  # frames per motion word at 25 Hz (Tanke et al. 2021)
LEFT_HIP, RIGHT_HIP, LEFT_SHOULDER, RIGHT_SHOULDER = 6, 1, 17, 25  # H3.6M joints (motion_core::skeleton)
AXES = [0, 2, 1]  # y-up H3.6M reordered to (x, z, y): the vertical last, as NdmsConfig::axis_order
EPSILON = 1e-7  # lower clamp of velocity magnitudes (motion_metrics::ndms::similarity::EPSILON)
BANK_STRIDE = 2  # frames between the starts of two bank words


def ndms_joints() -> list[int]:
    """The 12 NDMS joints (skeleton file order); they include both hips and both shoulders."""
    joints = skeleton()[3]
    missing = {LEFT_HIP, RIGHT_HIP, LEFT_SHOULDER, RIGHT_SHOULDER} - set(joints)
    if missing:
        raise ValueError(f"the skeleton's NDMS joints lack the hip/shoulder joints {sorted(missing)}")
    return joints


def world_positions(frames: torch.Tensor) -> torch.Tensor:
    """Positions ``[B, T, 12, 3]`` (mm, y up) of the NDMS joints of full exp-map frames ``[B, T, 99]``
    (un-normalized), h36m.md's FK with the root integrated as ``motion_core::root`` does from the first frame (its
    delta applied once, every later 25 Hz frame's twice): ``x_0 = offset_0 + T``, ``W_0 = R``. Differentiable."""
    joints = ndms_joints()
    body = body_positions(frames, joints)
    offset0 = skeleton()[1][0].to(dtype=frames.dtype, device=frames.device)
    rot, trans = root_poses(frames[..., :6])
    return (body - offset0) @ rot + (trans + offset0)[:, :, None, :]


def words(positions: torch.Tensor, stride: int = 1) -> torch.Tensor:
    """Normalized motion words ``[B, W, KAPPA * 12 * 3]`` (frame, then joint, then coordinate) starting every
    ``stride`` frames of ``positions [B, T, 12, 3]`` (``world_positions``' joints), T >= KAPPA. Differentiable."""
    joints = ndms_joints()
    il, ir, ils, irs = (joints.index(j) for j in (LEFT_HIP, RIGHT_HIP, LEFT_SHOULDER, RIGHT_SHOULDER))
    w = positions[..., AXES].unfold(1, KAPPA, stride).permute(0, 1, 4, 2, 3)  # [B, W, K, J, 3]
    first = w[:, :, 0]
    origin = 0.5 * (first[:, :, il] + first[:, :, ir])
    x = first[:, :, ir] - first[:, :, il]
    x = x / (x.norm(dim=-1, keepdim=True) + 1e-9)
    up = 0.5 * (first[:, :, ils] + first[:, :, irs]) - origin
    z = up - (up * x).sum(-1, keepdim=True) * x
    z = z / (z.norm(dim=-1, keepdim=True) + 1e-9)
    y = torch.cross(z, x, dim=-1)
    axes = torch.stack([x, y, z], dim=-2)  # rows: the new axes
    local = (w - origin[:, :, None, None]) @ axes[:, :, None].transpose(-1, -2)
    return local.flatten(2)


def similarity(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """NDMS of flattened words ``[..., KAPPA * J * 3]`` pairwise along the leading dims (``motion_metrics::ndms``:
    magnitudes clamped to ``EPSILON``, cosine clamped to [-1, 1]). Differentiable (the norms are smoothed by 1e-12
    under the square root so that a joint at rest has a gradient)."""
    va = a.unflatten(-1, (KAPPA, -1, 3)).diff(dim=-3)
    vb = b.unflatten(-1, (KAPPA, -1, 3)).diff(dim=-3)
    na = ((va * va).sum(-1) + 1e-12).sqrt().clamp_min(EPSILON)
    nb = ((vb * vb).sum(-1) + 1e-12).sqrt().clamp_min(EPSILON)
    cos = ((va * vb).sum(-1) / (na * nb)).clamp(-1.0, 1.0)
    ratio = torch.minimum(na, nb) / torch.maximum(na, nb)
    return (0.5 * (1.0 + cos) * ratio).mean(dim=(-1, -2))


class WordBank:
    """The normalized words (every ``stride`` frames) of real sequences, per action: ``words[a]`` ``[N_a, D]`` of
    ``dtype`` (float32 for training; float64 for an exact search). ``sequences[a]`` are full exp-map frames ``[T, 99]``
    at 25 Hz (or normalized model frames with ``unnormalize``)."""

    def __init__(self, sequences: list[list[np.ndarray]], unnormalize=None, stride: int = BANK_STRIDE,
                 dtype: torch.dtype = torch.float32):
        self.words: list[torch.Tensor | None] = []
        with torch.no_grad():
            for seqs in sequences:
                parts = []
                for s in seqs:
                    if s.shape[0] < KAPPA:
                        continue
                    full = torch.from_numpy(np.ascontiguousarray(s)).double()
                    if unnormalize is not None:
                        full = unnormalize(full.float()).double()
                    parts.append(words(world_positions(full[None]), stride)[0].to(dtype))
                self.words.append(torch.cat(parts) if parts else None)
        self.sq = [None if w is None else (w * w).sum(-1) for w in self.words]

    def __len__(self) -> int:
        return sum(0 if w is None else len(w) for w in self.words)

    @torch.no_grad()
    def nearest(self, queries: torch.Tensor, action: int) -> torch.Tensor:
        """The nearest bank word of ``action`` (Euclidean) to each query ``[Q, D]``: ``[Q, D]``."""
        bank = self.words[action]
        if bank is None:
            raise ValueError(f"the word bank has no words of action {action}")
        q = queries.detach().to(bank.dtype)
        d2 = self.sq[action][None] - 2.0 * q @ bank.T
        return bank[d2.argmin(-1)]


def word_realism_loss(model, moved: torch.Tensor, actions: torch.Tensor, bank: WordBank, stride: int = 2) -> torch.Tensor:
    """Mean over the words (every ``stride`` frames) of ``1 − NDMS(word, nearest bank word of its window's action)``
    of ``model``'s normalized frames ``moved [B, T, O]`` (T >= KAPPA; e.g. the last seed frame and the generated
    ones); ``actions [B]`` (long) index ``bank.words``. 0 when every word is a real one, or when ``moved`` is
    shorter than a word."""
    if moved.shape[1] < KAPPA:
        return moved.new_zeros(())
    q = words(world_positions(model.norm.unnormalize(moved)), stride)  # [B, W, D]
    total = q.new_zeros(())
    for a in torch.unique(actions).tolist():
        rows = (actions == a).nonzero().squeeze(-1)
        qa = q[rows].flatten(0, 1)
        total = total + (1.0 - similarity(qa, bank.nearest(qa, a).to(qa.dtype))).sum()
    return total / (q.shape[0] * q.shape[1])
