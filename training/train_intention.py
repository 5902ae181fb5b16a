"""Train and export the intention-based stochastic model of Tanke et al. 2021 (3DV, section 3).

    python -m training.train_intention --run-dir training/runs/intention --iterations 6000
    python -m training.train_intention --run-dir training/runs/intention --resume --iterations 9000
    python -m training.train_intention --export weights/intention.safetensors --from training/runs/intention/best.pt

What is trained (``models.IntentionModel`` holds the exported parts):

- **Labels** (3.3, ``intention_labels``): k-means (``--clusters``) on the normalized training poses, cycles merged
  into ``--intentions`` labels; fitted once at the start of a run, stored in the model's ``labels.*`` buffers.
- **Intention forecaster** (3.1): cross-entropy of the forecast over the ``--future`` frames after the seed
  (eq. 4) plus the adversarial label loss (eq. 5, weight ``--label-adv-weight``) against ``D_label``, an MLP with
  one hidden layer over windows of ``--label-window`` frames of intention probabilities (real: the labels'
  one-hots).
- **Pose generator** (3.2): the reconstruction loss of eq. 8 (per-joint L2 distance in normalized units, weight
  λ(τ) falling linearly from 1 at the last seed frame to 0 ``--rec-frames`` frames later) plus the adversarial pose
  loss of eq. 7 (weight ``--adv-weight``) against ``D_pose``, an MLP with two hidden layers over windows of
  ``--pose-window`` generated frames (flattened poses and their frame-to-frame changes; real: training windows).
  With ``--pose-context K`` every window D_pose judges comes with the seed's last K frames (real and fake alike):
  the discriminator then judges a window as a continuation of *this* seed, so motion that is plausible for some
  action but not for the seed's is caught (the paper's D_pose sees the whole sequence; a plain window does not).
  The generator reads the forecaster's probabilities without back-propagating into it (its losses are its own).
  Non-saturating GAN losses; Adam with β = (0.5, 0.9) for all four nets. ``--r1 γ`` adds the R1 penalty
  (γ/2 · E‖∇D_pose(real)‖², Mescheder et al. 2018) to D_pose's loss; ``--ema D`` keeps a moving average of the
  model's weights that validation, ``best.pt``'s choice and the export use (the GAN's weights oscillate; their
  average moves less).
- **Long horizon** (this project's addition, ``--long-weight``, 0 = the paper): after the ``--future`` frames the
  generator runs on without gradient for a random 0..``--long-burn-in`` frames, then ``--long-frames`` frames with
  gradient whose windows also go to ``D_pose`` (truncated back-propagation: what the 12 s measures ask for,
  far past any affordable full horizon; positions there are not compared, any plausible motion is right).
- **Speed** (this project's addition, ``--speed-weight``, 0 = the paper): the hinge terms of
  ``long_horizon.speed_loss`` and ``accel_loss`` (no penalty while the generated joints' mean frame-to-frame
  change, and its second difference, stay within 0.8-1.5 times the truth's) for the generated 4 s against the
  truth's 4 s, and for the long-horizon frames with gradient against the same 4 s of truth: a window-wise D_pose
  accepts a character that slows to a stop (real windows stand still too), this term does not.
- **Root speed** (this project's addition, ``--root-weight``, 0 = the paper): ``long_horizon.root_speed_loss`` of
  the same frames against the same truth, in the same hinge form: the speed of the root's translation. The
  joint-angle terms leave the root out, and without this the legs keep walking while the body slows to a stop
  (8-12 s root speed of walking 0.07 times the truth's).
- **Smoothness** (this project's addition, ``--smooth-weight``, 0 = the paper): ``kinematics.roughness_loss`` of
  the same frames against the same truth: the roughness (mean second difference over mean first difference) of
  the 12 NDMS joints' body-frame positions held within 1.2 times the truth's. The exp-map acceleration term above
  pools every angle, and real data's small joints are rough at 25 Hz, so it lets the limbs jitter; NDMS compares
  position velocities, which jitter turns in random directions.
- **Word realism** (this project's addition, ``--word-weight``, 0 = the paper): ``word_realism.word_realism_loss``
  of the same frames: Tanke et al. 2021's plausibility measure (eq. 10) as a training signal on training data only, ``1 −
  NDMS`` of each generated 8-frame word against its nearest word of the *training* subjects' motion of the
  window's action (the search is not differentiated). The terms above match overall speed and smoothness; this
  one pulls each stretch of motion toward the velocities real motion has in that pose.

Sizes default to ``make_config("intention")``: pose decoder 3 × 256 GRU (224 encoder units ⊕ 32 noise dims),
forecaster 128 units, 32 clusters → 8 intentions, γ = 10, 32 intention features (CPU budget; the paper gives no
sizes).

**Checkpoint choice (fixed before any score was seen).** Every ``--val-every`` iterations the model runs 12 s
(300 frames) from each S5 validation window's seed with one fixed ``z`` per window (seeded); per action, the speed
ratio at 8-12 s (predicted frames 200-300 against the window's truth, ``long_horizon.speed_ratios``). A
checkpoint is eligible when every action's ratio is >= 0.5 *and* <= 2; ``best.pt`` is the eligible one with the
lowest validation NPSS (reference variant, 4 s, same z); while none is eligible, the one whose worst ratio (the
ratio farthest from [0.5, 2] in log terms) is best.

Checkpoints (``last.pt``: the four nets, optimizers and RNG states, iteration) are written atomically every
``--checkpoint-every`` iterations; ``--resume`` continues a run; ``--device cuda`` runs unchanged on a GPU.
"""

