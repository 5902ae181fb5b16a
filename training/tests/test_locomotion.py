"""The control of training/locomotion.py on synthetic root motion with a known answer, and the goal-gru model's
control input."""

import math

import numpy as np
import torch

from training.locomotion import CONTROL_FRAMES, control_of, seed_controls
from training.models import GoalGRU, make_config


def frames_with_root(deltas: np.ndarray, rotations: np.ndarray) -> np.ndarray:
    """25 Hz full frames whose dims 0..5 are the given per-source-frame root deltas."""
    out = np.zeros((deltas.shape[0], 99))
    out[:, 0:3] = deltas
    out[:, 3:6] = rotations
    return out


def test_a_straight_walk_along_the_heading_is_all_forward():
    n = 60
    # 10 mm per 50 Hz source frame along the root's +z: 0.5 m/s; no rotation.
    deltas = np.tile([0.0, 0.0, 10.0], (n, 1))
    c = control_of(frames_with_root(deltas, np.zeros((n, 3))))
    assert c.shape == (n - CONTROL_FRAMES, 3)
    np.testing.assert_allclose(c[:, 0], 0.5, atol=1e-9)
    np.testing.assert_allclose(c[:, 1:], 0.0, atol=1e-9)


def test_a_turn_in_place_is_all_turn_and_a_side_step_is_side():
    n = 60
    # An exp-map delta of 0.01 rad about +y per source frame: the row-vector rotation turns the heading by
    # -0.01 (from +z toward -x), -0.5 rad in a second (to 1e-5: the exp map's epsilon); no translation.
    turning = frames_with_root(np.zeros((n, 3)), np.tile([0.0, 0.01, 0.0], (n, 1)))
    c = control_of(turning)
    np.testing.assert_allclose(c[:, 2], -0.5, atol=1e-4)
    np.testing.assert_allclose(c[:, :2], 0.0, atol=1e-9)
    # 4 mm per source frame along the root's +x: 0.2 m/s to the side (+x when facing +z).
    side = frames_with_root(np.tile([4.0, 0.0, 0.0], (n, 1)), np.zeros((n, 3)))
    c = control_of(side)
    np.testing.assert_allclose(c[:, 1], 0.2, atol=1e-9)
    np.testing.assert_allclose(c[:, [0, 2]], 0.0, atol=1e-9)
    # 0.07 rad per source frame: -3.5 rad in a second, wrapped into [-pi, pi).
    fast = control_of(frames_with_root(np.zeros((n, 3)), np.tile([0.0, 0.07, 0.0], (n, 1))))
    np.testing.assert_allclose(fast[:, 2], 2 * math.pi - 3.5, atol=1e-3)


def test_goal_gru_reads_its_control():
    config = make_config("goal-gru", list(range(6, 60)), hidden=16, layers=2)
    model = GoalGRU(config).eval()
    x = torch.randn(2, 5, 54)
    a = model.open_loop(x, action=torch.zeros(2, 5, 3))
    b = model.open_loop(x, action=torch.ones(2, 5, 3))
    assert not torch.allclose(a, b)
    assert torch.allclose(model.open_loop(x), a)  # no control = zeros
    seed = seed_controls(torch.arange(12.0).reshape(1, 4, 3), 2)
    assert torch.equal(seed[0, :2], torch.tensor([[3.0, 4.0, 5.0]] * 2))
    assert torch.equal(seed[0, 2:], torch.arange(6.0, 12.0).reshape(2, 3))
