"""Parity fixtures: small random-weight layers and models plus their outputs, the contract between
these PyTorch modules and the Rust engine (definitions: training/README.md, "Parity fixtures").

    python -m training.export_fixtures            # (re)write tests/fixtures/parity/
    python -m training.export_fixtures --check    # recompute and compare with the committed files

Deterministic: a fixed torch generator, weights drawn in f32 and stored in f32 (or f16), outputs
computed in float64 from exactly the stored values and then rounded to f32, so the files do not
depend on the BLAS's summation order.
"""

from __future__ import annotations

import argparse
import json
import os
import struct
import sys
import tempfile
from pathlib import Path

import torch
from safetensors import safe_open
from safetensors.torch import save
from torch import nn

from .classifier import ActionClassifier, make_classifier_config
from .export import weights_metadata, weights_tensors
from .layers import MLP, BodyGRUCell, GRUCell, LSTMCell
from .models import H36M_ACTIONS, build_model, make_config

FIXTURE_DIR = Path(__file__).resolve().parent.parent / "tests" / "fixtures" / "parity"
SEED = 20190616
ATOL = 1e-6

# dims_used_by_published_models of ../shared/reference/h36m_skeleton.json (copied so the fixtures
# regenerate without the shared directory; a test checks the copy against the file when present).
H36M_DIMS_USED = [
    0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 12, 13, 14, 15, 21, 22, 23, 24, 27, 28, 29, 30, 36, 37, 38, 39, 40,
    41, 42, 43, 44, 45, 46, 47, 51, 52, 53, 54, 55, 56, 57, 60, 61, 62, 75, 76, 77, 78, 79, 80, 81,
    84, 85, 86,
]  # fmt: skip

# Layer fixture sizes: input, hidden, plan, steps, batch; linear/MLP widths.
I, H, P, T, B = 7, 5, 3, 4, 2
MLP_SIZES = [7, 6, 5]

# Model fixture sizes.
MODEL_HIDDEN, MODEL_PLAN, SEED_FRAMES, HORIZON = 16, 8, 10, 30
LONG_HORIZON = 3 * HORIZON + 5  # VGRU-d closed loops through three streamed plan blocks

# Action classifier fixture sizes: hidden, layers, window frames, windows.
CLASSIFIER_HIDDEN, CLASSIFIER_LAYERS, CLASSIFIER_WINDOW, CLASSIFIER_WINDOWS = 16, 2, 12, 3

Fixture = tuple[dict[str, torch.Tensor], dict[str, str]]


def _uniform(gen: torch.Generator, shape, bound: float) -> torch.Tensor:
    return (torch.rand(shape, generator=gen, dtype=torch.float32) * 2.0 - 1.0) * bound


def _randomize(module: nn.Module, gen: torch.Generator, bounds: dict[str, float] | None = None) -> None:
    """Non-trivial f32 weights: kernels U(+-1/sqrt(fan_in)), vectors U(+-0.5), overrides by name."""
    bounds = bounds or {}
    with torch.no_grad():
        for name, param in module.named_parameters():
            if name in bounds:
                bound = bounds[name]
            elif param.dim() == 2:
                bound = param.shape[1] ** -0.5
            else:
                bound = 0.5
            param.copy_(_uniform(gen, param.shape, bound))


def _prefixed(name: str, module: nn.Module) -> dict[str, torch.Tensor]:
    return {f"{name}.{k}": v.detach().clone().contiguous() for k, v in module.state_dict().items()}


def _f32(t: torch.Tensor) -> torch.Tensor:
    return t.detach().to(torch.float32).contiguous()


