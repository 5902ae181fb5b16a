"""Motion words and NDMS in torch against a naive loop over metrics.md's recipe, and the word-realism term."""

import numpy as np
import pytest
import torch

from training import kinematics, word_realism as wr
from training.export_fixtures import H36M_DIMS_USED
from training.metrics_np import expmap2rotmat
from training.models import Norm


@pytest.fixture(autouse=True)
def skeleton_or_skip():
    if not kinematics.SKELETON.is_file():
        pytest.skip(f"H3.6M skeleton not found at {kinematics.SKELETON}")


def walking_frames(frames=40, seed=0):
    """Frames ``[frames, 99]`` that move every joint smoothly, the root turning and translating."""
    rng = np.random.default_rng(seed)
    t = np.arange(frames)[:, None]
    x = 0.4 * np.sin(0.3 * t + rng.uniform(0, 6, (1, 99))) + rng.normal(scale=0.1, size=(1, 99))
    x[:, 0:3] = [12.0, 0.5, 3.0] + 2.0 * np.sin(0.2 * t)  # mm per frame
    x[:, 3:6] = 0.02 * np.cos(0.1 * t + np.arange(3))
    unused = np.ones(99, dtype=bool)
    unused[H36M_DIMS_USED] = False
    x[:, unused] = 0.0  # as a model's frames have them (the dropped dims at their mean, 0 here)
    return x


def naive_world(frames: np.ndarray) -> np.ndarray:
    """h36m.md: the root integrated frame by frame from the identity (each 25 Hz delta twice after the first
    frame's once), then x_0 = offset_0 + T, x_j = offset_j · W_p + x_p with W_0 = R_abs."""
    parents, offsets, dims, ndms = kinematics.skeleton()
    offsets = offsets.numpy()
    rot, trans, out = np.eye(3), np.zeros(3), []
    for i, f in enumerate(frames):
        for _ in range(1 if i == 0 else 2):
            trans = trans + f[0:3] @ rot
            rot = expmap2rotmat(f[3:6]) @ rot
        world, pos = [rot], [offsets[0] + trans]
        for j in range(1, len(parents)):
            world.append(expmap2rotmat(f[dims[j]]) @ world[parents[j]])
            pos.append(offsets[j] @ world[parents[j]] + pos[parents[j]])
        out.append(np.stack(pos)[ndms])
    return np.stack(out)


def naive_word(positions: np.ndarray, start: int) -> np.ndarray:
    """metrics.md / motion_metrics::ndms::word, body frame, one point at a time."""
    ndms = kinematics.skeleton()[3]
    p = positions[start : start + wr.KAPPA][..., [0, 2, 1]]
    left, right = p[0, ndms.index(wr.LEFT_HIP)], p[0, ndms.index(wr.RIGHT_HIP)]
    shoulders = 0.5 * (p[0, ndms.index(wr.LEFT_SHOULDER)] + p[0, ndms.index(wr.RIGHT_SHOULDER)])
    origin = 0.5 * (left + right)
    x = (right - left) / np.linalg.norm(right - left)
    up = shoulders - origin
    z = up - (up @ x) * x
    z /= np.linalg.norm(z)
    y = np.cross(z, x)
    return np.array([[[a @ (q - origin) for a in (x, y, z)] for q in frame] for frame in p]).ravel()


def naive_ndms(a: np.ndarray, b: np.ndarray) -> float:
    va = np.diff(a.reshape(wr.KAPPA, -1, 3), axis=0)
    vb = np.diff(b.reshape(wr.KAPPA, -1, 3), axis=0)
    total = 0.0
    for t in range(wr.KAPPA - 1):
        for j in range(va.shape[1]):
            na, nb = max(np.linalg.norm(va[t, j]), wr.EPSILON), max(np.linalg.norm(vb[t, j]), wr.EPSILON)
            cos = np.clip(va[t, j] @ vb[t, j] / (na * nb), -1, 1)
            total += 0.5 * (1 + cos) * min(na, nb) / max(na, nb)
    return total / va.size * 3


def test_world_positions_and_words_match_the_naive_recipe():
    frames = walking_frames()
    pos = wr.world_positions(torch.from_numpy(frames)[None])[0].numpy()
    np.testing.assert_allclose(pos, naive_world(frames), rtol=0, atol=1e-8)
    got = wr.words(torch.from_numpy(pos)[None], stride=3)[0].numpy()
    assert got.shape == ((40 - wr.KAPPA) // 3 + 1, wr.KAPPA * 12 * 3)
    for k, start in enumerate(range(0, 40 - wr.KAPPA + 1, 3)):
        np.testing.assert_allclose(got[k], naive_word(pos, start), rtol=0, atol=1e-8)


def test_words_do_not_depend_on_where_the_root_integration_starts():
    frames = torch.from_numpy(walking_frames())[None]
    whole = wr.words(wr.world_positions(frames))
    later = wr.words(wr.world_positions(frames[:, 5:]))
    torch.testing.assert_close(later, whole[:, 5:], rtol=0, atol=1e-8)


def test_similarity_matches_the_naive_loop_is_one_for_a_moving_word_and_half_at_rest():
    rng = np.random.default_rng(2)
    a, b = rng.normal(size=(2, 3, wr.KAPPA * 12 * 3))
    got = wr.similarity(torch.from_numpy(a), torch.from_numpy(b)).numpy()
    np.testing.assert_allclose(got, [naive_ndms(a[i], b[i]) for i in range(3)], rtol=0, atol=1e-9)
    np.testing.assert_allclose(wr.similarity(torch.from_numpy(a), torch.from_numpy(a)).numpy(), 1.0, atol=1e-12)
    rest = torch.zeros(wr.KAPPA * 12 * 3, dtype=torch.float64)
    assert abs(wr.similarity(rest, rest).item() - 0.5) < 1e-12


def test_word_realism_is_zero_for_real_motion_and_pulls_a_perturbed_one():
    norm = Norm(99, H36M_DIMS_USED)
    norm.set_stats(torch.zeros(99), torch.ones(99))
    model = type("M", (), {"norm": norm.double()})()
    real = [walking_frames(60, seed=s) for s in range(3)]
    bank = wr.WordBank([[r] for r in real], stride=1)
    assert len(bank) == 3 * (60 - wr.KAPPA + 1)
    moved = torch.from_numpy(np.stack([r[10:40, H36M_DIMS_USED] for r in real]))
    actions = torch.tensor([0, 1, 2])
    assert wr.word_realism_loss(model, moved, actions, bank).item() < 1e-6
    noisy = (moved + 0.05 * torch.randn(moved.shape, generator=torch.Generator().manual_seed(0),
                                       dtype=moved.dtype)).requires_grad_(True)
    loss = wr.word_realism_loss(model, noisy, actions, bank)
    assert loss.item() > 0.05
    loss.backward()
    assert torch.isfinite(noisy.grad).all() and noisy.grad.abs().max() > 0
    with pytest.raises(ValueError, match="no words of action 3"):
        wr.word_realism_loss(model, moved[:1], torch.tensor([3]), wr.WordBank([[r] for r in real] + [[]]))
