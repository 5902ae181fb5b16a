"""DAE-LSTM (Ghosh et al. 2017) training pieces: the model against a hand-written step loop, min-max scaling, the joint
dropout, the schedules, the speed term, and a smoke run of all three stages with exact resume and export."""

import numpy as np
import pytest
import torch

from training import data, train_dae
from training.export import load_weights
from training.export_fixtures import H36M_DIMS_USED
from training.models import DAELSTM, H36M_ACTIONS, make_config

from .helpers import run_interrupted, synthetic_dataset


def small_model(actions=True, seed=0):
    torch.manual_seed(seed)
    config = make_config("dae-lstm", hidden=8, layers=2, dims_used=H36M_DIMS_USED,
                         actions=list(H36M_ACTIONS) if actions else [], normalization="min-max", derivative_order=0,
                         dae_hidden=6, dae_layers=2)
    model = DAELSTM(config).double().eval()
    with torch.no_grad():
        for p in model.parameters():
            p.copy_(torch.rand(p.shape, dtype=p.dtype) - 0.5)
    return model


@pytest.mark.parametrize("actions", [True, False])
def test_closed_loop_equals_a_hand_written_step_loop(actions):
    model = small_model(actions)
    gen = torch.Generator().manual_seed(3)
    seed = torch.rand(2, 5, model.output_size, generator=gen, dtype=torch.float64)
    act = torch.tensor([0, 12]) if actions else None
    got = model.closed_loop(seed, 7, act)

    def step(x, state):
        if actions:
            x = torch.cat([x, torch.nn.functional.one_hot(act, len(H36M_ACTIONS)).double()], dim=-1)
        new = []
        for cell, s in zip(model.rnn, state):
            h, c = cell(x, s)
            new.append((h, c))
            x = h
        raw = model.decoder(x)
        return model.dae(raw), new  # the DAE filters every prediction

    state = [(torch.zeros(2, 8, dtype=torch.float64),) * 2 for _ in model.rnn]
    for t in range(seed.shape[1]):
        out, state = step(seed[:, t], state)
    want = [out]
    for _ in range(6):
        out, state = step(out, state)  # the filtered pose is fed back
        want.append(out)
    torch.testing.assert_close(got, torch.stack(want, dim=1), rtol=0, atol=1e-12)


def test_minmax_stats_scale_training_frames_to_unit_range():
    rng = np.random.default_rng(0)
    seqs = [rng.normal(size=(40, data.FRAME_DIMS)) * 3 + 1 for _ in range(3)]
    for s in seqs:
        s[:, 7] = 2.5  # constant: dropped
    stats = data.minmax_stats(seqs)
    assert 7 not in stats.dims_used and stats.std[7] == 1.0
    z = np.concatenate([stats.normalize(s) for s in seqs])
    assert z.min() == pytest.approx(0.0, abs=1e-12) and z.max() == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(stats.unnormalize(stats.normalize(seqs[1])), seqs[1], atol=1e-12)


def test_drop_joints_removes_whole_joints():
    model = small_model()
    pose = torch.rand(200, model.output_size, dtype=torch.float64) + 1.0  # no zeros of its own
    assert torch.equal(model.drop_joints(pose, 0.0), pose)
    assert torch.count_nonzero(model.drop_joints(pose, 1.0)) == 0
    dropped = model.drop_joints(pose, 0.3, torch.Generator().manual_seed(0))
    zero = dropped == 0
    for group in model.groups:  # a joint's dims go together
        assert (zero[:, group].all(dim=1) == zero[:, group].any(dim=1)).all()
    frac = np.mean([zero[:, g[0]].double().mean().item() for g in model.groups])
    assert 0.2 < frac < 0.4
    kept = ~zero
    assert torch.equal(dropped[kept], pose[kept])


def test_schedules_rise_in_pretraining_and_anneal_to_zero_in_finetune():
    assert train_dae.stage_schedules("dae", 0.0) == (0.01, 0.01)
    assert train_dae.stage_schedules("dae", 0.99) == (0.1, 0.1)
    assert train_dae.stage_schedules("finetune", 0.0) == (0.1, 0.1)
    assert train_dae.stage_schedules("finetune", 0.99) == (0.0, 0.0)
    drops = [train_dae.stage_schedules("dae", f / 100)[0] for f in range(100)]
    assert drops == sorted(drops) and set(drops) == set(train_dae.DROP_SCHEDULE)