def layer_fixtures(gen: torch.Generator) -> Fixture:
    """``layers.safetensors``: every layer's weights, inputs and per-step outputs."""
    tensors: dict[str, torch.Tensor] = {}
    metadata = {"sizes": json.dumps({"I": I, "H": H, "P": P, "T": T, "B": B, "mlp": MLP_SIZES})}

    for convention in ("pytorch", "paper"):
        for body in (False, True):
            name = f"{'body_gru' if body else 'gru'}_{convention}"
            cell = BodyGRUCell(I, H, P, convention) if body else GRUCell(I, H, convention)
            _randomize(cell, gen)
            x = torch.randn(T, B, I, generator=gen)
            p = torch.randn(T, B, P, generator=gen) if body else None
            h0 = torch.randn(B, H, generator=gen) * 0.5
            ref = cell.double()
            h, hs = h0.double(), []
            with torch.no_grad():
                for t in range(T):
                    h = ref(x[t].double(), p[t].double(), h) if body else ref(x[t].double(), h)
                    hs.append(h)
            tensors.update(_prefixed(name, cell.float()))
            tensors[f"{name}.x"] = x
            if body:
                tensors[f"{name}.p"] = p
            tensors[f"{name}.h0"] = h0
            tensors[f"{name}.h"] = _f32(torch.stack(hs))
            metadata[f"{name}.convention"] = convention

    lstm = LSTMCell(I, H)
    _randomize(lstm, gen)
    x = torch.randn(T, B, I, generator=gen)
    h0 = torch.randn(B, H, generator=gen) * 0.5
    c0 = torch.randn(B, H, generator=gen) * 0.5
    ref = lstm.double()
    h, c, hs, cs = h0.double(), c0.double(), [], []
    with torch.no_grad():
        for t in range(T):
            h, c = ref(x[t].double(), (h, c))
            hs.append(h)
            cs.append(c)
    tensors.update(_prefixed("lstm", lstm.float()))
    tensors.update({"lstm.x": x, "lstm.h0": h0, "lstm.c0": c0})
    tensors["lstm.h"] = _f32(torch.stack(hs))
    tensors["lstm.c"] = _f32(torch.stack(cs))
    metadata["lstm.convention"] = "pytorch"

    for name, module in (("linear", nn.Linear(I, H)), ("mlp", MLP(MLP_SIZES))):
        _randomize(module, gen)
        x = torch.randn(B, I, generator=gen)
        with torch.no_grad():
            y = module.double()(x.double())
        tensors.update(_prefixed(name, module.float()))
        tensors[f"{name}.x"] = x
        tensors[f"{name}.y"] = _f32(y)
    return tensors, metadata


MODEL_SPECS = {
    # file stem: (architecture, overrides, stored dtype, action)
    "vgru_d": ("vgru-d", {"gru_convention": "paper", "residual": False}, torch.float32, "walking"),
    "vgru_d_residual": ("vgru-d", {"gru_convention": "paper", "residual": True}, torch.float32, "eating"),
    "gru_d": ("gru-d", {"gru_convention": "pytorch", "residual": False, "layers": 2}, torch.float32, ""),
    "gru_d_residual": ("gru-d", {"gru_convention": "paper", "residual": True, "layers": 2}, torch.float32, ""),
    "vgru_d_f16": ("vgru-d", {"gru_convention": "paper", "residual": False}, torch.float16, "smoking"),
}

# Drawn after the classifier so the files above stay byte-identical.
LATE_MODEL_SPECS = {
    "dae_lstm": ("dae-lstm", {"layers": 2, "dae_hidden": 24, "dae_layers": 2}, torch.float32, "walking"),
}

# Intention fixtures (Tanke et al. 2021), drawn after every file above so those stay byte-identical:
# file stem -> look-ahead gamma (3: the general case; 1 and 2: the edges of the engine's ring of
# intention probabilities, no forecast ahead of the first pose step).
INTENTION_SPECS = {"intention": 3, "intention_lookahead1": 1, "intention_lookahead2": 2, "intention_actions": 3}
# The action-conditioned intention fixture (drawn after every other file): its actions, the action of the
# expected closed loop, and the one ``switched`` changes to before the pose step producing frame S + SWITCH_AT.
INTENTION_ACTIONS = ["walking", "eating", "sitting"]
INTENTION_ACTION, INTENTION_SWITCH_TO, SWITCH_AT = "eating", "sitting", 5
INTENTION_SIZES = {
    "hidden": 24, "noise_dims": 6, "label_hidden": 10, "intentions": 4, "clusters": 7, "intention_features": 5,
    "layers": 2,
}  # fmt: skip
# The action-conditioned fixture is narrower (hidden 16), which keeps every fixture under 1.1 MB together.
INTENTION_ACTIONS_SIZES = INTENTION_SIZES | {"hidden": 16}
# Smallest gap between a seed frame's nearest and second-nearest centroid (squared distance in
# normalized units), so that the engine's f32 labelling cannot pick another cluster.
LABEL_MARGIN = 1e-2

