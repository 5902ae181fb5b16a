"""Motion models: VGRU-d (VTLN-RNN), GRU-d, DAE-LSTM and the intention-based model.

Gopalakrishnan, Mali, Kifer, Giles, Ororbia. A Neural Temporal Model for Human Motion Prediction
(CVPR 2019), sections 3.2 (VTLN-RNN: plan GRU running backwards in time + body GRU, eqs. 1-4),
3.3 (derivative features) and 3.4 (open-loop and closed-loop passes of the training loss).
Ghosh, Song, Aksan, Hilliges. Learning Human Motion Models for Long-term Predictions (3DV 2017),
section 3 (DAE-LSTM: three stacked LSTM layers whose every predicted pose is filtered by a dropout
autoencoder before it is fed back).
Tanke, Zaveri, Gall. Intention-based Long-Term Human Motion Anticipation (3DV 2021), section 3 (intention
labels, intention forecaster, pose generator conditioned on noise and on intentions forecast ahead).
``goal-gru`` (this project's, for steering; ``training/locomotion.py``): stacked GRU layers over plain poses
whose first layer also reads a control vector, where the root goes over the next second.

State-dict names are the tensor names of the weights schema (weights/README.md), which the Rust
engine reads. Models work on normalized used dims ``[B, T, O]``; ``predict`` wraps that with
normalization so callers see full frames, exactly as the Rust Generator does.

Time indexing: the body output after reading frame t is the prediction of frame t + 1.
"""

from __future__ import annotations

import copy

import torch
from torch import nn
from torch.nn import functional as F

from .data import ACTIONS
from .features import DERIVATIVE_PADDING, DerivativeHistory, derivative_features, normalize, unnormalize
from .layers import BIAS_INIT, MLP, BodyGRUCell, GRUCell, LSTMCell, orthogonal_blocks_

# The one-hot order of multi-action models: the action list of the data pipeline.
H36M_ACTIONS = list(ACTIONS)

ARCHITECTURES = ("vgru-d", "gru-d", "dae-lstm", "intention", "goal-gru")
MAX_NOISE_SCALE = 100.0  # the intention model's noise_scale: 0 ..= this (motion_core::model::config::limits)


def make_config(architecture: str, dims_used: list[int], **overrides) -> dict:
    """A complete weights-schema config with the paper's defaults (H3.6M, 512 units), overridable."""
    if architecture not in ARCHITECTURES:
        raise ValueError(f"unknown architecture {architecture!r}; expected one of {ARCHITECTURES}")
    config = {
        "architecture": architecture,
        "frame_dims": 99,
        "dims_used": [int(d) for d in dims_used],
        "hidden": 512,
        "layers": {"vgru-d": 1, "gru-d": 2, "dae-lstm": 3, "intention": 3, "goal-gru": 2}[architecture],
        "gru_convention": "paper" if architecture == "vgru-d" else "pytorch",
        "residual": False,
        "derivative_order": 3,
        "derivative_padding": DERIVATIVE_PADDING,
        "fps": 25,
        "skeleton": "h36m-32",
        "actions": list(H36M_ACTIONS) if architecture == "vgru-d" else [],
        "seed_frames": 50,
        "horizon": 100,
    }
    if architecture == "vgru-d":
        config["plan_hidden"] = 512
    if architecture == "dae-lstm":
        # Ghosh et al. 2017: plain poses (no derivatives), min-max scaling, direct (not residual) output,
        # a 3 x 3000 ReLU autoencoder; sizes are overridable (weights/README.md says what ships).
        config.update(derivative_order=0, residual=False, normalization="min-max", dae_hidden=3000, dae_layers=3)
    if architecture == "intention":
        # Tanke et al. 2021: unconditioned (the intentions replace the action), plain poses, residual output;
        # 8 intentions, look-ahead gamma = 10; the other sizes are this project's (weights/README.md).
        config.update(derivative_order=0, residual=True, hidden=256, noise_dims=32, label_hidden=128,
                      intentions=8, clusters=32, lookahead=10, intention_features=32)
    if architecture == "goal-gru":
        # Stage two of steering (training/locomotion.py): plain poses, residual output, 2 x 256 units, the
        # first layer also reads the control (root velocity forward / sideways in m/s and heading change in
        # radians over the next `control_frames`).
        config.update(derivative_order=0, residual=True, hidden=256, control_dims=3, control_frames=25)
    unknown = set(overrides) - set(config) - {"plan_hidden", "rig_bvh", "mm_per_unit", "prior_radius"}
    if unknown:
        raise ValueError(f"unknown config fields {sorted(unknown)}")
    config.update(overrides)
    return config


class Norm(nn.Module):
    """Normalization statistics over full frames: buffers ``mean``, ``std`` ``[frame_dims]``."""

    def __init__(self, frame_dims: int, dims_used: list[int]):
        super().__init__()
        self.register_buffer("mean", torch.zeros(frame_dims))
        self.register_buffer("std", torch.ones(frame_dims))
        self.register_buffer("dims_used", torch.tensor(dims_used, dtype=torch.long), persistent=False)

    def normalize(self, full: torch.Tensor) -> torch.Tensor:
        """Full frames ``[..., F]`` -> normalized used dims ``[..., O]``."""
        return normalize(full, self.mean, self.std, self.dims_used)

    def unnormalize(self, normalized: torch.Tensor) -> torch.Tensor:
        """Normalized used dims ``[..., O]`` -> full frames, dropped dims = mean."""
        return unnormalize(normalized, self.mean, self.std, self.dims_used)

    def set_stats(self, mean: torch.Tensor, std: torch.Tensor) -> None:
        """Copy training-set statistics in (full-frame vectors)."""
        with torch.no_grad():
            self.mean.copy_(torch.as_tensor(mean))
            self.std.copy_(torch.as_tensor(std))


