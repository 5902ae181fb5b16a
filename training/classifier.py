"""Action classifier of Ghosh et al. 2017 (section 4.5, Figures 4-5): the evaluation instrument for long horizons.

Ghosh, Song, Aksan, Hilliges. Learning Human Motion Models for Long-term Predictions (3DV 2017), section 4.5:
"we leverage a pre-trained activity classifier for the evaluation of synthetic motion sequences ... a high
quality synthetic sequence should be assigned the same action label as the seed". The paper does not give the
classifier's architecture beyond "an LSTM"; ours:

- input: a window of ``window`` full frames at ``fps`` (2 s at 25 Hz = 50), normalized used dims (the predictors'
  training statistics), plus backward differences up to ``derivative_order`` (1: velocities; repeat-first padding
  inside the window, so the window's first frame has zero velocity) -> ``[T, O * (1 + order)]``;
- ``layers`` stacked LSTM layers of ``hidden`` units (PyTorch convention, gate order i, f, g, o);
- a linear head on the last hidden state of the top layer -> ``A`` logits; softmax gives class probabilities.

State-dict names are the weights schema's (weights/README.md, architecture ``action-classifier``):
``norm.mean``, ``norm.std``, ``rnn.{k}.weight_ih/weight_hh/bias_ih/bias_hh``, ``head.weight``, ``head.bias``.
"""

from __future__ import annotations

import torch
from torch import nn

from .data import ACTIONS
from .features import DERIVATIVE_PADDING, derivative_features
from .layers import LSTMCell
from .models import Norm

ARCHITECTURE = "action-classifier"


def make_classifier_config(dims_used: list[int], **overrides) -> dict:
    """A complete ``action-classifier`` config (H3.6M, 2 s windows at 25 Hz), overridable."""
    config = {
        "architecture": ARCHITECTURE,
        "frame_dims": 99,
        "dims_used": [int(d) for d in dims_used],
        "hidden": 128,
        "layers": 1,
        "derivative_order": 1,
        "derivative_padding": DERIVATIVE_PADDING,
        "fps": 25,
        "skeleton": "h36m-32",
        "actions": list(ACTIONS),
        "window": 50,
        "center": False,
    }
    unknown = set(overrides) - set(config)
    if unknown:
        raise ValueError(f"unknown config fields {sorted(unknown)}")
    config.update(overrides)
    if config["architecture"] != ARCHITECTURE:
        raise ValueError(f"architecture must be {ARCHITECTURE!r}, got {config['architecture']!r}")
    if not 0 <= config["derivative_order"] <= 3:
        raise ValueError(f"derivative_order {config['derivative_order']} (expected 0..=3)")
    return config


class ActionClassifier(nn.Module):
    """LSTM action classifier over windows of full frames (see the module docstring)."""

    def __init__(self, config: dict, dropout: float = 0.0):
        super().__init__()
        self.config = dict(config)
        dims = config["dims_used"]
        self.order = int(config["derivative_order"])
        inputs = len(dims) * (1 + self.order)
        hidden = int(config["hidden"])
        self.norm = Norm(config["frame_dims"], dims)
        mask = torch.tensor([0.0 if d < 6 else 1.0 for d in dims])
        self.register_buffer("center_mask", mask, persistent=False)
        self.rnn = nn.ModuleList(
            LSTMCell(inputs if k == 0 else hidden, hidden) for k in range(int(config["layers"]))
        )
        self.head = nn.Linear(hidden, len(config["actions"]))
        self.dropout = nn.Dropout(dropout)

    def features(self, full: torch.Tensor) -> torch.Tensor:
        """Full frames ``[B, T, F]`` -> model inputs ``[B, T, O * (1 + order)]``."""
        return self.features_from_normalized(self.norm.normalize(full))

    def features_from_normalized(self, x: torch.Tensor) -> torch.Tensor:
        """Normalized used dims ``[B, T, O]`` -> model inputs: with ``center``, every used dim that is
        not a root delta (full-frame dims 0..5) minus its mean over the window; then the differences."""
        if self.config.get("center", False):
            x = x - x.mean(dim=1, keepdim=True) * self.center_mask
        return derivative_features(x, self.order)

    def logits_from_features(self, x: torch.Tensor) -> torch.Tensor:
        """Inputs ``[B, T, I]`` -> logits ``[B, A]`` (last hidden state of the top layer)."""
        batch, steps, _ = x.shape
        states = [
            (x.new_zeros(batch, cell.hidden_size), x.new_zeros(batch, cell.hidden_size)) for cell in self.rnn
        ]
        x = self.dropout(x)
        for t in range(steps):
            inp = x[:, t]
            for k, cell in enumerate(self.rnn):
                states[k] = cell(inp, states[k])
                inp = states[k][0]
        return self.head(self.dropout(states[-1][0]))

    def forward(self, full: torch.Tensor) -> torch.Tensor:
        """Full frames ``[B, T, F]`` -> logits ``[B, A]``."""
        return self.logits_from_features(self.features(full))

    def probabilities(self, full: torch.Tensor) -> torch.Tensor:
        """Full frames ``[B, T, F]`` -> class probabilities ``[B, A]`` (softmax of the logits)."""
        return torch.softmax(self.forward(full), dim=-1)
