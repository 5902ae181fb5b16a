"""The differentiable NPSS agrees with the evaluation's numpy NPSS and gives finite gradients."""

import numpy as np
import torch

from training import evaluate, spectral


def random_frames(rng, n=3, t=40, joints=32):
    base = rng.normal(scale=0.8, size=(n, 1, 3 + 3 * joints))
    drift = np.cumsum(rng.normal(scale=0.05, size=(n, t, 3 + 3 * joints)), axis=1)
    x = base + drift
    x[..., 30:36] = 0.0  # a joint at exactly zero rotation (the norm's gradient must stay finite there)
    return x


def test_euler_matches_the_evaluation_code():
    rng = np.random.default_rng(0)
    x = random_frames(rng)
    ours = spectral.expmap_to_euler(torch.from_numpy(x)).numpy()
    ref = evaluate.to_euler(x)
    assert np.abs(ours - ref).max() < 1e-6


def test_npss_matches_the_evaluation_code_and_has_finite_gradients():
    rng = np.random.default_rng(1)
    gt, pred = random_frames(rng), random_frames(rng)
    ge, pe = evaluate.to_euler(gt), evaluate.to_euler(pred)
    ref = evaluate.npss(ge, pe, "reference")
    ours = spectral.npss_reference(torch.from_numpy(ge), torch.from_numpy(pe)).item()
    assert abs(ours - ref) < 1e-9
    p = torch.from_numpy(pred).requires_grad_(True)
    loss = spectral.npss_reference(spectral.expmap_to_euler(torch.from_numpy(gt)), spectral.expmap_to_euler(p))
    assert abs(loss.item() - ref) < 1e-6
    loss.backward()
    assert torch.isfinite(p.grad).all() and p.grad.abs().sum() > 0
    # a perfect prediction scores 0
    assert spectral.npss_reference(torch.from_numpy(ge), torch.from_numpy(ge)).item() < 1e-12


def test_paired_bootstrap_orders_a_better_and_a_worse_prediction():
    rng = np.random.default_rng(2)
    gt = evaluate.to_euler(random_frames(rng, n=12))
    acts = ["walking"] * 6 + ["eating"] * 6
    close = gt + rng.normal(scale=0.01, size=gt.shape)
    far = gt + rng.normal(scale=0.5, size=gt.shape)
    boots = evaluate.paired_bootstrap(gt, [close, far, close], acts, reps=50)
    assert boots.shape == (50, 3)
    assert (boots[:, 1] > boots[:, 0]).all()  # the noisier prediction is worse in every resample
    assert np.array_equal(boots[:, 2], boots[:, 0])  # the same prediction, the same draw: paired
    assert np.isfinite(boots).all()
