"""MPJPE (LTD, HRI, siMLPe) against an independent NumPy implementation written here from
protocols_modern.md: numpy's own RandomState for the windows, forward kinematics from the
reference skeleton JSON, the 32-joint mean. `motion.evaluate(protocol="mpjpe")` must return the
CLI's report, its window starts must be the sampler's and its zero-velocity rows the oracle's to
1e-6 mm."""

import json
import os
from pathlib import Path

import numpy as np
import pytest

import motion

from conftest import ROOT

DATA = Path(os.environ.get("MOTION_DATA_DIR", ROOT.parent / "shared" / "data"))
DATASET = DATA / "h3.6m" / "dataset"
SKELETON = ROOT.parent / "shared" / "reference" / "h36m_skeleton.json"
EPS = float(np.finfo(np.float32).eps)


def needs_data():
    if not (DATASET / "S5").is_dir() or not SKELETON.is_file():
        pytest.skip(f"SKIPPED: no H3.6M data at {DATASET} or no {SKELETON}")


def rotmats(r):
    theta = np.linalg.norm(r, axis=-1)
    k = r / (theta[..., None] + EPS)
    z = np.zeros_like(k[..., 0])
    K = np.stack(
        [np.stack([z, -k[..., 2], k[..., 1]], -1), np.stack([k[..., 2], z, -k[..., 0]], -1),
         np.stack([-k[..., 1], k[..., 0], z], -1)], -2)  # fmt: skip
    s, c = np.sin(theta)[..., None, None], np.cos(theta)[..., None, None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def pelvis_positions(frames):
    """T x 99 exp-map -> T x 32 x 3 mm: dims 0..5 zeroed, row-vector FK (h36m.md)."""
    joints = json.loads(SKELETON.read_text())["joints"]
    frames = np.array(frames, dtype=np.float64)
    frames[:, :6] = 0.0
    t = len(frames)
    world = np.zeros((t, len(joints), 3, 3))
    pos = np.zeros((t, len(joints), 3))
    for j in joints:
        i, parent = j["index"], j["parent"]
        local = rotmats(frames[:, j["expmap_dims"]])
        if parent < 0:
            world[:, i] = local
            pos[:, i] = np.asarray(j["offset_mm"])
        else:
            world[:, i] = local @ world[:, parent]
            pos[:, i] = np.asarray(j["offset_mm"]) @ world[:, parent] + pos[:, parent]
    return pos


def take(action, sub):
    path = DATASET / "S5" / f"{action}_{sub}.txt.gz"
    if not path.is_file():
        path = path.with_suffix("")
    return np.loadtxt(path, delimiter=",")[::2]


def sampler(t1, t2, draws, input_n=50):
    rng = np.random.RandomState(1234567890)
    out = []
    for _ in range(draws):
        out.append((1, rng.randint(16, t1 - 150) + 50 - input_n))
        out.append((2, rng.randint(16, t2 - 150) + 50 - input_n))
    return out


def test_zero_velocity_and_windows_equal_the_numpy_oracle(cli):
    needs_data()
    actions = ["walking", "eating", "posing"]
    ours = motion.evaluate(data=DATA, actions=actions, protocol="mpjpe", windows=256)
    theirs = cli("eval", "--data", DATA, "--actions", ",".join(actions), "--protocol", "mpjpe", "--json")
    assert ours == theirs
    assert ours["windows"]["set"] == "256"
    for row in ours["actions"]:
        frames = {sub: take(row["action"], sub) for sub in (1, 2)}
        starts = sampler(len(frames[1]), len(frames[2]), 128)
        assert [tuple(s) for s in row["window_starts"]] == starts
        positions = {sub: pelvis_positions(f) for sub, f in frames.items()}
        errors = []
        for sub, start in starts:
            p = positions[sub]
            last = p[start + 49]
            truth = p[start + 50 : start + 75]
            errors.append(np.linalg.norm(truth - last, axis=-1).mean(axis=-1))
        oracle = np.mean(errors, axis=0)
        np.testing.assert_allclose(row["zero_velocity_per_frame"], oracle, rtol=0, atol=1e-6)
        np.testing.assert_allclose(row["zero_velocity"], oracle[[1, 3, 7, 9, 13, 17, 21, 24]], rtol=0, atol=1e-6)
        assert np.all(np.isfinite(row["model_per_frame"]))


def test_the_martinez_set_and_ltd_placement(cli):
    needs_data()
    eight = motion.evaluate(data=DATA, actions="walking", protocol="mpjpe", windows=8)
    ltd = motion.evaluate(data=DATA, actions="walking", protocol="mpjpe", windows="8", ltd_sampler=True)
    frames = [len(take("walking", s)) for s in (1, 2)]
    assert [tuple(s) for s in eight["actions"][0]["window_starts"]] == sampler(*frames, 4)
    assert [tuple(s) for s in ltd["actions"][0]["window_starts"]] == sampler(*frames, 4, input_n=10)
    assert ltd["windows"]["sampler_input"] == 10 and ltd["windows"]["input_frames"] == 50


def test_mpjpe_on_arrays_matches_numpy():
    needs_data()
    rng = np.random.default_rng(3)
    gt = rng.normal(size=(2, 25, 99)) * 0.3
    pred = gt + rng.normal(size=gt.shape) * 0.05
    got = motion.mpjpe(gt, pred)
    a = np.stack([pelvis_positions(g) for g in gt])
    b = np.stack([pelvis_positions(p) for p in pred])
    np.testing.assert_allclose(got, np.linalg.norm(a - b, axis=-1).mean(axis=(0, 2)), rtol=0, atol=1e-9)
    positions = motion.mpjpe(a, b, input_space="positions")
    np.testing.assert_allclose(positions, got, rtol=0, atol=1e-12)


def test_bad_mpjpe_requests_are_value_errors():
    with pytest.raises(ValueError, match="windows `test`"):
        motion.evaluate(protocol="mpjpe", windows="test")
    with pytest.raises(ValueError, match="protocol"):
        motion.evaluate(protocol="dlow")
    with pytest.raises(ValueError, match="MPJPE"):
        motion.mpjpe(np.zeros((1, 25, 98)), np.zeros((1, 25, 98)))
    with pytest.raises(ValueError, match="joints"):
        motion.mpjpe(np.zeros((1, 2, 32, 3)), np.zeros((1, 2, 32, 3)), input_space="positions", joints="17")


def test_sample_set_metrics_match_numpy():
    rng = np.random.default_rng(5)
    samples = rng.normal(size=(4, 3, 6, 9))
    gt = rng.normal(size=(4, 6, 9))
    last = np.zeros((4, 9))
    got = motion.sample_set_metrics(samples, gt, last, threshold=0.5)
    dist = np.linalg.norm(samples - gt[:, None], axis=-1)  # N x K x T
    np.testing.assert_allclose(got["ade"], dist.mean(-1).min(-1).mean(), rtol=0, atol=1e-12)
    np.testing.assert_allclose(got["fde"], dist[..., -1].min(-1).mean(), rtol=0, atol=1e-12)
    flat = samples.reshape(4, 3, -1)
    pairs = [np.linalg.norm(f[i] - f[j]) for f in flat for i in range(3) for j in range(i + 1, 3)]
    np.testing.assert_allclose(got["apd"], np.mean(pairs), rtol=0, atol=1e-12)
    assert got["multimodal_set_sizes"] == [4, 4, 4, 4]


def test_the_stochastic_variant_is_the_cli_report(cli):
    needs_data()
    ours = motion.evaluate(data=DATA, actions="walking", protocol="stochastic", samples=3)
    theirs = cli("eval", "--data", DATA, "--actions", "walking", "--protocol", "stochastic", "--samples", 3, "--json")
    assert ours == theirs
    assert "not comparable" in ours["not_comparable"]
    z = ours["zero_velocity"]
    assert z["apd"] == 0.0 and 0 < z["ade"] < z["mmade"] + 1.0
    assert ours["windows"] == ours["actions"][0]["windows"] > 100
    with pytest.raises(ValueError, match="stochastic"):
        motion.evaluate(protocol="stochastic", windows=8)
