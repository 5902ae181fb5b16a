"""Recurrent and dense layers shared by the motion models.

Gopalakrishnan, Mali, Kifer, Giles, Ororbia. A Neural Temporal Model for Human Motion Prediction
(CVPR 2019), section 3.2, equations 1-4 (body GRU); Ghosh, Song, Aksan, Hilliges. Learning Human Motion
Models for Long-term Predictions (3DV 2017) for the LSTM cell and the MLP of the DAE-LSTM.

Two conventions exist for the GRU candidate state and both are supported, because the weights file
names the one it was trained with:

- ``"pytorch"``: ``n = tanh(W_n x + b_in + r * (U_n h + b_hn))`` (``torch.nn.GRUCell``)
- ``"paper"``:   ``n = tanh(W_n x + b_in + U_n (r * h) + b_hn)`` (Gopalakrishnan et al. 2019 eq. 3)

Parameter names and gate order (r, z, n) are those of ``torch.nn.GRUCell``; the update is
``h' = (1 - z) * n + z * h``. The Rust engine reads these tensors by the same names.
"""

from __future__ import annotations

import torch
from torch import nn
from torch.nn import functional as F

GRU_CONVENTIONS = ("pytorch", "paper")
BIAS_INIT = 0.1


def _check_convention(convention: str) -> str:
    if convention not in GRU_CONVENTIONS:
        raise ValueError(f"unknown GRU convention {convention!r}; expected one of {GRU_CONVENTIONS}")
    return convention


def orthogonal_blocks_(weight: torch.Tensor, blocks: int) -> None:
    """Orthogonal init of each gate block ``[H, in]`` of a stacked kernel ``[blocks*H, in]``.

    Per block because each gate is its own matrix in the equations (models.md: kernels orthogonal).
    """
    with torch.no_grad():
        for block in weight.chunk(blocks, dim=0):
            nn.init.orthogonal_(block)


def gru_update(
    gi: torch.Tensor,
    h: torch.Tensor,
    weight_hh: torch.Tensor,
    bias_hh: torch.Tensor,
    convention: str,
) -> torch.Tensor:
    """One GRU update from the input pre-activations ``gi = W x + b_i (+ V p)`` ``[B, 3H]``.

    Split out so callers can compute ``gi`` for a whole sequence in one matrix product.
    """
    hidden = h.shape[-1]
    gi_r, gi_z, gi_n = gi.split(hidden, dim=-1)
    if convention == "pytorch":
        gh_r, gh_z, gh_n = F.linear(h, weight_hh, bias_hh).split(hidden, dim=-1)
        r = torch.sigmoid(gi_r + gh_r)
        z = torch.sigmoid(gi_z + gh_z)
        n = torch.tanh(gi_n + r * gh_n)
    else:
        gh_r, gh_z = F.linear(h, weight_hh[: 2 * hidden], bias_hh[: 2 * hidden]).split(hidden, dim=-1)
        r = torch.sigmoid(gi_r + gh_r)
        z = torch.sigmoid(gi_z + gh_z)
        n = torch.tanh(gi_n + F.linear(r * h, weight_hh[2 * hidden :], bias_hh[2 * hidden :]))
    return (1.0 - z) * n + z * h


class GRUCell(nn.Module):
    """GRU cell in the ``"pytorch"`` or ``"paper"`` convention (see module doc)."""

    def __init__(self, input_size: int, hidden_size: int, convention: str = "pytorch"):
        super().__init__()
        self.input_size = input_size
        self.hidden_size = hidden_size
        self.convention = _check_convention(convention)
        self.weight_ih = nn.Parameter(torch.empty(3 * hidden_size, input_size))
        self.weight_hh = nn.Parameter(torch.empty(3 * hidden_size, hidden_size))
        self.bias_ih = nn.Parameter(torch.empty(3 * hidden_size))
        self.bias_hh = nn.Parameter(torch.empty(3 * hidden_size))
        self.reset_parameters()

    def reset_parameters(self) -> None:
        """Training init: orthogonal kernels per gate, biases 0.1 (models.md)."""
        orthogonal_blocks_(self.weight_ih, 3)
        orthogonal_blocks_(self.weight_hh, 3)
        nn.init.constant_(self.bias_ih, BIAS_INIT)
        nn.init.constant_(self.bias_hh, BIAS_INIT)

    def input_gates(self, x: torch.Tensor) -> torch.Tensor:
        """``W x + b_i`` for any leading shape ``[..., I] -> [..., 3H]``."""
        return F.linear(x, self.weight_ih, self.bias_ih)

    def step(self, gi: torch.Tensor, h: torch.Tensor) -> torch.Tensor:
        """Update from precomputed input pre-activations ``gi [B, 3H]``."""
        return gru_update(gi, h, self.weight_hh, self.bias_hh, self.convention)

    def forward(self, x: torch.Tensor, h: torch.Tensor) -> torch.Tensor:
        """``x [B, I]``, ``h [B, H]`` -> ``h' [B, H]``."""
        return self.step(self.input_gates(x), h)

    def extra_repr(self) -> str:
        return f"{self.input_size}, {self.hidden_size}, convention={self.convention!r}"


