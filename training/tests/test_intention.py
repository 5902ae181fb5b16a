"""The intention-based model of Tanke et al. 2021: labels (k-means, cycle merging), the model's time indexing against a
hand-written step loop, the losses, and a smoke run with exact resume and export."""

import json
import math
from pathlib import Path
import numpy as np
import pytest
import torch
from torch.nn import functional as F

from training import data, intention_labels, long_horizon, train_intention
from training.export import load_weights
from training.export_fixtures import H36M_DIMS_USED
from training.models import IntentionModel, make_config

from .helpers import run_interrupted, synthetic_dataset


def small_model(lookahead=3, seed=0):
    torch.manual_seed(seed)
    config = make_config("intention", H36M_DIMS_USED, hidden=10, layers=2, noise_dims=3, label_hidden=5,
                         intentions=4, clusters=6, lookahead=lookahead, intention_features=2)
    model = IntentionModel(config).double().eval()
    with torch.no_grad():
        for name, p in model.named_parameters():
            p.copy_(torch.rand(p.shape, dtype=p.dtype) - 0.5)
        model.labels.centroids.copy_(torch.randn(6, len(H36M_DIMS_USED), dtype=torch.float64) * 0.5)
        model.labels.merge.copy_(torch.tensor([0, 1, 2, 3, 1, 0], dtype=torch.float64))
    return model


# ---------------------------------------------------------------- labels


def test_kmeans_finds_separated_clusters():
    rng = np.random.default_rng(0)
    centres = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]])
    points = np.concatenate([c + rng.normal(scale=0.1, size=(50, 2)) for c in centres])
    found = intention_labels.kmeans(points, 3, seed=1)
    for c in centres:
        assert np.min(np.linalg.norm(found - c, axis=1)) < 0.1


def test_cycles_count_clusters_that_alternate_and_not_a_pose_left_for_good():
    walk = np.array([0, 0, 1, 1, 0, 0, 1, 1, 0, 0, 2, 2, 2, 2])  # 0-1-0-1-0 cycles, then 2 for good
    counts = intention_labels.cycle_counts([walk], 3, cycle_frames=10)
    assert counts[0, 1] == counts[1, 0] > 0
    assert counts[0, 2] == counts[1, 2] == 0
    # a return after more than cycle_frames frames is no cycle
    slow = np.array([0] + [1] * 20 + [0])
    assert intention_labels.cycle_counts([slow], 2, cycle_frames=10)[0, 1] == 0


def test_merging_joins_cycling_clusters_first_and_labels_follow_the_merge_table():
    counts = np.zeros((4, 4), dtype=np.int64)
    counts[0, 1] = counts[1, 0] = 5  # 0 and 1 cycle, 2 and 3 never
    sizes = np.array([10, 10, 10, 10])
    centroids = np.array([[0.0], [5.0], [1.0], [9.0]])
    merge = intention_labels.merge_cycles(counts, sizes, centroids, 3)
    assert merge[0] == merge[1] and len(set(merge.tolist())) == 3
    assert merge.tolist() == [0, 0, 1, 2]  # groups numbered by their smallest cluster
    frames = np.array([[0.1], [4.9], [1.2], [8.0]])
    assert intention_labels.label(frames, centroids, merge).tolist() == [0, 0, 1, 2]
    with pytest.raises(ValueError):
        intention_labels.merge_cycles(counts, sizes, centroids, 5)


def test_merged_labels_change_more_slowly_than_their_clusters():
    ts, _ = synthetic_dataset()
    seqs = [s for lst in ts.by_action for _, s in lst]
    centroids, merge = intention_labels.fit_labels(seqs, clusters=12, intentions=4, seed=0)
    assert sorted(set(merge.tolist())) == [0, 1, 2, 3]
    clusters = [intention_labels.nearest_cluster(s, centroids) for s in seqs]
    labels = [merge[c] for c in clusters]
    assert intention_labels.mean_run_length(labels) >= intention_labels.mean_run_length(clusters)