PROVENANCE = {
    "data": "none: random weights (parity fixture)",
    "iterations": 0,
    "date": "2026-01-01T00:00:00Z",
    "command": "python -m training.export_fixtures",
    "seed": SEED,
}


def _random_norm(model: nn.Module, gen: torch.Generator) -> tuple[torch.Tensor, torch.Tensor]:
    """Random normalization statistics set on ``model.norm``: mean U(+-1), std in [0.2, 1.0] on the
    used dims and 1 on the dropped ones. Returns ``(mean, std)``."""
    used = model.config["dims_used"]
    frame_dims = model.config["frame_dims"]
    mean = _uniform(gen, (frame_dims,), 1.0)
    std = torch.ones(frame_dims)
    std[used] = 0.2 + 0.8 * torch.rand(len(used), generator=gen)
    model.norm.set_stats(mean, std)
    return mean, std


def _seed_frames(
    gen: torch.Generator, mean: torch.Tensor, std: torch.Tensor, used: list[int], frames: int = SEED_FRAMES
) -> torch.Tensor:
    """Smooth seed motion for the used dims (sinusoids in normalized units, so the derivative
    features stay motion-like); junk in the dropped dims, which the model must ignore."""
    frame_dims = mean.shape[0]
    t = torch.arange(frames, dtype=torch.float32).unsqueeze(1)
    amp = 0.3 + 0.7 * torch.rand(len(used), generator=gen)
    freq = 0.1 + 0.4 * torch.rand(len(used), generator=gen)
    phase = 6.283185 * torch.rand(len(used), generator=gen)
    normalized = amp * torch.sin(freq * t + phase)
    seed = _uniform(gen, (frames, frame_dims), 3.0)
    seed[:, used] = normalized * std[used] + mean[used]
    return seed


