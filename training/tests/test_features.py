"""Derivative features (Gopalakrishnan et al. 2019 eq. 5, repeat-first padding) and normalization."""

import torch

from training.features import DerivativeHistory, compute_norm_stats, derivative_features, normalize, unnormalize


def test_derivatives_by_hand():
    x = torch.tensor([1.0, 3.0, 6.0, 10.0]).reshape(1, 4, 1)
    # [x, x_t - x_{t-1}, x_t - 2x_{t-1} + x_{t-2}, x_t - 3x_{t-1} + 3x_{t-2} - x_{t-3}],
    # frames before the first are copies of it.
    expected = torch.tensor(
        [
            [1.0, 0.0, 0.0, 0.0],
            [3.0, 2.0, 2.0, 2.0],
            [6.0, 3.0, 1.0, -1.0],
            [10.0, 4.0, 1.0, 0.0],
        ]
    ).reshape(1, 4, 4)
    assert torch.equal(derivative_features(x, 3), expected)


def test_feature_layout_is_blocks_of_dims():
    x = torch.randn(2, 5, 3)
    f = derivative_features(x, 3)
    assert f.shape == (2, 5, 12)
    assert torch.equal(f[..., :3], x)
    torch.testing.assert_close(f[:, 1:, 3:6], x[:, 1:] - x[:, :-1])


def test_incremental_matches_batch_bit_for_bit():
    x = torch.randn(3, 9, 4)
    history = DerivativeHistory(3)
    incremental = torch.stack([history.push(x[:, t]) for t in range(9)], dim=1)
    assert torch.equal(incremental, derivative_features(x, 3))


def test_order_zero_is_identity():
    x = torch.randn(2, 4, 3)
    assert torch.equal(derivative_features(x, 0), x)
    assert torch.equal(DerivativeHistory(0).push(x[:, 0]), x[:, 0])


def test_normalize_roundtrip_and_dropped_dims_restored_to_mean():
    frames = torch.randn(200, 6, dtype=torch.float64) * torch.tensor([1.0, 0.0, 2.0, 0.0, 0.5, 3.0])
    frames[:, 1] = 7.0
    mean, std, used = compute_norm_stats(frames)
    assert used == [0, 2, 4, 5]
    assert std[1] == 1.0 and std[3] == 1.0
    norm = normalize(frames.float(), mean, std, used)
    assert norm.shape == (200, 4)
    torch.testing.assert_close(norm.mean(0), torch.zeros(4), rtol=0, atol=1e-5)
    full = unnormalize(norm, mean, std, used)
    assert torch.equal(full[:, 1], mean[1].expand(200)) and full[0, 1] == 7.0
    torch.testing.assert_close(full[:, used], frames.float()[:, used], rtol=0, atol=1e-5)
