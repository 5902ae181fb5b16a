"""H3.6M data pipeline (training/data.py) and validation metrics (training/evaluate.py).

Tests that need the data read $MOTION_DATA_DIR (default <repo>/../shared/data) and print a visible
SKIPPED line to stderr when it is absent.
"""

import sys

import numpy as np
import pytest

from training import data, evaluate


def dataset_or_skip():
    d = data.default_dataset_dir()
    if not (d / "S1").is_dir():
        print(f"SKIPPED: H3.6M data not found at {d} (set MOTION_DATA_DIR)", file=sys.stderr)
        pytest.skip(f"H3.6M data not found at {d} (set MOTION_DATA_DIR)")
    return d


_CACHE = {}


def training_set():
    if "ts" not in _CACHE:
        _CACHE["ts"] = data.load_training_set(dataset_or_skip(), log=lambda m: None)
    return _CACHE["ts"]


# ------------------------------------------------------------------ no data needed


def test_free_window_starts_avoid_blocked_intervals():
    blocked = [(100, 250), (400, 550)]
    starts = data.free_window_starts(900, blocked, 150)
    assert starts, "some windows fit"
    for s in starts:
        assert s >= data.MIN_START and s + 150 <= 900
        for b0, b1 in blocked:
            assert s + 150 <= b0 or s >= b1
    assert all(b - a >= 150 for a, b in zip(starts, starts[1:])), "windows do not overlap each other"
    dense = data.free_window_starts(900, blocked, 150, stride=50)
    assert set(starts) <= set(dense) and len(dense) > len(starts)
    for s in dense:
        assert all(s + 150 <= b0 or s >= b1 for b0, b1 in blocked)


def test_spread_is_a_permutation():
    for n in range(0, 12):
        assert sorted(data._spread(n)) == list(range(n))


def test_normalization_stats_drop_constant_dims():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(500, 6))
    x[:, 2] = 3.0
    x[:, 4] = 1e-6 * rng.normal(size=500)
    st = data.normalization_stats([x[:200], x[200:]])
    assert list(st.dims_used) == [0, 1, 3, 5]
    assert st.std[2] == 1.0 and st.std[4] == 1.0
    z = st.normalize(x)
    assert np.allclose(z.mean(0), 0, atol=1e-12) and np.allclose(z.std(0), 1)
    back = st.unnormalize(z)
    assert np.allclose(back[:, st.dims_used], x[:, st.dims_used])
    assert np.allclose(back[:, 2], st.mean[2])


def test_euler_of_identity_and_npss_identities():
    rng = np.random.default_rng(1)
    frames = rng.normal(scale=0.5, size=(3, 40, 99))
    e = evaluate.to_euler(frames)
    assert e.shape == frames.shape and np.all(e[..., :6] == 0)
    # a rotation about x by a: R = I + sin K + (1-cos) K^2 -> euler (a, 0, 0) in this convention up to sign
    R = evaluate.expmap2rotmat(np.array([0.3, 0.0, 0.0]))
    assert np.allclose(R @ R.T, np.eye(3), atol=1e-6)
    assert np.allclose(np.abs(evaluate.rotmat2euler(R)), [0.3, 0, 0], atol=1e-6)
    for variant in ("paper", "reference"):
        assert evaluate.npss(e, e, variant) == 0.0
        assert evaluate.npss(e, e[:, ::-1], variant) >= 0.0
    assert np.all(evaluate.euler_error(e, e) == 0)


def test_rotmat2euler_gimbal_cases():
    for sign in (-1.0, 1.0):
        R = np.zeros((3, 3))
        R[0, 2] = sign
        R[0, 1] = 0.0
        R[1, 1] = 1.0
        R[2, 0] = -sign
        e = evaluate.rotmat2euler(R)
        assert e[2] == 0.0
        assert e[1] == pytest.approx(-sign * np.pi / 2)


# ------------------------------------------------------------------ with the data


def test_stats_give_the_published_54_dims():
    ts = training_set()
    assert len(ts.stats.dims_used) == 54
    assert list(ts.stats.dims_used) == data.published_dims_used()
    assert ts.stats.mean.shape == (99,) and ts.stats.std.shape == (99,)


def test_training_windows_shapes_and_determinism():
    ts = training_set()
    f1, a1 = ts.sample_batch(np.random.default_rng(7), 5)
    f2, a2 = ts.sample_batch(np.random.default_rng(7), 5)
    assert f1.shape == (5, data.WINDOW, 54) and f1.dtype == np.float32
    assert np.array_equal(f1, f2) and np.array_equal(a1, a2)
    assert a1.min() >= 0 and a1.max() < 15
    # single-action mode
    walk = data.TrainingSet(actions=("walking",), stats=ts.stats, by_action=[ts.by_action[data.ACTIONS.index("walking")]])
    f, a = walk.sample_batch(np.random.default_rng(0), 3)
    assert f.shape == (3, 151, 54) and np.all(a == 0)


def test_validation_windows_do_not_overlap_test_windows():
    d = dataset_or_skip()
    rows = data.read_test_windows()
    wins = data.validation_windows(d, log=lambda m: None)
    assert len(wins) >= 3 * 11
    for w in wins:
        assert w.frames.shape == (150, 99)
        for r in rows:
            if (r["action"], r["subaction"]) != (w.action, w.subaction):
                continue
            t0, t1 = r["seed_start"], r["predict_start"] + 100
            assert w.start + 150 <= t0 or w.start >= t1, (w.action, w.subaction, w.start, r)
    again = data.validation_windows(d, log=lambda m: None)
    assert [(w.action, w.subaction, w.start) for w in again] == [(w.action, w.subaction, w.start) for w in wins]


def test_missing_files_are_reported_not_fatal(tmp_path):
    msgs = []
    seqs = data.load_sequences(tmp_path, [1], ["walking"], log=msgs.append)
    assert seqs == {} and len(msgs) == 1 and "S1/walking_1" in msgs[0]
    (tmp_path / "S1").mkdir()
    (tmp_path / "S1" / "walking_1.txt").write_text("1,2,x\n")
    seqs = data.load_sequences(tmp_path, [1], ["walking"], log=msgs.append)
    assert seqs == {} and "cannot parse" in msgs[-1]


def test_zero_velocity_reproduces_the_published_baseline_on_walking():
    # Metric check only (Gopalakrishnan et al. 2019 Table 6 / issue 5: zero-velocity walking NPSS 1.141, Euler 0.39 at 80 ms).
    d = dataset_or_skip()
    seqs = data.load_sequences(d, [5], ["walking"], log=lambda m: None)
    rows = [r for r in data.read_test_windows() if r["action"] == "walking"]
    seed, gt = [], []
    for r in rows:
        s = data.downsample(seqs[(5, "walking", r["subaction"])])
        seed.append(s[r["seed_start"] : r["predict_start"]])
        gt.append(s[r["predict_start"] : r["predict_start"] + 100])
    sc = evaluate.score_windows(np.array(gt), evaluate.zero_velocity(np.array(seed), 100))
    assert sc["npss_ref"] == pytest.approx(1.141, abs=5e-4)
    assert sc["euler"][1] == pytest.approx(0.39, abs=5e-3)
