"""Training loop (training/train.py): schedules, a tiny smoke run on synthetic data, exact resume, rollback, export.

Synthetic data (smooth random walks shaped like H3.6M frames) keeps these tests independent of the dataset and fast.
"""

import argparse

import numpy as np
import pytest
import torch

from training import data, long_horizon, train
from training.export import load_weights

from .helpers import synthetic_dataset


SMALL = ["--hidden", "8", "--plan-hidden", "4", "--batch", "2", "--log-every", "1", "--val-every", "2"]
SMALL += ["--seed-frames", "6", "--horizon", "8"]


def run(tmp, extra, ds, quiet=True):
    argv = ["--run-dir", str(tmp)] + SMALL + extra
    args = train.build_parser().parse_args(argv)
    return train.train(args, argv, dataset=ds[0], val_windows=ds[1], quiet=quiet)


def test_lambda_schedule():
    assert [train.lambda_at(i) for i in (1, 499, 500, 999, 1000, 1999, 2000, 4000, 6999, 7000, 10000)] == [
        0.0, 0.0, 0.2, 0.2, 0.4, 0.4, 0.6, 0.8, 0.8, 1.0, 1.0
    ]
    assert train.lambda_at(250, 0.5) == 0.2 and train.lambda_at(249, 0.5) == 0.0 and train.lambda_at(3500, 0.5) == 1.0


def test_lr_schedule():
    assert train.lr_at(1, 2e-4, 0.6, 2000) == 2e-4
    assert train.lr_at(2000, 2e-4, 0.6, 2000) == 2e-4
    assert train.lr_at(2001, 2e-4, 0.6, 2000) == pytest.approx(1.2e-4)
    assert train.lr_at(10000, 2e-4, 0.6, 2000) == pytest.approx(2e-4 * 0.6**4)


def test_smoke_train_resume_is_exact_and_export_loads(tmp_path):
    ds = synthetic_dataset()
    extra = ["--iterations", "3", "--checkpoint-every", "1", "--schedule-scale", "0.004"]  # lambda > 0 from it 2
    full = run(tmp_path / "full", extra, ds)
    assert full["iteration"] == 3 and np.isfinite(full["ol"]) and np.isfinite(full["cl"])

    run(tmp_path / "split", ["--iterations", "2", "--checkpoint-every", "1", "--schedule-scale", "0.004"], ds)
    resumed = run(tmp_path / "split", ["--resume", "--iterations", "3"], ds)
    assert resumed["iteration"] == 3
    assert resumed["ol"] == full["ol"] and resumed["cl"] == full["cl"]
    a = torch.load(tmp_path / "full" / "last.pt", weights_only=False)["model"]
    b = torch.load(tmp_path / "split" / "last.pt", weights_only=False)["model"]
    for k in a:
        assert torch.equal(a[k], b[k]), k
    assert (tmp_path / "full" / "best.pt").is_file()

    for dtype in ("float32", "float16"):
        out = tmp_path / f"w_{dtype}.safetensors"
        argv = ["--export", str(out), "--from", str(tmp_path / "full" / "best.pt"), "--dtype", dtype]
        assert train.main(argv) == 0
        model = load_weights(out)
        assert model.config["architecture"] == "vgru-d" and model.config["residual"] is True
        assert model.provenance["iterations"] >= 2 and "best_validation" in model.provenance
        ref = torch.load(tmp_path / "full" / "best.pt", weights_only=False)["model"]
        tol = 0 if dtype == "float32" else 1e-2
        for k, v in model.state_dict().items():
            assert torch.allclose(v, ref[k].float(), atol=tol, rtol=tol), k


def test_gru_d_and_auto_conditioning_run(tmp_path):
    ds = synthetic_dataset(1)
    r = run(tmp_path / "g", ["--model", "gru-d", "--iterations", "2", "--schedule-scale", "0.002"], ds)
    assert r["iteration"] == 2 and np.isfinite(r["cl"])
    r = run(tmp_path / "ac", ["--loss", "auto-conditioning", "--iterations", "2"], ds)
    assert r["iteration"] == 2 and np.isfinite(r["ol"])