from __future__ import annotations

import argparse
import copy
import datetime
import json
import math
import shlex
import sys
import time
from pathlib import Path

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from . import data as h36m
from . import intention_labels
from .export import load_weights, save_weights
from .layers import MLP
from . import long_horizon
from .crouch import CrouchFloor, TiptoeCeiling, crouch_loss, tiptoe_loss
from .foot_skate import skate_of_poses
from .posture_term import PostureGaussian, posture_loss
from .kinematics import roughness_loss
from .long_horizon import LONG_HORIZON, accel_loss, root_speed_loss, speed_loss, speed_ratios
from .models import IntentionModel, joint_groups, make_config, parameter_count
from .root_drift import drift_of_poses, scored_root_poses
from .word_realism import WordBank, word_realism_loss
from .checkpoint_io import BEST, CHECKPOINT, add_run_arguments, atomic_save, begin_run, read_checkpoint
from .train import RESUME_OVERRIDABLE, Logger, Validator, explicit_args

CHECKPOINT_KEYS = ("config", "args", "model", "d_pose", "d_label", "opt_g", "opt_f", "opt_dp", "opt_dl",
                   "iteration", "numpy_rng", "torch_rng")
RATIO_BAND = (0.5, 2.0)
VAL_NOISE_SEED = 20261202


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m training.train_intention",
        description="Train and export the intention-based stochastic model of Tanke et al. 2021.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=__doc__,
    )
    p.add_argument("--run-dir", type=Path, help="where last.pt, best.pt, train.log and metrics.jsonl go")
    g = p.add_argument_group("model")
    g.add_argument("--hidden", type=int, default=256, help="pose decoder GRU units (encoder units + noise dims)")
    g.add_argument("--layers", type=int, default=3, help="pose decoder GRU layers (paper: 3)")
    g.add_argument("--noise-dims", type=int, default=32, help="size of z")
    g.add_argument("--label-hidden", type=int, default=128, help="forecaster GRU units")
    g.add_argument("--clusters", type=int, default=intention_labels.DEFAULT_CLUSTERS, help="k-means clusters")
    g.add_argument("--intentions", type=int, default=intention_labels.DEFAULT_INTENTIONS, help="labels (paper: 8)")
    g.add_argument("--lookahead", type=int, default=10, help="γ, frames of intention forecast read ahead (paper: 10)")
    g.add_argument("--intention-features", type=int, default=32, help="channels of the temporal convolution f")
    g = p.add_argument_group("optimisation")
    g.add_argument("--iterations", type=int, default=6000)
    g.add_argument("--batch", type=int, default=32)
    g.add_argument("--future", type=int, default=100, help="frames generated after the 50 seed frames (4 s)")
    g.add_argument("--lr", type=float, default=5e-4, help="Adam learning rate of generator and forecaster")
    g.add_argument("--lr-d", type=float, default=2e-4, help="Adam learning rate of the discriminators")
    g.add_argument("--rec-frames", type=int, default=15, help="τ_rec of eq. 8 (paper: 15)")
    g.add_argument("--adv-weight", type=float, default=0.3, help="weight of the adversarial pose loss")
    g.add_argument("--label-adv-weight", type=float, default=0.1, help="weight of the adversarial label loss")
    g.add_argument("--pose-window", type=int, default=10, help="frames per D_pose window")
    g.add_argument("--label-window", type=int, default=20, help="frames per D_label window")
    g.add_argument("--d-hidden", type=int, default=256, help="D_pose hidden units (D_label: a quarter)")
    g.add_argument("--pose-context", type=int, default=0, metavar="K",
                   help="seed frames given to D_pose with every window (0: windows alone)")
    g.add_argument("--r1", type=float, default=0.0, metavar="GAMMA",
                   help="R1 gradient penalty on D_pose's real windows (0: off)")
    g.add_argument("--ema", type=float, default=0.0, metavar="D",
                   help="weight moving-average decay per iteration (0: off); validation, best.pt and export use it")
    g.add_argument("--ema-start", type=int, default=0, metavar="IT",
                   help="with --ema: before this iteration the average just follows the weights")
    g.add_argument("--long-weight", type=float, default=1.0, help="weight of the long-horizon adversarial term")
    g.add_argument("--long-burn-in", type=int, default=200, help="most frames run without gradient")
    g.add_argument("--long-frames", type=int, default=40, help="frames with gradient after the burn-in")
    g.add_argument("--speed-weight", type=float, default=0.0, metavar="W",
                   help="adds W x the hinge speed and acceleration terms (long_horizon.speed_loss, accel_loss) of the "
                        "generated 4 s and of the long-horizon frames, each against the truth's 4 s (0: off)")
    g.add_argument("--root-weight", type=float, default=0.0, metavar="W",
                   help="adds W x the hinge root-speed term (long_horizon.root_speed_loss: the root's translation "
                        "speed against the truth's 4 s) of the generated 4 s and of the long-horizon frames (0: off)")
    g.add_argument("--smooth-weight", type=float, default=0.0, metavar="W",
                   help="adds W x the roughness term (kinematics.roughness_loss: the NDMS joints' positions no "
                        "rougher than 1.2 x the truth's) of the generated 4 s and of the long-horizon frames (0: off)")
    g.add_argument("--word-weight", type=float, default=0.0, metavar="W",
                   help="adds W x the word-realism term (word_realism.word_realism_loss: 1 - NDMS of each generated "
                        "8-frame word against its nearest word of the training subjects' motion of the window's "
                        "action) of the generated 4 s and of the long-horizon frames (0: off)")
    g.add_argument("--drift-weight", type=float, default=0.0, metavar="W",
                   help="adds W x the root-drift penalty (root_drift.drift_penalty: hip height and lean of the "
                        "integrated root held within 100 mm and 10 degrees of the last seed frame's) of the generated "
                        "frames with gradient (the 4 s and, with --long-weight, the long frames)")
    g.add_argument("--crouch-weight", type=float, default=0.0, metavar="W",
                   help="adds W x the crouch penalty (crouch.crouch_loss: the root's height over the lowest foot "
                        "point held at or above the action's real 5th percentile) of the generated frames with "
                        "gradient")
    g.add_argument("--tiptoe-weight", type=float, default=0.0, metavar="W",
                   help="adds W x the tiptoe penalty (crouch.tiptoe_loss: the ankle's height over the lowest foot point "
                        "held at or below the action's real 95th percentile) of the generated frames with gradient")
    g.add_argument("--skate-weight", type=float, default=0.0, metavar="W",
                   help="adds W x the foot-skating penalty (foot_skate.skate_penalty: low foot points of the "
                        "world-space output, root integrated, moving faster than 0.25 m/s horizontally) of the "
                        "generated frames with gradient")
    g.add_argument("--posture-weight", type=float, default=0.0, metavar="W",
                   help="adds W x the posture term (posture_term.posture_loss: relu(m - R)^2 of each generated frame's "
                        "standardized deviation m from its action's real poses, the closed-loop prior's measure); "
                        "0 = off")
    g.add_argument("--posture-radius", type=float, default=1.0, metavar="R",
                   help="the posture term's radius (real poses: m about 1 on average)")
    g.add_argument("--init-weights", type=Path, metavar="FILE.safetensors",
                   help="a new run whose model (and clustering) starts from an exported intention file; fresh "
                        "discriminators and optimizers; the model size flags do not apply")
    g.add_argument("--condition-on-actions", action="store_true",
                   help="the model reads the action's one-hot (every H3.6M action; models.IntentionModel); with "
                        "--init-weights of an unconditioned file its new input columns start at zero")
    g.add_argument("--switch-prob", type=float, default=0.0, metavar="P",
                   help="with --condition-on-actions and --long-weight: each window's action is switched to another "
                        "(uniform) with probability P where the frames after the 4 s start; the word-realism term "
                        "(--word-weight) then judges the long-horizon frames against the new action's words")
    g.add_argument("--d-warmup", type=int, default=0, metavar="N",
                   help="the first N iterations train only the discriminators (the model is not updated): fresh "
                        "discriminators catch up with a model loaded by --init-weights before their gradients reach it")
    g.add_argument("--clip", type=float, default=5.0, help="gradient-norm clipping")
    g.add_argument("--seed", type=int, default=1)
    add_run_arguments(p, log_every=25)
    p.add_argument("--choice", metavar="TEXT",
                   help="with --export: how the checkpoint was chosen, stored as provenance checkpoint_choice (default: "
                        "this module's validation rule)")
    p.add_argument("--noise-scale", type=float, default=None, metavar="S",
                   help="with --export: store noise_scale S in the file: its drawn z ~ N(0, S² I) at inference "
                        "(training always draws N(0, I); absent = 1, the paper's)")
    return p


