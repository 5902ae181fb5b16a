"""A penalty on crouching: the hip height over the feet below what real motion of the action shows.

The 60 s plausibility target (`motion-cli eval --horizon 1500`, `motion_metrics::plausibility`) wants the grounded
hip height's 5th percentile at or above real motion's, per action. Grounding's hip-height hold
(`motion_core::grounding`) raises a crouching body only as far as its legs reach from where its feet are held, so
a model that walks with bent knees at a long stride stays under the real range. This term teaches the model
itself to stand as tall as real people do.

The measure is the root's height over the lowest foot point (RightFoot, RightToeBase, RightToeSite and the left
ones) along the root's own up axis, from the body-frame joint positions (`kinematics.body_positions`: the root's
rotation left out). It needs no integration of the root and no floor; the limit it is held to is the 5th
percentile of the same measure over the action's training frames (`CrouchFloor`), so real motion costs nothing
beyond its own lowest 5 %.

A model can also meet that limit by pointing its feet (the toes under the heel lift the root over the lowest foot
point): `tiptoe_loss` holds the ankle's height over the lowest foot point (`ankle_over_sole`) at or under the 95th
percentile of real motion of the action (`TiptoeCeiling`).
"""

from __future__ import annotations

import numpy as np
import torch

from .kinematics import body_positions

FOOT_JOINTS = [3, 4, 5, 8, 9, 10]  # RightFoot, RightToeBase, RightToeSite, LeftFoot, LeftToeBase, LeftToeSite
CROUCH_SCALE_MM = 50.0  # a frame this far under the limit costs 1
PERCENTILE = 5.0


def hip_over_feet(frames: torch.Tensor) -> torch.Tensor:
    """Height (mm) of the root over the lowest foot point along the root's up axis, ``[...]``, of full
    un-normalized exp-map frames ``[..., 99]``. Differentiable."""
    p = body_positions(frames, [0, *FOOT_JOINTS])
    return p[..., 0, 1] - p[..., 1:, 1].min(dim=-1).values


def per_action_percentile(sequences: list[list[np.ndarray]], unnormalize, measure, q: float, empty: float) -> torch.Tensor:
    """Per action, the ``q``-th percentile of ``measure`` (of full frames) over ``sequences[a]`` (normalized model
    frames, ``unnormalize`` maps them to full frames), ``[A]`` f64; ``empty`` for an action without frames."""
    limits = []
    with torch.no_grad():
        for seqs in sequences:
            values = [measure(unnormalize(torch.from_numpy(np.ascontiguousarray(s)).float()).double())
                      for s in seqs if s.shape[0] > 0]
            limits.append(float(np.percentile(torch.cat(values).numpy(), q)) if values else empty)
    return torch.tensor(limits, dtype=torch.float64)


class CrouchFloor:
    """Per action, the ``PERCENTILE``-th percentile of ``hip_over_feet`` over real sequences: ``limits [A]`` (mm)
    from ``sequences[a]`` (normalized model frames, ``unnormalize`` maps them to full frames); an action without
    frames gets no limit (``-inf``)."""

    def __init__(self, sequences: list[list[np.ndarray]], unnormalize):
        self.limits = per_action_percentile(sequences, unnormalize, hip_over_feet, PERCENTILE, float("-inf"))


def crouch_loss(model, moved: torch.Tensor, actions: torch.Tensor, floor: CrouchFloor) -> torch.Tensor:
    """Mean over sequences and frames of ``relu(limit_a − h_t)² / CROUCH_SCALE_MM²`` of ``model``'s normalized
    frames ``moved [B, T, O]`` of actions ``actions [B]`` (long, indexing ``floor.limits``). Zero while every
    frame stands at least as tall as the action's real 5th percentile."""
    h = hip_over_feet(model.norm.unnormalize(moved).double())
    limit = floor.limits.to(h.device)[actions][:, None]
    return ((torch.relu(limit - h) / CROUCH_SCALE_MM) ** 2).mean()


ANKLES = [3, 8]  # RightFoot, LeftFoot (the ankle joints)
TIPTOE_PERCENTILE = 95.0


def ankle_over_sole(frames: torch.Tensor) -> torch.Tensor:
    """Height (mm, along the root's up axis) of the lower ankle over the lowest foot point, ``[...]``, of full
    un-normalized exp-map frames ``[..., 99]``: about 20-30 mm on average for real walking (the heel near the floor),
    more while a foot stands on its toes. Differentiable."""
    p = body_positions(frames, FOOT_JOINTS)[..., 1]
    ankles = torch.minimum(p[..., FOOT_JOINTS.index(3)], p[..., FOOT_JOINTS.index(8)])
    return ankles - p.min(dim=-1).values


class TiptoeCeiling:
    """Per action, the ``TIPTOE_PERCENTILE``-th percentile of ``ankle_over_sole`` over real sequences: ``limits
    [A]`` (mm), as ``CrouchFloor`` (an action without frames: ``+inf``)."""

    def __init__(self, sequences: list[list[np.ndarray]], unnormalize):
        self.limits = per_action_percentile(sequences, unnormalize, ankle_over_sole, TIPTOE_PERCENTILE, float("inf"))


def tiptoe_loss(model, moved: torch.Tensor, actions: torch.Tensor, ceiling: TiptoeCeiling) -> torch.Tensor:
    """Mean over sequences and frames of ``relu(a_t − limit_a)² / CROUCH_SCALE_MM²`` with ``a_t`` the
    ``ankle_over_sole`` of ``model``'s normalized frames ``moved [B, T, O]``: feet that stand on their toes more than
    real people's do cost, so that the crouch term is met by straight legs, not by pointed feet."""
    a = ankle_over_sole(model.norm.unnormalize(moved).double())
    limit = ceiling.limits.to(a.device)[actions][:, None]
    return ((torch.relu(a - limit) / CROUCH_SCALE_MM) ** 2).mean()