def test_blow_up_rolls_back_and_halves_lr(tmp_path, monkeypatch):
    monkeypatch.setattr(train, "MIN_HISTORY", 1)
    ds = synthetic_dataset(2)
    # any closed-loop loss above 1e-9 x the median counts as a blow-up once lambda > 0 and one loss is recorded
    with pytest.raises(SystemExit, match="rollbacks"):
        run(
            tmp_path / "b",
            ["--iterations", "6", "--schedule-scale", "0.002", "--blowup-factor", "1e-9", "--max-rollbacks", "3"],
            ds,
        )
    log = (tmp_path / "b" / "train.log").read_text()
    assert log.count("BLOW-UP") == 4 and "lr scale now 0.125" in log


def test_explicit_args_detects_given_flags():
    assert train.explicit_args(["--run-dir", "x", "--iterations", "5", "--resume"]) == {"run_dir", "iterations", "resume"}
    assert isinstance(train.build_parser().parse_args([]), argparse.Namespace)


def test_evaluate_cli_scores_an_exported_file(tmp_path, capsys):
    import json
    import sys

    from training import evaluate

    if not (data.default_dataset_dir() / "S5").is_dir():
        print("SKIPPED: H3.6M data not found (set MOTION_DATA_DIR)", file=sys.stderr)
        pytest.skip("H3.6M data not found")
    ds = synthetic_dataset(3)
    run(tmp_path / "e", ["--iterations", "1"], ds)
    out = tmp_path / "e.safetensors"
    assert train.main(["--export", str(out), "--from", str(tmp_path / "e" / "last.pt"), "--dtype", "float32"]) == 0
    capsys.readouterr()
    assert evaluate.main(["--weights", str(out), "--json", "--val-per-action", "1"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert set(res) == {"model", "zero_velocity", "windows"} and len(res["model"]["per_action"]) == 13
    assert evaluate.main(["--weights", str(tmp_path / "missing.safetensors")]) == 2
    # a checkpoint sweep: the checkpoint and its f32 export score the same on the same windows
    ckpt = str(tmp_path / "e" / "last.pt")
    capsys.readouterr()
    assert evaluate.main(["--weights", str(out), ckpt, "--json", "--val-per-action", "1"]) == 0
    sweep = json.loads(capsys.readouterr().out)["models"]
    assert abs(sweep[str(out)]["npss_ref"] - sweep[ckpt]["npss_ref"]) < 1e-9
    assert evaluate.main(["--weights", str(out), ckpt, "--val-per-action", "1"]) == 0
    assert "pick (lowest mean reference NPSS)" in capsys.readouterr().out


def test_ema_branch_and_export_use_the_average(tmp_path):
    ds = synthetic_dataset()
    sched = ["--schedule-scale", "0.004", "--checkpoint-every", "1"]
    run(tmp_path / "parent", ["--iterations", "2"] + sched, ds)
    # the branch continues the parent's iteration count (so its schedules), with its own settings
    out = run(tmp_path / "child", ["--iterations", "4", "--ema", "0.5", "--branch-from",
                                   str(tmp_path / "parent" / "last.pt")] + sched, ds)
    assert out["iteration"] == 4
    ck = torch.load(tmp_path / "child" / "last.pt", weights_only=False)
    assert ck["parent"]["iteration"] == 2 and ck["ema"] is not None
    # the average differs from the raw weights after training steps, and lags them
    raw, avg = ck["model"], ck["ema"]
    assert any(not torch.equal(raw[k], avg[k]) for k in raw)
    assert "raw_npss_ref" in ck["state"]["best"]
    out_file = tmp_path / "w.safetensors"
    assert train.main(["--export", str(out_file), "--from", str(tmp_path / "child" / "last.pt"), "--dtype", "float32"]) == 0
    model = load_weights(out_file)
    sd = model.state_dict()
    for k in avg:
        if k in sd:
            assert torch.allclose(sd[k].float(), avg[k].float()), k
    assert model.provenance["branched_from"]["iteration"] == 2
    # resuming the branch keeps its average; a second branch into an existing run dir is refused
    resumed = run(tmp_path / "child", ["--resume", "--iterations", "5"], ds)
    assert resumed["iteration"] == 5
    with pytest.raises(SystemExit, match="exists"):
        run(tmp_path / "child", ["--iterations", "6", "--branch-from", str(tmp_path / "parent" / "last.pt")], ds)


def test_branch_fine_tunes_a_multi_action_model_on_one_action(tmp_path, monkeypatch):
    ds = synthetic_dataset()
    sched = ["--schedule-scale", "0.004", "--checkpoint-every", "1"]
    run(tmp_path / "parent", ["--iterations", "2"] + sched, ds)
    walking = data.TrainingSet(actions=("walking",), stats=ds[0].stats,
                               by_action=[ds[0].by_action[data.ACTIONS.index("walking")]])
    wins = [data.ValidationWindow(action="walking", subaction=1, start=0, frames=ds[1][0].frames)]
    argv = ["--run-dir", str(tmp_path / "walk")] + SMALL + ["--iterations", "4", "--actions", "walking",
                                                          "--branch-from", str(tmp_path / "parent" / "last.pt")] + sched
    args = train.build_parser().parse_args(argv)
    labels = []
    real_terms = train.multi_objective_terms
    def spy(model, frames, actions, *a):
        labels.append(actions.clone())
        return real_terms(model, frames, actions, *a)
    monkeypatch.setattr(train, "multi_objective_terms", spy)
    out = train.train(args, argv, dataset=walking, val_windows=wins, quiet=True)
    assert out["iteration"] == 4 and labels
    # the one-hot the model sees is walking's index among its 15 labels, not the dataset's index 0
    assert all((l == data.ACTIONS.index("walking")).all() for l in labels)
    ck = torch.load(tmp_path / "walk" / "last.pt", weights_only=False)
    assert ck["config"]["actions"] == list(data.ACTIONS)  # still the 15-label model
    assert list(ck["state"]["best"]["per_action"]) == ["walking"]
    # a model conditioned on walking alone cannot be fine-tuned on smoking
    run(tmp_path / "walk_only", ["--iterations", "1", "--actions", "walking"], (walking, wins))
    smoke_wins = [data.ValidationWindow(action="smoking", subaction=1, start=0, frames=ds[1][0].frames)]
    with pytest.raises(SystemExit, match="conditioned"):
        run(tmp_path / "bad", ["--iterations", "3", "--actions", "smoking", "--branch-from",
                               str(tmp_path / "walk_only" / "last.pt")], (ds[0], smoke_wins))


@pytest.mark.parametrize("flag", ["--spectral-weight", "--spectral-balance"])
def test_spectral_term_trains_and_logs_the_closed_loop_npss(tmp_path, flag):
    import json

    ds = synthetic_dataset()
    out = run(tmp_path / "spec", ["--iterations", "3", "--schedule-scale", "0.004", flag, "0.5"], ds)
    assert out["iteration"] == 3
    recs = [json.loads(l) for l in open(tmp_path / "spec" / "metrics.jsonl")]
    spec = [r["spectral"] for r in recs if r["kind"] == "train" and "spectral" in r]
    assert spec and all(np.isfinite(spec)) and all(0 < v < 10 for v in spec)
    # the balanced variant logs the weight it ended up using
    ws = [r["spectral_weight"] for r in recs if r["kind"] == "train" and "spectral_weight" in r]
    assert (len(ws) > 0) == (flag == "--spectral-balance") and all(np.isfinite(ws)) and all(w > 0 for w in ws)


def test_spectral_weight_and_balance_together_are_refused():
    assert train.main(["--spectral-weight", "0.1", "--spectral-balance", "0.5"]) == 2


def test_branch_from_a_file_that_is_not_a_checkpoint_is_a_clear_error(tmp_path):
    ds = synthetic_dataset()
    bad = tmp_path / "not_a_checkpoint.pt"
    bad.write_bytes(b"hello")
    with pytest.raises(SystemExit, match="not a training checkpoint"):
        run(tmp_path / "child", ["--iterations", "1", "--branch-from", str(bad)], ds)
    assert not (tmp_path / "child" / "last.pt").exists()
    with pytest.raises(SystemExit):
        train.build_parser().parse_args(["--val-stride", "0"])


def test_balanced_backward_scales_the_spectral_gradient_to_the_ratio():
    torch.manual_seed(0)
    model = torch.nn.Sequential(torch.nn.Linear(4, 3), torch.nn.Tanh(), torch.nn.Linear(3, 2))
    x = torch.randn(5, 4)
    y = model(x)
    mse, spec = (y ** 2).mean(), 30.0 * y[:, 0].sin().sum()
    params = list(model.parameters())
    g_mse = torch.autograd.grad(mse, params, retain_graph=True)
    g_spec = torch.autograd.grad(spec, params, retain_graph=True)
    w = train.balanced_backward(model, mse, spec, 0.3)
    norm = lambda gs: float(torch.sqrt(sum((g ** 2).sum() for g in gs)))
    assert abs(w * norm(g_spec) - 0.3 * norm(g_mse)) < 1e-6 * norm(g_mse)
    for p, a, b in zip(params, g_mse, g_spec):
        assert torch.allclose(p.grad, a + w * b, atol=1e-7)


def test_ema_start_makes_the_average_follow_the_weights_until_then(tmp_path):
    ds = synthetic_dataset()
    for start, same in ((100, True), (0, False)):
        run(tmp_path / f"s{start}", ["--iterations", "3", "--ema", "0.9", "--ema-start", str(start)], ds)
        ck = train.load_checkpoint(tmp_path / f"s{start}" / "last.pt")
        equal = all(torch.equal(ck["ema"][k], v) for k, v in ck["model"].items())
        assert equal == same


def test_export_of_several_checkpoints_writes_the_mean_of_their_weights(tmp_path):
    ds = synthetic_dataset()
    sched = ["--schedule-scale", "0.004", "--checkpoint-every", "1"]
    run(tmp_path / "parent", ["--iterations", "2"] + sched, ds)
    parent = str(tmp_path / "parent" / "last.pt")
    for name, seed in (("a", "5"), ("b", "6")):
        run(tmp_path / name, ["--iterations", "3", "--seed", seed, "--branch-from", parent] + sched, ds)
    files = [str(tmp_path / n / "last.pt") for n in ("a", "b")]
    out = tmp_path / "soup.safetensors"
    assert train.main(["--export", str(out), "--from", *files, "--dtype", "float32"]) == 0
    model = load_weights(out)
    wa, wb = (torch.load(f, weights_only=False)["model"] for f in files)
    assert any(not torch.equal(wa[k], wb[k]) for k in wa)
    sd = model.state_dict()
    for k in wa:
        if k in sd:
            assert torch.allclose(sd[k].float(), (wa[k].double() + wb[k].double()).div(2).float(), atol=1e-7), k
    prov = model.provenance
    assert [a["checkpoint"] for a in prov["averaged"]] == files and "best_validation" not in prov
    assert prov["averaged"][0]["branched_from"]["iteration"] == 2
    # checkpoints of different models cannot be averaged: a one-line error naming the file, exit 2
    run(tmp_path / "wide", ["--iterations", "1", "--hidden", "12"] + sched, ds)
    other = str(tmp_path / "wide" / "last.pt")
    assert train.main(["--export", str(tmp_path / "bad.safetensors"), "--from", files[0], other]) == 2
    assert not (tmp_path / "bad.safetensors").exists()
    # nor with a file that is not a checkpoint
    junk = tmp_path / "junk.pt"
    junk.write_bytes(b"junk")
    assert train.main(["--export", str(tmp_path / "bad.safetensors"), "--from", files[0], str(junk)]) == 2
    assert not (tmp_path / "bad.safetensors").exists()


def test_init_weights_fine_tune_with_the_long_horizon_options(tmp_path):
    """--init-weights starts from an exported file (lr 0: the weights stay the file's); the closed-loop weight,
    fed-back noise, speed term and the long checkpoint choice run and are logged."""
    ds = synthetic_dataset()
    run(tmp_path / "parent", ["--iterations", "2"], ds)
    weights = tmp_path / "parent.safetensors"
    argv = ["--export", str(weights), "--from", str(tmp_path / "parent" / "last.pt"), "--dtype", "float32"]
    assert train.main(argv) == 0
    extra = ["--init-weights", str(weights), "--iterations", "2", "--lr", "0", "--closed-loop-weight", "1",
             "--feed-noise", "0.05", "--speed-weight", "0.5", "--choose", "long",
             "--long-weight", "0.5", "--long-burn-in", "3", "--long-frames", "4", "--long-batch", "2", "--device", "cpu"]
    out = run(tmp_path / "child", extra, ds)
    assert out["iteration"] == 2 and np.isfinite(out["cl"])
    start = load_weights(weights).state_dict()
    end = torch.load(tmp_path / "child" / "last.pt", weights_only=False)["model"]
    for k in start:
        assert torch.equal(start[k], end[k]), k
    records = [__import__("json").loads(line) for line in open(tmp_path / "child" / "metrics.jsonl")]
    assert any("motion" in r and "long" in r for r in records if r.get("kind") == "train")
    vals = [r for r in records if r.get("kind") == "val"]
    assert vals and all(set(r["long_speed"]) == {w.action for w in ds[1]} for r in vals)
    with pytest.raises(SystemExit, match="init-weights"):
        run(tmp_path / "bad", ["--init-weights", str(tmp_path / "missing.safetensors")], ds)


def test_feed_noise_changes_only_the_training_closed_loop():
    torch.manual_seed(0)
    config = train.model_config(train.build_parser().parse_args(SMALL + ["--model", "gru-d"]), list(range(54)))
    model = train.build_model(config, dropout=0.0).eval()
    seed = torch.randn(2, 6, 54)
    clean = model.closed_loop(seed, 5)
    assert torch.equal(clean, model.closed_loop(seed, 5, feed_noise=0.0))
    noisy = model.closed_loop(seed, 5, feed_noise=0.5)
    assert torch.equal(clean[:, 0], noisy[:, 0])  # the first prediction reads only the seed
    assert not torch.allclose(clean[:, 1:], noisy[:, 1:])


def test_long_motion_loss_is_zero_for_the_truth_and_reaches_the_weights():
    """The long term compares speed and acceleration only: a model whose closed loop reproduces the truth scores
    0; its gradient reaches the decoder through the frames after the burn-in."""
    torch.manual_seed(1)
    config = train.model_config(train.build_parser().parse_args(SMALL + ["--model", "vgru-d"]), list(range(54)))
    config["actions"] = ["walking"]
    model = train.build_model(config, dropout=0.0)
    model.norm.set_stats(torch.zeros(99), torch.ones(99))
    frames = torch.cumsum(0.05 * torch.randn(2, 6 + 20 + 5 + 1, 54), dim=1)
    loss = long_horizon.long_motion_loss(model, frames, torch.zeros(2, dtype=torch.long), 6, 20, 5)
    loss.backward()
    assert loss.item() > 0 and model.decoder.weight.grad.abs().sum() > 0
    assert long_horizon.speed_loss(model, frames, frames).item() == 0.0
