"""Train and export the DAE-LSTM of Ghosh et al. 2017 (3DV, sections 3 and 4.1) in its three stages.

    python -m training.train_dae --stage dae  --run-dir training/runs/dae      # the dropout autoencoder alone
    python -m training.train_dae --stage lstm --run-dir training/runs/lstm     # LSTM-3LR alone (teacher forcing)
    python -m training.train_dae --stage finetune --run-dir training/runs/ft \\
        --init-dae training/runs/dae/last.pt --init-lstm training/runs/lstm/last.pt
    python -m training.train_dae --export weights/dae_lstm.safetensors --from training/runs/ft/best.pt

The stages (Ghosh et al. 2017, 3.1-3.3 and 4.1):

- **dae**: the autoencoder reconstructs single poses from corrupted copies: whole joints removed (dims set to 0)
  with the dropout schedule and Gaussian noise with the noise schedule, both stepped up as a curriculum over the
  stage (the paper's lists: dropout 0.01, 0.02, 0.04, 0.08, 0.1; noise 0.01, 0.05, 0.1 — used here as standard
  deviations in the [0, 1] feature scale). Squared error (paper eq. 1).
- **lstm**: LSTM-3LR predicts frame t + 1 from the noisy ground truth up to t (teacher forcing, input noise
  curriculum as above); squared error (eq. 2); no filter.
- **finetune**: both stacked; the loss is eq. 2 on the LSTM's output plus eq. 1 on the DAE's filtering of it,
  with the schedules reversed and annealed to 0 (section 4.1: "a reverse schedule", "annealing the dropout rate
  ... to zero"); learning rate 1e-4. Optionally (``--closed-loop-weight``) a closed-loop term: the stacked model
  fed its own filtered output for ``--closed-loop-horizon`` frames after a seed, squared error to the truth
  (``--speed-weight``: plus the squared log ratio of predicted to true joint speed there); and (``--long-weight``)
  a long-horizon term: the closed loop run on for a random 0..``--long-burn-in`` frames without gradient, then
  ``--long-frames`` frames with it, whose joint speed and acceleration must match the truth's (truncated
  back-propagation through time: what keeps the model moving at 8-12 s, far past any affordable full horizon).

Features are min-max scaled to [0, 1] on the training subjects (``data.minmax_stats``). Multi-action: one model
for all 15 actions, with the action one-hot concatenated to the LSTM input unless ``--no-action-input``.

**Checkpoint choice (fixed before any score was seen).** Every ``--val-every`` iterations of the finetune stage
the model is run closed loop for 12 s from the S5 validation seeds (disjoint from the test windows); per action,
the speed ratio at 8-12 s is its mean absolute frame-to-frame joint-angle change over predicted frames 200-300
divided by the ground truth's over the window's 100 frames. A checkpoint is eligible when every action's ratio
is >= 0.5; ``best.pt`` is the eligible one with the lowest validation NPSS (reference variant, 4 s); while none
is eligible, the one with the highest smallest ratio. The dae and lstm stages keep their last iteration.

Checkpoints (``last.pt``: model, optimizer and RNG states, iteration, stage) are written atomically every
``--checkpoint-every`` iterations; ``--resume`` continues a run exactly (``--iterations`` may extend it); ``--device cuda`` runs unchanged on a GPU.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import shlex
import sys
import time
from pathlib import Path

import numpy as np
import torch

from . import data as h36m
from .export import save_weights
from .models import DAELSTM, H36M_ACTIONS, make_config, parameter_count
from . import long_horizon
from .long_horizon import (  # noqa: F401 (re-exported: tests and callers use train_dae.X)
    ACCEL_FLOOR, ELIGIBLE_RATIO, HINGE_BAND, LONG_HORIZON, LONG_WINDOW, MOTION_LOSS, SPEED_FLOOR, accel_loss, choice_key,
    long_closed_loop, ratio_loss, speed_loss, speed_ratios,
)
from .checkpoint_io import BEST, CHECKPOINT, add_run_arguments, atomic_save, begin_run, read_checkpoint
from .train import RESUME_OVERRIDABLE, Logger, Validator, explicit_args

CHECKPOINT_KEYS = ("stage", "config", "args", "model", "optimizer", "iteration", "numpy_rng", "torch_rng")
STAGES = ("dae", "lstm", "finetune")
DROP_SCHEDULE = (0.01, 0.02, 0.04, 0.08, 0.1)
NOISE_SCHEDULE = (0.01, 0.05, 0.1)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m training.train_dae",
        description="Train (in stages) and export the DAE-LSTM of Ghosh et al. 2017.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--stage", choices=STAGES, help="dae, lstm or finetune (see the module doc)")
    p.add_argument("--run-dir", type=Path, help="where last.pt, best.pt, train.log and metrics.jsonl go")
    g = p.add_argument_group("model (dae and lstm stages; finetune takes them from the checkpoints)")
    g.add_argument("--hidden", type=int, default=256, help="LSTM units per layer (paper: 1000)")
    g.add_argument("--layers", type=int, default=3, help="LSTM layers (paper: 3)")
    g.add_argument("--dae-hidden", type=int, default=512, help="units per DAE layer (paper: 3000)")
    g.add_argument("--dae-layers", type=int, default=3, help="DAE hidden layers (paper: 3)")
    g.add_argument("--no-action-input", action="store_true", help="do not feed the action one-hot to the LSTM")
    g.add_argument("--residual", action="store_true", help="predict the change of the pose (paper: the pose)")
    g.add_argument("--scaling", choices=["min-max", "standard"], default="min-max",
                   help="feature scaling: min-max to [0, 1] (paper 4.1) or z-score; the noise and dropout schedules "
                        "act in the scaled space either way")
    g.add_argument("--drop-scale", type=float, default=1.0,
                   help="dae stage and --input-drop: multiply the joint-dropout schedule (paper: 1, up to 0.1)")
    g.add_argument("--noise-scale", type=float, default=1.0,
                   help="multiply the Gaussian noise schedule, every stage (paper: 1, std up to 0.1 of the scaled "
                        "range)")
    g.add_argument("--input-drop", action="store_true",
                   help="lstm stage: corrupt the LSTM's inputs with the autoencoder's whole-joint dropout as well as "
                        "the Gaussian noise (the LSTM trained on the corruption its filter removes)")
    g = p.add_argument_group("optimisation")
    g.add_argument("--iterations", type=int, default=3000)
    g.add_argument("--batch", type=int, default=None, help="default: 256 poses (dae), 32 sequences (lstm, finetune)")
    g.add_argument("--window", type=int, default=100, help="frames per training sequence at 25 Hz (lstm, finetune)")
    g.add_argument("--lr", type=float, default=None, help="Adam learning rate (default 1e-3; finetune 1e-4)")
    g.add_argument("--weight-decay", type=float, default=1e-5, help="l2 regularization (paper 4.1)")
    g.add_argument("--clip", type=float, default=5.0, help="gradient-norm clipping")
    g.add_argument("--closed-loop-weight", type=float, default=0.0, help="finetune: weight of the closed-loop term")
    g.add_argument("--closed-loop-horizon", type=int, default=50, help="finetune: self-fed frames of that term")
    g.add_argument("--closed-loop-seed", type=int, default=25, help="finetune: seed frames of that term")
    g.add_argument("--speed-weight", type=float, default=0.0,
                   help="finetune: weight of the speed term on the closed loop (squared log ratio of the mean joint "
                        "speed of prediction and truth, per sequence); needs --closed-loop-weight > 0")
    g.add_argument("--long-weight", type=float, default=0.0,
                   help="finetune: weight of the long-horizon motion term: the closed loop run on without gradient "
                        "for a random 0..--long-burn-in frames, then --long-frames frames with gradient, whose joint "
                        "speed and acceleration are matched (log ratio) to the truth's over the same frames")
    g.add_argument("--long-burn-in", type=int, default=200, help="finetune: most frames run without gradient")
    g.add_argument("--long-frames", type=int, default=50, help="finetune: frames with gradient after the burn-in")
    g.add_argument("--motion-loss", default="log", choices=["log", "hinge"],
                   help="form of the speed and acceleration terms: 'log' = squared log ratio (its gradient at a "
                        "frozen prediction is ~1/floor and swamps the rest after clipping); 'hinge' = squared "
                        "shortfall below 0.8x the truth plus excess over 1.5x, as fractions of the truth (bounded)")
    g.add_argument("--freeze-dae", action="store_true",
                   help="finetune: keep the pre-trained autoencoder fixed (train the LSTM and decoder only)")
    g.add_argument("--init-dae", type=Path, metavar="CKPT", help="finetune: the dae stage's checkpoint")
    g.add_argument("--init-lstm", type=Path, metavar="CKPT", help="finetune: the lstm stage's checkpoint")
    g.add_argument("--seed", type=int, default=1)
    add_run_arguments(p, log_every=50)
    p.add_argument("--raw", action="store_true",
                   help="with --export: replace the autoencoder by an exact identity (the bare LSTM-3LR's predictions; "
                        "a finetune or lstm checkpoint)")
    return p


# ---------------------------------------------------------------- checkpoints


def load_checkpoint(path: Path) -> dict:
    """A DAE-LSTM checkpoint; ValueError naming the file when it is not one."""
    state = read_checkpoint(path, CHECKPOINT_KEYS, "DAE-LSTM")
    if state["config"].get("architecture") != "dae-lstm":
        raise ValueError(f"{path}: checkpoint holds {state['config'].get('architecture')!r}, not a DAE-LSTM")
    return state


def model_from_checkpoint(state: dict) -> DAELSTM:
    model = DAELSTM(state["config"])
    model.load_state_dict(state["model"])
    return model


# ---------------------------------------------------------------- schedules and losses


def scheduled(values, fraction: float) -> float:
    """The entry of a schedule for the fraction of the stage done: the list stepped through in equal parts."""
    k = min(len(values) - 1, int(fraction * len(values)))
    return float(values[k])


def stage_schedules(stage: str, fraction: float, drop_scale: float = 1.0, noise_scale: float = 1.0
                    ) -> tuple[float, float]:
    """(joint-drop rate, Gaussian noise std) at this point of the stage: rising curricula for the pre-training
    stages, the reverse annealed to 0 for the fine-tuning; the drop rates times ``drop_scale``, the noise times
    ``noise_scale``."""
    if stage == "finetune":
        drop, noise = scheduled(DROP_SCHEDULE[::-1] + (0.0,), fraction), scheduled(NOISE_SCHEDULE[::-1] + (0.0,), fraction)
    else:
        drop, noise = scheduled(DROP_SCHEDULE, fraction), scheduled(NOISE_SCHEDULE, fraction)
    return min(1.0, drop * drop_scale), noise * noise_scale


def dae_loss(model: DAELSTM, poses: torch.Tensor, drop: float, noise: float) -> torch.Tensor:
    """Paper eq. 1: reconstruct clean poses [N, O] from whole-joint dropout plus Gaussian noise."""
    corrupted = model.drop_joints(poses, drop) + noise * torch.randn_like(poses)
    return ((model.filter(corrupted) - poses) ** 2).mean()


def sequence_losses(model: DAELSTM, frames: torch.Tensor, actions: torch.Tensor, stage: str, drop: float,
                    noise: float, input_drop: bool = False) -> tuple[torch.Tensor, torch.Tensor | None]:
    """Teacher-forced losses of frames [B, T+1, O]: eq. 2 on the LSTM output and (finetune) eq. 1 on the DAE's
    filtering of the output with whole joints dropped at ``drop``. ``input_drop``: the inputs lose whole joints
    at ``drop`` too (before the noise)."""
    inputs = frames[:, :-1]
    if input_drop:
        inputs = model.drop_joints(inputs, drop)
    inputs = inputs + noise * torch.randn_like(inputs)
    target = frames[:, 1:]
    raw = model.open_loop_raw(inputs, actions)
    lstm = ((raw - target) ** 2).mean()
    if stage != "finetune":
        return lstm, None
    filtered = model.filter(model.drop_joints(raw, drop))
    return lstm, ((filtered - target) ** 2).mean()


def closed_loop_loss(model: DAELSTM, frames: torch.Tensor, actions: torch.Tensor, seed: int, horizon: int):
    """The stacked model fed its own filtered output after ``seed`` true frames over ``horizon`` frames:
    (squared error to the truth, squared log ratio of predicted to true joint speed)."""
    pred = model.closed_loop(frames[:, :seed], horizon, actions)
    truth = frames[:, seed - 1 : seed + horizon]
    error = ((pred - truth[:, 1:]) ** 2).mean()
    return error, speed_loss(model, torch.cat([truth[:, :1], pred], dim=1), truth)


def long_motion_loss(model: DAELSTM, frames: torch.Tensor, actions, seed: int, burn_in: int, length: int):
    """The long-horizon term of the finetune stage: ``long_horizon.long_motion_loss`` without input dropout (the
    stacked model feeds its filtered poses straight back)."""
    return long_horizon.long_motion_loss(model, frames, actions, seed, burn_in, length, dropout=False)


# ---------------------------------------------------------------- validation


def long_speed_ratios(model: DAELSTM, validator: Validator) -> dict[str, float]:
    """Per validation action: the 12 s speed ratio (``long_horizon``) of the model's closed loop."""
    return speed_ratios(long_closed_loop(model, validator), validator)


