"""VGRU-d and GRU-d: open/closed loop consistency, dropout, noise, parameter counts."""

import pytest
import torch

from training.export_fixtures import H36M_DIMS_USED
from training.models import GRUD, VGRUD, build_model, make_config, parameter_count

SMALL = {"hidden": 12, "seed_frames": 6, "horizon": 9}


def small_models():
    torch.manual_seed(0)
    return [
        VGRUD(make_config("vgru-d", H36M_DIMS_USED, plan_hidden=4, **SMALL)),
        VGRUD(make_config("vgru-d", H36M_DIMS_USED, plan_hidden=4, residual=True, **SMALL)),
        GRUD(make_config("gru-d", H36M_DIMS_USED, **SMALL)),
        GRUD(make_config("gru-d", H36M_DIMS_USED, residual=True, gru_convention="paper", **SMALL)),
    ]


def _args(model, batch):
    if isinstance(model, VGRUD):
        return {"action": "walking", "eps": torch.randn(batch, model.plan_size)}
    return {}


@pytest.mark.parametrize("model", small_models(), ids=["vgru", "vgru-res", "gru", "gru-res"])
def test_closed_loop_equals_open_loop_on_its_own_outputs(model):
    model.eval()
    seed_len, horizon = 6, 9
    seed = torch.randn(2, seed_len, 54)
    args = _args(model, 2)
    with torch.no_grad():
        seed_out, generated = model.closed_loop(seed, horizon, return_seed_outputs=True, **args)
        fed = torch.cat([seed, generated[:, :-1]], dim=1)
        open_out = model.open_loop(fed, plan_steps=seed_len + horizon, **args)
    assert generated.shape == (2, horizon, 54)
    assert torch.equal(seed_out[:, -1], generated[:, 0])
    torch.testing.assert_close(open_out[:, :seed_len], seed_out, rtol=0, atol=1e-6)
    torch.testing.assert_close(open_out[:, seed_len - 1 :], generated, rtol=0, atol=1e-6)


def test_dropout_only_in_training():
    model = small_models()[0]
    x = torch.randn(2, 8, 54)
    eps = torch.zeros(4)
    model.train()
    assert not torch.equal(model.open_loop(x, "eating", eps), model.open_loop(x, "eating", eps))
    model.eval()
    assert torch.equal(model.open_loop(x, "eating", eps), model.open_loop(x, "eating", eps))


def test_vgru_noise_and_action_change_the_future():
    model = small_models()[0].eval()
    with torch.no_grad():
        model.plan.sigma.fill_(1.0)
    seed = torch.randn(1, 6, 54)
    base = model.closed_loop(seed, 5, "walking", torch.zeros(4))
    assert torch.equal(base, model.closed_loop(seed, 5, "walking", torch.zeros(4)))
    assert not torch.allclose(base, model.closed_loop(seed, 5, "walking", torch.ones(4)))
    assert not torch.allclose(base, model.closed_loop(seed, 5, "eating", torch.zeros(4)))
    assert not torch.equal(model.closed_loop(seed, 5, "walking"), model.closed_loop(seed, 5, "walking"))


def test_guides_are_plan_outputs_reversed():
    model = small_models()[0].eval()
    action = torch.tensor([3])
    eps = torch.randn(4)
    guides = model.plan.guides(action, 5, eps, torch.zeros(1))
    h = model.plan.mu + torch.sqrt(torch.nn.functional.softplus(model.plan.sigma)) * eps
    onehot = torch.nn.functional.one_hot(action, 15).float()
    outputs = []
    for _ in range(5):
        h = model.plan.cell(onehot, h)
        outputs.append(h)
    torch.testing.assert_close(guides, torch.stack(outputs[::-1]), rtol=0, atol=1e-7)


def test_unknown_action_lists_valid_ones():
    model = small_models()[0]
    with pytest.raises(ValueError, match="walkingdog"):
        model.closed_loop(torch.zeros(1, 3, 54), 2, "dancing")


def test_closed_loop_backpropagates_through_fed_back_frames():
    model = small_models()[1].train()
    seed = torch.randn(2, 6, 54)
    model.closed_loop(seed, 4, "walking").pow(2).mean().backward()
    assert model.body.weight_ih.grad is not None and model.plan.mu.grad.abs().sum() > 0


def test_state_dict_names_follow_the_schema():
    names = set(small_models()[0].state_dict())
    assert names == {
        "norm.mean", "norm.std", "decoder.weight", "decoder.bias",
        "plan.cell.weight_ih", "plan.cell.weight_hh", "plan.cell.bias_ih", "plan.cell.bias_hh",
        "plan.mu", "plan.sigma",
        "body.weight_ih", "body.weight_hh", "body.weight_ph", "body.bias_ih", "body.bias_hh",
    }  # fmt: skip
    gru = small_models()[2].state_dict()
    assert gru["rnn.0.weight_ih"].shape == (36, 216) and gru["rnn.1.weight_ih"].shape == (36, 12)


# Gopalakrishnan et al. 2019 Table 1: GRU-d 2,735,670; VGRU-d 3,413,047. Ours at the paper's sizes (512 units,
# 216 inputs, 54 outputs, 15 actions); training/README.md explains the differences.
PAPER_SIZES = {"gru-d": (2_724_918, 2_735_670), "vgru-d": (2_748_982, 3_413_047)}


@pytest.mark.parametrize("architecture", ["gru-d", "vgru-d"])
def test_parameter_count_at_paper_sizes(architecture):
    model = build_model(make_config(architecture, H36M_DIMS_USED))
    ours, paper = PAPER_SIZES[architecture]
    count = parameter_count(model)
    print(f"{architecture}: {count:,} parameters (Gopalakrishnan et al. 2019 Table 1: {paper:,})")
    assert count == ours
