"""A penalty on foot skating in the model's own world-space output (issue 40's hip-height target).

Grounding (`motion_core::grounding`) holds a foot that touches the floor where it landed. When the model's root
travels further than its stance foot's leg spans (the stance foot slides in the raw output: 0.7-0.8 of the frames
of run `intention_crouch2`'s walkingtogether 60 s validation predictions skate ungrounded in the first 8 s), the
hold pulls the body down onto the held foot, and the grounded hip height falls under real motion's. This term
teaches the model to move its root and its stance foot together, so the hold has nothing to pull.

The measure follows the plausibility metric's skating (`motion_metrics::plausibility`, "Foot skating"): the six
foot points `FEET` (RightFoot, RightToeBase, RightToeSite and the left ones) in world space (the root integrated
exactly as `motion_core::root`, `root_drift.scored_root_poses`; a joint at ``(x_body − o) · R + o + T``, ``o`` the
root's offset), their horizontal speed between consecutive frames, counted where the point is low. Two
differences make it trainable without a floor: a point's height is taken over the lowest foot point of the same
frame (so a drifting root does not switch it off), and "low" is soft, ``sigmoid((SKATE_HEIGHT_MM − h) /
SKATE_SOFT_MM)``. Per low point, ``relu(v − SKATE_FREE_MM) ² / SKATE_SCALE_MM ²`` with ``v`` its horizontal
displacement per 25 Hz frame: free under 10 mm (0.25 m/s, half the metric's 0.5 m/s), 1 at 30 mm.
"""

from __future__ import annotations

import torch

from .crouch import FOOT_JOINTS
from .kinematics import body_positions, skeleton
from .root_drift import scored_root_poses

SKATE_HEIGHT_MM = 50.0  # the metric's SKATING_HEIGHT_MM
SKATE_SOFT_MM = 10.0  # width of the soft "low" step
SKATE_FREE_MM = 10.0  # horizontal displacement per frame that costs nothing (0.25 m/s at 25 Hz)
SKATE_SCALE_MM = 20.0  # SKATE_FREE_MM + this costs 1


def world_feet(frames: torch.Tensor, rot: torch.Tensor, trans: torch.Tensor) -> torch.Tensor:
    """World positions (mm) ``[B, T, 6, 3]`` of the foot points of full frames ``[B, T, 99]`` under root poses
    ``rot [B, T, 3, 3]``, ``trans [B, T, 3]`` (row vectors, as ``motion_metrics::plausibility``)."""
    _, offsets, _, _ = skeleton()
    o = offsets[0].to(dtype=frames.dtype, device=frames.device)
    body = body_positions(frames, FOOT_JOINTS) - o
    return torch.einsum("btjk,btkl->btjl", body, rot) + o + trans[:, :, None]


def skate_cost(feet: torch.Tensor) -> torch.Tensor:
    """Per point and frame pair, ``[B, T-1, 6]``: the soft-low weight of the later frame times the squared
    excess of the horizontal displacement (module doc) of world foot points ``feet [B, T, 6, 3]`` (mm, y up)."""
    h = feet[..., 1] - feet[..., 1].min(dim=-1, keepdim=True).values
    low = torch.sigmoid((SKATE_HEIGHT_MM - h[:, 1:]) / SKATE_SOFT_MM)
    step = feet[:, 1:, :, [0, 2]] - feet[:, :-1, :, [0, 2]]
    v = (step.pow(2).sum(-1) + 1e-6).sqrt()
    return low * (torch.relu(v - SKATE_FREE_MM) / SKATE_SCALE_MM) ** 2


def skate_penalty(model, seed: torch.Tensor, parts: list[tuple[torch.Tensor, bool]]) -> torch.Tensor:
    """Mean ``skate_cost`` over the scored parts of a closed loop (``root_drift.scored_root_poses``' ``seed`` and
    ``parts``, normalized model frames), the gradient flowing through both the pose and the root."""
    return skate_of_poses(model, scored_root_poses(model, seed, parts)[1])


def skate_of_poses(model, scored) -> torch.Tensor:
    """``skate_penalty`` from the scored parts of ``scored_root_poses``' result (a loop integrated once for several
    terms)."""
    costs = []
    for rot, trans, frames in scored:
        if frames.shape[1] < 2:
            continue
        full = model.norm.unnormalize(frames).double()
        costs.append(skate_cost(world_feet(full, rot, trans)).flatten())
    if not costs:
        raise ValueError("skate_penalty needs a scored part of at least two frames")
    return torch.cat(costs).mean()