# ---------------------------------------------------------------- pieces


def load_checkpoint(path: Path) -> dict:
    """An intention-model checkpoint; ValueError naming the file when it is not one."""
    return read_checkpoint(path, CHECKPOINT_KEYS, "intention-model")


class PoseDiscriminator(nn.Module):
    """D_pose: two hidden layers (ReLU) over a window of frames ``[..., W, O]`` and its frame-to-frame changes,
    with ``context`` seed frames ``[..., K, O]`` beside it when ``context > 0``."""

    def __init__(self, window: int, dims: int, hidden: int, context: int = 0):
        super().__init__()
        self.window, self.context = window, context
        self.net = MLP([(window + context) * dims + (window - 1) * dims, hidden, hidden, 1])

    def forward(self, windows: torch.Tensor, context: torch.Tensor | None = None) -> torch.Tensor:
        change = (windows[..., 1:, :] - windows[..., :-1, :]) * 5.0  # changes are ~0.2 of a pose's spread
        parts = [windows.flatten(-2), change.flatten(-2)]
        if self.context:
            parts.append(context.flatten(-2))
        return self.net(torch.cat(parts, dim=-1)).squeeze(-1)


class LabelDiscriminator(nn.Module):
    """D_label: one hidden layer (ReLU) over a window of intention probabilities ``[..., W, C]``."""

    def __init__(self, window: int, intentions: int, hidden: int):
        super().__init__()
        self.net = MLP([window * intentions, hidden, 1])

    def forward(self, windows: torch.Tensor) -> torch.Tensor:
        return self.net(windows.flatten(-2)).squeeze(-1)