class PosePrior(nn.Module):
    """The pose prior of a closed loop (``training/pose_prior.py``, ``motion_core::model::prior``): buffers
    ``mean [A, O]``, ``components [A, O, O]``, ``inv_std [A, O]``; frames beyond ``radius`` are pulled back to it."""

    def __init__(self, radius: float, groups: int, dims: int):
        super().__init__()
        self.radius = float(radius)
        self.register_buffer("mean", torch.zeros(groups, dims))
        self.register_buffer("components", torch.zeros(groups, dims, dims))
        self.register_buffer("inv_std", torch.zeros(groups, dims))

    def forward(self, y: torch.Tensor, groups: torch.Tensor) -> torch.Tensor:
        """``y [B, O]`` of rows doing actions ``groups [B]`` (clamped to the prior's) -> pulled frames."""
        g = groups.clamp(max=self.mean.shape[0] - 1)
        comps, inv = self.components[g], self.inv_std[g]
        z = torch.einsum("bko,bo->bk", comps, y - self.mean[g])
        axes = (inv > 0).sum(-1).clamp(min=1).to(y.dtype)
        m = torch.sqrt(((z * inv) ** 2).sum(-1) / axes)
        shrink = torch.where(m > self.radius, 1.0 - self.radius / m.clamp(min=1e-30), torch.zeros_like(m))
        return y - torch.einsum("bk,bko->bo", shrink.unsqueeze(-1) * z, comps)


