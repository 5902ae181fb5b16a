"""foot_skate: world-space foot points and the skating penalty's zero, value and gradient."""

import math

import torch

from training.crouch import FOOT_JOINTS
from training.foot_skate import SKATE_FREE_MM, SKATE_HEIGHT_MM, SKATE_SCALE_MM, SKATE_SOFT_MM, skate_penalty
from training.kinematics import body_positions

from .helpers import FullFrames


def rest_sliding(mm_per_source_frame: float, frames: int) -> torch.Tensor:
    """Rest-pose frames ``[1, frames, 99]`` whose root moves along x by this much per 50 Hz source frame."""
    x = torch.zeros(1, frames, 99, dtype=torch.float64)
    x[..., 0] = mm_per_source_frame
    return x


def test_a_still_body_costs_nothing():
    seed = rest_sliding(0.0, 5)
    assert skate_penalty(FullFrames, seed, [(rest_sliding(0.0, 12), True)]).item() == 0.0


def test_a_sliding_rest_pose_costs_each_low_point_its_excess():
    """The root moves 2 x 10 mm per 25 Hz frame: every foot point slides 20 mm, 10 over the free speed, weighted
    by how low it is over the lowest foot point (computed here from the body positions, loop by loop)."""
    seed = rest_sliding(10.0, 5)
    got = skate_penalty(FullFrames, seed, [(rest_sliding(10.0, 8), True)]).item()
    heights = body_positions(torch.zeros(99, dtype=torch.float64), FOOT_JOINTS)[:, 1]
    excess = ((2 * 10.0 - SKATE_FREE_MM) / SKATE_SCALE_MM) ** 2
    want = sum(excess / (1 + math.exp(-(SKATE_HEIGHT_MM - (h - heights.min()).item()) / SKATE_SOFT_MM))
               for h in heights) / len(heights)
    assert abs(got - want) < 1e-6 * want


def test_unscored_parts_carry_the_root_and_the_gradient_reaches_the_frames():
    seed = rest_sliding(10.0, 5)
    burned = rest_sliding(10.0, 6)
    scored = rest_sliding(10.0, 6).requires_grad_(True)
    loss = skate_penalty(FullFrames, seed, [(burned, False), (scored, True)])
    alone = skate_penalty(FullFrames, seed, [(rest_sliding(10.0, 6), True)])
    assert abs(loss.item() - alone.item()) < 1e-9  # a straight slide costs the same wherever it starts
    loss.backward()
    assert scored.grad[..., 0].abs().sum() > 0  # slower root deltas would cost less
