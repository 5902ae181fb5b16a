"""The training posture term (training/posture_term.py): its deviation equals the closed-loop prior's, it is zero
inside the radius, and its gradient pulls a drifted frame back toward the action's real poses."""

import numpy as np
import torch

from training.models import PosePrior
from training.posture_term import PostureGaussian, posture_loss

DIMS = [0, 3, 6, 7, 8, 9, 10]


def real_like(rng, n, shift):
    return rng.normal(size=(n, len(DIMS))) @ rng.normal(size=(len(DIMS), len(DIMS))) * 0.3 + shift


def test_deviation_is_the_closed_loop_priors_and_the_term_is_a_hinge():
    rng = np.random.default_rng(0)
    seqs = [[real_like(rng, 400, 0.0)], [real_like(rng, 400, 1.0), real_like(rng, 30, 1.0)]]
    g = PostureGaussian(seqs, DIMS)
    prior = PosePrior(1.0, 2, len(DIMS))
    with torch.no_grad():
        prior.mean.copy_(g.mean)
        prior.components.copy_(g.components)
        prior.inv_std.copy_(g.inv_std)
    y = torch.tensor(rng.normal(size=(2, 6, len(DIMS))) * 2, dtype=torch.float32)
    acts = torch.tensor([0, 1])
    m = g.deviation(y, acts)
    # The prior pulls exactly the frames with m > 1 back onto m = 1.
    for b in range(2):
        pulled = prior(y[b], acts[b].repeat(6))
        moved = (pulled - y[b]).abs().sum(-1) > 1e-6
        assert torch.equal(moved, m[b] > 1.0)
        np.testing.assert_allclose(g.deviation(pulled[None], acts[b : b + 1])[0][moved].numpy(), 1.0, atol=1e-4)
    assert posture_loss(y, acts, g, 1e6).item() == 0.0
    want = (torch.relu(m - 1.0) ** 2).mean()
    assert abs(posture_loss(y, acts, g, 1.0).item() - want.item()) < 1e-7


def test_gradient_moves_a_drifted_frame_toward_the_real_poses():
    rng = np.random.default_rng(1)
    g = PostureGaussian([[real_like(rng, 500, 0.0)]], DIMS)
    y = (g.mean[0] + 3.0).reshape(1, 1, -1).clone().requires_grad_(True)
    acts = torch.tensor([0])
    before = g.deviation(y, acts).item()
    posture_loss(y, acts, g, 1.0).backward()
    with torch.no_grad():
        stepped = y - 0.01 * y.grad
    assert before > 1.0 and g.deviation(stepped, acts).item() < before
    assert torch.all(y.grad[0, 0, :2] == 0)  # the root's dims are never judged


def test_an_action_without_frames_gets_the_pooled_gaussian():
    rng = np.random.default_rng(2)
    g = PostureGaussian([[real_like(rng, 300, 0.0)], [], [real_like(rng, 10, 0.0)]], DIMS)
    assert torch.allclose(g.mean[1], g.mean[0]) and torch.all(torch.isfinite(g.inv_std))