class MotionModel(nn.Module):
    """What VGRU-d and GRU-d share: config, norm, decoder, residual output, derivative inputs,
    and the open-loop / closed-loop passes. Subclasses provide ``_begin`` and ``_run``."""

    def __init__(self, config: dict, dropout: float = 0.3):
        super().__init__()
        self.config = copy.deepcopy(config)
        self.frame_dims = int(config["frame_dims"])
        self.dims_used = [int(d) for d in config["dims_used"]]
        self.output_size = len(self.dims_used)
        self.derivative_order = int(config["derivative_order"])
        if config.get("derivative_padding", DERIVATIVE_PADDING) != DERIVATIVE_PADDING:
            raise ValueError(f"unsupported derivative_padding {config['derivative_padding']!r}")
        self.input_size = self.output_size * (1 + self.derivative_order)
        self.hidden_size = int(config["hidden"])
        self.residual = bool(config["residual"])
        self.convention = config["gru_convention"]
        self.actions = list(config.get("actions", []))
        self.norm = Norm(self.frame_dims, self.dims_used)
        self.decoder = nn.Linear(self.hidden_size, self.output_size)
        orthogonal_blocks_(self.decoder.weight, 1)
        nn.init.constant_(self.decoder.bias, BIAS_INIT)
        # Dropout on the recurrent net's input features and on its output (before the decoder),
        # training only; the recurrent state itself is never dropped.
        self.input_dropout = nn.Dropout(dropout)
        self.output_dropout = nn.Dropout(dropout)
        radius = config.get("prior_radius")
        self.prior = PosePrior(radius, max(1, len(self.actions)), self.output_size) if radius else None

    # ---- subclass interface -------------------------------------------------------------------
    def _begin(self, batch: int, steps: int, action, eps, like: torch.Tensor, seed_len: int | None = None) -> dict:
        """Per-sequence context (hidden state, guides) for a run of ``steps`` body steps (``seed_len`` of them
        teacher-forced seed frames, when known: the VGRU plan streams in blocks after it)."""
        raise NotImplementedError

    def _run(self, ctx: dict, features: torch.Tensor, t0: int) -> torch.Tensor:
        """Feed ``features [B, T, I]`` as body steps ``t0 .. t0+T``; returns top hidden ``[B, T, H]``."""
        raise NotImplementedError

    # ---- shared ---------------------------------------------------------------------------------
    def action_indices(self, action, batch: int, device) -> torch.Tensor | None:
        """Action given as label, index, list of those, or LongTensor ``[B]`` -> LongTensor ``[B]``."""
        if not self.actions:
            return None
        if action is None:
            raise ValueError(f"this model is action-conditioned; pass one of {self.actions}")
        if isinstance(action, torch.Tensor):
            idx = action.to(device=device, dtype=torch.long).reshape(-1)
        else:
            items = action if isinstance(action, (list, tuple)) else [action]
            idx = torch.tensor([self._action_index(a) for a in items], dtype=torch.long, device=device)
        if idx.numel() == 1:
            idx = idx.expand(batch)
        if idx.numel() != batch:
            raise ValueError(f"{idx.numel()} actions for a batch of {batch}")
        return idx

    def _action_index(self, action) -> int:
        if isinstance(action, str):
            if action not in self.actions:
                raise ValueError(f"unknown action {action!r}; valid: {self.actions}")
            return self.actions.index(action)
        index = int(action)
        if not 0 <= index < len(self.actions):
            raise ValueError(f"action index {index} out of range 0..{len(self.actions)}")
        return index

    def _prior_groups(self, action, batch: int, like: torch.Tensor) -> torch.Tensor | None:
        """Each row's pose-prior group (its action index; 0 unconditioned), or None without a prior."""
        if self.prior is None:
            return None
        idx = self.action_indices(action, batch, like.device) if self.actions else None
        return idx if idx is not None else torch.zeros(batch, dtype=torch.long, device=like.device)

    def _pulled(self, frames: torch.Tensor, groups: torch.Tensor | None) -> torch.Tensor:
        """``frames [B, T, O]`` with the pose prior applied to each (unchanged without one)."""
        if groups is None:
            return frames
        return torch.stack([self.prior(frames[:, t], groups) for t in range(frames.shape[1])], dim=1)

    def _decode(self, hidden: torch.Tensor, inputs: torch.Tensor) -> torch.Tensor:
        out = self.decoder(self.output_dropout(hidden))
        return inputs + out if self.residual else out

    def open_loop(self, x: torch.Tensor, action=None, eps=None, plan_steps: int | None = None) -> torch.Tensor:
        """Ground truth fed at every step. ``x [B, T, O]`` normalized -> predictions ``[B, T, O]``
        where output t predicts frame t + 1. The VGRU plan covers ``plan_steps`` (default T) steps."""
        batch, steps, _ = x.shape
        ctx = self._begin(batch, plan_steps or steps, action, eps, x)
        features = self.input_dropout(derivative_features(x, self.derivative_order))
        return self._decode(self._run(ctx, features, 0), x)

    def closed_loop(
        self,
        seed: torch.Tensor,
        horizon: int,
        action=None,
        eps=None,
        return_seed_outputs: bool = False,
        feed_noise: float = 0.0,
    ):
        """Teacher-force ``seed [B, S, O]``, then feed own outputs back for ``horizon`` predictions.

        Returns ``[B, horizon, O]`` (frames S .. S+horizon-1); with ``return_seed_outputs`` also the
        seed-phase outputs ``[B, S, O]`` first. The last seed output is the first prediction. The
        VGRU plan covers ``S + horizon`` steps (streamed in blocks past the config's, as the engine
        does). Derivative features of fed-back frames come from the history including the seed
        frames. ``feed_noise`` (training only): Gaussian noise of that standard deviation (normalized
        units) added to every fed-back frame, which is then both the input and the residual base of
        the next prediction (the model learns to pull a disturbed pose back).
        """
        batch, seed_len, _ = seed.shape
        if seed_len < 1 or horizon < 1:
            raise ValueError(f"need at least 1 seed frame and horizon >= 1, got {seed_len}, {horizon}")
        ctx = self._begin(batch, seed_len + horizon, action, eps, seed, seed_len=seed_len)
        groups = None if isinstance(action, torch.Tensor) and action.dim() == 3 else self._prior_groups(action, batch, seed)
        if self.prior is not None and groups is None:  # a control sequence, no action: one prior
            groups = torch.zeros(batch, dtype=torch.long, device=seed.device)
        history = DerivativeHistory(self.derivative_order)
        seed_out = self._pulled(self._teacher_force(ctx, history, seed), groups)
        outputs = [seed_out[:, -1:]]
        for k in range(1, horizon):
            fed = self._feed_back(ctx, history, outputs[-1], seed_len + k - 1, feed_noise)
            outputs.append(self._pulled(fed, groups))
        generated = torch.cat(outputs, dim=1)
        return (seed_out, generated) if return_seed_outputs else generated

    def _teacher_force(self, ctx: dict, history: DerivativeHistory, seed: torch.Tensor, dropout: bool = True):
        """Body steps ``0 .. S-1`` read ``seed [B, S, O]`` (``history`` filled with it); returns their outputs
        ``[B, S, O]``, the last being the first prediction. ``dropout``: the input dropout applies (training mode)."""
        features = torch.stack([history.push(seed[:, t]) for t in range(seed.shape[1])], dim=1)
        return self._decode(self._run(ctx, self.input_dropout(features) if dropout else features, 0), seed)

    def _feed_back(self, ctx: dict, history: DerivativeHistory, frame: torch.Tensor, t: int, feed_noise: float = 0.0,
                   dropout: bool = True) -> torch.Tensor:
        """One closed-loop step: ``frame [B, 1, O]`` (plus ``N(0, feed_noise²)`` noise, which then is also the
        residual base) read as body step ``t``; returns the next frame ``[B, 1, O]``."""
        fed = frame + feed_noise * torch.randn_like(frame) if feed_noise > 0 else frame
        features = history.push(fed[:, 0]).unsqueeze(1)
        return self._decode(self._run(ctx, self.input_dropout(features) if dropout else features, t), fed)

    @staticmethod
    def _cut_graph(ctx: dict, history: DerivativeHistory) -> None:
        """Detach a context's recurrent state (``h`` or ``state``: a tensor or a sequence of them) and the
        derivative history, so back-propagation stops here (truncated BPTT)."""
        for key in ("h", "state"):
            value = ctx.get(key)
            if isinstance(value, torch.Tensor):
                ctx[key] = value.detach()
            elif isinstance(value, (tuple, list)):
                ctx[key] = type(value)(v.detach() for v in value)
        history.previous = [p.detach() for p in history.previous]

    @torch.no_grad()
    def predict(self, seed_full: torch.Tensor, action=None, horizon: int = 100, eps=None, with_seed_outputs=False):
        """Full frames in, full frames out (what the Rust Generator does), in eval mode semantics.

        ``seed_full [S, F]`` or ``[B, S, F]`` -> ``[horizon, F]`` (or batched); with
        ``with_seed_outputs`` returns ``(teacher_forced, generated)``, ``teacher_forced[t]`` being
        the prediction of frame t + 1 after reading seed frame t.
        """
        unbatched = seed_full.dim() == 2
        if unbatched:
            seed_full = seed_full.unsqueeze(0)
        seed = self.norm.normalize(seed_full.to(self.decoder.weight.dtype))
        seed_out, generated = self.closed_loop(seed, horizon, action, eps, return_seed_outputs=True)
        seed_out, generated = self.norm.unnormalize(seed_out), self.norm.unnormalize(generated)
        if unbatched:
            seed_out, generated = seed_out[0], generated[0]
        return (seed_out, generated) if with_seed_outputs else generated


