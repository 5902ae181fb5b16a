"""Layer cells against torch.nn and against the equations written out by hand."""

import pytest
import torch

from training.layers import MLP, BodyGRUCell, GRUCell, LSTMCell


def _inputs(batch=3, inp=7, hidden=5, seed=0):
    gen = torch.Generator().manual_seed(seed)
    return torch.randn(batch, inp, generator=gen, dtype=torch.float64), torch.randn(
        batch, hidden, generator=gen, dtype=torch.float64
    )


def _randomized(module, seed=1):
    gen = torch.Generator().manual_seed(seed)
    with torch.no_grad():
        for p in module.parameters():
            p.copy_(torch.rand(p.shape, generator=gen) - 0.5)
    return module.double()


def test_gru_pytorch_convention_equals_torch_grucell():
    cell = _randomized(GRUCell(7, 5, "pytorch"))
    ref = torch.nn.GRUCell(7, 5).double()
    ref.load_state_dict(cell.state_dict())
    x, h = _inputs()
    torch.testing.assert_close(cell(x, h), ref(x, h), rtol=0, atol=1e-12)


def _paper_gru_by_hand(x, h, w_ih, w_hh, b_ih, b_hh, guide_term=None):
    H = h.shape[1]
    gi = x @ w_ih.T + b_ih
    if guide_term is not None:
        gi = gi + guide_term
    r = torch.sigmoid(gi[:, :H] + h @ w_hh[:H].T + b_hh[:H])
    z = torch.sigmoid(gi[:, H : 2 * H] + h @ w_hh[H : 2 * H].T + b_hh[H : 2 * H])
    n = torch.tanh(gi[:, 2 * H :] + (r * h) @ w_hh[2 * H :].T + b_hh[2 * H :])
    return z * h + (1 - z) * n


def test_gru_paper_convention_by_hand():
    cell = _randomized(GRUCell(7, 5, "paper"))
    x, h = _inputs()
    expected = _paper_gru_by_hand(x, h, cell.weight_ih, cell.weight_hh, cell.bias_ih, cell.bias_hh)
    torch.testing.assert_close(cell(x, h), expected, rtol=0, atol=1e-12)
    pytorch = GRUCell(7, 5, "pytorch").double()
    pytorch.load_state_dict(cell.state_dict())
    assert (pytorch(x, h) - cell(x, h)).abs().max() > 1e-3  # the conventions really differ


@pytest.mark.parametrize("convention", ["pytorch", "paper"])
def test_body_gru_is_gru_plus_guide_term(convention):
    body = _randomized(BodyGRUCell(7, 5, 3, convention))
    plain = GRUCell(7, 5, convention).double()
    plain.load_state_dict({k: v for k, v in body.state_dict().items() if k != "weight_ph"})
    x, h = _inputs()
    p = torch.randn(3, 3, dtype=torch.float64)
    with torch.no_grad():
        zero_guide = body(x, torch.zeros_like(p), h)
    torch.testing.assert_close(zero_guide, plain(x, h), rtol=0, atol=1e-12)
    if convention == "paper":
        expected = _paper_gru_by_hand(
            x, h, body.weight_ih, body.weight_hh, body.bias_ih, body.bias_hh, p @ body.weight_ph.T
        )
        torch.testing.assert_close(body(x, p, h), expected, rtol=0, atol=1e-12)


def test_lstm_equals_torch_lstmcell():
    cell = _randomized(LSTMCell(7, 5))
    ref = torch.nn.LSTMCell(7, 5).double()
    ref.load_state_dict(cell.state_dict())
    x, h = _inputs()
    c = torch.randn_like(h)
    for ours, theirs in zip(cell(x, (h, c)), ref(x, (h, c))):
        torch.testing.assert_close(ours, theirs, rtol=0, atol=1e-12)


def test_mlp_names_and_relu_between_layers():
    mlp = _randomized(MLP([4, 6, 3]))
    assert list(mlp.state_dict()) == ["layers.0.weight", "layers.0.bias", "layers.1.weight", "layers.1.bias"]
    x = torch.randn(2, 4, dtype=torch.float64)
    l0, l1 = mlp.layers
    torch.testing.assert_close(mlp(x), l1(torch.relu(l0(x))), rtol=0, atol=0)


def test_training_init_orthogonal_blocks_and_bias():
    cell = GRUCell(16, 8)
    for block in cell.weight_hh.detach().chunk(3):
        torch.testing.assert_close(block @ block.T, torch.eye(8), rtol=0, atol=1e-5)
    assert torch.all(cell.bias_ih == 0.1) and torch.all(cell.bias_hh == 0.1)


def test_unknown_convention_rejected():
    with pytest.raises(ValueError, match="convention"):
        GRUCell(3, 2, "tensorflow")