def test_the_model_labels_frames_as_the_numpy_labelling():
    model = small_model()
    frames = torch.randn(3, 7, len(H36M_DIMS_USED), dtype=torch.float64) * 0.5
    expected = intention_labels.label(frames.numpy(), model.labels.centroids.numpy(), model.labels.merge.long().numpy())
    assert model.labels(frames).numpy().tolist() == expected.tolist()


# ---------------------------------------------------------------- the model's time indexing


def hand_written(model: IntentionModel, seed: torch.Tensor, horizon: int, z: torch.Tensor) -> torch.Tensor:
    """Eq. 6 step by step, as the engine streams it: before the step producing frame τ the label decoder has
    forecast up to frame τ + γ - 2 (for γ = 1 that is frame τ - 1: no forecast before the second step)."""
    g, c = model.lookahead, model.intentions
    labels = model.labels(seed)
    onehots = F.one_hot(labels, c).double()
    hl = torch.zeros(seed.shape[0], model.label_hidden, dtype=torch.float64)
    for t in range(seed.shape[1]):
        hl = model.label_encoder(torch.cat([seed[:, t], onehots[:, t]], -1), hl)
    probs = {seed.shape[1] - 1: onehots[:, -1]}  # frame -> probabilities
    x_in = onehots[:, -1]

    def forecast_next():
        nonlocal hl, x_in
        hl = model.label_decoder(x_in, hl)
        x_in = torch.softmax(model.label_out(hl), -1)
        probs[max(probs) + 1] = x_in

    hp = torch.zeros(seed.shape[0], model.hidden_size - model.noise_dims, dtype=torch.float64)
    for t in range(seed.shape[1]):
        hp = model.pose_encoder(seed[:, t], hp)
    hs = [torch.cat([hp, z], -1) for _ in model.rnn]
    x = seed[:, -1]
    s = seed.shape[1]
    out = []
    for tau in range(s, s + horizon):
        while max(probs) < tau + g - 2:  # the forecast reaches frame τ + γ - 2 (γ - 2 ahead of τ)
            forecast_next()
        window = torch.stack([probs[u] for u in range(tau - 1, tau + g - 1)], dim=2)  # [B, C, γ]
        feat = (model.intent_conv.weight[None] * window[:, None]).sum((2, 3)) + model.intent_conv.bias
        inp = torch.cat([x, z, feat], -1)
        for k, cell in enumerate(model.rnn):
            hs[k] = cell(inp, hs[k])
            inp = hs[k]
        x = x + model.decoder(inp)
        out.append(x)
    return torch.stack(out, 1)


@pytest.mark.parametrize("lookahead", [1, 2, 3, 10])
def test_closed_loop_equals_the_streamed_step_loop(lookahead):
    model = small_model(lookahead)
    seed = torch.randn(2, 6, len(H36M_DIMS_USED), dtype=torch.float64) * 0.5
    z = torch.randn(2, 3, dtype=torch.float64)
    with torch.no_grad():
        got = model.closed_loop(seed, 9, eps=z)
        want = hand_written(model, seed, 9, z)
        shorter = model.closed_loop(seed, 4, eps=z)
    torch.testing.assert_close(got, want, rtol=1e-12, atol=1e-12)
    torch.testing.assert_close(shorter, got[:, :4], rtol=0, atol=0)  # the horizon does not change the frames


def test_samples_differ_by_their_noise_only():
    model = small_model()
    seed = torch.randn(1, 6, len(H36M_DIMS_USED), dtype=torch.float64).expand(3, -1, -1)
    z = torch.randn(3, 3, dtype=torch.float64)
    z[1] = z[0]
    with torch.no_grad():
        out = model.closed_loop(seed, 5, eps=z)
    torch.testing.assert_close(out[0], out[1], rtol=0, atol=1e-12)
    assert not torch.allclose(out[0], out[2])


# ---------------------------------------------------------------- losses


def test_reconstruction_weights_fall_linearly_to_zero_at_tau_rec():
    w = train_intention.rec_weights(20, 15, "cpu")
    assert w[0].item() == pytest.approx(14 / 15) and w[13].item() == pytest.approx(1 / 15)
    assert torch.all(w[14:] == 0)