class PlanRNN(nn.Module):
    """Top-level noise process of the VTLN-RNN: a GRU fed the action one-hot at every step from the
    initial state ``mu + sqrt(softplus(sigma)) * eps``; its outputs, reversed in time, are the guides."""

    def __init__(self, num_actions: int, plan_size: int, convention: str):
        super().__init__()
        self.num_actions = num_actions
        self.plan_size = plan_size
        self.cell = GRUCell(num_actions, plan_size, convention)
        self.mu = nn.Parameter(torch.zeros(plan_size))
        self.sigma = nn.Parameter(torch.zeros(plan_size))

    def initial_state(self, batch: int, eps: torch.Tensor | None, like: torch.Tensor) -> torch.Tensor:
        """``mu + sqrt(softplus(sigma)) * eps``; eps ``[P]`` or ``[B, P]``, sampled N(0, I) if None."""
        if eps is None:
            eps = torch.randn(batch, self.plan_size, dtype=like.dtype, device=like.device)
        eps = torch.as_tensor(eps, dtype=self.mu.dtype, device=self.mu.device)
        return (self.mu + torch.sqrt(F.softplus(self.sigma)) * eps).expand(batch, -1)

    def guides(self, action: torch.Tensor, steps: int, eps, like: torch.Tensor) -> torch.Tensor:
        """Guide vectors ``[steps, B, P]``: guide t = plan output ``steps - 1 - t``."""
        batch = action.shape[0]
        onehot = F.one_hot(action, self.num_actions).to(self.mu.dtype)
        gi = self.cell.input_gates(onehot)  # constant input, projected once
        h = self.initial_state(batch, eps, like)
        outputs = []
        for _ in range(steps):
            h = self.cell.step(gi, h)
            outputs.append(h)
        return torch.stack(outputs[::-1], dim=0)


class VGRUD(MotionModel):
    """VGRU-d (VTLN-RNN with derivative inputs): plan GRU + body GRU (Gopalakrishnan et al. 2019 eqs. 1-4) + decoder."""

    def __init__(self, config: dict, dropout: float = 0.3):
        super().__init__(config, dropout)
        if config["architecture"] != "vgru-d":
            raise ValueError(f"VGRUD needs architecture 'vgru-d', got {config['architecture']!r}")
        if not self.actions:
            raise ValueError("vgru-d needs at least one action label")
        self.plan_size = int(config["plan_hidden"])
        self.plan = PlanRNN(len(self.actions), self.plan_size, self.convention)
        self.body = BodyGRUCell(self.input_size, self.hidden_size, self.plan_size, self.convention)

    def _begin(self, batch, steps, action, eps, like, seed_len=None):
        action = self.action_indices(action, batch, like.device)
        guides = self.plan_guides(action, steps, eps, like, seed_len)
        h = torch.zeros(batch, self.hidden_size, dtype=like.dtype, device=like.device)
        # V p_t for every step at once: one matrix product instead of one per step.
        # Unbound into per-step views: indexing a tensor per step would make autograd allocate a full-size
        # zero gradient for every step (quadratic memory traffic); unbind's backward stacks once.
        guide_gates = F.linear(guides, self.body.weight_ph).unbind(0)
        return {"h": h, "guide_gates": guide_gates, "steps": steps}

    def plan_guides(self, action: torch.Tensor, steps: int, eps, like: torch.Tensor, seed_len: int | None = None):
        """Guides ``[steps, B, P]``. Up to ``S + T`` steps (``S`` = ``seed_len``, default the config's
        ``seed_frames``; ``T`` = the config's ``horizon``) one plan of ``steps`` steps, as trained. Beyond that the
        engine's streaming rule (motion-core ``model/vgru.rs``,
        "Streaming beyond the planned horizon"): every further block of ``T`` steps reads the guides ``S .. S+T``
        of a fresh ``S + T``-step plan (a new ``eps ~ N(0, I)`` when ``eps`` is None, else the same ``eps``), so
        long closed loops here match the Rust generator's."""
        block = int(self.config["horizon"])
        span = (int(self.config.get("seed_frames", 50)) if seed_len is None else seed_len) + block
        if steps <= span:
            return self.plan.guides(action, steps, eps, like)
        blocks = [self.plan.guides(action, span, eps, like)]
        covered = span
        while covered < steps:
            blocks.append(self.plan.guides(action, span, eps, like)[span - block :])
            covered += block
        return torch.cat(blocks, dim=0)[:steps]

    def _run(self, ctx, features, t0):
        steps = features.shape[1]
        if t0 + steps > ctx["steps"]:
            raise ValueError(f"body step {t0 + steps - 1} beyond the plan's {ctx['steps']} steps")
        gi = F.linear(features, self.body.weight_ih, self.body.bias_ih).unbind(1)
        h = ctx["h"]
        outputs = []
        for t in range(steps):
            h = self.body.step(gi[t] + ctx["guide_gates"][t0 + t], h)
            outputs.append(h)
        ctx["h"] = h
        return torch.stack(outputs, dim=1)