class BodyGRUCell(nn.Module):
    """Body GRU of Gopalakrishnan et al. 2019 (eqs. 1-4): every gate (r, z, n) also reads the guide ``V p``.

    ``weight_ph [3H, P]`` holds ``V_r, V_z, V``; the guide term has no bias of its own.
    The paper's convention (``U (r * h)``) is the default; ``"pytorch"`` is supported too.
    """

    def __init__(self, input_size: int, hidden_size: int, plan_size: int, convention: str = "paper"):
        super().__init__()
        self.input_size = input_size
        self.hidden_size = hidden_size
        self.plan_size = plan_size
        self.convention = _check_convention(convention)
        self.weight_ih = nn.Parameter(torch.empty(3 * hidden_size, input_size))
        self.weight_hh = nn.Parameter(torch.empty(3 * hidden_size, hidden_size))
        self.weight_ph = nn.Parameter(torch.empty(3 * hidden_size, plan_size))
        self.bias_ih = nn.Parameter(torch.empty(3 * hidden_size))
        self.bias_hh = nn.Parameter(torch.empty(3 * hidden_size))
        self.reset_parameters()

    def reset_parameters(self) -> None:
        """Training init: orthogonal kernels per gate, biases 0.1 (models.md)."""
        orthogonal_blocks_(self.weight_ih, 3)
        orthogonal_blocks_(self.weight_hh, 3)
        orthogonal_blocks_(self.weight_ph, 3)
        nn.init.constant_(self.bias_ih, BIAS_INIT)
        nn.init.constant_(self.bias_hh, BIAS_INIT)

    def input_gates(self, x: torch.Tensor, p: torch.Tensor) -> torch.Tensor:
        """``W x + b_i + V p`` for any leading shape -> ``[..., 3H]``."""
        return F.linear(x, self.weight_ih, self.bias_ih) + F.linear(p, self.weight_ph)

    def step(self, gi: torch.Tensor, h: torch.Tensor) -> torch.Tensor:
        """Update from precomputed input pre-activations ``gi [B, 3H]``."""
        return gru_update(gi, h, self.weight_hh, self.bias_hh, self.convention)

    def forward(self, x: torch.Tensor, p: torch.Tensor, h: torch.Tensor) -> torch.Tensor:
        """``x [B, I]``, guide ``p [B, P]``, ``h [B, H]`` -> ``h' [B, H]``."""
        return self.step(self.input_gates(x, p), h)

    def extra_repr(self) -> str:
        return (
            f"{self.input_size}, {self.hidden_size}, plan={self.plan_size}, "
            f"convention={self.convention!r}"
        )


class LSTMCell(nn.Module):
    """LSTM cell, PyTorch convention: gate order i, f, g, o; ``c' = f c + i g``, ``h' = o tanh(c')``.

    For Ghosh et al. 2017's DAE-LSTM (LSTM-3LR).
    """

    def __init__(self, input_size: int, hidden_size: int):
        super().__init__()
        self.input_size = input_size
        self.hidden_size = hidden_size
        self.weight_ih = nn.Parameter(torch.empty(4 * hidden_size, input_size))
        self.weight_hh = nn.Parameter(torch.empty(4 * hidden_size, hidden_size))
        self.bias_ih = nn.Parameter(torch.empty(4 * hidden_size))
        self.bias_hh = nn.Parameter(torch.empty(4 * hidden_size))
        self.reset_parameters()

    def reset_parameters(self) -> None:
        """Training init: orthogonal kernels per gate, biases 0.1 (models.md)."""
        orthogonal_blocks_(self.weight_ih, 4)
        orthogonal_blocks_(self.weight_hh, 4)
        nn.init.constant_(self.bias_ih, BIAS_INIT)
        nn.init.constant_(self.bias_hh, BIAS_INIT)

    def forward(
        self, x: torch.Tensor, state: tuple[torch.Tensor, torch.Tensor]
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """``x [B, I]``, ``(h, c)`` each ``[B, H]`` -> ``(h', c')``."""
        h, c = state
        gates = F.linear(x, self.weight_ih, self.bias_ih) + F.linear(h, self.weight_hh, self.bias_hh)
        i, f, g, o = gates.split(self.hidden_size, dim=-1)
        c_next = torch.sigmoid(f) * c + torch.sigmoid(i) * torch.tanh(g)
        h_next = torch.sigmoid(o) * torch.tanh(c_next)
        return h_next, c_next


class MLP(nn.Module):
    """Linear layers with ReLU between them (none after the last); names ``layers.{k}.weight/bias``."""

    def __init__(self, sizes: list[int]):
        super().__init__()
        if len(sizes) < 2:
            raise ValueError(f"MLP needs at least input and output sizes, got {sizes}")
        self.sizes = list(sizes)
        self.layers = nn.ModuleList(nn.Linear(a, b) for a, b in zip(sizes[:-1], sizes[1:]))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """``x [..., sizes[0]] -> [..., sizes[-1]]``."""
        last = len(self.layers) - 1
        for k, layer in enumerate(self.layers):
            x = layer(x)
            if k < last:
                x = torch.relu(x)
        return x
