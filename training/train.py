"""Train VGRU-d / GRU-d on H3.6M with the multi-objective loss of Gopalakrishnan et al. 2019 (section 3.4, equation 6).

Gopalakrishnan et al., A Neural Temporal Model for Human Motion Prediction (CVPR 2019), sections 3.4 and 4.1:
open-loop squared error over all steps + lambda x closed-loop squared error over the horizon, lambda on the
published step schedule, RMSprop, global gradient-norm clipping, step learning-rate decay.

    python -m training.train --run-dir training/runs/NAME [options]      # train (or --resume)
    python -m training.train --export OUT.safetensors --from RUN/best.pt --dtype float16
    python -m training.train --export OUT.safetensors --from A/best.pt B/best.pt ...   # mean of their weights

Checkpoints (atomic) hold model, optimizer and RNG states, so `--resume` continues exactly. `best.pt` is the
checkpoint with the best validation score (reference-variant NPSS over the S5 validation windows, mean over
actions; ties broken by Euler error at 80 ms). A blow-up of the closed-loop loss (non-finite, or 10x its
recent median) rolls back to the last checkpoint and halves the learning rate.

`--ema D` keeps an exponential moving average of the weights (decay D per iteration); validation, `best.pt`
selection and export then use the averaged weights, which smooth out the iteration-to-iteration wander of the
closed-loop error. `--branch-from RUN/x.pt` starts a new run from another run's checkpoint (its weights, or their
average if it kept one; optimizer state; iteration), so the lambda and learning-rate schedules continue from there
under the new run's settings and seed. With `--actions` naming some of a multi-action model's actions, the branch
fine-tunes it on them (the model keeps all its labels). `--spectral-weight W` adds W x the closed loop's NPSS to
the loss; `--spectral-balance R` instead scales that term's gradient to R x the squared error's every iteration.
Exporting several checkpoints of one model (e.g. sibling branches) writes the mean of their weights.
"""

from __future__ import annotations

import argparse
import collections
import copy
import datetime
import json
import math
import os
import shlex
import sys
import time
from pathlib import Path

import numpy as np
import torch

from . import data as h36m
from . import metrics_np
from .checkpoint_io import BEST, CHECKPOINT, atomic_save, read_checkpoint
from .features import DerivativeHistory
from .models import build_model, make_config, parameter_count
from .long_horizon import (
    MOTION_LOSS, accel_loss, choice_key, long_closed_loop, long_motion_loss, speed_loss, speed_ratios,
)
from .spectral import spectral_loss

#: Iterations at which the published lambda schedule steps up, and the values from then on.
LAMBDA_STEPS = ((500, 0.2), (1000, 0.4), (2000, 0.6), (4000, 0.8), (7000, 1.0))
#: Arguments that may be changed on --resume (they do not change what is computed, except --iterations
#: which only extends or shortens the run).
#: Closed-loop losses (lambda > 0) needed before the blow-up guard compares against their median.
MIN_HISTORY = 20
RESUME_OVERRIDABLE = ("iterations", "run_dir", "data_dir", "log_every", "val_every", "checkpoint_every", "threads", "device")


# ------------------------------------------------------------------------------------------ schedules


def lambda_at(iteration: int, scale: float = 1.0) -> float:
    """Closed-loop weight at `iteration` (1-based): 0 until 500, 0.2, 0.4 from 1000, 0.6 from 2000, 0.8 from 4000,
    1.0 from 7000. `scale` multiplies the step iterations (0.5 = the same schedule over half the iterations)."""
    lam = 0.0
    for start, value in LAMBDA_STEPS:
        if iteration >= start * scale:
            lam = value
    return lam


