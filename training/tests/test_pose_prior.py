"""The pose prior (training/pose_prior.py, models.PosePrior): its statistics on real-like frames, its pull against a
NumPy statement of the definition, and that it changes a closed loop (the goal_gru_prior parity fixture)."""

import numpy as np
import torch

from training.export_fixtures import build_all
from training.models import PosePrior
from training.pose_prior import prior_of


def test_prior_of_standardizes_the_body_dims_and_leaves_the_root_alone():
    rng = np.random.default_rng(0)
    dims = [0, 3, 6, 7, 8, 9]
    frames = rng.normal(size=(5000, 6)) @ rng.normal(size=(6, 6))
    mean, comps, inv = prior_of(frames, dims)
    assert np.all(comps[:, :2] == 0) and np.all(comps[4:] == 0) and np.all(inv[4:] == 0)
    z = (frames - mean) @ comps.T
    m2 = ((z * inv) ** 2).sum(axis=1) / 4
    assert abs(m2.mean() - 1.0) < 1e-3
    np.testing.assert_allclose(comps[:4, 2:] @ comps[:4, 2:].T, np.eye(4), atol=1e-9)


def test_pull_matches_the_definition():
    rng = np.random.default_rng(1)
    o = 5
    q, _ = np.linalg.qr(rng.normal(size=(o, o)))
    prior = PosePrior(1.2, 2, o).double()
    with torch.no_grad():
        prior.mean.copy_(torch.from_numpy(rng.normal(size=(2, o))))
        prior.components.copy_(torch.from_numpy(np.stack([q.T, q])))
        prior.inv_std.copy_(torch.from_numpy(rng.uniform(0.5, 2.0, size=(2, o))))
    y = rng.normal(scale=2.0, size=(6, o))
    groups = np.array([0, 1, 0, 1, 5, 0])
    got = prior(torch.from_numpy(y), torch.from_numpy(groups)).numpy()
    for b in range(6):
        g = min(groups[b], 1)
        c, inv = prior.components[g].numpy(), prior.inv_std[g].numpy()
        z = c @ (y[b] - prior.mean[g].numpy())
        m = np.sqrt(np.mean((z * inv) ** 2))
        want = y[b] - (1 - 1.2 / m) * c.T @ z if m > 1.2 else y[b]
        np.testing.assert_allclose(got[b], want, atol=1e-12)


def test_the_fixture_prior_changes_the_closed_loop():
    from training.export_fixtures import SEED_FRAMES
    from training.models import build_model

    files = build_all()
    (tensors, meta), (expected, _) = files["goal_gru_prior.safetensors"], files["goal_gru_prior.expected.safetensors"]
    import json

    config = json.loads(meta["config"])
    model = build_model(config).double().eval()
    model.load_state_dict({k: v.double() for k, v in tensors.items()})
    control = expected["control"].double().unsqueeze(0)
    with_prior = model.predict(expected["seed"].double(), action=control, horizon=10)
    model.prior = None
    without = model.predict(expected["seed"].double(), action=control, horizon=10)
    assert SEED_FRAMES > 0 and (with_prior - without).abs().max() > 1e-3