def windows_of(x: torch.Tensor, length: int, stride: int) -> torch.Tensor:
    """All windows ``[B * n, length, D]`` of ``x [B, T, D]`` every ``stride`` frames."""
    w = x.unfold(1, length, stride)  # [B, n, D, length]
    return w.permute(0, 1, 3, 2).reshape(-1, length, x.shape[-1])


def with_context(windows: torch.Tensor, seed: torch.Tensor, k: int) -> tuple[torch.Tensor, torch.Tensor | None]:
    """``windows`` ``[B * n, W, O]`` (from ``windows_of``) and each one's seed context: the last ``k`` frames of
    its row of ``seed`` ``[B, S, O]`` (None when ``k`` is 0)."""
    if k == 0:
        return windows, None
    n = windows.shape[0] // seed.shape[0]
    return windows, seed[:, -k:].repeat_interleave(n, dim=0)


def r1_penalty(d: nn.Module, windows: torch.Tensor, context: torch.Tensor | None) -> torch.Tensor:
    """E‖∇ D(real)‖² over the discriminator's inputs (the window and its context)."""
    inputs = [windows.detach().requires_grad_(True)]
    if context is not None:
        inputs.append(context.detach().requires_grad_(True))
    out = d(*inputs)
    grads = torch.autograd.grad(out.sum(), inputs, create_graph=True)
    return sum(g.pow(2).flatten(1).sum(1) for g in grads).mean()


def rec_weights(frames: int, rec_frames: int, device) -> torch.Tensor:
    """λ(τ) of eq. 8 for predicted frames 1..``frames`` after the seed: 1 at the seed, 0 from ``rec_frames`` on."""
    tau = torch.arange(1, frames + 1, dtype=torch.float32, device=device)
    return (1.0 - tau / rec_frames).clamp(min=0.0)


def rec_loss(pred: torch.Tensor, truth: torch.Tensor, groups: list[list[int]], weights: torch.Tensor) -> torch.Tensor:
    """Eq. 8: mean over frames and joints of λ(τ) ‖x - x̂‖₂ per joint (normalized units)."""
    diff = pred - truth
    per_joint = torch.stack([diff[..., g].norm(dim=-1) for g in groups], dim=-1)  # [B, T, J]
    return (per_joint * weights[None, :, None]).mean()


def gan_d_loss(real: torch.Tensor, fake: torch.Tensor) -> torch.Tensor:
    return F.binary_cross_entropy_with_logits(real, torch.ones_like(real)) + \
        F.binary_cross_entropy_with_logits(fake, torch.zeros_like(fake))


def gan_g_loss(fake: torch.Tensor) -> torch.Tensor:
    return F.binary_cross_entropy_with_logits(fake, torch.ones_like(fake))


class LabelledSet:
    """Training sequences (normalized, 25 Hz) with their intention labels; windows sampled as
    ``TrainingSet.sample_batch`` does (action uniform, then a sequence, then a start)."""

    def __init__(self, dataset: h36m.TrainingSet, centroids: np.ndarray, merge: np.ndarray):
        self.seqs = [[s for _, s in lst] for lst in dataset.by_action]
        self.labels = [[intention_labels.label(s, centroids, merge) for s in lst] for lst in self.seqs]

    def sample(self, rng: np.random.Generator, batch: int, window: int):
        present = [i for i, seqs in enumerate(self.seqs) if any(s.shape[0] > h36m.MIN_START + window for s in seqs)]
        frames = np.empty((batch, window, self.seqs[present[0]][0].shape[1]), dtype=np.float32)
        labels = np.empty((batch, window), dtype=np.int64)
        actions = np.empty(batch, dtype=np.int64)
        for b in range(batch):
            ai = present[int(rng.integers(len(present)))]
            actions[b] = ai
            options = [k for k, s in enumerate(self.seqs[ai]) if s.shape[0] > h36m.MIN_START + window]
            k = options[int(rng.integers(len(options)))]
            start = int(rng.integers(h36m.MIN_START, self.seqs[ai][k].shape[0] - window))
            frames[b] = self.seqs[ai][k][start : start + window]
            labels[b] = self.labels[ai][k][start : start + window]
        return frames, labels, actions


# ---------------------------------------------------------------- validation


@torch.no_grad()
def validate(model: IntentionModel, validator: Validator) -> dict:
    """Scores of the fixed validation windows (module doc): NPSS etc. over 4 s and speed ratios at 8-12 s, one
    seeded z per window."""
    was = model.training
    model.eval()
    try:
        n = validator.seed_norm.shape[0]
        z = torch.randn(n, model.noise_dims, generator=torch.Generator().manual_seed(VAL_NOISE_SEED))
        action = validator.window_actions if model.actions else None
        pred = model.closed_loop(validator.seed_norm, LONG_HORIZON, action=action, eps=z).double().numpy()
    finally:
        model.train(was)
    full = validator.stats.unnormalize(pred)
    horizon = validator.gt_full.shape[1]
    val = validator.score(full[:, :horizon])
    val["long_speed"] = speed_ratios(full, validator)
    return val