def model_fixture(stem: str, gen: torch.Generator) -> tuple[Fixture, Fixture]:
    """``<stem>.safetensors`` (weights schema) and ``<stem>.expected.safetensors``."""
    architecture, overrides, dtype, action = {**MODEL_SPECS, **LATE_MODEL_SPECS}[stem]
    extra = {"plan_hidden": MODEL_PLAN} if architecture == "vgru-d" else {}
    config = make_config(
        architecture,
        H36M_DIMS_USED,
        hidden=MODEL_HIDDEN,
        seed_frames=SEED_FRAMES,
        horizon=HORIZON,
        **extra,
        **overrides,
    )
    model = build_model(config, dropout=0.0)
    # Scales chosen so the closed loop keeps moving but is not chaotic: f32 rounding must stay
    # ~1e-6 after 30 fed-back steps (measured: <= 1e-6 with torch f32 vs these f64 references).
    bounds = {"plan.cell.weight_ih": 1.0, "plan.sigma": 1.0}
    input_width = len(H36M_DIMS_USED) * (1 + config["derivative_order"])
    if config["residual"]:
        bounds.update({"decoder.weight": 0.3 * MODEL_HIDDEN**-0.5, "decoder.bias": 0.02})  # modest drift
    else:
        bounds["decoder.weight"] = 1.5 * MODEL_HIDDEN**-0.5
        first = {"gru-d": "rnn.0.weight_ih", "vgru-d": "body.weight_ih", "dae-lstm": "rnn.0.weight_ih"}[architecture]
        bounds[first] = 1.5 * (input_width + (len(config["actions"]) if architecture == "dae-lstm" else 0)) ** -0.5
    if architecture == "dae-lstm":  # livelier: without these the closed loop settles in ~5 steps
        widths = [len(H36M_DIMS_USED)] + [config["dae_hidden"]] * config["dae_layers"]
        bounds.update({f"dae.layers.{k}.weight": 2.5 * w**-0.5 for k, w in enumerate(widths)})
        bounds.update({f"rnn.{k}.weight_hh": 2.5 * MODEL_HIDDEN**-0.5 for k in range(config["layers"])})
    _randomize(model, gen, bounds)

    used = config["dims_used"]
    mean, std = _random_norm(model, gen)

    tensors = weights_tensors(model, dtype)
    weights = (tensors, weights_metadata(model, PROVENANCE))

    seed = _seed_frames(gen, mean, std, used)
    eps = torch.randn(MODEL_PLAN, generator=gen) if architecture == "vgru-d" else None

    # Reference computation in float64 from exactly the stored (possibly f16-rounded) values.
    ref = build_model(config, dropout=0.0).double().eval()
    ref.load_state_dict({k: v.to(torch.float64) for k, v in tensors.items()})
    teacher_forced, closed_loop = ref.predict(
        seed.double(),
        action=action or None,
        horizon=HORIZON,
        eps=None if eps is None else eps.double(),
        with_seed_outputs=True,
    )
    expected = {"seed": seed, "teacher_forced": _f32(teacher_forced), "closed_loop": _f32(closed_loop)}
    if eps is not None:
        expected["eps"] = eps
    meta = {"action": action, "horizon": str(HORIZON), "seed_frames": str(SEED_FRAMES), "weights": f"{stem}.safetensors"}
    if architecture == "vgru-d":
        # Past the plan: the engine's streamed plan blocks (models.VGRUD.plan_guides), eps reused by every block.
        expected["closed_loop_long"] = _f32(
            ref.predict(seed.double(), action=action or None, horizon=LONG_HORIZON, eps=eps.double())
        )
        meta["long_horizon"] = str(LONG_HORIZON)
    return weights, (expected, meta)