def test_speed_term_is_zero_for_the_truth_and_grows_when_the_motion_stops(monkeypatch):
    # the form under test (a trainer run earlier in the session may have set another)
    monkeypatch.setattr(train_dae.long_horizon, "MOTION_LOSS", ["log"])
    model = small_model()
    model.norm.set_stats(torch.zeros(model.frame_dims, dtype=torch.float64),
                         torch.ones(model.frame_dims, dtype=torch.float64))
    t = torch.linspace(0, 6, 50, dtype=torch.float64)
    truth = 0.5 + 0.3 * torch.sin(t[None, :, None] + torch.arange(model.output_size)[None, None, :])
    assert train_dae.speed_loss(model, truth, truth).item() == pytest.approx(0.0, abs=1e-15)
    frozen = truth[:, :1].expand_as(truth)
    slow = truth[:, :1] + 0.5 * (truth - truth[:, :1])
    fast = truth[:, :1] + 2.0 * (truth - truth[:, :1])
    l_frozen, l_slow, l_fast = (train_dae.speed_loss(model, p, truth).item() for p in (frozen, slow, fast))
    assert l_frozen > l_slow > 0
    assert l_slow == pytest.approx(l_fast, rel=0.1)  # log ratio: half as fast ~ twice as fast
    # only the joint angles count: moving the root dims alone does not change it
    root = truth.clone()
    root[..., :6] += torch.linspace(0, 1, 50, dtype=torch.float64)[None, :, None]
    assert train_dae.speed_loss(model, root, truth).item() == pytest.approx(0.0, abs=1e-15)


def test_accel_term_tells_jitter_from_smooth_motion():
    model = small_model()
    model.norm.set_stats(torch.zeros(model.frame_dims, dtype=torch.float64),
                         torch.ones(model.frame_dims, dtype=torch.float64))
    t = torch.linspace(0, 6, 60, dtype=torch.float64)
    truth = 0.5 + 0.3 * torch.sin(t[None, :, None] + torch.arange(model.output_size)[None, None, :])
    step = (truth[:, 1:] - truth[:, :-1]).abs().mean()
    sign = torch.tensor([(-1.0) ** i for i in range(60)], dtype=torch.float64)[None, :, None]
    jitter = 0.5 + 0.5 * step * sign.expand_as(truth)  # about the same speed, all of it back and forth
    assert train_dae.accel_loss(model, truth, truth).item() == pytest.approx(0.0, abs=1e-15)
    assert train_dae.accel_loss(model, jitter, truth).item() > 1.0


def test_long_term_follows_the_closed_loop_and_cuts_the_gradient_at_the_burn_in():
    model = small_model().train()
    gen = torch.Generator().manual_seed(4)
    frames = torch.rand(2, 20, model.output_size, generator=gen, dtype=torch.float64)
    act = torch.tensor([1, 2])
    loss = train_dae.long_motion_loss(model, frames, act, seed=5, burn_in=6, length=4)
    loss.backward()
    assert torch.isfinite(loss) and model.decoder.weight.grad.abs().sum() > 0
    # the frames it scores are the closed loop's frames 6..10 after the seed
    with torch.no_grad():
        pred = model.closed_loop(frames[:, :5], 11, act)
        want = train_dae.speed_loss(model, pred[:, 6:11], frames[:, 11:16]) + train_dae.accel_loss(
            model, pred[:, 6:11], frames[:, 11:16])
        got = train_dae.long_motion_loss(model, frames, act, seed=5, burn_in=6, length=4)
    torch.testing.assert_close(got, want, rtol=1e-12, atol=1e-12)


TINY = ["--hidden", "8", "--layers", "2", "--dae-hidden", "6", "--dae-layers", "2", "--batch", "2", "--window", "12",
        "--log-every", "1", "--val-every", "2", "--checkpoint-every", "1", "--val-per-action", "1"]
FINETUNE = ["--closed-loop-weight", "1", "--closed-loop-seed", "4", "--closed-loop-horizon", "8",
            "--speed-weight", "0.5", "--long-weight", "0.2", "--long-burn-in", "3", "--long-frames", "4"]


@pytest.fixture
def synthetic(monkeypatch):
    ts, wins = synthetic_dataset(scaling="min-max")
    monkeypatch.setattr(data, "load_training_set", lambda *a, **k: ts)
    monkeypatch.setattr(data, "validation_windows", lambda *a, **k: wins)
    return ts


def run(argv):
    assert train_dae.main(argv) == 0