def test_reconstruction_loss_is_the_mean_per_joint_distance():
    groups = [[0, 1, 2], [3, 4, 5]]
    truth = torch.zeros(1, 2, 6)
    pred = truth.clone()
    pred[0, 0, :3] = torch.tensor([3.0, 4.0, 0.0])  # joint 0 of frame 0 is 5 away
    weights = torch.tensor([1.0, 1.0])
    assert train_intention.rec_loss(pred, truth, groups, weights).item() == pytest.approx(5 / 4)


def test_windows_cover_the_sequence_at_the_stride():
    x = torch.arange(2 * 7 * 1, dtype=torch.float32).reshape(2, 7, 1)
    w = train_intention.windows_of(x, 3, 2)
    assert w.shape == (6, 3, 1)
    assert w[0, :, 0].tolist() == [0, 1, 2] and w[1, :, 0].tolist() == [2, 3, 4] and w[3, :, 0].tolist() == [7, 8, 9]


def test_choice_prefers_a_model_that_moves_in_band_then_the_lower_npss():
    moving = {"npss_ref": 2.0, "long_speed": {"a": 0.6, "b": 1.5}}
    better = {"npss_ref": 1.0, "long_speed": {"a": 0.7, "b": 1.9}}
    frozen = {"npss_ref": 0.5, "long_speed": {"a": 0.05, "b": 1.0}}
    wild = {"npss_ref": 0.5, "long_speed": {"a": 8.0, "b": 1.0}}
    assert sorted([frozen, moving, better, wild], key=train_intention.choice_key)[:2] == [better, moving]
    assert train_intention.choice_key(wild) < train_intention.choice_key(frozen)  # log 4 < log 10


# ---------------------------------------------------------------- a run


TINY = ["--hidden", "8", "--layers", "2", "--noise-dims", "2", "--label-hidden", "4", "--clusters", "6",
        "--intentions", "3", "--lookahead", "3", "--intention-features", "2", "--batch", "2", "--future", "12",
        "--pose-window", "4", "--label-window", "5", "--d-hidden", "8", "--long-burn-in", "3", "--long-frames", "4",
        "--log-every", "1", "--val-every", "2", "--checkpoint-every", "1", "--val-per-action", "1"]


@pytest.fixture
def synthetic(monkeypatch):
    ts, wins = synthetic_dataset()
    monkeypatch.setattr(data, "load_training_set", lambda *a, **k: ts)
    monkeypatch.setattr(data, "validation_windows", lambda *a, **k: wins)
    return ts


def run(argv):
    assert train_intention.main(argv) == 0


def test_a_run_resumes_exactly_and_exports(tmp_path, synthetic, monkeypatch):
    run(["--run-dir", str(tmp_path / "full"), "--iterations", "3"] + TINY)
    run_interrupted(monkeypatch, train_intention, "rec_loss", 3,
                    lambda: run(["--run-dir", str(tmp_path / "split"), "--iterations", "3"] + TINY))
    run(["--run-dir", str(tmp_path / "split"), "--resume"])
    a = torch.load(tmp_path / "full" / "last.pt", weights_only=False)
    b = torch.load(tmp_path / "split" / "last.pt", weights_only=False)
    assert a["iteration"] == b["iteration"] == 3
    for key in ("model", "d_pose", "d_label"):
        for k in a[key]:
            assert torch.equal(a[key][k], b[key][k]), (key, k)
    best = torch.load(tmp_path / "full" / "best.pt", weights_only=False)
    assert set(best["best"]["long_speed"]) == {w.action for w in data.validation_windows()}
    out = tmp_path / "w.safetensors"
    run(["--export", str(out), "--from", str(tmp_path / "full" / "best.pt")])
    model = load_weights(out)
    assert model.config["architecture"] == "intention" and model.config["lookahead"] == 3
    assert sorted(set(model.labels.merge.long().tolist())) == [0, 1, 2]
    for k, v in best["model"].items():
        torch.testing.assert_close(model.state_dict()[k], v, rtol=0, atol=0)
    assert "noise_scale" not in model.config and model.noise_scale == 1.0
    # --noise-scale: stored in the file's config; a drawn z is scaled by it, an explicit z is not.
    half = tmp_path / "half.safetensors"
    run(["--export", str(half), "--from", str(tmp_path / "full" / "best.pt"), "--noise-scale", "0.5"])
    scaled = load_weights(half).double().eval()
    assert scaled.config["noise_scale"] == 0.5
    model = model.double().eval()
    seed = torch.randn(2, 5, model.output_size, dtype=torch.float64)
    torch.manual_seed(3)
    z = model.sample_noise(2, seed)
    torch.manual_seed(3)
    got = scaled.closed_loop(seed, 4)
    torch.testing.assert_close(got, model.closed_loop(seed, 4, eps=0.5 * z), rtol=0, atol=1e-12)
    torch.testing.assert_close(scaled.closed_loop(seed, 4, eps=z), model.closed_loop(seed, 4, eps=z), rtol=0, atol=0)
    assert train_intention.main(["--export", str(tmp_path / "bad.safetensors"), "--from",
                                 str(tmp_path / "full" / "best.pt"), "--noise-scale", "-1"]) == 2
    assert not (tmp_path / "bad.safetensors").exists()