def intention_fixture(stem: str, gen: torch.Generator) -> tuple[Fixture, Fixture]:
    """``<stem>.safetensors`` (an ``intention`` model) and ``<stem>.expected.safetensors``: ``seed [S, 99]``,
    ``eps`` (the noise ``z [N]``), ``seed_labels [S]`` (intention of each seed frame, as floats), ``intentions
    [horizon + γ - 2, C]`` (the forecast probabilities of frames ``S ..``) and ``closed_loop [horizon, 99]``; no
    ``teacher_forced`` (the model makes no predictions during the seed)."""
    lookahead = INTENTION_SPECS[stem]
    conditioned = stem == "intention_actions"
    config = make_config(
        "intention", H36M_DIMS_USED, seed_frames=SEED_FRAMES, horizon=HORIZON, lookahead=lookahead,
        **(INTENTION_ACTIONS_SIZES if conditioned else INTENTION_SIZES),
    ) | ({"actions": INTENTION_ACTIONS} if conditioned else {})
    model = build_model(config)
    hidden, label_hidden = config["hidden"], config["label_hidden"]
    bounds = {
        "decoder.weight": 0.3 * hidden**-0.5,  # modest drift, as the residual fixtures above
        "decoder.bias": 0.02,
        "label_out.weight": 3.0 * label_hidden**-0.5,  # peaked intention probabilities that move
    }
    _randomize(model, gen, bounds)
    used = config["dims_used"]
    mean, std = _random_norm(model, gen)
    seed = _seed_frames(gen, mean, std, used)

    # Centroids: normalized seed frames, jittered, so that the seed visits several clusters; a merge table
    # that uses every intention.
    clusters, intentions = config["clusters"], config["intentions"]
    normalized = (seed[:, used] - mean[used]) / std[used]
    picks = torch.randperm(SEED_FRAMES, generator=gen)[:clusters]
    centroids = normalized[picks] + 0.1 * torch.randn(clusters, len(used), generator=gen)
    merge = (torch.randperm(clusters, generator=gen) % intentions).to(torch.float32)
    assert set(merge.long().tolist()) == set(range(intentions))
    with torch.no_grad():
        model.labels.centroids.copy_(centroids)
        model.labels.merge.copy_(merge)
    z = torch.randn(config["noise_dims"], generator=gen)

    tensors = weights_tensors(model)
    weights = (tensors, weights_metadata(model, PROVENANCE))

    ref = build_model(config).double().eval()
    ref.load_state_dict({k: v.to(torch.float64) for k, v in tensors.items()})
    with torch.no_grad():
        norm_seed = ref.norm.normalize(seed.double().unsqueeze(0))
        d = ((norm_seed[0].unsqueeze(-2) - ref.labels.centroids) ** 2).sum(-1).sort(-1).values
        margin = (d[:, 1] - d[:, 0]).min().item()
        assert margin > LABEL_MARGIN, f"{stem}: a seed frame is {margin:.3g} from a tie between centroids"
        action = INTENTION_ACTION if conditioned else None
        onehot = ref.action_onehot(action, 1, norm_seed)
        steps = HORIZON + lookahead - 2
        labels, _, probs = ref.forecast_intentions(norm_seed, steps, action=onehot)
        assert len(set(labels[0].tolist())) >= 2, f"{stem}: the seed has a single intention"
        closed_loop = ref.predict(seed.double(), action=action, horizon=HORIZON, eps=z.double())
        if conditioned:
            # A switch before the pose step producing frame S + k: that step and every later one read the new
            # action, and so do the intention frames the engine has not forecast yet (S + k + γ - 2 on).
            new = ref.action_onehot(INTENTION_SWITCH_TO, 1, norm_seed)
            k = SWITCH_AT
            forecast_acts = onehot[:, None, :].repeat(1, steps, 1)
            forecast_acts[:, k + lookahead - 2 :] = new[:, None, :]
            pose_acts = onehot[:, None, :].repeat(1, HORIZON, 1)
            pose_acts[:, k:] = new[:, None, :]
            sl, _, sprobs = ref.forecast_intentions(norm_seed, steps, action=forecast_acts)
            switched = ref.norm.unnormalize(ref.generate(norm_seed, HORIZON, z.double()[None], sl, sprobs, pose_acts))
    expected = {
        "seed": seed,
        "eps": z,
        "seed_labels": labels[0].to(torch.float32),
        "intentions": _f32(probs[0]),
        "closed_loop": _f32(closed_loop),
    }
    meta = {
        "action": action or "",
        "horizon": str(HORIZON),
        "lookahead": str(lookahead),
        "seed_frames": str(SEED_FRAMES),
        "weights": f"{stem}.safetensors",
    }
    if conditioned:
        expected["switched"] = _f32(switched[0])
        meta |= {"switch_to": INTENTION_SWITCH_TO, "switch_at": str(SWITCH_AT)}
    return weights, (expected, meta)


def classifier_fixture(gen: torch.Generator) -> tuple[Fixture, Fixture]:
    """``action_classifier.safetensors`` (2 LSTM layers, centered windows, velocity features) and its expected outputs:
    ``windows [N, T, 99]`` (full frames, junk in dropped dims), ``logits [N, A]``, ``probabilities [N, A]``."""
    config = make_classifier_config(
        H36M_DIMS_USED, hidden=CLASSIFIER_HIDDEN, layers=CLASSIFIER_LAYERS, window=CLASSIFIER_WINDOW, center=True
    )
    model = ActionClassifier(config)
    _randomize(model, gen, {"head.weight": 3.0 * CLASSIFIER_HIDDEN**-0.5})
    used = config["dims_used"]
    mean, std = _random_norm(model, gen)
    tensors = weights_tensors(model)
    metadata = weights_metadata(model, PROVENANCE)
    windows = torch.stack([_seed_frames(gen, mean, std, used, CLASSIFIER_WINDOW) for _ in range(CLASSIFIER_WINDOWS)])
    ref = ActionClassifier(config).double().eval()
    ref.load_state_dict({k: v.to(torch.float64) for k, v in tensors.items()})
    logits = ref(windows.double())
    expected = {"windows": windows, "logits": _f32(logits), "probabilities": _f32(torch.softmax(logits, dim=-1))}
    return (tensors, metadata), (expected, {"weights": "action_classifier.safetensors"})