def test_three_stages_resume_exactly_and_export(tmp_path, synthetic, monkeypatch):
    run(["--stage", "dae", "--run-dir", str(tmp_path / "dae"), "--iterations", "2"] + TINY)
    run(["--stage", "lstm", "--run-dir", str(tmp_path / "lstm"), "--iterations", "2"] + TINY)
    init = ["--init-dae", str(tmp_path / "dae" / "last.pt"), "--init-lstm", str(tmp_path / "lstm" / "last.pt")]
    run(["--stage", "finetune", "--run-dir", str(tmp_path / "full"), "--iterations", "3"] + TINY + FINETUNE + init)
    # the same run interrupted during its third iteration (last.pt holds iteration 2), then resumed
    run_interrupted(monkeypatch, train_dae, "closed_loop_loss", 3, lambda: run(
        ["--stage", "finetune", "--run-dir", str(tmp_path / "split"), "--iterations", "3"] + TINY + FINETUNE + init))
    assert torch.load(tmp_path / "split" / "last.pt", weights_only=False)["iteration"] == 2
    run(["--stage", "finetune", "--run-dir", str(tmp_path / "split"), "--resume"])
    a = torch.load(tmp_path / "full" / "last.pt", weights_only=False)
    b = torch.load(tmp_path / "split" / "last.pt", weights_only=False)
    assert a["iteration"] == b["iteration"] == 3
    for k in a["model"]:
        assert torch.equal(a["model"][k], b["model"][k]), k
    # the finetune starts from both pre-trained stages
    dae = torch.load(tmp_path / "dae" / "last.pt", weights_only=False)["model"]
    lstm = torch.load(tmp_path / "lstm" / "last.pt", weights_only=False)["model"]
    assert not torch.equal(dae["dae.layers.0.weight"], lstm["dae.layers.0.weight"])
    best = torch.load(tmp_path / "full" / "best.pt", weights_only=False)
    assert set(best["best"]["long_speed"]) == {w.action for w in data.validation_windows()}

    out = tmp_path / "w.safetensors"
    run(["--export", str(out), "--from", str(tmp_path / "full" / "best.pt")])
    model = load_weights(out)
    assert model.config["architecture"] == "dae-lstm" and model.config["normalization"] == "min-max"
    trained = train_dae.model_from_checkpoint(best)
    for k, v in trained.state_dict().items():
        torch.testing.assert_close(model.state_dict()[k], v, rtol=0, atol=0)
    with pytest.raises(SystemExit, match="finetune"):
        train_dae.main(["--export", str(tmp_path / "x.safetensors"), "--from", str(tmp_path / "dae" / "last.pt")])


def test_freeze_dae_keeps_the_autoencoder_and_trains_the_rest(tmp_path, synthetic):
    run(["--stage", "dae", "--run-dir", str(tmp_path / "dae"), "--iterations", "2"] + TINY)
    run(["--stage", "lstm", "--run-dir", str(tmp_path / "lstm"), "--iterations", "2"] + TINY)
    init = ["--init-dae", str(tmp_path / "dae" / "last.pt"), "--init-lstm", str(tmp_path / "lstm" / "last.pt")]
    run(["--stage", "finetune", "--run-dir", str(tmp_path / "ft"), "--iterations", "2", "--freeze-dae"]
        + TINY + FINETUNE + init)
    dae = torch.load(tmp_path / "dae" / "last.pt", weights_only=False)["model"]
    lstm = torch.load(tmp_path / "lstm" / "last.pt", weights_only=False)["model"]
    ft = torch.load(tmp_path / "ft" / "last.pt", weights_only=False)["model"]
    for k in ft:
        if k.startswith("dae."):
            assert torch.equal(ft[k], dae[k]), k
    assert not torch.equal(ft["rnn.0.weight_ih"], lstm["rnn.0.weight_ih"])


def test_bad_arguments_are_refused(tmp_path, synthetic):
    with pytest.raises(SystemExit, match="exceed"):
        train_dae.main(["--stage", "finetune", "--run-dir", str(tmp_path / "a"), "--closed-loop-weight", "1",
                        "--closed-loop-seed", "10", "--closed-loop-horizon", "10"] + TINY)
    with pytest.raises(SystemExit, match="closed-loop"):
        train_dae.main(["--stage", "finetune", "--run-dir", str(tmp_path / "b"), "--speed-weight", "1"] + TINY)
    with pytest.raises(SystemExit, match="init"):
        train_dae.main(["--stage", "finetune", "--run-dir", str(tmp_path / "c")] + TINY)