class GRUD(MotionModel):
    """GRU-d: stacked GRU cells (``rnn.{k}``) over derivative features + decoder; unconditioned."""

    ARCHITECTURE = "gru-d"

    def __init__(self, config: dict, dropout: float = 0.3, extra_inputs: int = 0):
        super().__init__(config, dropout)
        if config["architecture"] != self.ARCHITECTURE:
            raise ValueError(
                f"{type(self).__name__} needs architecture {self.ARCHITECTURE!r}, got {config['architecture']!r}"
            )
        layers = int(config["layers"])
        sizes = [self.input_size + extra_inputs] + [self.hidden_size] * layers
        self.rnn = nn.ModuleList(GRUCell(a, self.hidden_size, self.convention) for a in sizes[:-1])

    def action_indices(self, action, batch, device):
        return None  # unconditioned: any action argument is ignored

    def _begin(self, batch, steps, action, eps, like, seed_len=None):
        h = [torch.zeros(batch, self.hidden_size, dtype=like.dtype, device=like.device) for _ in self.rnn]
        return {"h": h}

    def _run(self, ctx, features, t0):
        return self._stack(ctx, features)

    def _stack(self, ctx, inputs):
        """The stacked cells over the first layer's ``inputs [B, T, in]`` from ``ctx["h"]``; returns the top
        hidden ``[B, T, H]``."""
        steps = inputs.shape[1]
        gi0 = self.rnn[0].input_gates(inputs).unbind(1)  # per-step views (see VGRUD._begin)
        hs = list(ctx["h"])
        outputs = []
        for t in range(steps):
            x = None
            for k, cell in enumerate(self.rnn):
                gi = gi0[t] if k == 0 else cell.input_gates(x)
                hs[k] = cell.step(gi, hs[k])
                x = hs[k]
            outputs.append(x)
        ctx["h"] = hs
        return torch.stack(outputs, dim=1)