# The goal-gru fixture (drawn after every other file): its sizes; its control is constant over the seed (as the
# engine starts a character) and then changes every step.
GOAL_SIZES = {"hidden": 8, "layers": 2}
GOAL_HORIZON = 10  # closed-loop frames of the goal fixture (small: every fixture together stays under 1.1 MB)


def goal_fixture(stem: str, gen: torch.Generator, prior_radius: float | None = None) -> tuple[Fixture, Fixture]:
    """``goal_gru.safetensors`` and its expected closed loop under a per-step control (``control [S + H, 3]``);
    with ``prior_radius`` the model has a random pose prior (``PosePrior``: orthonormal axes off the root's dims)."""
    extra = {"prior_radius": prior_radius} if prior_radius else {}
    config = make_config("goal-gru", H36M_DIMS_USED, seed_frames=SEED_FRAMES, horizon=GOAL_HORIZON, **GOAL_SIZES,
                         **extra)
    model = build_model(config)
    hidden = config["hidden"]
    _randomize(model, gen, {"decoder.weight": 0.3 * hidden**-0.5, "decoder.bias": 0.02})
    if model.prior is not None:
        o = model.output_size
        body = torch.tensor([d >= 6 for d in config["dims_used"]])
        k = int(body.sum())
        q, _ = torch.linalg.qr(torch.randn(k, k, generator=gen, dtype=torch.float64))
        comps = torch.zeros(1, o, o, dtype=torch.float64)
        comps[0, :k][:, body] = q.T
        inv = torch.zeros(1, o, dtype=torch.float64)
        inv[0, :k] = _uniform(gen, (k,), 1.0).double().abs() + 0.5
        with torch.no_grad():
            model.prior.mean.copy_(_uniform(gen, (1, o), 0.5))
            model.prior.components.copy_(comps.float())
            model.prior.inv_std.copy_(inv.float())
    mean, std = _random_norm(model, gen)
    tensors = weights_tensors(model, torch.float32)
    weights = (tensors, weights_metadata(model, PROVENANCE))
    seed = _seed_frames(gen, mean, std, config["dims_used"])
    steps = SEED_FRAMES + GOAL_HORIZON
    control = _uniform(gen, (steps, config["control_dims"]), 1.0)
    control[:SEED_FRAMES] = control[SEED_FRAMES - 1]
    ref = build_model(config).double().eval()
    ref.load_state_dict({k: v.to(torch.float64) for k, v in tensors.items()})
    teacher_forced, closed_loop = ref.predict(
        seed.double(), action=control.double().unsqueeze(0), horizon=GOAL_HORIZON, with_seed_outputs=True
    )
    expected = {"seed": seed, "control": control, "teacher_forced": _f32(teacher_forced),
                "closed_loop": _f32(closed_loop)}
    meta = {"horizon": str(GOAL_HORIZON), "seed_frames": str(SEED_FRAMES), "weights": f"{stem}.safetensors"}
    return weights, (expected, meta)