def worst_ratio_gap(ratios: dict) -> float:
    """How far the worst action's ratio is outside ``RATIO_BAND`` (log terms; 0 inside)."""
    low, high = RATIO_BAND
    gaps = [max(0.0, math.log(low / r) if r > 0 else math.inf, math.log(r / high) if r > 0 else 0.0)
            for r in ratios.values()]
    return max(gaps)


def choice_key(val: dict) -> tuple:
    """Sort key of the checkpoint choice (smaller is better; module doc)."""
    gap = worst_ratio_gap(val["long_speed"])
    return (0, val["npss_ref"]) if gap == 0 else (1, gap)


# ---------------------------------------------------------------- training


def build_config(args, dims_used) -> dict:
    return make_config(
        "intention", dims_used, hidden=args.hidden, layers=args.layers, noise_dims=args.noise_dims,
        label_hidden=args.label_hidden, intentions=args.intentions, clusters=args.clusters,
        lookahead=args.lookahead, intention_features=args.intention_features,
        seed_frames=h36m.SEED_FRAMES, horizon=h36m.HORIZON,
    ) | ({"actions": list(h36m.ACTIONS)} if args.condition_on_actions else {})


def train(args, argv: list[str]) -> None:
    if args.run_dir is None:
        raise SystemExit("error: training needs --run-dir (or --export with --from)")
    args, resume = begin_run(args, explicit_args(argv), RESUME_OVERRIDABLE, load_checkpoint)
    run_dir = args.run_dir
    ckpt_path = run_dir / CHECKPOINT
    if args.future < 2 or args.pose_window > args.future or args.label_window > args.future:
        raise SystemExit("error: --future must be >= 2 and at least --pose-window and --label-window frames")
    if not 0 <= args.pose_context <= h36m.SEED_FRAMES:
        raise SystemExit(f"error: --pose-context must be 0 to the {h36m.SEED_FRAMES} seed frames")
    if min(args.r1, args.speed_weight, args.root_weight, args.smooth_weight, args.word_weight) < 0 or not 0 <= args.ema < 1:
        raise SystemExit("error: --r1, --speed-weight, --root-weight, --smooth-weight and --word-weight must be >= 0 "
                         "and --ema in [0, 1)")
    torch.set_num_threads(args.threads)
    device = torch.device(args.device)
    long_horizon.MOTION_LOSS[0] = "hinge"  # the form of --speed-weight's terms
    log = Logger(run_dir)
    command = resume["command"] if resume else "python -m training.train_intention " + shlex.join(argv)
    log(("resuming: " if resume else "starting: ") + command)

    dataset = h36m.load_training_set(args.data_dir, h36m.ACTIONS, log=log)
    stats = dataset.stats
    torch.manual_seed(args.seed)
    if resume is not None:
        config = resume["config"]
        model = IntentionModel(config)
        model.load_state_dict(resume["model"])
    elif args.init_weights is not None:
        try:
            model = load_weights(args.init_weights)
        except (OSError, ValueError, KeyError, RuntimeError) as e:
            raise SystemExit(f"error: --init-weights {args.init_weights}: {e}") from e
        if not isinstance(model, IntentionModel):
            raise SystemExit(f"error: {args.init_weights}: not an intention model ({model.config['architecture']})")
        model = model.float()
        if args.condition_on_actions and not model.actions:
            model = model.with_actions(list(h36m.ACTIONS))
            log("action-conditioned: the new one-hot input columns start at zero")
        config = model.config
        log(f"initial weights (and clustering) from {args.init_weights}")
    else:
        config = build_config(args, stats.dims_used)
        model = IntentionModel(config)
        model.norm.set_stats(torch.from_numpy(stats.mean).float(), torch.from_numpy(stats.std).float())
        t0 = time.time()
        seqs = [s for lst in dataset.by_action for _, s in lst]
        centroids, merge = intention_labels.fit_labels(seqs, args.clusters, args.intentions, seed=args.seed)
        raw8 = intention_labels.kmeans(np.concatenate(seqs)[:: max(1, sum(map(len, seqs)) // 100_000)],
                                       args.intentions, seed=args.seed)
        slow = intention_labels.mean_run_length([intention_labels.label(s, centroids, merge) for s in seqs])
        naive = intention_labels.mean_run_length([intention_labels.nearest_cluster(s, raw8) for s in seqs])
        log(f"labels: {args.clusters} clusters -> {args.intentions} intentions in {time.time() - t0:.0f} s; mean run "
            f"{slow:.1f} frames (plain k-means with {args.intentions} clusters: {naive:.1f}); merge {merge.tolist()}")
        with torch.no_grad():
            model.labels.centroids.copy_(torch.from_numpy(centroids).float())
            model.labels.merge.copy_(torch.from_numpy(merge).float())
    centroids = model.labels.centroids.double().numpy()
    merge = model.labels.merge.long().numpy()
    labelled = LabelledSet(dataset, centroids, merge)
    bank = None
    if args.word_weight > 0:
        t0 = time.time()
        bank = WordBank(labelled.seqs, model.norm.unnormalize)
        log(f"word bank: {len(bank):,} words of the training subjects' motion in {time.time() - t0:.0f} s")
    crouch_floor = None
    if args.crouch_weight > 0:
        crouch_floor = CrouchFloor(labelled.seqs, model.norm.unnormalize)
        log("crouch limits (mm, hip over the feet, real p5): " + ", ".join(
            f"{a} {v:.0f}" for a, v in zip(h36m.ACTIONS, crouch_floor.limits.tolist())))
    tiptoe_ceiling = None
    if args.tiptoe_weight > 0:
        tiptoe_ceiling = TiptoeCeiling(labelled.seqs, model.norm.unnormalize)
        log("tiptoe limits (mm, ankle over the lowest foot point, real p95): " + ", ".join(
            f"{a} {v:.0f}" for a, v in zip(h36m.ACTIONS, tiptoe_ceiling.limits.tolist())))
    posture = None
    if args.posture_weight > 0:
        if not args.posture_radius > 0:
            raise SystemExit("error: --posture-radius must be positive")
        posture = PostureGaussian(labelled.seqs, model.dims_used)
        log(f"posture term: per-action Gaussians of the real poses, radius {args.posture_radius}")
    d_pose = PoseDiscriminator(args.pose_window, model.output_size, args.d_hidden, args.pose_context)
    d_label = LabelDiscriminator(args.label_window, model.intentions, max(8, args.d_hidden // 4))
    model.to(device).train()
    d_pose.to(device).train()
    d_label.to(device).train()
    forecaster = [p for n, p in model.named_parameters() if n.startswith("label_")]
    generator = [p for n, p in model.named_parameters() if not n.startswith("label_")]
    betas = (0.5, 0.9)
    opt_g = torch.optim.Adam(generator, lr=args.lr, betas=betas)
    opt_f = torch.optim.Adam(forecaster, lr=args.lr, betas=betas)
    opt_dp = torch.optim.Adam(d_pose.parameters(), lr=args.lr_d, betas=betas)
    opt_dl = torch.optim.Adam(d_label.parameters(), lr=args.lr_d, betas=betas)
    rng = np.random.default_rng(args.seed)
    iteration, best = 0, None
    if resume is not None:
        d_pose.load_state_dict(resume["d_pose"])
        d_label.load_state_dict(resume["d_label"])
        for opt, key in ((opt_g, "opt_g"), (opt_f, "opt_f"), (opt_dp, "opt_dp"), (opt_dl, "opt_dl")):
            opt.load_state_dict(resume[key])
        rng.bit_generator.state = resume["numpy_rng"]
        torch.set_rng_state(resume["torch_rng"])
        iteration, best = resume["iteration"], resume.get("best")
        log(f"resumed at iteration {iteration}")
    ema_model = None
    if args.ema > 0:  # the average starts at the current weights (or the saved average on resume)
        ema_model = copy.deepcopy(model).train()
        for p_ in ema_model.parameters():
            p_.requires_grad_(False)
        if resume is not None and resume.get("ema") is not None:
            ema_model.load_state_dict(resume["ema"])
    else:
        log(f"intention model: {parameter_count(model):,} parameters (D_pose {parameter_count(d_pose):,}, D_label "
            f"{parameter_count(d_label):,}); config {json.dumps({k: v for k, v in config.items() if k != 'dims_used'})}")

    windows = h36m.validation_windows(args.data_dir, h36m.ACTIONS, args.val_per_action, log=log)
    validator = Validator(windows, stats, list(h36m.ACTIONS))

    def snapshot() -> dict:
        return {
            "config": config, "model": {k: v.cpu() for k, v in model.state_dict().items()},
            "ema": None if ema_model is None else {k: v.cpu() for k, v in ema_model.state_dict().items()},
            "d_pose": d_pose.state_dict(), "d_label": d_label.state_dict(),
            "opt_g": opt_g.state_dict(), "opt_f": opt_f.state_dict(), "opt_dp": opt_dp.state_dict(),
            "opt_dl": opt_dl.state_dict(), "iteration": iteration, "best": best,
            "numpy_rng": rng.bit_generator.state, "torch_rng": torch.get_rng_state(),
            "args": {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items()
                     if k not in ("export", "from_", "resume")},
            "command": command, "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        }

    seed_len, future, g = h36m.SEED_FRAMES, args.future, model.lookahead
    groups = joint_groups(model.dims_used)
    lam = rec_weights(future, args.rec_frames, device)
    long_total = args.long_burn_in + args.long_frames if args.long_weight > 0 else 0
    t_last, acc, n_acc = time.time(), {}, 0
    while iteration < args.iterations:
        frames_np, labels_np, actions_np = labelled.sample(rng, args.batch, seed_len + future)
        frames = torch.from_numpy(frames_np).to(device)
        labels = torch.from_numpy(labels_np).to(device)
        seed, truth = frames[:, :seed_len], frames[:, seed_len:]
        burn = int(rng.integers(0, args.long_burn_in + 1)) if long_total else 0
        steps = future + (burn + args.long_frames if long_total else 0)
        acts = torch.from_numpy(actions_np).to(device)
        long_acts = acts
        act_steps = None  # one-hot per forecast step [B, steps + γ - 2, A]; the pose step producing S+j reads row j
        if model.actions:
            n_act = len(model.actions)
            if long_total and args.switch_prob > 0:
                switch = torch.from_numpy(rng.random(args.batch) < args.switch_prob).to(device)
                other = (acts + torch.from_numpy(rng.integers(1, n_act, args.batch)).to(device)) % n_act
                long_acts = torch.where(switch, other, acts)
            act_steps = F.one_hot(acts, n_act).to(frames.dtype)[:, None, :].repeat(1, steps + g - 2, 1)
            act_steps[:, future:] = F.one_hot(long_acts, n_act).to(frames.dtype)[:, None, :]

        def step_acts(a: int, b: int):
            return None if act_steps is None else act_steps[:, a:b]

        seed_labels, logits, probs = model.forecast_intentions(seed, steps + g - 2, labels=labels[:, :seed_len],
                                                               action=act_steps)
        # --- forecaster: eq. 4 and eq. 5
        ce = F.cross_entropy(logits[:, :future].reshape(-1, model.intentions), labels[:, seed_len:].reshape(-1))
        real_l = windows_of(F.one_hot(labels[:, seed_len:], model.intentions).float(), args.label_window, 5)
        fake_l = windows_of(probs[:, :future], args.label_window, 5)
        dl = gan_d_loss(d_label(real_l), d_label(fake_l.detach()))
        opt_dl.zero_grad(set_to_none=True)
        dl.backward()
        opt_dl.step()
        lf = ce + args.label_adv_weight * gan_g_loss(d_label(fake_l))
        # --- pose generator: eq. 8 and eq. 7 (+ the long-horizon windows)
        z = model.sample_noise(args.batch, seed)
        feats = model.intention_features_of(seed_labels, probs.detach(), steps, seed)
        state = model.initial_state(seed, z)
        pred, state = model.rollout(seed[:, -1], state, z, feats[:, :future], step_acts(0, future))
        rec = rec_loss(pred, truth, groups, lam)
        k = args.pose_context
        fake_p = with_context(windows_of(torch.cat([seed[:, -1:], pred], 1), args.pose_window, 3), seed, k)
        real_p = with_context(windows_of(torch.cat([seed[:, -1:], truth], 1), args.pose_window, 3), seed, k)
        long_fake = None
        drift_parts = [(pred, True)]
        if long_total:
            with torch.no_grad():
                x = pred[:, -1]
                hs = [h.detach() for h in state]
                if burn:
                    burned, hs = model.rollout(x, hs, z, feats[:, future : future + burn],
                                               step_acts(future, future + burn))
                    x = burned[:, -1]
                    drift_parts.append((burned, False))
            more, _ = model.rollout(x, hs, z, feats[:, future + burn :], step_acts(future + burn, steps))
            long_fake = with_context(windows_of(torch.cat([x[:, None], more], 1), args.pose_window, 3), seed, k)
            drift_parts.append((more, True))
        fakes = fake_p if long_fake is None else tuple(
            None if a is None else torch.cat([a, b]) for a, b in zip(fake_p, long_fake))
        dp = gan_d_loss(d_pose(*real_p), d_pose(*(None if t is None else t.detach() for t in fakes)))
        d_total = dp
        if args.r1 > 0:
            r1 = r1_penalty(d_pose, *real_p)
            d_total = dp + 0.5 * args.r1 * r1
        opt_dp.zero_grad(set_to_none=True)
        d_total.backward()
        opt_dp.step()
        adv = gan_g_loss(d_pose(*fake_p))
        lg = rec + args.adv_weight * adv
        terms = {"ce": ce.item(), "rec": rec.item(), "adv": adv.item(), "d_pose": dp.item(), "d_label": dl.item()}
        if args.r1 > 0:
            terms["r1"] = r1.item()
        if long_fake is not None:
            adv_long = gan_g_loss(d_pose(*long_fake))
            lg = lg + args.long_weight * args.adv_weight * adv_long
            terms["adv_long"] = adv_long.item()
        real = torch.cat([seed[:, -1:], truth], 1)
        moved = [torch.cat([seed[:, -1:], pred], 1)]
        if long_total:
            moved.append(torch.cat([x[:, None], more], 1))
        if args.speed_weight > 0:
            speed = sum(speed_loss(model, m, real) + accel_loss(model, m, real) for m in moved)
            lg = lg + args.speed_weight * speed
            terms["speed"] = speed.item()
        if args.root_weight > 0:
            root = sum(root_speed_loss(model, m, real) for m in moved)
            lg = lg + args.root_weight * root
            terms["root"] = root.item()
        if args.smooth_weight > 0:
            rough = sum(roughness_loss(model, m, real) for m in moved)
            lg = lg + args.smooth_weight * rough
            terms["rough"] = rough.item()
        if bank is not None:
            word = sum(word_realism_loss(model, m, a, bank) for m, a in zip(moved, (acts, long_acts)))
            lg = lg + args.word_weight * word
            terms["word"] = word.item()
        if crouch_floor is not None:
            crouch = sum(crouch_loss(model, m, a, crouch_floor) for m, a in zip(moved, (acts, long_acts)))
            lg = lg + args.crouch_weight * crouch
            terms["crouch"] = crouch.item()
        if tiptoe_ceiling is not None:
            tiptoe = sum(tiptoe_loss(model, m, a, tiptoe_ceiling) for m, a in zip(moved, (acts, long_acts)))
            lg = lg + args.tiptoe_weight * tiptoe
            terms["tiptoe"] = tiptoe.item()
        if posture is not None:
            held = sum(posture_loss(m, a, posture, args.posture_radius) for m, a in zip(moved, (acts, long_acts)))
            lg = lg + args.posture_weight * held
            terms["posture"] = held.item()
        # The loop's root, integrated once for the drift and skating terms.
        poses = scored_root_poses(model, seed, drift_parts) if args.drift_weight > 0 or args.skate_weight > 0 else None
        if args.drift_weight > 0:
            drift = drift_of_poses(*poses).to(lg.dtype)
            lg = lg + args.drift_weight * drift
            terms["drift"] = drift.item()
        if args.skate_weight > 0:
            skate = skate_of_poses(model, poses[1]).to(lg.dtype)
            lg = lg + args.skate_weight * skate
            terms["skate"] = skate.item()
        loss = lf + lg
        if not math.isfinite(loss.item()):
            raise SystemExit(f"error: loss became {loss.item()} at iteration {iteration + 1}; see {run_dir}")
        if iteration >= args.d_warmup:
            opt_g.zero_grad(set_to_none=True)
            opt_f.zero_grad(set_to_none=True)
            loss.backward()
            torch.nn.utils.clip_grad_norm_(generator, args.clip)
            torch.nn.utils.clip_grad_norm_(forecaster, args.clip)
            opt_g.step()
            opt_f.step()
        if ema_model is not None:
            with torch.no_grad():
                follow = 1.0 - args.ema if iteration >= args.ema_start else 1.0
                for pe, p_ in zip(ema_model.parameters(), model.parameters()):
                    pe.lerp_(p_, follow)
        iteration += 1
        for k, v in terms.items():
            acc[k] = acc.get(k, 0.0) + v
        n_acc += 1
        if iteration % args.log_every == 0 or iteration == args.iterations:
            now = time.time()
            means = {k: v / n_acc for k, v in acc.items()}
            spi = (now - t_last) / n_acc
            log(f"it {iteration:6d} " + " ".join(f"{k} {v:.4f}" for k, v in means.items()) + f" {spi:.2f} s/it")
            log.record(kind="train", iteration=iteration, s_per_it=spi, **means)
            t_last, acc, n_acc = now, {}, 0
        if iteration % args.val_every == 0 or iteration == args.iterations:
            scored = model if ema_model is None else ema_model
            scored.cpu()
            val = validate(scored, validator)
            scored.to(device)
            is_best = best is None or choice_key(val) < choice_key(best)
            if is_best:
                best = {k: v for k, v in val.items() if k != "per_action"} | {"iteration": iteration}
            ratios = val["long_speed"]
            lo = min(ratios.items(), key=lambda kv: kv[1])
            hi = max(ratios.items(), key=lambda kv: kv[1])
            log(f"val it {iteration:6d} npss_ref {val['npss_ref']:.4f} euler80 {val['euler_80']:.3f} "
                f"speed(8-12s) min {lo[1]:.2f} ({lo[0]}) max {hi[1]:.2f} ({hi[0]}) "
                f"median {np.median(list(ratios.values())):.2f}{'  [best]' if is_best else ''}")
            log.record(kind="val", iteration=iteration, best=is_best, **val)
            if is_best:
                atomic_save(snapshot(), run_dir / BEST)
        if iteration % args.checkpoint_every == 0 or iteration == args.iterations:
            atomic_save(snapshot(), ckpt_path)
    log(f"done: iteration {iteration}" + (f", best at {best['iteration']}" if best else ""))
    log.close()


def export(out: Path, ckpt: Path, dtype: str, argv: list[str], noise_scale: float | None = None,
           choice: str | None = None) -> None:
    state = load_checkpoint(ckpt)
    config = dict(state["config"])
    if noise_scale is not None:
        config["noise_scale"] = noise_scale
    model = IntentionModel(config)  # ValueError (exit 2) for a noise scale out of range
    averaged = state.get("ema") is not None
    model.load_state_dict(state["ema"] if averaged else state["model"])
    best = state.get("best") or {}
    provenance = {
        "data": "Human3.6M S1, S6, S7, S8, S9, S11 (25 Hz), all 15 actions",
        "iterations": int(state["iteration"]),
        "date": state["date"],
        "command": state["command"],
        "export_command": "python -m training.train_intention " + shlex.join(argv),
        "checkpoint_choice": choice or "train_intention module doc (S5 validation windows, 12 s speed ratios, then NPSS)",
    }
    if best.get("iteration") == int(state["iteration"]):
        provenance["validation"] = {k: best[k] for k in ("npss_ref", "euler_80", "iteration") if k in best}
    if noise_scale is not None:
        provenance["noise_scale"] = "chosen at export (weights/README.md): drawn z ~ N(0, s² I)"
    if averaged:
        provenance["weights"] = f"moving average of the training weights, decay {state['args']['ema']} per iteration"
    save_weights(model, out, provenance, dtype=getattr(torch, dtype))
    print(f"wrote {out} ({parameter_count(model):,} parameters, {dtype}, iteration {state['iteration']})")


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser().parse_args(argv)
    try:
        if args.export is not None:
            if args.from_ is None:
                raise SystemExit("error: --export needs --from CKPT")
            export(args.export, args.from_, args.dtype, argv, args.noise_scale, args.choice)
        else:
            train(args, argv)
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