def joint_groups(dims_used: list[int]) -> list[list[int]]:
    """Positions in ``dims_used`` grouped by joint (full-frame dim // 3: an exp-map triple, or the
    root position), in joint order: the units the DAE's dropout removes whole."""
    groups: dict[int, list[int]] = {}
    for k, d in enumerate(dims_used):
        groups.setdefault(int(d) // 3, []).append(k)
    return [groups[j] for j in sorted(groups)]


class DAELSTM(MotionModel):
    """DAE-LSTM (Ghosh et al. 2017, section 3): LSTM-3LR over the pose (⊕ the action one-hot when the config
    names actions), a linear decoder to the next pose, and the dropout autoencoder ``dae`` (an MLP
    ``O -> dae_hidden x dae_layers -> O``, ReLU) that filters every prediction. The filtered pose is
    both the output and what is fed back. ``filter_enabled = False`` gives the bare LSTM-3LR (its
    pre-training). Tensors: ``rnn.{k}.*`` (LSTM cells, PyTorch gate order), ``decoder.*``,
    ``dae.layers.{k}.*``, ``norm.mean`` / ``norm.std`` (min and max - min for min-max scaling)."""

    def __init__(self, config: dict, dropout: float = 0.0):
        super().__init__(config, dropout)
        if config["architecture"] != "dae-lstm":
            raise ValueError(f"DAELSTM needs architecture 'dae-lstm', got {config['architecture']!r}")
        self.num_layers = int(config["layers"])
        if self.num_layers < 1:
            raise ValueError("dae-lstm needs at least one LSTM layer")
        rnn_input = self.input_size + len(self.actions)
        sizes = [rnn_input] + [self.hidden_size] * self.num_layers
        self.rnn = nn.ModuleList(LSTMCell(a, self.hidden_size) for a in sizes[:-1])
        dae_sizes = [self.output_size] + [int(config["dae_hidden"])] * int(config["dae_layers"]) + [self.output_size]
        self.dae = MLP(dae_sizes)
        self.filter_enabled = True
        self.groups = joint_groups(self.dims_used)

    def action_indices(self, action, batch, device):
        if not self.actions:
            return None
        return super().action_indices(action, batch, device)

    def _flat_weights(self) -> list[torch.Tensor]:
        flat = []
        for cell in self.rnn:
            flat += [cell.weight_ih, cell.weight_hh, cell.bias_ih, cell.bias_hh]
        return flat

    def _begin(self, batch, steps, action, eps, like, seed_len=None):
        zeros = torch.zeros(self.num_layers, batch, self.hidden_size, dtype=like.dtype, device=like.device)
        onehot = None
        if self.actions:
            idx = self.action_indices(action, batch, like.device)
            onehot = F.one_hot(idx, len(self.actions)).to(like.dtype)
        return {"state": (zeros, zeros.clone()), "onehot": onehot}

    def _run(self, ctx, features, t0):
        if ctx["onehot"] is not None:
            onehot = ctx["onehot"][:, None, :].expand(-1, features.shape[1], -1)
            features = torch.cat([features, onehot], dim=-1)
        # torch's fused multi-layer LSTM over the cells' own parameters: the same equations as
        # LSTMCell (gate order i, f, g, o), one call for all steps and layers.
        out, h, c = torch._VF.lstm(
            features, ctx["state"], self._flat_weights(), True, self.num_layers, 0.0, self.training, False, True
        )
        ctx["state"] = (h, c)
        return out

    def filter(self, pose: torch.Tensor) -> torch.Tensor:
        """The DAE's reconstruction of a (normalized) pose ``[..., O]``."""
        return self.dae(pose)

    def _decode(self, hidden, inputs):
        raw = super()._decode(hidden, inputs)
        return self.filter(raw) if self.filter_enabled else raw

    def open_loop_raw(self, x: torch.Tensor, action=None) -> torch.Tensor:
        """Teacher-forced pass of the bare LSTM-3LR over ``x [B, T, O]``: its unfiltered predictions
        (output t predicts frame t + 1); the training losses filter them themselves."""
        ctx = self._begin(x.shape[0], x.shape[1], action, None, x)
        hidden = self._run(ctx, self.input_dropout(derivative_features(x, self.derivative_order)), 0)
        return MotionModel._decode(self, hidden, x)

    def drop_joints(self, pose: torch.Tensor, rate: float, generator: torch.Generator | None = None) -> torch.Tensor:
        """The DAE's corruption (section 3.1): each joint's dims set to 0 with probability ``rate``
        (whole joints removed, no rescaling)."""
        if rate <= 0:
            return pose
        keep_joint = (torch.rand(*pose.shape[:-1], len(self.groups), generator=generator) >= rate).to(pose.dtype)
        index = torch.empty(self.output_size, dtype=torch.long)
        for j, group in enumerate(self.groups):
            index[group] = j
        return pose * keep_joint.to(pose.device).index_select(-1, index.to(pose.device))


class IntentionLabels(nn.Module):
    """The intention labelling of Tanke et al. 2021, 3.3 (``training/intention_labels.py``): buffers ``centroids
    [clusters, O]`` (normalized used dims) and ``merge [clusters]`` (the intention of each cluster, as floats)."""

    def __init__(self, clusters: int, dims: int):
        super().__init__()
        self.register_buffer("centroids", torch.zeros(clusters, dims))
        self.register_buffer("merge", torch.zeros(clusters))

    def forward(self, frames: torch.Tensor) -> torch.Tensor:
        """Intention of each normalized frame ``[..., O]`` (long): the nearest centroid's entry of the merge
        table (squared distance, lowest index on ties)."""
        d = ((frames.unsqueeze(-2) - self.centroids) ** 2).sum(-1)
        return self.merge.long()[d.argmin(-1)]


class IntentionModel(MotionModel):
    """The intention-based stochastic model of Tanke et al. 2021, section 3 (docs/models.md, "Intention model").

    - ``labels``: the seed's frames labelled with intentions (3.3, ``IntentionLabels``).
    - Intention forecaster (3.1, eq. 3): ``label_encoder`` (GRU, ``label_hidden`` units) over the seed, each
      frame's input its normalized pose and the one-hot of its label; ``label_decoder`` (GRU, same units, starting
      from the encoder's state) auto-regressive over intention probabilities: its first input is the one-hot of
      the last seed label, then its own previous output ``softmax(label_out(h))``.
    - Pose generator (3.2, eq. 6): ``pose_encoder`` (GRU, ``hidden - noise_dims`` units) over the seed gives
      ``h_p``; every layer of the ``rnn.{k}`` decoder (``layers`` GRUs of ``hidden`` units) starts from
      ``h_p ⊕ z``, ``z ~ N(0, I)`` of ``noise_dims``; the step producing frame ``τ`` reads
      ``x̂_{τ-1} ⊕ z ⊕ f(ĉ_{τ-1 .. τ+γ-2})`` where ``f`` = ``intent_conv`` (a temporal convolution of kernel
      ``γ = lookahead`` over the intention probabilities, ``intention_features`` channels; frames up to the
      last seed frame are their labels' one-hots, later ones the forecast) and ``x̂_{S-1}`` is the last seed
      frame; ``decoder`` maps the top layer to the change of the pose (residual).
    All GRUs use the PyTorch convention. The discriminators are training-only (``training/train_intention.py``).
    Frame indices: seed frames ``0 .. S-1``, predictions ``S ..``.

    Action conditioning (this project's addition; the paper's model is unconditioned): a config with ``actions``
    appends the action's one-hot ``a`` (``A`` = ``len(actions)`` dims) to three inputs, last: the label encoder's
    (pose ⊕ label one-hot ⊕ a), the label decoder's (probabilities ⊕ a) and the first decoder layer's
    (``x̂ ⊕ z ⊕ f ⊕ a``). ``with_actions`` turns an unconditioned model into one whose new columns are zero, so it
    starts computing exactly what the unconditioned one does."""

    def __init__(self, config: dict, dropout: float = 0.0):
        super().__init__(config, 0.0)
        if config["architecture"] != "intention":
            raise ValueError(f"IntentionModel needs architecture 'intention', got {config['architecture']!r}")
        if self.derivative_order != 0 or not self.residual:
            raise ValueError("the intention model reads plain poses (derivative_order 0) and is residual")
        self.noise_dims = int(config["noise_dims"])
        self.intentions = int(config["intentions"])
        self.lookahead = int(config["lookahead"])
        self.intention_features = int(config["intention_features"])
        self.label_hidden = int(config["label_hidden"])
        self.num_layers = int(config["layers"])
        self.noise_scale = float(config.get("noise_scale", 1.0))
        if not 0 < self.noise_dims < self.hidden_size or self.lookahead < 1 or self.num_layers < 1:
            raise ValueError("intention model needs 0 < noise_dims < hidden, lookahead >= 1, layers >= 1")
        if not 0.0 <= self.noise_scale <= MAX_NOISE_SCALE:
            raise ValueError(f"noise_scale {self.noise_scale} is not in [0, {MAX_NOISE_SCALE}]")
        o, c, a = self.output_size, self.intentions, len(self.actions)
        self.labels = IntentionLabels(int(config["clusters"]), o)
        self.label_encoder = GRUCell(o + c + a, self.label_hidden)
        self.label_decoder = GRUCell(c + a, self.label_hidden)
        self.label_out = nn.Linear(self.label_hidden, c)
        self.pose_encoder = GRUCell(o, self.hidden_size - self.noise_dims)
        self.intent_conv = nn.Conv1d(c, self.intention_features, self.lookahead)
        sizes = [o + self.noise_dims + self.intention_features + a] + [self.hidden_size] * self.num_layers
        self.rnn = nn.ModuleList(GRUCell(a, self.hidden_size) for a in sizes[:-1])
        nn.init.zeros_(self.decoder.weight)  # residual: start by holding the pose
        nn.init.zeros_(self.decoder.bias)

    def action_indices(self, action, batch, device):
        if not self.actions:
            return None  # unconditioned: the intentions take the action's place
        return super().action_indices(action, batch, device)

    def action_onehot(self, action, batch: int, like: torch.Tensor) -> torch.Tensor | None:
        """The action's one-hot ``[B, A]`` (None for an unconditioned model)."""
        idx = self.action_indices(action, batch, like.device)
        return None if idx is None else F.one_hot(idx, len(self.actions)).to(like.dtype)

    def with_actions(self, actions: list[str]) -> "IntentionModel":
        """An action-conditioned copy of this unconditioned model: the one-hot columns appended to the three
        inputs are zero, every other weight and buffer is copied, so it computes what this model does."""
        if self.actions:
            raise ValueError(f"the model is already conditioned on {self.actions}")
        if not actions or len(set(actions)) != len(actions):
            raise ValueError(f"need distinct action labels, got {actions}")
        config = dict(self.config) | {"actions": list(actions)}
        out = IntentionModel(config).to(self.decoder.weight.dtype)
        state = self.state_dict()
        with torch.no_grad():
            for name in ("label_encoder.weight_ih", "label_decoder.weight_ih", "rnn.0.weight_ih"):
                w = state[name]
                state[name] = torch.cat([w, w.new_zeros(w.shape[0], len(actions))], dim=1)
        out.load_state_dict(state)
        return out

    @staticmethod
    def _encode(cell: GRUCell, inputs: torch.Tensor) -> torch.Tensor:
        gi = cell.input_gates(inputs).unbind(1)
        h = torch.zeros(inputs.shape[0], cell.hidden_size, dtype=inputs.dtype, device=inputs.device)
        for g in gi:
            h = cell.step(g, h)
        return h

    def forecast_intentions(self, seed: torch.Tensor, steps: int, labels: torch.Tensor | None = None,
                            action: torch.Tensor | None = None):
        """Seed ``[B, S, O]`` -> (seed labels ``[B, S]``, forecast logits ``[B, steps, C]`` of frames
        ``S .. S+steps-1``, their probabilities). ``labels`` overrides the seed's own labelling; ``action`` is
        the action one-hot ``[B, A]`` of a conditioned model (``action_onehot``), or one per forecast step
        ``[B, steps, A]`` (an action switched mid-stream; the encoder reads the first)."""
        labels = self.labels(seed) if labels is None else labels
        onehot = F.one_hot(labels, self.intentions).to(seed.dtype)
        enc_in = torch.cat([seed, onehot], dim=-1)
        if action is not None:
            first = action if action.dim() == 2 else action[:, 0]
            enc_in = torch.cat([enc_in, first[:, None, :].expand(-1, seed.shape[1], -1)], dim=-1)
        h = self._encode(self.label_encoder, enc_in)
        x = onehot[:, -1]
        logits, probs = [], []
        for j in range(steps):
            if action is not None:
                x = torch.cat([x, action if action.dim() == 2 else action[:, j]], dim=-1)
            h = self.label_decoder(x, h)
            lg = self.label_out(h)
            x = torch.softmax(lg, dim=-1)
            logits.append(lg)
            probs.append(x)
        if steps == 0:
            empty = seed.new_zeros(seed.shape[0], 0, self.intentions)
            return labels, empty, empty
        return labels, torch.stack(logits, 1), torch.stack(probs, 1)

    def sample_noise(self, batch: int, like: torch.Tensor, generator: torch.Generator | None = None) -> torch.Tensor:
        return torch.randn(batch, self.noise_dims, generator=generator, dtype=like.dtype).to(like.device)

    def generate(self, seed: torch.Tensor, horizon: int, z: torch.Tensor, seed_labels: torch.Tensor,
                 future_probs: torch.Tensor, action: torch.Tensor | None = None) -> torch.Tensor:
        """Poses of frames ``S .. S+horizon-1`` ``[B, horizon, O]`` from the seed, the noise ``z [B, N]``, the
        seed's labels and intention probabilities of frames ``S .. S+horizon+γ-3`` (``[B, >= horizon+γ-2, C]``)
        (and the action one-hot ``[B, A]`` of a conditioned model)."""
        feats = self.intention_features_of(seed_labels, future_probs, horizon, seed)
        outputs, _ = self.rollout(seed[:, -1], self.initial_state(seed, z), z, feats, action)
        return outputs

    def intention_features_of(self, seed_labels: torch.Tensor, future_probs: torch.Tensor, horizon: int,
                              like: torch.Tensor) -> torch.Tensor:
        """``f`` of eq. 6 for the steps producing frames ``S .. S+horizon-1``: ``[B, horizon, Fe]``."""
        onehot = F.one_hot(seed_labels[:, -1:], self.intentions).to(like.dtype)  # frame S-1
        window = torch.cat([onehot, future_probs[:, : max(0, horizon + self.lookahead - 2)]], dim=1)
        return self.intent_conv(window.transpose(1, 2)).transpose(1, 2)

    def initial_state(self, seed: torch.Tensor, z: torch.Tensor) -> list[torch.Tensor]:
        """Every decoder layer's first state: ``h_p ⊕ z``."""
        h0 = torch.cat([self._encode(self.pose_encoder, seed), z], dim=-1)
        return [h0 for _ in self.rnn]

    def rollout(self, x: torch.Tensor, hs: list[torch.Tensor], z: torch.Tensor, feats: torch.Tensor,
                action: torch.Tensor | None = None):
        """Pose steps from the last frame ``x [B, O]`` and decoder states ``hs``, one per row of ``feats
        [B, T, Fe]`` (``action``: the one-hot ``[B, A]`` of a conditioned model, or one per step ``[B, T, A]``):
        (frames ``[B, T, O]``, final states)."""
        hs = list(hs)
        outputs = []
        for j in range(feats.shape[1]):
            parts = [x, z, feats[:, j]]
            if action is not None:
                parts.append(action if action.dim() == 2 else action[:, j])
            inp = torch.cat(parts, dim=-1)
            for k, cell in enumerate(self.rnn):
                hs[k] = cell(inp, hs[k])
                inp = hs[k]
            x = x + self.decoder(inp)
            if self.prior is not None:
                groups = (action.argmax(-1) if action is not None and action.dim() == 2 else
                          action[:, j].argmax(-1) if action is not None else
                          torch.zeros(x.shape[0], dtype=torch.long, device=x.device))
                x = self.prior(x, groups)
            outputs.append(x)
        return torch.stack(outputs, 1), hs

    def closed_loop(self, seed: torch.Tensor, horizon: int, action=None, eps=None, return_seed_outputs: bool = False):
        """Frames ``S .. S+horizon-1`` for ``seed [B, S, O]``; ``eps`` is ``z`` (``[N]`` or ``[B, N]``, used as
        given; when None drawn from torch's generator as ``N(0, s² I)``, ``s`` = ``config['noise_scale']``, 1 when
        absent). No teacher-forced seed outputs exist (``return_seed_outputs``
        gives None for them)."""
        batch = seed.shape[0]
        if seed.shape[1] < 1 or horizon < 1:
            raise ValueError(f"need at least 1 seed frame and horizon >= 1, got {seed.shape[1]}, {horizon}")
        if eps is None:  # drawn: N(0, s² I) with the file's noise_scale s; training draws N(0, I) itself
            z = self.noise_scale * self.sample_noise(batch, seed)
        else:
            z = torch.as_tensor(eps, dtype=seed.dtype).expand(batch, -1)
        onehot = self.action_onehot(action, batch, seed)
        labels, _, probs = self.forecast_intentions(seed, max(0, horizon + self.lookahead - 2), action=onehot)
        out = self.generate(seed, horizon, z, labels, probs, onehot)
        return (None, out) if return_seed_outputs else out

    @torch.no_grad()
    def predict(self, seed_full: torch.Tensor, action=None, horizon: int = 100, eps=None, with_seed_outputs=False):
        """Full frames in, full frames out, as ``MotionModel.predict`` (no seed outputs)."""
        if with_seed_outputs:
            raise ValueError("the intention model has no teacher-forced seed outputs")
        unbatched = seed_full.dim() == 2
        if unbatched:
            seed_full = seed_full.unsqueeze(0)
        seed = self.norm.normalize(seed_full.to(self.decoder.weight.dtype))
        out = self.norm.unnormalize(self.closed_loop(seed, horizon, action=action, eps=eps))
        return out[0] if unbatched else out


class GoalGRU(GRUD):
    """``goal-gru``: GRU-d's stacked cells (``rnn.{k}``) over plain poses + decoder (residual); the first layer
    reads the frame followed by its control vector ``[control_dims]`` (``training/locomotion.py`` says what it
    holds). The control sequence ``[B, T, C]`` is passed where other models take the action (``action`` of
    ``open_loop`` / ``closed_loop`` / ``predict``); step ``t`` reads control ``t``. Without one every control is
    0."""

    ARCHITECTURE = "goal-gru"

    def __init__(self, config: dict, dropout: float = 0.0):
        super().__init__(config, dropout, extra_inputs=int(config["control_dims"]))
        self.control_dims = int(config["control_dims"])

    def _begin(self, batch, steps, action, eps, like, seed_len=None):
        ctx = super()._begin(batch, steps, action, eps, like, seed_len)
        control = action if isinstance(action, torch.Tensor) else None
        if control is not None and (control.dim() != 3 or control.shape[0] != batch or
                                    control.shape[2] != self.control_dims or control.shape[1] < steps):
            raise ValueError(f"control must be [{batch}, >= {steps}, {self.control_dims}], got {tuple(control.shape)}")
        if control is None:
            control = like.new_zeros(batch, steps, self.control_dims)
        ctx["control"] = control.to(like.dtype)
        return ctx

    def _run(self, ctx, features, t0):
        return self._stack(ctx, torch.cat([features, ctx["control"][:, t0 : t0 + features.shape[1]]], dim=-1))


def build_model(config: dict, dropout: float = 0.3) -> MotionModel:
    """The model class named by ``config['architecture']``."""
    architecture = config.get("architecture")
    if architecture == "vgru-d":
        return VGRUD(config, dropout)
    if architecture == "gru-d":
        return GRUD(config, dropout)
    if architecture == "dae-lstm":
        return DAELSTM(config, 0.0)
    if architecture == "intention":
        return IntentionModel(config)
    if architecture == "goal-gru":
        return GoalGRU(config, 0.0)
    raise ValueError(f"unknown architecture {architecture!r}; expected one of {ARCHITECTURES}")


def parameter_count(model: nn.Module) -> int:
    """Trainable parameters (the norm buffers are not parameters)."""
    return sum(p.numel() for p in model.parameters())