def test_bad_arguments_are_refused(tmp_path, synthetic):
    with pytest.raises(SystemExit, match="future"):
        train_intention.main(["--run-dir", str(tmp_path / "a")] + TINY + ["--future", "3"])
    with pytest.raises(SystemExit, match="resume"):
        train_intention.main(["--run-dir", str(tmp_path / "b"), "--resume"])


def test_init_weights_and_drift_term(tmp_path, synthetic):
    """A run from an exported file keeps its weights and clustering (lr 0 changes nothing) and logs the drift and
    the foot-skating terms."""
    run(["--run-dir", str(tmp_path / "base"), "--iterations", "2"] + TINY)
    out = tmp_path / "base.safetensors"
    run(["--export", str(out), "--from", str(tmp_path / "base" / "last.pt"), "--dtype", "float32"])
    run(["--run-dir", str(tmp_path / "ft"), "--iterations", "2", "--init-weights", str(out), "--lr", "0",
         "--drift-weight", "1", "--skate-weight", "1"] + TINY)
    start = load_weights(out).state_dict()
    after = torch.load(tmp_path / "ft" / "last.pt", weights_only=False)["model"]
    for k, v in start.items():
        torch.testing.assert_close(after[k], v, rtol=0, atol=0)
    records = [json.loads(line) for line in (tmp_path / "ft" / "metrics.jsonl").read_text().splitlines()]
    drifts = [r["drift"] for r in records if r.get("kind") == "train"]
    assert drifts and all(d >= 0 for d in drifts)
    skates = [r["skate"] for r in records if r.get("kind") == "train"]
    assert skates and all(math.isfinite(v) and v >= 0 for v in skates)
    with pytest.raises(SystemExit, match="not an intention model"):
        gru_d = Path(__file__).resolve().parents[2] / "tests" / "fixtures" / "parity" / "gru_d.safetensors"
        train_intention.main(["--run-dir", str(tmp_path / "bad"), "--init-weights", str(gru_d)] + TINY)
    with pytest.raises(SystemExit, match="--init-weights .*missing.safetensors"):
        train_intention.main(["--run-dir", str(tmp_path / "bad2"), "--init-weights", str(tmp_path / "missing.safetensors")]
                             + TINY)


def test_discriminator_warmup_leaves_the_model(tmp_path, synthetic):
    """--d-warmup N: N iterations move the discriminators and not the model; the next one moves the model."""
    run(["--run-dir", str(tmp_path / "base"), "--iterations", "2"] + TINY)
    out = tmp_path / "base.safetensors"
    run(["--export", str(out), "--from", str(tmp_path / "base" / "last.pt"), "--dtype", "float32"])
    start = load_weights(out).state_dict()
    common = ["--init-weights", str(out), "--lr", "1e-2", "--d-warmup", "2"] + TINY
    warm = []
    for n in (1, 2):
        run(["--run-dir", str(tmp_path / f"warm{n}"), "--iterations", str(n)] + common)
        warm.append(torch.load(tmp_path / f"warm{n}" / "last.pt", weights_only=False))
        for k, v in start.items():
            torch.testing.assert_close(warm[-1]["model"][k], v, rtol=0, atol=0)
    assert any(not torch.equal(warm[1]["d_pose"][k], v) for k, v in warm[0]["d_pose"].items())
    run(["--run-dir", str(tmp_path / "on"), "--iterations", "3"] + common)
    moved = torch.load(tmp_path / "on" / "last.pt", weights_only=False)["model"]
    assert any(not torch.equal(moved[k], v) for k, v in start.items() if v.is_floating_point())