def build_all() -> dict[str, Fixture]:
    """Every fixture file's tensors and metadata, keyed by file name."""
    gen = torch.Generator().manual_seed(SEED)
    files = {"layers.safetensors": layer_fixtures(gen)}
    for stem in MODEL_SPECS:
        weights, expected = model_fixture(stem, gen)
        files[f"{stem}.safetensors"] = weights
        files[f"{stem}.expected.safetensors"] = expected
    # Drawn after the others so their files stay byte-identical.
    weights, expected = classifier_fixture(gen)
    files["action_classifier.safetensors"] = weights
    files["action_classifier.expected.safetensors"] = expected
    for stem in LATE_MODEL_SPECS:
        weights, expected = model_fixture(stem, gen)
        files[f"{stem}.safetensors"] = weights
        files[f"{stem}.expected.safetensors"] = expected
    # Drawn last, for the same reason.
    for stem in INTENTION_SPECS:
        weights, expected = intention_fixture(stem, gen)
        files[f"{stem}.safetensors"] = weights
        files[f"{stem}.expected.safetensors"] = expected
    weights, expected = goal_fixture("goal_gru", gen)
    files["goal_gru.safetensors"] = weights
    files["goal_gru.expected.safetensors"] = expected
    # Drawn after the goal fixture.
    weights, expected = goal_fixture("goal_gru_prior", gen, prior_radius=0.6)
    files["goal_gru_prior.safetensors"] = weights
    files["goal_gru_prior.expected.safetensors"] = expected
    return files


def serialize(tensors: dict[str, torch.Tensor], metadata: dict[str, str]) -> bytes:
    """safetensors bytes with the header's keys sorted, so regenerating gives identical files
    (the library writes the metadata map in hash order). Same data layout, valid safetensors."""
    raw = save({k: v.contiguous() for k, v in tensors.items()}, metadata=metadata)
    size = struct.unpack("<Q", raw[:8])[0]
    header = json.loads(raw[8 : 8 + size])
    text = json.dumps(header, sort_keys=True, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 8)
    return struct.pack("<Q", len(text)) + text + raw[8 + size :]


def write_all(files: dict[str, Fixture], directory: Path = FIXTURE_DIR) -> None:
    """Write each file atomically (temp file in the same directory, then rename)."""
    directory.mkdir(parents=True, exist_ok=True)
    for name, (tensors, metadata) in files.items():
        fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".safetensors", dir=directory)
        try:
            with os.fdopen(fd, "wb") as out:
                out.write(serialize(tensors, metadata))
            os.chmod(tmp, 0o644)
            os.replace(tmp, directory / name)
        except BaseException:
            if os.path.exists(tmp):
                os.remove(tmp)
            raise


def check_all(files: dict[str, Fixture], directory: Path = FIXTURE_DIR, atol: float = ATOL) -> list[str]:
    """Differences between recomputed fixtures and the files on disk (empty list = identical)."""
    problems = []
    for name, (tensors, metadata) in files.items():
        path = directory / name
        if not path.exists():
            problems.append(f"{path}: missing")
            continue
        with safe_open(str(path), framework="pt") as f:
            stored_meta = f.metadata() or {}
            if stored_meta != metadata:
                problems.append(f"{path}: metadata differs: {stored_meta} != {metadata}")
            names = set(f.keys())
            if names != set(tensors):
                problems.append(f"{path}: tensor names differ: extra {sorted(names - set(tensors))}, "
                                f"missing {sorted(set(tensors) - names)}")
            for key in sorted(names & set(tensors)):
                stored, fresh = f.get_tensor(key), tensors[key]
                if stored.dtype != fresh.dtype or stored.shape != fresh.shape:
                    problems.append(f"{path}: {key}: {stored.dtype}{list(stored.shape)} != {fresh.dtype}{list(fresh.shape)}")
                    continue
                diff = (stored.double() - fresh.double()).abs().max().item() if fresh.numel() else 0.0
                if not diff <= atol:
                    problems.append(f"{path}: {key}: max abs difference {diff:.3g} > {atol}")
    return problems


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--check", action="store_true", help="compare with the committed fixtures, write nothing")
    parser.add_argument("--dir", type=Path, default=FIXTURE_DIR, help="fixture directory")
    args = parser.parse_args(argv)
    torch.set_num_threads(1)
    files = build_all()
    if args.check:
        problems = check_all(files, args.dir)
        for problem in problems:
            print(problem, file=sys.stderr)
        print(f"{len(files)} fixture files checked: {'OK' if not problems else f'{len(problems)} differences'}")
        return 1 if problems else 0
    write_all(files, args.dir)
    total = sum((args.dir / name).stat().st_size for name in files)
    print(f"wrote {len(files)} files to {args.dir} ({total} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