# ---------------------------------------------------------------- training


def build_config(args, dims_used) -> dict:
    return make_config(
        "dae-lstm",
        dims_used,
        hidden=args.hidden,
        layers=args.layers,
        dae_hidden=args.dae_hidden,
        dae_layers=args.dae_layers,
        residual=bool(args.residual),
        normalization=args.scaling,
        actions=[] if args.no_action_input else list(H36M_ACTIONS),
        seed_frames=h36m.SEED_FRAMES,
        horizon=h36m.HORIZON,
    )


def train(args, argv: list[str]) -> None:
    MOTION_LOSS[0] = getattr(args, "motion_loss", "log")
    if args.stage is None or args.run_dir is None:
        raise SystemExit("error: training needs --stage and --run-dir (or --export with --from)")
    args, resume = begin_run(args, explicit_args(argv), RESUME_OVERRIDABLE, load_checkpoint)
    run_dir = args.run_dir
    ckpt_path = run_dir / CHECKPOINT
    stage = args.stage
    if stage == "finetune" and args.closed_loop_weight > 0 and args.closed_loop_seed + args.closed_loop_horizon > args.window + 1:
        raise SystemExit(f"error: --closed-loop-seed + --closed-loop-horizon ({args.closed_loop_seed} + "
                         f"{args.closed_loop_horizon}) exceed the {args.window + 1} frames of a --window {args.window} sequence")
    if stage == "finetune" and args.long_weight > 0 and args.closed_loop_seed + args.long_burn_in + args.long_frames > args.window:
        raise SystemExit(f"error: --closed-loop-seed + --long-burn-in + --long-frames ({args.closed_loop_seed} + "
                         f"{args.long_burn_in} + {args.long_frames}) exceed the {args.window + 1} frames of a "
                         f"--window {args.window} sequence (minus one)")
    if args.speed_weight > 0 and args.closed_loop_weight <= 0:
        raise SystemExit("error: --speed-weight acts on the closed-loop term: give --closed-loop-weight > 0 too")
    torch.set_num_threads(args.threads)
    device = torch.device(args.device)
    log = Logger(run_dir)
    command = resume["command"] if resume else "python -m training.train_dae " + shlex.join(argv)
    log(("resuming: " if resume else "starting: ") + command)

    dae_state = lstm_state = None
    if resume is None and stage == "finetune":
        if not (args.init_dae and args.init_lstm):
            raise SystemExit("error: --stage finetune needs --init-dae and --init-lstm")
        dae_state, lstm_state = load_checkpoint(args.init_dae), load_checkpoint(args.init_lstm)
        scalings = {s["config"].get("normalization", "standard") for s in (dae_state, lstm_state)}
        if len(scalings) > 1:
            raise SystemExit(f"error: {args.init_dae} and {args.init_lstm} were trained with different scalings "
                             f"({' and '.join(sorted(scalings))})")
    source = resume or lstm_state
    scaling = source["config"].get("normalization", "standard") if source else args.scaling
    dataset = h36m.load_training_set(args.data_dir, h36m.ACTIONS, log=log, scaling=scaling)
    stats = dataset.stats
    torch.manual_seed(args.seed)  # every stage: initialization (dae, lstm) and the noise and joint drops
    if resume is not None:
        config = resume["config"]
        model = model_from_checkpoint(resume)
    elif stage == "finetune":
        config = dict(lstm_state["config"], dae_hidden=dae_state["config"]["dae_hidden"],
                      dae_layers=dae_state["config"]["dae_layers"])
        model = DAELSTM(config)
        own = {k: v for k, v in lstm_state["model"].items() if not k.startswith("dae.")}
        own.update({k: v for k, v in dae_state["model"].items() if k.startswith("dae.")})
        model.load_state_dict(own)
    else:
        config = build_config(args, stats.dims_used)
        model = DAELSTM(config)
    model.norm.set_stats(torch.from_numpy(stats.mean).float(), torch.from_numpy(stats.std).float())
    model.filter_enabled = stage != "lstm"
    model.to(device).train()
    if stage == "dae":
        params = list(model.dae.parameters())
    elif stage == "lstm":
        params = [p for n, p in model.named_parameters() if not n.startswith("dae.")]
    elif args.freeze_dae:
        params = [p for n, p in model.named_parameters() if not n.startswith("dae.")]
        for p in model.dae.parameters():
            p.requires_grad_(False)
    else:
        params = list(model.parameters())
    lr = args.lr if args.lr is not None else (1e-4 if stage == "finetune" else 1e-3)
    opt = torch.optim.Adam(params, lr=lr, weight_decay=args.weight_decay)
    rng = np.random.default_rng(args.seed)
    iteration, best = 0, None
    if resume is not None:
        opt.load_state_dict(resume["optimizer"])
        rng.bit_generator.state = resume["numpy_rng"]
        torch.set_rng_state(resume["torch_rng"])
        iteration, best = resume["iteration"], resume.get("best")
        log(f"resumed {stage} at iteration {iteration}")
    else:
        log(f"dae-lstm {stage}: {parameter_count(model):,} parameters, {sum(p.numel() for p in params):,} trained; "
            f"config {json.dumps(config)}")

    validator = None
    if stage != "dae":
        windows = h36m.validation_windows(args.data_dir, h36m.ACTIONS, args.val_per_action, log=log)
        validator = Validator(windows, stats, list(h36m.ACTIONS))

    def snapshot() -> dict:
        return {
            "stage": stage, "config": config, "model": {k: v.cpu() for k, v in model.state_dict().items()},
            "optimizer": opt.state_dict(), "iteration": iteration, "best": best,
            "numpy_rng": rng.bit_generator.state, "torch_rng": torch.get_rng_state(),
            "args": {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items()
                     if k not in ("export", "from_", "resume")},
            "command": command, "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        }

    batch = args.batch or (256 if stage == "dae" else 32)
    label_map = np.array([config["actions"].index(a) for a in dataset.actions] if config["actions"]
                         else [0] * len(dataset.actions))
    t_last, acc, n_acc = time.time(), {}, 0
    while iteration < args.iterations:
        fraction = iteration / args.iterations
        drop, noise = stage_schedules(stage, fraction, args.drop_scale, args.noise_scale)
        if stage == "dae":
            frames_np, _ = dataset.sample_batch(rng, batch, 1)
            poses = torch.from_numpy(frames_np[:, 0]).to(device)
            loss = dae_loss(model, poses, drop, noise)
            terms = {"dae": loss.item()}
        else:
            frames_np, acts_np = dataset.sample_batch(rng, batch, args.window + 1)
            frames = torch.from_numpy(frames_np).to(device)
            acts = torch.from_numpy(label_map[acts_np]).to(device) if config["actions"] else None
            lstm, dae = sequence_losses(model, frames, acts, stage, drop, noise, args.input_drop and stage == "lstm")
            loss = lstm if dae is None else lstm + dae
            terms = {"lstm": lstm.item()} | ({} if dae is None else {"dae": dae.item()})
            if stage == "finetune" and args.closed_loop_weight > 0:
                cl, sp = closed_loop_loss(model, frames, acts, args.closed_loop_seed, args.closed_loop_horizon)
                loss = loss + args.closed_loop_weight * cl + args.speed_weight * sp
                terms["closed"] = cl.item()
                terms["speed"] = sp.item()
            if stage == "finetune" and args.long_weight > 0:
                burn = int(rng.integers(0, args.long_burn_in + 1))
                lm = long_motion_loss(model, frames, acts, args.closed_loop_seed, burn, args.long_frames)
                loss = loss + args.long_weight * lm
                terms["long"] = lm.item()
        if not math.isfinite(loss.item()):
            raise SystemExit(f"error: loss became {loss.item()} at iteration {iteration + 1}; see {run_dir}")
        opt.zero_grad(set_to_none=True)
        loss.backward()
        torch.nn.utils.clip_grad_norm_(params, args.clip)
        opt.step()
        iteration += 1
        for k, v in terms.items():
            acc[k] = acc.get(k, 0.0) + v
        n_acc += 1
        if iteration % args.log_every == 0 or iteration == args.iterations:
            now = time.time()
            means = {k: v / n_acc for k, v in acc.items()}
            spi = (now - t_last) / n_acc
            log(f"it {iteration:6d} " + " ".join(f"{k} {v:.5f}" for k, v in means.items())
                + f" drop {drop:.2f} noise {noise:.2f} {spi:.2f} s/it")
            log.record(kind="train", iteration=iteration, drop=drop, noise=noise, s_per_it=spi, **means)
            t_last, acc, n_acc = now, {}, 0
        if validator is not None and (iteration % args.val_every == 0 or iteration == args.iterations):
            model.cpu()
            val = validator(model)
            val["long_speed"] = long_speed_ratios(model, validator)
            model.to(device)
            is_best = stage == "finetune" and (best is None or choice_key(val) < choice_key(best))
            if is_best:
                best = {k: v for k, v in val.items() if k != "per_action"} | {"iteration": iteration}
            smallest = min(val["long_speed"].items(), key=lambda kv: kv[1])
            log(f"val it {iteration:6d} npss_ref {val['npss_ref']:.4f} euler80 {val['euler_80']:.3f} "
                f"speed(4s) {val['speed_ratio']:.2f} speed(8-12s) mean {np.mean(list(val['long_speed'].values())):.2f} "
                f"min {smallest[1]:.2f} ({smallest[0]}){'  [best]' if is_best else ''}")
            log.record(kind="val", iteration=iteration, best=is_best, **val)
            if is_best:
                atomic_save(snapshot(), run_dir / BEST)
        if iteration % args.checkpoint_every == 0 or iteration == args.iterations:
            atomic_save(snapshot(), ckpt_path)
    log(f"done: {stage} iteration {iteration}" + (f", best at {best['iteration']}" if best else ""))
    log.close()


def identity_filter(model: DAELSTM) -> DAELSTM:
    """The same LSTM and decoder with an autoencoder that computes the identity exactly: one hidden layer of
    ``2 O`` ReLU units ``[I; -I]`` and the output ``[I, -I]`` (relu(x) - relu(-x) = x). Its file is a valid
    ``dae-lstm`` whose predictions are the bare LSTM-3LR's (the unfiltered rows of the paper's Table 1)."""
    o = model.output_size
    config = dict(model.config, dae_hidden=2 * o, dae_layers=1)
    dtype = next(model.parameters()).dtype
    bare = DAELSTM(config).to(dtype)
    state = {k: v for k, v in model.state_dict().items() if not k.startswith("dae.")}
    eye = torch.eye(o, dtype=dtype)
    state["dae.layers.0.weight"] = torch.cat([eye, -eye], dim=0)
    state["dae.layers.0.bias"] = torch.zeros(2 * o, dtype=dtype)
    state["dae.layers.1.weight"] = torch.cat([eye, -eye], dim=1)
    state["dae.layers.1.bias"] = torch.zeros(o, dtype=dtype)
    bare.load_state_dict(state)
    return bare


def export(out: Path, ckpt: Path, dtype: str, argv: list[str], raw: bool = False) -> None:
    state = load_checkpoint(ckpt)
    if state["stage"] == "dae" or (state["stage"] == "lstm" and not raw):
        raise SystemExit(f"error: {ckpt} is a {state['stage']} checkpoint; export the finetune stage's"
                         + ("" if state["stage"] == "dae" else " (or give --raw for the bare LSTM-3LR)"))
    model = model_from_checkpoint(state).eval()
    if raw:
        model = identity_filter(model)
    scaling = state["config"].get("normalization", "standard")
    provenance = {
        "data": f"Human3.6M S1, S6, S7, S8, S9, S11; {scaling} scaling over their frames",
        "iterations": state["iteration"],
        "stage": state["stage"],
        "filter": "identity (the bare LSTM-3LR)" if raw else "the trained dropout autoencoder",
        "best_validation": state.get("best"),
        "command": state["command"],
        "export_command": "python -m training.train_dae " + shlex.join(argv),
        "date": state["date"],
        "seed": state["args"].get("seed"),
    }
    save_weights(model, out, provenance, dtype=getattr(torch, dtype))
    print(f"wrote {out} ({parameter_count(model):,} parameters, {dtype}) from {ckpt} (iteration {state['iteration']})")


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    args = build_parser().parse_args(argv)
    if args.export:
        if not args.from_:
            raise SystemExit("error: --export needs --from CKPT")
        export(args.export, args.from_, args.dtype, argv, raw=args.raw)
        return 0
    train(args, argv)
    return 0


if __name__ == "__main__":
    sys.exit(main())