def test_context_windows_carry_their_rows_seed():
    seed = torch.arange(2 * 6 * 1, dtype=torch.float32).reshape(2, 6, 1)
    x = torch.randn(2, 9, 1)
    w, ctx = train_intention.with_context(train_intention.windows_of(x, 4, 3), seed, 2)
    assert w.shape == (4, 4, 1) and ctx.shape == (4, 2, 1)  # 2 windows per row
    for i in range(4):
        torch.testing.assert_close(ctx[i], seed[i // 2, -2:])
    assert train_intention.with_context(w, seed, 0)[1] is None


def test_r1_penalty_is_the_squared_input_gradient_of_a_linear_critic():
    torch.manual_seed(0)
    d = train_intention.PoseDiscriminator(3, 2, 4, context=2)
    lin = torch.nn.Linear(3 * 2 + 2 * 2 + 2 * 2, 1)
    d.net = lin  # D(x) = w·[window, changes, context] + b: the gradient is known in closed form
    w = lin.weight.detach()[0]
    windows, context = torch.randn(5, 3, 2), torch.randn(5, 2, 2)
    gw = w[:6].reshape(3, 2).clone()
    change = w[6:10].reshape(2, 2) * 5.0  # d/dx of the scaled frame-to-frame changes
    gw[1:] += change
    gw[:-1] -= change
    expected = gw.pow(2).sum() + w[10:].pow(2).sum()
    got = train_intention.r1_penalty(d, windows, context)
    torch.testing.assert_close(got, expected)


def test_context_r1_and_weight_average_run_resume_and_export_the_average(tmp_path, synthetic, monkeypatch):
    """--pose-context, --r1 and --ema: the run resumes exactly (average included) and the export is the average."""
    extra = ["--pose-context", "3", "--r1", "1", "--ema", "0.5"]
    run(["--run-dir", str(tmp_path / "full"), "--iterations", "3"] + TINY + extra)
    run_interrupted(monkeypatch, train_intention, "rec_loss", 3,
                    lambda: run(["--run-dir", str(tmp_path / "split"), "--iterations", "3"] + TINY + extra))
    run(["--run-dir", str(tmp_path / "split"), "--resume"])
    a = torch.load(tmp_path / "full" / "last.pt", weights_only=False)
    b = torch.load(tmp_path / "split" / "last.pt", weights_only=False)
    for key in ("model", "ema", "d_pose"):
        for k in a[key]:
            assert torch.equal(a[key][k], b[key][k]), (key, k)
    assert any(not torch.equal(a["ema"][k], v) for k, v in a["model"].items() if v.is_floating_point())
    records = [json.loads(line) for line in (tmp_path / "full" / "metrics.jsonl").read_text().splitlines()]
    assert all(r["r1"] >= 0 for r in records if r.get("kind") == "train")
    out = tmp_path / "avg.safetensors"
    run(["--export", str(out), "--from", str(tmp_path / "full" / "last.pt"), "--dtype", "float32"])
    model = load_weights(out)
    for k, v in a["ema"].items():
        torch.testing.assert_close(model.state_dict()[k], v, rtol=0, atol=0)
    assert "moving average" in model.provenance["weights"]
    with pytest.raises(SystemExit, match="pose-context"):
        train_intention.main(["--run-dir", str(tmp_path / "bad")] + TINY + ["--pose-context", "51"])
    for bad in (["--pose-context", "-1"], ["--r1", "-1"], ["--ema", "1"], ["--speed-weight", "-2"],
                ["--smooth-weight", "-1"], ["--root-weight", "-1"], ["--word-weight", "-1"]):
        with pytest.raises(SystemExit, match="must be"):
            train_intention.main(["--run-dir", str(tmp_path / "bad")] + TINY + bad)


def test_speed_term_is_logged_and_pulls_a_frozen_generator(tmp_path, synthetic):
    """--speed-weight: the term is logged, is positive for a model that does not move (its output layer zeroed:
    every generated frame equals the last seed frame, ratio 0 below the 0.8 band) and moves its weights."""
    run(["--run-dir", str(tmp_path / "base"), "--iterations", "1"] + TINY)
    ck = torch.load(tmp_path / "base" / "last.pt", weights_only=False)
    frozen = {k: (torch.zeros_like(v) if k.startswith("decoder.") else v) for k, v in ck["model"].items()}
    assert any(k.startswith("decoder.") for k in frozen)
    ck["model"] = frozen
    torch.save(ck, tmp_path / "base" / "last.pt")
    out = tmp_path / "frozen.safetensors"
    run(["--export", str(out), "--from", str(tmp_path / "base" / "last.pt"), "--dtype", "float32"])
    run(["--run-dir", str(tmp_path / "s"), "--iterations", "1", "--init-weights", str(out), "--speed-weight", "1",
         "--adv-weight", "0", "--lr", "1e-2"] + TINY)
    records = [json.loads(line) for line in (tmp_path / "s" / "metrics.jsonl").read_text().splitlines()]
    speeds = [r["speed"] for r in records if r.get("kind") == "train"]
    assert speeds and speeds[0] > 0.5  # (0.8 - 0)² for the speed, about as much for the acceleration, twice
    after = torch.load(tmp_path / "s" / "last.pt", weights_only=False)["model"]
    assert any(not torch.equal(after[k], v) for k, v in frozen.items() if k.startswith("decoder."))


def test_smooth_root_and_word_terms_are_logged(tmp_path, synthetic):
    """--smooth-weight, --root-weight and --word-weight: the roughness term (tests/test_kinematics.py), the
    root-speed term and the word-realism term (tests/test_word_realism.py) are logged, finite and non-negative, on
    the 4 s and the long-horizon frames."""
    run(["--run-dir", str(tmp_path / "s"), "--iterations", "2", "--smooth-weight", "10", "--root-weight", "1",
         "--word-weight", "1"] + TINY)
    records = [json.loads(line) for line in (tmp_path / "s" / "metrics.jsonl").read_text().splitlines()]
    for term in ("rough", "root", "word"):
        values = [r[term] for r in records if r.get("kind") == "train"]
        assert len(values) == 2 and all(np.isfinite(values)) and min(values) >= 0


def test_root_speed_term_sees_only_the_root_translation(monkeypatch):
    """long_horizon.root_speed_loss: zero for the truth, grows as the root translation slows (hinge: nothing
    inside the band), blind to the joint angles, and refuses a model whose first dims are not the root's."""
    monkeypatch.setattr(long_horizon, "MOTION_LOSS", ["hinge"])
    model = small_model()
    model.norm.set_stats(torch.zeros(99, dtype=torch.float64), torch.full((99,), 10.0, dtype=torch.float64))
    t = torch.linspace(0, 6, 40, dtype=torch.float64)
    truth = 1.0 + 0.3 * torch.sin(t[None, :, None] + torch.arange(model.output_size)[None, None, :])
    assert long_horizon.root_speed_loss(model, truth, truth).item() == 0.0
    losses = []
    for f in (0.9, 0.5, 0.1):
        slow = truth.clone()
        slow[..., :3] *= f
        losses.append(long_horizon.root_speed_loss(model, slow, truth).item())
    assert losses[0] == 0.0 < losses[1] < losses[2]
    angles = truth.clone()
    angles[..., 3:] = 0.0
    assert long_horizon.root_speed_loss(model, angles, truth).item() == 0.0
    model.norm.dims_used = torch.arange(1, model.output_size + 1)
    with pytest.raises(ValueError, match="root translation"):
        long_horizon.root_speed_loss(model, truth, truth)
