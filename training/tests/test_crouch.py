"""crouch: the hip height over the feet against the engine's rest-pose height, and the penalty's zero and gradient."""

import math

import numpy as np
import torch

from training.crouch import (
    CROUCH_SCALE_MM,
    CrouchFloor,
    TiptoeCeiling,
    ankle_over_sole,
    crouch_loss,
    hip_over_feet,
    tiptoe_loss,
)
from training.kinematics import skeleton

from .helpers import FullFrames

# motion_core::grounding::H36M_STANDING_HEIGHT_MM: the rest pose's root height over its lowest foot point.
STANDING_MM = 897.1


def turned(joints: tuple[int, ...], angle: float, frames: int) -> torch.Tensor:
    """Full frames [frames, 99] of the rest pose with `joints` turned by `angle` radians about x."""
    _, _, dims, _ = skeleton()
    x = torch.zeros(frames, 99, dtype=torch.float64)
    for j in joints:
        x[:, dims[j][0]] = angle
    return x


def bent_knees(angle: float, frames: int = 1) -> torch.Tensor:
    """The rest pose with both knees (RightLeg, LeftLeg) bent by `angle` radians."""
    return turned((2, 7), angle, frames)


def test_the_rest_pose_stands_at_the_engines_standing_height():
    h = hip_over_feet(torch.zeros(1, 99, dtype=torch.float64))
    assert abs(h.item() - STANDING_MM) < 0.1


def test_bent_knees_lower_the_hips():
    heights = [hip_over_feet(bent_knees(a)).item() for a in (0.0, 0.3, 0.6, 0.9)]
    assert all(a > b for a, b in zip(heights, heights[1:])), heights


def test_the_floor_is_the_percentile_of_each_actions_frames():
    angles = np.linspace(0.0, 1.0, 101)
    seqs = [[bent_knees(float(a)).numpy() for a in angles]]
    floor = CrouchFloor(seqs + [[]], lambda x: x)
    expected = np.percentile([hip_over_feet(bent_knees(float(a))).item() for a in angles], 5.0)
    assert abs(floor.limits[0].item() - expected) < 1e-3  # the frames pass through float32
    assert math.isinf(floor.limits[1].item())


def test_the_penalty_is_zero_over_the_limit_and_pulls_a_crouch_up():
    floor = CrouchFloor([[bent_knees(0.3).numpy()]], lambda x: x)  # limit: the 0.3 rad crouch
    actions = torch.zeros(1, dtype=torch.long)
    tall = bent_knees(0.1, frames=4)[None]
    assert crouch_loss(FullFrames, tall, actions, floor).item() == 0.0
    low = bent_knees(0.9, frames=4)[None].requires_grad_(True)
    loss = crouch_loss(FullFrames, low, actions, floor)
    short = floor.limits[0].item() - hip_over_feet(bent_knees(0.9)).item()
    assert abs(loss.item() - (short / CROUCH_SCALE_MM) ** 2) < 1e-9
    loss.backward()
    _, _, dims, _ = skeleton()
    # Less knee bend raises the hips: the gradient on the knee angle is positive.
    assert low.grad[0, 0, dims[2][0]].item() > 0.0


def pointed_feet(angle: float, frames: int = 1) -> torch.Tensor:
    """The rest pose with both ankles (RightFoot, LeftFoot) turned by `angle` radians."""
    return turned((3, 8), angle, frames)


def test_the_rest_feet_sit_their_ankles_over_the_sole_as_the_skeleton_says():
    parents, offsets, _, _ = skeleton()

    def rest_y(j):
        return 0.0 if j < 0 else offsets[j, 1].item() + rest_y(parents[j])

    sole = min(rest_y(j) for j in (3, 4, 5, 8, 9, 10))
    expected = min(rest_y(3), rest_y(8)) - sole
    assert abs(ankle_over_sole(torch.zeros(1, 99, dtype=torch.float64)).item() - expected) < 1e-9


def test_pointed_feet_raise_the_ankle_and_the_tiptoe_penalty_pulls_them_flat():
    heights = [ankle_over_sole(pointed_feet(a)).item() for a in (0.0, 0.4, 0.8)]
    sign = 1.0 if heights[1] > heights[0] else -1.0  # the direction that points the toes down
    heights = [ankle_over_sole(pointed_feet(sign * a)).item() for a in (0.0, 0.4, 0.8)]
    assert heights[0] < heights[1] < heights[2], heights
    ceiling = TiptoeCeiling([[pointed_feet(sign * 0.4).numpy()], []], lambda x: x)
    assert math.isinf(ceiling.limits[1].item())
    actions = torch.zeros(1, dtype=torch.long)
    assert tiptoe_loss(FullFrames, pointed_feet(0.0, 3)[None], actions, ceiling).item() == 0.0
    high = pointed_feet(sign * 0.8, 3)[None].requires_grad_(True)
    loss = tiptoe_loss(FullFrames, high, actions, ceiling)
    over = heights[2] - ceiling.limits[0].item()
    assert abs(loss.item() - (over / CROUCH_SCALE_MM) ** 2) < 1e-6
    loss.backward()
    _, _, dims, _ = skeleton()
    # Pointing the feet less lowers the ankles: the gradient on their angles has the pointing sign (it reaches
    # whichever foot holds the minimum).
    assert (high.grad[0, 0, dims[3][0]] + high.grad[0, 0, dims[8][0]]).item() * sign > 0.0