def lr_at(iteration: int, base: float, decay: float, every: int) -> float:
    """Learning rate at `iteration` (1-based): base x decay^(number of completed `every` blocks)."""
    return base * decay ** ((iteration - 1) // every) if every > 0 else base


# ------------------------------------------------------------------------------------------ arguments


def positive_int(text: str) -> int:
    """argparse type: an integer >= 1."""
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def build_parser() -> argparse.ArgumentParser:
    """All command-line flags."""
    p = argparse.ArgumentParser(prog="python -m training.train", description=__doc__.split("\n\n")[0])
    g = p.add_argument_group("model")
    g.add_argument("--model", default="vgru-d", choices=["vgru-d", "gru-d"])
    g.add_argument("--hidden", type=int, default=512)
    g.add_argument("--plan-hidden", type=int, default=None, help="plan GRU units (vgru-d; default = --hidden)")
    g.add_argument("--layers", type=int, default=None, help="GRU layers (gru-d: default 2; vgru-d: 1)")
    g.add_argument("--residual", default="true", choices=["true", "false"])
    g.add_argument("--convention", default=None, choices=["paper", "pytorch"], help="default: paper for vgru-d")
    g.add_argument("--dropout", type=float, default=0.3)
    g = p.add_argument_group("data")
    g.add_argument("--data-dir", default=None, help="H3.6M dataset dir (default $MOTION_DATA_DIR/h3.6m/dataset)")
    g.add_argument("--actions", default="all", help="'all' or comma-separated action labels")
    g.add_argument("--val-per-action", type=int, default=4)
    g.add_argument("--val-stride", type=positive_int, default=None,
                   help="frames between validation window starts (default: windows do not overlap)")
    g.add_argument("--seed-frames", type=int, default=h36m.SEED_FRAMES, help="seed length S of training windows")
    g.add_argument("--horizon", type=int, default=h36m.HORIZON, help="predicted frames T of training windows")
    g = p.add_argument_group("optimisation")
    g.add_argument("--iterations", type=int, default=10000)
    g.add_argument("--batch", type=int, default=32)
    g.add_argument("--loss", default="multi-objective", choices=["multi-objective", "auto-conditioning"])
    g.add_argument("--ac-length", type=int, default=5, help="auto-conditioning: ground-truth/self-fed block length")
    g.add_argument("--spectral-weight", type=float, default=0.0,
                   help="adds this x the closed loop's NPSS (reference variant, on Euler angles) to the loss "
                   "while lambda > 0; 0 = the paper's loss")
    g.add_argument("--spectral-balance", type=float, default=0.0, metavar="R",
                   help="instead of a fixed --spectral-weight: each iteration, scale the spectral term's gradient to "
                   "R x the norm of the squared-error terms' gradient (one more backward pass through the closed loop)")
    g.add_argument("--schedule-scale", type=float, default=1.0, help="scales the lambda and lr step iterations")
    g.add_argument("--closed-loop-weight", type=float, default=None, metavar="LAMBDA",
                   help="a constant closed-loop weight instead of the lambda schedule (fine-tunes)")
    g.add_argument("--feed-noise", type=float, default=0.0, metavar="SIGMA",
                   help="Gaussian noise (normalized units) added to every fed-back frame of the training closed loop")
    g.add_argument("--speed-weight", type=float, default=0.0, metavar="W",
                   help="adds W x the closed loop's joint speed + acceleration penalty (long_horizon.speed_loss)")
    g.add_argument("--motion-loss", default="hinge", choices=["hinge", "log"],
                   help="form of the --speed-weight and --long-weight terms (long_horizon.ratio_loss)")
    g.add_argument("--long-weight", type=float, default=0.0, metavar="W",
                   help="adds W x the long-horizon term (long_horizon.long_motion_loss): the closed loop run on "
                        "without gradient for 0..--long-burn-in frames, then --long-frames with it, joint speed and "
                        "acceleration matched to the truth's")
    g.add_argument("--drift-weight", type=float, default=0.0, metavar="W",
                   help="with --long-weight: adds W x the root-drift penalty of the long term's frames "
                        "(root_drift.drift_penalty: hip height and lean of the integrated root held within 100 mm and "
                        "10 degrees of the last seed frame's)")
    g.add_argument("--long-burn-in", type=int, default=250, metavar="FRAMES")
    g.add_argument("--long-frames", type=int, default=50, metavar="FRAMES")
    g.add_argument("--long-batch", type=int, default=8, help="sequences of the long-horizon term per iteration")
    g.add_argument("--lr", type=float, default=2e-4)
    g.add_argument("--lr-decay", type=float, default=0.6)
    g.add_argument("--lr-every", type=int, default=2000, help="decay period (before --schedule-scale)")
    g.add_argument("--rms-decay", type=float, default=0.9)
    g.add_argument("--momentum", type=float, default=0.0)
    g.add_argument("--centered", default="true", choices=["true", "false"])
    g.add_argument("--rms-eps", type=float, default=1e-8)
    g.add_argument("--clip", type=float, default=5.0)
    g.add_argument("--blowup-factor", type=float, default=10.0, help="closed-loop loss > this x recent median = blow-up")
    g.add_argument("--max-rollbacks", type=int, default=20, help="stop with an error after this many rollbacks")
    g.add_argument("--ema", type=float, default=0.0,
                   help="weight moving-average decay per iteration (0 = off); validation, best.pt and export use it")
    g.add_argument("--ema-start", type=int, default=0, metavar="IT",
                   help="with --ema: before this iteration the average just follows the weights (a fresh run's first "
                   "iterations would otherwise stay in the average for thousands of iterations)")
    g.add_argument("--seed", type=int, default=1234)
    g.add_argument("--choose", default="npss", choices=["npss", "long"],
                   help="best.pt rule: npss = lowest validation NPSS; long = every action's 12 s speed ratio >= 0.5 "
                        "first, then NPSS, else the highest smallest ratio (long_horizon.choice_key)")
    g = p.add_argument_group("run")
    g.add_argument("--run-dir", default=None)
    g.add_argument("--resume", action="store_true", help="continue from RUN_DIR/last.pt")
    g.add_argument("--init-weights", default=None, metavar="FILE.safetensors",
                   help="a new run whose model starts from an exported weights file (its config; fresh optimizer, "
                        "iteration 0); the size flags do not apply")
    g.add_argument("--branch-from", default=None, metavar="CHECKPOINT",
                   help="start this new run from another run's checkpoint (model config, weights, optimizer state and "
                   "iteration from it; every other setting, and the RNG seed, from this command line)")
    g.add_argument("--log-every", type=int, default=10)
    g.add_argument("--val-every", type=int, default=100)
    g.add_argument("--checkpoint-every", type=int, default=100)
    g.add_argument("--threads", type=int, default=1, help="torch threads (1: OpenMP barriers stall badly on a shared CPU)")
    g.add_argument("--device", default="cpu", help="cpu or cuda (validation runs on the CPU either way)")
    g = p.add_argument_group("export")
    g.add_argument("--export", default=None, metavar="OUT.safetensors")
    g.add_argument("--from", dest="from_ckpt", default=None, nargs="+", metavar="CHECKPOINT",
                   help="checkpoint(s) to export; several (of one model, e.g. branches of one parent) are averaged")
    g.add_argument("--dtype", default="float16", choices=["float32", "float16", "bfloat16"])
    return p


def explicit_args(argv: list[str]) -> set[str]:
    """Names of the flags given explicitly on the command line."""
    p = build_parser()
    for a in p._actions:
        a.default = argparse.SUPPRESS
    ns, _ = p.parse_known_args(argv)
    return set(vars(ns))


def parse_actions(spec: str) -> list[str]:
    """'all' -> the 15 actions in h36m.md order; else the listed ones, in that order, checked."""
    if spec == "all":
        return list(h36m.ACTIONS)
    acts = [a.strip() for a in spec.split(",") if a.strip()]
    bad = [a for a in acts if a not in h36m.ACTIONS]
    if bad or not acts:
        raise SystemExit(f"error: unknown action(s) {bad}; valid: all or {', '.join(h36m.ACTIONS)}")
    order = [a for a in h36m.ACTIONS if a in acts]
    return order


def model_config(args, dims_used) -> dict:
    """Weights-schema config for the chosen model and sizes."""
    kw = {
        "seed_frames": args.seed_frames,
        "horizon": args.horizon,
        "hidden": args.hidden,
        "residual": args.residual == "true",
        "dims_used": [int(d) for d in dims_used],
    }
    if args.convention:
        kw["gru_convention"] = args.convention
    if args.model == "vgru-d":
        kw["plan_hidden"] = args.plan_hidden or args.hidden
        kw["actions"] = parse_actions(args.actions)
        kw["layers"] = 1
    else:
        kw["layers"] = args.layers or 2
    return make_config(args.model, **kw)


def init_residual_decoder(model) -> None:
    """Residual models predict a per-step change: start near zero velocity. With the generic init (orthogonal,
    bias 0.1) the closed loop drifts by ~0.1-0.5 std per step (closed-loop loss ~10^3 at 100 steps), and RMSprop,
    whose steps are ~lr, needs ~500 iterations to unlearn a 0.1 bias. Uniform(-0.04, 0.04) weights and zero bias,
    as in the residual model of Martinez et al. (CVPR 2017) that Gopalakrishnan et al. 2019 builds on."""
    with torch.no_grad():
        model.decoder.weight.uniform_(-0.04, 0.04)
        model.decoder.bias.zero_()


# ------------------------------------------------------------------------------------------ losses


def sample_eps(model, batch: int) -> torch.Tensor | None:
    """One plan noise vector per sequence (shared by the open- and closed-loop passes of a batch)."""
    if hasattr(model, "plan"):
        return torch.randn(batch, model.plan_size, device=model.plan.mu.device)
    return None


def multi_objective_terms(model, frames: torch.Tensor, actions: torch.Tensor, seed_frames: int, horizon: int,
                          spectral: bool = False, feed_noise: float = 0.0, motion: bool = False):
    """Open-loop mean squared error over all steps and closed-loop mean squared error over the horizon; with
    `spectral`, also the closed loop's NPSS (reference variant, `training/spectral.py`), else None; with `motion`,
    also the closed loop's joint speed and acceleration against the truth's (`long_horizon.speed_loss` +
    `accel_loss`, the last seed frame prepended to both), else None. `feed_noise`: the closed loop's fed-back
    frames get that much Gaussian noise (`MotionModel.closed_loop`).

    frames [B, seed+horizon+1, O]: open loop reads frames 0..S+T-1 and predicts 1..S+T; the closed loop is
    seeded with 0..S-1 and predicts S..S+T-1 from its own outputs. The plan covers S+T steps in both."""
    steps = seed_frames + horizon
    eps = sample_eps(model, frames.shape[0])
    ol = model.open_loop(frames[:, :steps], actions, eps)
    ol_loss = ((ol - frames[:, 1 : steps + 1]) ** 2).mean()
    cl = model.closed_loop(frames[:, :seed_frames], horizon, actions, eps, feed_noise=feed_noise)
    cl_loss = ((cl - frames[:, seed_frames:steps]) ** 2).mean()
    spec = spectral_loss(model, cl, frames[:, seed_frames:steps]) if spectral else None
    moving = None
    if motion:
        truth = frames[:, seed_frames - 1 : steps]
        pred = torch.cat([truth[:, :1], cl], dim=1)
        moving = speed_loss(model, pred, truth) + accel_loss(model, pred, truth)
    return ol_loss, cl_loss, spec, moving


def auto_conditioning_loss(model, frames: torch.Tensor, actions: torch.Tensor, seed_frames: int, horizon: int, length: int):
    """Auto-conditioning baseline (VGRU-ac): over the seed + horizon steps, alternate `length` ground-truth-fed
    and `length` self-fed steps (the seed is always ground truth); squared error over all steps."""
    steps = seed_frames + horizon
    eps = sample_eps(model, frames.shape[0])
    ctx = model._begin(frames.shape[0], steps, model.action_indices(actions, frames.shape[0], frames.device), eps, frames)
    history = DerivativeHistory(model.derivative_order)
    outputs = []
    prev = None
    for t in range(steps):
        self_fed = t >= seed_frames and ((t - seed_frames) // length) % 2 == 1
        x = prev if self_fed else frames[:, t]
        feats = model.input_dropout(history.push(x)).unsqueeze(1)
        out = model._decode(model._run(ctx, feats, t), x.unsqueeze(1))
        outputs.append(out)
        prev = out[:, 0]
    pred = torch.cat(outputs, dim=1)
    return ((pred - frames[:, 1 : steps + 1]) ** 2).mean()


def balanced_backward(model, mse: torch.Tensor, spec: torch.Tensor, ratio: float) -> float:
    """Sets the parameters' gradients to grad(mse) + w grad(spec) with w chosen so that |w grad(spec)| = ratio
    |grad(mse)| (global L2 norms): the spectral term then steers the update without taking it over, however its
    scale drifts during training (a fixed weight of 0.25 gave it 5-10x the squared error's gradient norm).
    Returns the effective weight w."""
    params = [p for p in model.parameters() if p.requires_grad]
    g_mse = torch.autograd.grad(mse, params, retain_graph=True, allow_unused=True)
    g_spec = torch.autograd.grad(spec, params, allow_unused=True)
    g_mse = [torch.zeros_like(p) if g is None else g for p, g in zip(params, g_mse)]
    g_spec = [torch.zeros_like(p) if g is None else g for p, g in zip(params, g_spec)]
    n_mse = torch.sqrt(sum((g.double() ** 2).sum() for g in g_mse))
    n_spec = torch.sqrt(sum((g.double() ** 2).sum() for g in g_spec))
    w = float(ratio * n_mse / n_spec) if float(n_spec) > 0 else 0.0
    for p, a, b in zip(params, g_mse, g_spec):
        p.grad = a + w * b
    return w


# ------------------------------------------------------------------------------------------ validation


class Validator:
    """Fixed S5 validation windows, scored with the protocol's metrics on full frames (eps = 0 for the plan).

    Windows hold the protocol's 50 seed + 100 frames; a model trained with other lengths is seeded with the last
    `seed_frames` of the 50 and scored on the first `horizon` frames after them."""

    def __init__(self, windows, stats: h36m.NormStats, actions: list[str], seed_frames: int = h36m.SEED_FRAMES,
                 horizon: int = h36m.HORIZON):
        self.actions = [a for a in actions if any(w.action == a for w in windows)]
        self.windows = [w for w in windows if w.action in self.actions]
        if not self.windows:
            raise ValueError(f"no validation windows for the actions {actions}")
        self.stats = stats
        full = np.stack([w.frames for w in self.windows])  # [N, 150, F]
        split = h36m.SEED_FRAMES
        self.seed_full = full[:, split - min(seed_frames, split) : split]
        self.gt_full = full[:, split : split + horizon]
        self.seed_norm = torch.from_numpy(stats.normalize(self.seed_full).astype(np.float32))
        self.window_actions = [w.action for w in self.windows]

    def baseline(self) -> dict:
        """Zero-velocity scores of the same windows."""
        return self.score(metrics_np.zero_velocity(self.seed_full, self.gt_full.shape[1]))

    def __call__(self, model) -> dict:
        return self.score(self.predict(model))

    @torch.no_grad()
    def predict(self, model, noise_seed: int | None = None) -> np.ndarray:
        """The model's closed-loop predictions of every window's horizon, full frames [N, horizon, F]. The plan noise
        is eps = 0 by default; with `noise_seed`, one eps ~ N(0, I) per window drawn from that seed (what
        `motion-cli eval` does, which samples the plan noise)."""
        was_training = model.training
        model.eval()
        try:
            horizon = self.gt_full.shape[1]
            acts = torch.tensor(
                [model.actions.index(a) for a in self.window_actions] if model.actions else [0] * len(self.windows)
            )
            eps = None
            if hasattr(model, "plan"):
                shape = (len(self.windows), model.plan_size)
                eps = torch.zeros(shape) if noise_seed is None else \
                    torch.randn(shape, generator=torch.Generator().manual_seed(noise_seed))
            pred = model.closed_loop(self.seed_norm, horizon, acts, eps).double().numpy()
        finally:
            model.train(was_training)
        return self.stats.unnormalize(pred)

    def score(self, pred_full: np.ndarray) -> dict:
        """Protocol scores of full-frame predictions [N, horizon, F] of these windows (per action and mean)."""
        per_action = {}
        for a in self.actions:
            idx = [i for i, wa in enumerate(self.window_actions) if wa == a]
            per_action[a] = metrics_np.score_windows(self.gt_full[idx], pred_full[idx])
        summary = metrics_np.summarize(per_action)
        summary["per_action"] = {
            a: {
                "npss_ref": v["npss_ref"],
                "euler_80": float(v["euler"][1]),
                "euler_1000": float(v["euler"][24]) if len(v["euler"]) > 24 else float("nan"),
                "speed_ratio": v["speed_ratio"],
            }
            for a, v in per_action.items()
        }
        return summary


def better(a: dict | None, b: dict | None) -> bool:
    """Is validation result `a` better than `b`? Lower reference NPSS, ties by Euler error at 80 ms."""
    if a is None or not math.isfinite(a["npss_ref"]):
        return False
    if b is None:
        return True
    return (a["npss_ref"], a["euler_80"]) < (b["npss_ref"], b["euler_80"])


# ------------------------------------------------------------------------------------------ checkpoints


#: What every checkpoint of `train` holds (load_checkpoint refuses a file without them).
CHECKPOINT_KEYS = frozenset({"config", "model", "optimizer", "state", "args", "command"})


def load_checkpoint(path: Path) -> dict:
    """A checkpoint written by this module. Raises ValueError naming the file if it is not one."""
    return read_checkpoint(path, CHECKPOINT_KEYS, "training")


def checkpoint_weights(ck: dict) -> dict:
    """The state dict a checkpoint's model is validated and exported with: the weight average if the run kept one."""
    return ck["ema"] if ck.get("ema") is not None else ck["model"]


class Logger:
    """Progress lines to stdout and RUN_DIR/train.log; structured records to RUN_DIR/metrics.jsonl."""

    def __init__(self, run_dir: Path, quiet: bool = False):
        self.log = open(run_dir / "train.log", "a", buffering=1)
        self.metrics = open(run_dir / "metrics.jsonl", "a", buffering=1)
        self.quiet = quiet

    def __call__(self, msg: str) -> None:
        line = f"{datetime.datetime.now(datetime.timezone.utc).strftime('%H:%M:%S')} {msg}"
        self.log.write(line + "\n")
        if not self.quiet:
            print(line, flush=True)

    def record(self, **kv) -> None:
        self.metrics.write(json.dumps(kv) + "\n")

    def close(self) -> None:
        self.log.close()
        self.metrics.close()


# ------------------------------------------------------------------------------------------ training


def make_optimizer(model, args) -> torch.optim.Optimizer:
    """RMSprop with the run's settings."""
    return torch.optim.RMSprop(
        model.parameters(),
        lr=args.lr,
        alpha=args.rms_decay,
        eps=args.rms_eps,
        momentum=args.momentum,
        centered=args.centered == "true",
    )


def train(args, argv: list[str] | None = None, dataset=None, val_windows=None, quiet: bool = False) -> dict:
    """Run (or resume) training as configured by `args`. `dataset`/`val_windows` may be passed preloaded
    (tests). Returns a summary dict (last iteration, losses, best validation)."""
    argv = sys.argv[1:] if argv is None else argv
    if not args.run_dir:
        raise SystemExit("error: --run-dir is required for training")
    run_dir = Path(args.run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    ckpt_path = run_dir / CHECKPOINT
    resume_state = None
    if args.resume:
        if not ckpt_path.is_file():
            raise SystemExit(f"error: --resume but {ckpt_path} does not exist")
        try:
            resume_state = load_checkpoint(ckpt_path)
        except ValueError as e:
            raise SystemExit(f"error: --resume: {e}") from None
        given = explicit_args(argv)
        saved = dict(resume_state["args"])
        for k in RESUME_OVERRIDABLE:
            if k in given:
                saved[k] = getattr(args, k)
        saved["resume"] = True
        args = argparse.Namespace(**{**vars(args), **saved})
    branch_state = None
    if args.branch_from and resume_state is None:
        if ckpt_path.exists():
            raise SystemExit(f"error: {ckpt_path} exists: --resume it, or branch into a new --run-dir")
        if not Path(args.branch_from).is_file():
            raise SystemExit(f"error: --branch-from {args.branch_from} does not exist")
        try:
            branch_state = load_checkpoint(Path(args.branch_from))
        except ValueError as e:
            raise SystemExit(f"error: --branch-from {e}") from None
    torch.set_num_threads(args.threads)
    MOTION_LOSS[0] = getattr(args, "motion_loss", "hinge")
    log = Logger(run_dir, quiet)
    command = resume_state["command"] if resume_state else "python -m training.train " + shlex.join(argv)
    log(("resuming: " if resume_state else "starting: ") + command)

    actions = parse_actions(args.actions)
    if dataset is None:
        dataset = h36m.load_training_set(args.data_dir, actions, log=log)
    if val_windows is None:
        val_windows = h36m.validation_windows(
            args.data_dir, actions, args.val_per_action, log=log, stride=args.val_stride
        )
    try:
        validator = Validator(val_windows, dataset.stats, actions, args.seed_frames, args.horizon)
    except ValueError as e:
        raise SystemExit(f"error: {e}") from None
    init_model = None
    if args.init_weights and resume_state is None:
        if branch_state is not None:
            raise SystemExit("error: give --init-weights or --branch-from, not both")
        if ckpt_path.exists():
            raise SystemExit(f"error: {ckpt_path} exists: --resume it, or start into a new --run-dir")
        from .export import load_weights

        try:
            init_model = load_weights(args.init_weights)
        except (OSError, ValueError, KeyError) as e:
            raise SystemExit(f"error: --init-weights {args.init_weights}: {e}") from None
        config = init_model.config
        log(f"initial weights from {args.init_weights}")
    elif branch_state is not None:
        config = branch_state["config"]  # the model is the parent's; its size flags do not apply
        missing = [a for a in actions if config.get("actions") is not None and a not in config["actions"]]
        if missing:
            raise SystemExit(f"error: --branch-from model is conditioned on {config['actions']}, not on {missing}")
    elif resume_state is not None:
        config = resume_state["config"]
    else:
        config = model_config(args, dataset.stats.dims_used)
    if resume_state is None:
        torch.manual_seed(args.seed)
    model = build_model(config, dropout=args.dropout)
    if model.residual:
        init_residual_decoder(model)
    model.norm.set_stats(torch.from_numpy(dataset.stats.mean).float(), torch.from_numpy(dataset.stats.std).float())
    model.train()
    device = torch.device(args.device)
    model.to(device)  # before the optimizer; checkpoints load into it wherever they were saved (read as CPU tensors)
    opt = make_optimizer(model, args)
    rng = np.random.default_rng(args.seed)
    # Batch action indices index dataset.actions; the model's one-hot indexes config["actions"]. They are the same
    # list except when a branch fine-tunes a multi-action model on some of its actions.
    label_map = np.array(
        [config["actions"].index(a) for a in dataset.actions] if config.get("actions") else [0] * len(dataset.actions),
        dtype=np.int64,
    )

    state = {"iteration": 0, "lr_scale": 1.0, "cl_history": [], "best": None, "best_iteration": None, "rollbacks": 0}
    parent = None
    if init_model is not None:
        model.load_state_dict(init_model.state_dict())
        parent = {"weights": str(args.init_weights), "provenance": getattr(init_model, "provenance", None)}
    if branch_state is not None:
        model.load_state_dict(checkpoint_weights(branch_state))  # the parent's average if it kept one
        opt.load_state_dict(branch_state["optimizer"])
        for g in opt.param_groups:  # this run's optimiser settings, the parent's running averages
            g.update(alpha=args.rms_decay, eps=args.rms_eps, momentum=args.momentum)
        bs = branch_state["state"]
        state.update(iteration=bs["iteration"], lr_scale=bs["lr_scale"], cl_history=list(bs["cl_history"]))
        parent = {"checkpoint": str(args.branch_from), "iteration": bs["iteration"], "command": branch_state["command"]}
        log(f"branched from {args.branch_from} at iteration {bs['iteration']} (parent: {branch_state['command']})")
    if resume_state is not None:
        model.load_state_dict(resume_state["model"])
        opt.load_state_dict(resume_state["optimizer"])
        rng.bit_generator.state = resume_state["np_rng"]
        torch.set_rng_state(resume_state["torch_rng"])
        state = dict(resume_state["state"])
        parent = resume_state.get("parent")
        log(f"resumed at iteration {state['iteration']} (lr scale {state['lr_scale']}, best {state['best_iteration']})")
    else:
        log(f"model {args.model}: {parameter_count(model):,} parameters; config {json.dumps(config)}")
        base = validator.baseline()
        log(f"validation zero-velocity: {fmt_val(base)}")
        log.record(kind="baseline", **base)

    # Weight average (--ema): starts from the current weights (or the saved average on resume).
    ema_model = None
    if args.ema > 0:
        ema_model = copy.deepcopy(model).eval()
        for p_ in ema_model.parameters():
            p_.requires_grad_(False)
        saved_ema = (resume_state or {}).get("ema")  # a branch starts its average at its (averaged) start weights
        if saved_ema is not None:
            ema_model.load_state_dict(saved_ema)

    def snapshot() -> dict:
        return {
            "model": model.state_dict(),
            "ema": ema_model.state_dict() if ema_model is not None else None,
            "parent": parent,
            "optimizer": opt.state_dict(),
            "np_rng": rng.bit_generator.state,
            "torch_rng": torch.get_rng_state(),
            "state": dict(state, cl_history=list(state["cl_history"])),
            "args": {k: v for k, v in vars(args).items() if k not in ("export", "from_ckpt", "resume")},
            "config": config,
            "command": command,
            "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        }

    if resume_state is None:
        atomic_save(snapshot(), ckpt_path)  # iteration 0: a rollback target from the start

    seed_frames, horizon = args.seed_frames, args.horizon
    lr_every = max(1, int(round(args.lr_every * args.schedule_scale)))
    history = collections.deque(state["cl_history"], maxlen=100)
    t_last = time.time()
    acc = {"ol": 0.0, "cl": 0.0, "n": 0, "ncl": 0}
    last_ol = last_cl = float("nan")
    while state["iteration"] < args.iterations:
        it = state["iteration"] + 1
        lam = lambda_at(it, args.schedule_scale) if args.closed_loop_weight is None else args.closed_loop_weight
        lr = lr_at(it, args.lr, args.lr_decay, lr_every) * state["lr_scale"]
        for g in opt.param_groups:
            g["lr"] = lr
        frames_np, acts_np = dataset.sample_batch(rng, args.batch, seed_frames + horizon + 1)
        frames = torch.from_numpy(frames_np).to(device)
        acts = torch.from_numpy(label_map[acts_np]).to(device)
        spec = None
        if args.loss == "auto-conditioning":
            ol_loss = auto_conditioning_loss(model, frames, acts, seed_frames, horizon, args.ac_length)
            cl_loss = torch.tensor(float("nan"))
            total = ol_loss
        elif lam > 0:
            w_spec = args.spectral_weight
            want_spec = w_spec > 0 or args.spectral_balance > 0
            ol_loss, cl_loss, spec, moving = multi_objective_terms(
                model, frames, acts, seed_frames, horizon, want_spec, args.feed_noise, args.speed_weight > 0
            )
            total = ol_loss + lam * cl_loss
            if args.long_weight > 0:
                burn = int(rng.integers(0, args.long_burn_in + 1))
                long_np, long_acts = dataset.sample_batch(
                    rng, args.long_batch, seed_frames + args.long_burn_in + args.long_frames + 1
                )
                long_term = long_motion_loss(
                    model, torch.from_numpy(long_np).to(device), torch.from_numpy(label_map[long_acts]).to(device), seed_frames, burn,
                    args.long_frames, sample_eps(model, args.long_batch), args.feed_noise,
                    drift_weight=args.drift_weight,
                )
                total = total + args.long_weight * long_term
                acc["long"] = acc.get("long", 0.0) + long_term.item()
            if moving is not None:
                total = total + args.speed_weight * moving
                acc["motion"] = acc.get("motion", 0.0) + moving.item()
            if spec is not None:
                if args.spectral_balance <= 0:
                    total = total + w_spec * spec
                acc["spec"] = acc.get("spec", 0.0) + spec.item()
        else:
            steps = seed_frames + horizon
            eps = sample_eps(model, frames.shape[0])
            ol = model.open_loop(frames[:, :steps], acts, eps)
            ol_loss = ((ol - frames[:, 1 : steps + 1]) ** 2).mean()
            total = ol_loss
            cl_loss = torch.tensor(float("nan"))
            if it % args.log_every == 0:  # measured for the log only; RNG forked so runs stay reproducible
                with torch.no_grad(), torch.random.fork_rng():
                    cl = model.closed_loop(frames[:, :seed_frames], horizon, acts, eps)
                    cl_loss = ((cl - frames[:, seed_frames:steps]) ** 2).mean()
        ol_v, cl_v = ol_loss.item(), cl_loss.item()
        blown = not math.isfinite(total.item())
        if lam > 0 and math.isfinite(cl_v) and len(history) >= MIN_HISTORY:
            blown = blown or cl_v > args.blowup_factor * float(np.median(history))
        if blown:
            state["rollbacks"] += 1
            median = float(np.median(history)) if history else float("nan")
            log(f"BLOW-UP at it {it}: open-loop {ol_v:.4g} closed-loop {cl_v:.4g} (recent median {median:.4g})")
            if state["rollbacks"] > args.max_rollbacks:
                log(f"giving up after {state['rollbacks'] - 1} rollbacks (--max-rollbacks {args.max_rollbacks})")
                log.close()
                raise SystemExit(f"error: training unstable: {state['rollbacks'] - 1} rollbacks; see {run_dir / 'train.log'}")
            good = load_checkpoint(ckpt_path)
            model.load_state_dict(good["model"])
            opt.load_state_dict(good["optimizer"])
            if ema_model is not None and good.get("ema") is not None:
                ema_model.load_state_dict(good["ema"])
            state["iteration"] = good["state"]["iteration"]
            state["lr_scale"] *= 0.5
            log(f"rolled back to it {state['iteration']} ({ckpt_path.name}), lr scale now {state['lr_scale']}")
            log.record(kind="rollback", iteration=it, to=state["iteration"], ol=ol_v, cl=cl_v, lr_scale=state["lr_scale"])
            continue
        opt.zero_grad(set_to_none=True)
        if spec is not None and args.spectral_balance > 0:
            acc["w_spec"] = acc.get("w_spec", 0.0) + balanced_backward(model, total, spec, args.spectral_balance)
        else:
            total.backward()
        gnorm = float(torch.nn.utils.clip_grad_norm_(model.parameters(), args.clip))
        opt.step()
        if ema_model is not None:
            with torch.no_grad():
                follow = 1.0 - args.ema if it >= args.ema_start else 1.0
                for pe, p_ in zip(ema_model.parameters(), model.parameters()):
                    pe.lerp_(p_, follow)
        state["iteration"] = it
        last_ol, last_cl = ol_v, cl_v
        if lam > 0 and math.isfinite(cl_v):
            history.append(cl_v)
        acc["ol"] += ol_v
        acc["n"] += 1
        if math.isfinite(cl_v):
            acc["cl"] += cl_v
            acc["ncl"] += 1
        if it % args.log_every == 0 or it == args.iterations:
            now = time.time()
            spi = (now - t_last) / max(1, acc["n"])
            t_last = now
            mol = acc["ol"] / max(1, acc["n"])
            mcl = acc["cl"] / acc["ncl"] if acc["ncl"] else float("nan")
            extra, rec = "", {}
            for key, name, label in (("long", "long", "long"), ("motion", "motion", "motion"), ("spec", "spectral", "npss")):
                if key in acc:
                    rec[name] = acc[key] / max(1, acc["ncl"])
                    extra += f" {label} {rec[name]:.4f}"
            if "w_spec" in acc:
                rec["spectral_weight"] = acc["w_spec"] / max(1, acc["ncl"])
                extra += f" (weight {rec['spectral_weight']:.3g})"
            log(f"it {it:6d} open-loop {mol:.5f} closed-loop {mcl:.5f}{extra} lambda {lam:.1f} lr {lr:.3g} |g| {gnorm:.3g} {spi:.2f} s/it")
            log.record(kind="train", iteration=it, ol=mol, cl=mcl, lam=lam, lr=lr, grad_norm=gnorm, s_per_it=spi, **rec)
            acc = {"ol": 0.0, "cl": 0.0, "n": 0, "ncl": 0}
        state["cl_history"] = list(history)
        if it % args.val_every == 0 or it == args.iterations:
            model.cpu()  # validation runs on the CPU (its windows and numpy metrics live there)
            if ema_model is not None:
                ema_model.cpu()
            scored = ema_model if ema_model is not None else model
            val = validator(scored)
            if ema_model is not None:
                val["raw_npss_ref"] = validator(model)["npss_ref"]
            if args.choose == "long":
                plan_eps = torch.zeros(scored.plan_size) if hasattr(scored, "plan") else None
                val["long_speed"] = speed_ratios(long_closed_loop(scored, validator, plan_eps), validator)
                log("val it {:6d} 8-12 s speed ratio: {}".format(
                    it, " ".join(f"{a} {r:.2f}" for a, r in val["long_speed"].items())))
                is_best = state["best"] is None or choice_key(val) < choice_key(state["best"])
            else:
                is_best = better(val, state["best"])
            model.to(device)
            if ema_model is not None:
                ema_model.to(device)
            if is_best:
                state["best"] = {k: v for k, v in val.items()}
                state["best_iteration"] = it
            log(f"val it {it:6d} {fmt_val(val)}{'  [best]' if is_best else ''}")
            log.record(kind="val", iteration=it, best=is_best, **val)
            if is_best:
                atomic_save(snapshot(), run_dir / BEST)
        if it % args.checkpoint_every == 0 or it == args.iterations:
            atomic_save(snapshot(), ckpt_path)
    log(f"done: iteration {state['iteration']}, best validation at {state['best_iteration']}: {fmt_val(state['best'])}")
    log.close()
    return {"iteration": state["iteration"], "ol": last_ol, "cl": last_cl, "best": state["best"], "state": state}


def fmt_val(v: dict | None) -> str:
    """One-line validation summary."""
    if not v:
        return "n/a"
    raw = f" (raw weights {v['raw_npss_ref']:.4f})" if "raw_npss_ref" in v else ""
    s = (
        f"npss_ref {v['npss_ref']:.4f} npss_paper {v['npss_paper']:.4f} "
        f"euler@80 {v['euler_80']:.4f} euler@1000 {v['euler_1000']:.4f} speed {v.get('speed_ratio', float('nan')):.2f}"
        + raw
    )
    pa = v.get("per_action", {})
    if "walking" in pa:
        w = pa["walking"]
        s += f" | walking npss_ref {w['npss_ref']:.4f} euler@80 {w['euler_80']:.4f} @1000 {w['euler_1000']:.4f}"
    return s


# ------------------------------------------------------------------------------------------ export


def average_checkpoints(ckpt_files: list[str]) -> tuple[dict, dict, list[dict]]:
    """The first checkpoint, the mean (in float64) of the weights of all of them (a "model soup": checkpoints of one
    model, e.g. branches of a common parent) and all the checkpoints. Each contributes its averaged weights if it
    kept some.
    Raises ValueError naming the file whose model config differs from the first's."""
    cks = [load_checkpoint(Path(f)) for f in ckpt_files]
    for f, ck in zip(ckpt_files[1:], cks[1:]):
        if ck["config"] != cks[0]["config"]:
            raise ValueError(f"{f}: model config differs from {ckpt_files[0]}'s; only checkpoints of one model "
                             "can be averaged")
    weights = [checkpoint_weights(ck) for ck in cks]
    mean = {k: (sum(w[k].double() for w in weights) / len(weights)).to(weights[0][k].dtype) for k in weights[0]}
    return cks[0], mean, cks


def export(out: str, ckpt_files: list[str], dtype: str, argv: list[str]) -> dict:
    """Write the weights file of a checkpoint's model with provenance; with several checkpoints, of the mean of
    their weights (`average_checkpoints`). Returns the provenance."""
    from .export import save_weights

    ck, weights, cks = average_checkpoints(ckpt_files)
    model = build_model(ck["config"])
    model.load_state_dict(weights)
    model.eval()
    st = ck["state"]
    args = ck["args"]
    best = st.get("best")
    prov = {
        "data": "H3.6M S" + ",S".join(str(s) for s in h36m.TRAIN_SUBJECTS),
        "actions_trained": parse_actions(args["actions"]),
        "iterations": int(st["iteration"]),
        "date": ck.get("date") or datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "command": ck["command"],
        "export_command": "python -m training.train " + shlex.join(argv),
        "seed": int(args["seed"]),
        "checkpoint": os.path.basename(ckpt_files[0]),
    }
    if ck.get("ema") is not None:
        prov["weights"] = f"moving average of the training weights, decay {args['ema']} per iteration"
    if ck.get("parent"):
        prov["branched_from"] = ck["parent"]
    if len(cks) > 1:
        prov["weights"] = f"mean of the weights of {len(cks)} checkpoints (each its moving average if it kept one)"
        prov["averaged"] = [
            {"checkpoint": f, "iteration": int(c["state"]["iteration"]), "command": c["command"],
             **({"branched_from": c["parent"]} if c.get("parent") else {})}
            for f, c in zip(ckpt_files, cks)
        ]
        best = None  # the mean was not validated during training
    if best and st.get("best_iteration") == st["iteration"]:
        prov["best_validation"] = {
            "iteration": st["best_iteration"],
            "windows": "S5 validation windows disjoint from the test windows (training/data.py)",
            "npss_ref": best["npss_ref"],
            "npss_paper": best["npss_paper"],
            "euler_80": best["euler_80"],
            "euler_1000": best["euler_1000"],
            "per_action": best.get("per_action", {}),
        }
    torch_dtype = {"float32": torch.float32, "float16": torch.float16, "bfloat16": torch.bfloat16}[dtype]
    save_weights(model, out, prov, dtype=torch_dtype)
    return prov


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    args = build_parser().parse_args(argv)
    if args.spectral_weight > 0 and args.spectral_balance > 0:
        print("error: give --spectral-weight or --spectral-balance, not both", file=sys.stderr)
        return 2
    if args.export:
        if not args.from_ckpt:
            print("error: --export needs --from CHECKPOINT", file=sys.stderr)
            return 2
        for f in args.from_ckpt:
            if not Path(f).is_file():
                print(f"error: checkpoint {f} does not exist", file=sys.stderr)
                return 2
        try:
            prov = export(args.export, args.from_ckpt, args.dtype, argv)
        except ValueError as e:
            print(f"error: {e}", file=sys.stderr)
            return 2
        print(f"wrote {args.export} ({args.dtype}) from {', '.join(args.from_ckpt)}: iteration {prov['iterations']}")
        return 0
    train(args, argv)
    return 0


if __name__ == "__main__":
    sys.exit(main())