def test_hinge_motion_loss_is_zero_in_band_and_bounded_at_a_frozen_prediction():
    truth = torch.tensor([0.02, 0.05])
    assert train_dae.ratio_loss(truth * 1.2, truth, "hinge").item() == 0.0
    frozen = torch.full_like(truth, train_dae.SPEED_FLOOR).requires_grad_(True)
    train_dae.ratio_loss(frozen, truth, "hinge").backward()
    hinge_grad = frozen.grad.abs().max().item()
    frozen_log = torch.full_like(truth, train_dae.SPEED_FLOOR).requires_grad_(True)
    train_dae.ratio_loss(frozen_log, truth, "log").backward()
    # The log form's gradient at a frozen prediction is ~1/floor; the hinge's ~1/truth.
    assert hinge_grad < 0.1 * frozen_log.grad.abs().max().item()
    assert train_dae.ratio_loss(truth * 0.5, truth, "hinge").item() == pytest.approx(0.3**2, rel=1e-5)


def test_identity_filter_gives_the_bare_lstm_exactly():
    model = small_model()
    model.eval()
    bare = train_dae.identity_filter(model).double().eval()
    assert bare.config["dae_layers"] == 1 and bare.config["dae_hidden"] == 2 * model.output_size
    gen = torch.Generator().manual_seed(5)
    seed = torch.rand(2, 5, model.output_size, generator=gen, dtype=torch.float64) * 4 - 2  # negatives too
    act = torch.tensor([1, 3])
    model.filter_enabled = False
    torch.testing.assert_close(bare.closed_loop(seed, 6, act), model.closed_loop(seed, 6, act), rtol=0, atol=1e-12)


def test_input_drop_corrupts_the_lstm_inputs_by_whole_joints(monkeypatch):
    model = small_model()
    seen = []
    monkeypatch.setattr(model, "open_loop_raw", lambda x, a: seen.append(x) or x)
    frames = torch.rand(3, 6, model.output_size, dtype=torch.float64) + 1.0
    train_dae.sequence_losses(model, frames, None, "lstm", 0.5, 0.0, input_drop=False)
    train_dae.sequence_losses(model, frames, None, "lstm", 0.5, 0.0, input_drop=True)
    assert torch.equal(seen[0], frames[:, :-1])
    zeroed = seen[1] == 0
    assert zeroed.any() and not zeroed.all()
    for group in model.groups:  # a joint is dropped with all its dims or not at all
        g = zeroed[..., group]
        assert torch.equal(g.all(-1), g.any(-1))


def test_drop_and_noise_scales_multiply_their_schedules():
    assert train_dae.stage_schedules("dae", 0.99, 3.0)[0] == pytest.approx(0.3)
    assert train_dae.stage_schedules("dae", 0.99) == pytest.approx((0.1, 0.1))
    assert train_dae.stage_schedules("lstm", 0.99, 1.0, 0.1)[1] == pytest.approx(0.01)
    assert train_dae.stage_schedules("finetune", 0.0, 1.0, 0.1)[1] == pytest.approx(0.01)


def test_the_ablation_trains_every_stage_after_the_stages_it_starts_from():
    from training import dae_ablation
    order = dae_ablation.stage_order()
    for i, name in enumerate(order):
        for parent in dae_ablation.STAGES[name][1]:
            assert order.index(parent) < i, (name, parent)
    for lstm, ft in dae_ablation.VARIANTS.values():
        assert lstm in order and ft in order


def test_standard_scaling_trains_and_the_finetune_refuses_mixed_scalings(tmp_path, synthetic):
    run(["--stage", "dae", "--run-dir", str(tmp_path / "dae"), "--iterations", "1"] + TINY)
    run(["--stage", "lstm", "--run-dir", str(tmp_path / "lstm"), "--iterations", "1", "--scaling", "standard",
         "--input-drop"] + TINY)
    lstm = torch.load(tmp_path / "lstm" / "last.pt", weights_only=False)
    assert lstm["config"]["normalization"] == "standard"
    out = tmp_path / "raw.safetensors"
    run(["--export", str(out), "--from", str(tmp_path / "lstm" / "last.pt"), "--raw"])
    assert load_weights(out).config["dae_layers"] == 1
    init = ["--init-dae", str(tmp_path / "dae" / "last.pt"), "--init-lstm", str(tmp_path / "lstm" / "last.pt")]
    with pytest.raises(SystemExit, match="different scalings"):
        train_dae.main(["--stage", "finetune", "--run-dir", str(tmp_path / "ft"), "--iterations", "1"] + TINY + init)
