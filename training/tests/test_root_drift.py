"""root_drift: the torch root integration against the formulas of motion_core::root, and the drift penalty."""

import math

import numpy as np
import pytest
import torch

from training import long_horizon, train
from training.metrics_np import expmap2rotmat
from training.root_drift import (
    DRIFT_HIP_MM,
    DRIFT_LEAN_RAD,
    drift_loss,
    expmap_rotmat,
    hip_and_lean,
    root_poses,
)


def reference_poses(root: np.ndarray, step: int = 2):
    """motion_core::root's loop, one sequence: the first frame once, every later one `step` times."""
    rot, trans, out = np.eye(3), np.zeros(3), []
    for t, frame in enumerate(root):
        rd = expmap2rotmat(frame[3:6])
        for _ in range(1 if t == 0 else step):
            trans = trans + frame[0:3] @ rot
            rot = rd @ rot
        out.append((rot.copy(), trans.copy()))
    return out


def random_root(batch=3, frames=12, seed=0):
    g = np.random.default_rng(seed)
    root = np.concatenate([g.normal(scale=20.0, size=(batch, frames, 3)), g.normal(scale=0.05, size=(batch, frames, 3))], -1)
    root[0, 2, 3:6] = 0.0  # an exact zero rotation
    return root


def test_expmap_matches_the_numpy_reference():
    r = random_root()[..., 3:6]
    assert np.allclose(expmap_rotmat(torch.from_numpy(r)).numpy(), expmap2rotmat(r), atol=1e-12)


def test_integration_matches_the_reference_loop_and_continues():
    root = random_root()
    rot, trans = root_poses(torch.from_numpy(root))
    for b in range(root.shape[0]):
        for t, (r_ref, t_ref) in enumerate(reference_poses(root[b])):
            assert np.allclose(rot[b, t].numpy(), r_ref, atol=1e-10)
            assert np.allclose(trans[b, t].numpy(), t_ref, atol=1e-9)
    # Continuing from the pose after frame 4 gives the same poses as one pass.
    head_rot, head_trans = root_poses(torch.from_numpy(root[:, :5]))
    tail_rot, tail_trans = root_poses(torch.from_numpy(root[:, 5:]), start=(head_rot[:, -1], head_trans[:, -1]))
    assert torch.allclose(tail_rot, rot[:, 5:], atol=1e-12) and torch.allclose(tail_trans, trans[:, 5:], atol=1e-9)


def test_height_and_lean_of_simple_motions():
    # Rising 10 mm per delta: the first frame once, then two per 25 Hz frame.
    up = torch.zeros(1, 4, 6, dtype=torch.float64)
    up[..., 1] = 10.0
    hip, lean = hip_and_lean(*root_poses(up))
    assert torch.allclose(hip[0], torch.tensor([10.0, 30.0, 50.0, 70.0], dtype=torch.float64))
    assert torch.allclose(lean, torch.zeros_like(lean), atol=1e-3)
    # Tilting 0.01 rad about x per delta: lean 0.01, 0.03, 0.05; turning about y leans nothing.
    tilt = torch.zeros(2, 3, 6, dtype=torch.float64)
    tilt[0, :, 3] = 0.01
    tilt[1, :, 4] = 0.3
    _, lean = hip_and_lean(*root_poses(tilt))
    assert torch.allclose(lean[0], torch.tensor([0.01, 0.03, 0.05], dtype=torch.float64), atol=1e-6)
    assert lean[1].abs().max() < 1e-3


def test_drift_penalty_is_free_inside_the_band_and_one_at_twice_it():
    ref = torch.zeros(1, dtype=torch.float64)
    inside = drift_loss(torch.full((1, 5), 0.9 * DRIFT_HIP_MM), torch.full((1, 5), 0.9 * DRIFT_LEAN_RAD), ref, ref)
    assert inside.item() == 0.0
    hip_twice = drift_loss(torch.full((1, 5), -2 * DRIFT_HIP_MM), torch.zeros(1, 5), ref, ref)
    assert hip_twice.item() == pytest.approx(1.0)
    lean_twice = drift_loss(torch.zeros(1, 5), torch.full((1, 5), 2 * DRIFT_LEAN_RAD + 1.0), ref, ref + 1.0)
    assert lean_twice.item() == pytest.approx(1.0)
    assert math.isclose(DRIFT_LEAN_RAD, math.radians(10))


def test_long_term_with_drift_adds_the_penalty_and_its_gradient():
    """Same model, frames and RNG: the drift weight adds exactly its penalty, whose gradient reaches the decoder."""
    config = train.model_config(
        train.build_parser().parse_args(["--hidden", "16", "--model", "vgru-d"]), list(range(54))
    )
    config["actions"] = ["walking"]
    model = train.build_model(config, dropout=0.0)
    model.norm.set_stats(torch.zeros(99), torch.full((99,), 400.0))  # root deltas of ~ +-400 mm: drift
    frames = torch.cumsum(0.05 * torch.randn(2, 6 + 20 + 5 + 1, 54, generator=torch.Generator().manual_seed(3)), 1)
    acts = torch.zeros(2, dtype=torch.long)

    def term(weight):
        torch.manual_seed(7)
        model.zero_grad()
        return long_horizon.long_motion_loss(model, frames, acts, 6, 20, 5, drift_weight=weight)

    plain, drifting = term(0.0), term(1.0)
    assert drifting.item() > plain.item() > 0
    (drifting - plain).backward()
    assert model.decoder.weight.grad.abs().sum() > 0
