"""Body-frame forward kinematics against a naive loop over the reference's formulas, and the roughness term."""

import numpy as np
import pytest
import torch

from training import kinematics
from training.export_fixtures import H36M_DIMS_USED
from training.metrics_np import expmap2rotmat
from training.models import Norm


@pytest.fixture(autouse=True)
def skeleton_or_skip():
    if not kinematics.SKELETON.is_file():
        pytest.skip(f"H3.6M skeleton not found at {kinematics.SKELETON}")


def naive_positions(frame: np.ndarray) -> np.ndarray:
    """h36m.md "Skeleton", one joint at a time, root rotation and translation left out."""
    parents, offsets, dims, _ = kinematics.skeleton()
    offsets = offsets.numpy()
    world, pos = [np.eye(3)], [offsets[0]]
    for j in range(1, len(parents)):
        p = parents[j]
        world.append(expmap2rotmat(frame[dims[j]]) @ world[p])
        pos.append(offsets[j] @ world[p] + pos[p])
    return np.stack(pos)


def test_body_positions_match_the_naive_loop_and_keep_bone_lengths():
    rng = np.random.default_rng(0)
    frames = rng.normal(scale=0.8, size=(2, 3, 99))
    got = kinematics.body_positions(torch.from_numpy(frames)).numpy()
    assert got.shape == (2, 3, 32, 3)
    for b in range(2):
        for t in range(3):
            np.testing.assert_allclose(got[b, t], naive_positions(frames[b, t]), rtol=0, atol=1e-9)
    parents, offsets, _, _ = kinematics.skeleton()
    bones = np.linalg.norm(got[..., 1:, :] - got[..., parents[1:], :], axis=-1)
    np.testing.assert_allclose(bones, np.broadcast_to(offsets[1:].norm(dim=-1).numpy(), bones.shape), atol=1e-3)
    rest = kinematics.body_positions(torch.zeros(1, 99, dtype=torch.float64), [0, 2])[0].numpy()
    np.testing.assert_allclose(rest[1], offsets[0].numpy() + offsets[1].numpy() + offsets[2].numpy(), atol=1e-12)


def test_roughness_is_zero_for_uniform_motion_and_grows_with_jitter():
    t = torch.arange(20, dtype=torch.float64)[None, :, None, None]
    line = t * torch.tensor([3.0, -1.0, 2.0], dtype=torch.float64)
    assert kinematics.roughness(line.expand(2, 20, 4, 3)).abs().max() < 1e-12
    jitter = line + torch.randn(2, 20, 4, 3, generator=torch.Generator().manual_seed(0), dtype=torch.float64)
    assert (kinematics.roughness(jitter) > 0.2).all()


def test_roughness_loss_is_zero_for_the_truth_and_pulls_a_jittery_prediction():
    rng = np.random.default_rng(1)
    norm = Norm(99, H36M_DIMS_USED)
    norm.set_stats(torch.zeros(99), torch.ones(99))
    model = type("M", (), {"norm": norm.double()})()
    steps = np.linspace(0, 1, 30)[None, :, None]
    truth = torch.from_numpy(np.sin(2 * np.pi * steps + rng.uniform(0, 6, (2, 1, len(H36M_DIMS_USED)))) * 0.5)
    assert kinematics.roughness_loss(model, truth, truth).item() == 0.0
    pred = (truth + 0.05 * torch.from_numpy(rng.normal(size=truth.shape))).requires_grad_(True)
    loss = kinematics.roughness_loss(model, pred, truth)
    assert loss.item() > 0.1
    loss.backward()
    assert pred.grad.abs().max() > 0


def test_a_broken_skeleton_file_is_named(tmp_path):
    bad = tmp_path / "s.json"
    bad.write_text('{"joints": [{"parent": 0}]}')
    with pytest.raises(ValueError, match="s.json"):
        kinematics.skeleton(bad)
