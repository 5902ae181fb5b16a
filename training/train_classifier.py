"""Train, evaluate and export the action classifier of Ghosh et al. 2017 (section 4.5); see ``classifier.py``.

    python -m training.train_classifier --run-dir training/runs/classifier [--iterations N] [--device cuda]
    python -m training.train_classifier --run-dir training/runs/clf_val --val-subject 11   # choose a config
    python -m training.train_classifier --evaluate RUN/last.pt                 # S5 accuracy per action
    python -m training.train_classifier --export weights/action_classifier.safetensors --from RUN/last.pt

Training data: subjects S1, S6, S7, S8, S9, S11 (minus ``--val-subject`` when given) over the 15 H3.6M actions,
normalized with the predictors' statistics (all training frames at 50 Hz), 25 Hz; windows of ``--window`` frames
(default 50 = 2 s): action uniform, then a sequence of it, then a start uniform (the data pipeline's sampler).
Cross-entropy, Adam, cosine learning-rate decay, gradient-norm clipping 1.

Model choice is fixed before any S5 number is seen: configurations are compared on ``--val-subject`` (a training
subject held out), the shipped classifier is the **last** iteration of a run on all six training subjects, and S5
(the protocol's test subject) is scored once, at the end: every non-overlapping 2 s window of both subactions.

Checkpoints (``last.pt``: model, optimizer, RNG states, iteration) are written atomically every
``--checkpoint-every`` iterations; ``--resume`` continues a run exactly.
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
from torch.nn import functional as F

from . import data as h36m
from .classifier import ActionClassifier, make_classifier_config
from .export import save_weights
from .checkpoint_io import CHECKPOINT, atomic_save, read_checkpoint

CHECKPOINT_KEYS = ("config", "args", "model", "optimizer", "iteration", "numpy_rng", "torch_rng")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m training.train_classifier",
        description="Train / evaluate / export the action classifier of Ghosh et al. 2017 (section 4.5).",
    )
    p.add_argument("--run-dir", type=Path, help="where last.pt, train.log and metrics.jsonl go")
    p.add_argument("--iterations", type=int, default=3000)
    p.add_argument("--batch", type=int, default=128)
    p.add_argument("--lr", type=float, default=2e-3)
    p.add_argument("--hidden", type=int, default=128)
    p.add_argument("--layers", type=int, default=1)
    p.add_argument("--derivative-order", type=int, default=1, choices=(0, 1, 2, 3))
    p.add_argument("--window", type=int, default=50, help="frames per window at 25 Hz (default 50 = 2 s)")
    p.add_argument("--dropout", type=float, default=0.2, help="dropout on the inputs and the last hidden state")
    p.add_argument("--noise", type=float, default=0.05, help="Gaussian noise std on normalized training frames")
    p.add_argument("--offset-noise", type=float, default=0.0,
                   help="std of a per-window constant offset added to normalized frames (subject variation)")
    p.add_argument("--center", action="store_true",
                   help="subtract each window's mean pose (all used dims but the root deltas) before the differences")
    p.add_argument("--val-subject", type=int, default=None, help="hold this training subject out and score it")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--device", default="cpu", help="cpu or cuda")
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--log-every", type=int, default=50)
    p.add_argument("--checkpoint-every", type=int, default=250)
    p.add_argument("--resume", action="store_true", help="continue the run in --run-dir from last.pt")
    p.add_argument("--data-dir", type=Path, default=None)
    p.add_argument("--evaluate", type=Path, metavar="CKPT", help="score a checkpoint on S5 and exit")
    p.add_argument("--export", type=Path, metavar="OUT", help="write a weights file from --from and exit")
    p.add_argument("--from", dest="from_", type=Path, metavar="CKPT")
    return p


# ---------------------------------------------------------------- checkpoints


def load_checkpoint(path: Path) -> dict:
    """A classifier checkpoint; ValueError naming the file when it is not one."""
    state = read_checkpoint(path, CHECKPOINT_KEYS, "classifier")
    if state["config"].get("architecture") != "action-classifier":
        raise ValueError(f"{path}: checkpoint holds {state['config'].get('architecture')!r}, not an action classifier")
    return state


def model_from_checkpoint(state: dict) -> ActionClassifier:
    model = ActionClassifier(state["config"])
    model.load_state_dict(state["model"])
    return model.eval()


# ---------------------------------------------------------------- evaluation windows


def subject_windows(dataset_dir, subject: int, stats: h36m.NormStats, window: int):
    """Every non-overlapping ``window``-frame window (25 Hz, from frame 0) of both subactions of every action of
    ``subject``: ``(frames [N, window, O] normalized float32, labels [N])``."""
    seqs = h36m.load_sequences(dataset_dir, [subject], h36m.ACTIONS)
    frames, labels = [], []
    for (s, action, sub), seq in sorted(seqs.items()):
        s25 = stats.normalize(h36m.downsample(seq)).astype(np.float32)
        for start in range(0, s25.shape[0] - window + 1, window):
            frames.append(s25[start : start + window])
            labels.append(h36m.ACTIONS.index(action))
    if not frames:
        raise FileNotFoundError(f"no S{subject} windows of {window} frames under {dataset_dir}")
    return np.stack(frames), np.asarray(labels, dtype=np.int64)


@torch.no_grad()
def predict_windows(model: ActionClassifier, frames: np.ndarray, device: str = "cpu", chunk: int = 512) -> np.ndarray:
    """Class probabilities ``[N, A]`` of normalized windows ``[N, T, O]``."""
    out = []
    for i in range(0, len(frames), chunk):
        x = torch.as_tensor(frames[i : i + chunk], device=device)
        logits = model.logits_from_features(model.features_from_normalized(x))
        out.append(torch.softmax(logits, dim=-1).cpu().numpy())
    return np.concatenate(out)


def accuracy_report(probs: np.ndarray, labels: np.ndarray, actions) -> dict:
    """Per-action top-1 accuracy, mean over actions, overall, the confusion matrix (rows: true, columns: predicted)
    and the mean probability of the true class."""
    pred = probs.argmax(axis=1)
    n = len(actions)
    confusion = np.zeros((n, n), dtype=np.int64)
    for t, p in zip(labels, pred):
        confusion[t, p] += 1
    per_action = {}
    for i, a in enumerate(actions):
        total = int(confusion[i].sum())
        per_action[a] = {
            "windows": total,
            "accuracy": float(confusion[i, i] / total) if total else None,
            "true_prob": float(probs[labels == i, i].mean()) if total else None,
            "most_confused_with": actions[int(np.argmax(np.where(np.arange(n) == i, -1, confusion[i])))]
            if total
            else None,
        }
    accs = [v["accuracy"] for v in per_action.values() if v["accuracy"] is not None]
    return {
        "mean_accuracy": float(np.mean(accs)),
        "overall_accuracy": float((pred == labels).mean()),
        "windows": int(len(labels)),
        "per_action": per_action,
        "confusion": confusion.tolist(),
        "actions": list(actions),
    }


def markdown(report: dict) -> str:
    """The report as the markdown tables of weights/README.md."""
    actions = report["actions"]
    short = [a[:6] for a in actions]
    lines = ["| action | windows | top-1 accuracy | mean p(true) | most confused with |", "|---|---|---|---|---|"]
    for a in actions:
        v = report["per_action"][a]
        if not v["windows"]:
            lines.append(f"| {a} | 0 | - | - | (no data) |")
            continue
        lines.append(
            f"| {a} | {v['windows']} | {v['accuracy']:.3f} | {v['true_prob']:.3f} | {v['most_confused_with']} |"
        )
    lines.append(
        f"| **mean over actions with data** | {report['windows']} | {report['mean_accuracy']:.3f} | | (overall {report['overall_accuracy']:.3f}; chance {1 / len(actions):.3f}) |"
    )
    lines += ["", "Confusion matrix (rows: true action, columns: predicted):", ""]
    lines.append("| | " + " | ".join(short) + " |")
    lines.append("|---" * (len(actions) + 1) + "|")
    for a, row in zip(short, report["confusion"]):
        lines.append(f"| {a} | " + " | ".join(str(c) for c in row) + " |")
    return "\n".join(lines)


# ---------------------------------------------------------------- training


def lr_at(iteration: int, base: float, total: int) -> float:
    """Cosine decay from ``base`` to ``base / 20``."""
    frac = min(1.0, iteration / max(1, total))
    return base * (0.05 + 0.95 * 0.5 * (1.0 + math.cos(math.pi * frac)))


def train(args) -> None:
    run = args.run_dir
    if run is None:
        raise SystemExit("error: --run-dir is required for training")
    run.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(args.threads)
    log_file = open(run / "train.log", "a")

    def log(msg: str) -> None:
        print(msg, flush=True)
        log_file.write(msg + "\n")
        log_file.flush()

    dataset_dir = args.data_dir or h36m.default_dataset_dir()
    ckpt_path = run / CHECKPOINT
    state = None
    if args.resume:
        state = load_checkpoint(ckpt_path)
        saved = state["args"]
        for key in ("hidden", "layers", "derivative_order", "window", "val_subject", "seed", "batch", "lr", "center", "offset_noise"):
            setattr(args, key, saved[key])
        log(f"resumed from {ckpt_path} at iteration {state['iteration']}")
    subjects = [s for s in h36m.TRAIN_SUBJECTS if s != args.val_subject]
    # The normalization statistics are the predictors' (all six training subjects) whatever is held out.
    stats = h36m.load_training_set(dataset_dir, log=log).stats
    train_set = h36m.load_training_set(dataset_dir, subjects=subjects, log=log)
    train_set.stats = stats
    config = make_classifier_config(
        [int(d) for d in stats.dims_used],
        hidden=args.hidden,
        layers=args.layers,
        derivative_order=args.derivative_order,
        window=args.window,
        center=args.center,
    )
    torch.manual_seed(args.seed)
    model = ActionClassifier(config, dropout=args.dropout)
    model.norm.set_stats(torch.as_tensor(stats.mean, dtype=torch.float32), torch.as_tensor(stats.std, dtype=torch.float32))
    model.to(args.device)
    opt = torch.optim.Adam(model.parameters(), lr=args.lr)
    rng = np.random.default_rng(args.seed)
    start = 0
    if state is not None:
        model.load_state_dict(state["model"])
        opt.load_state_dict(state["optimizer"])
        rng.bit_generator.state = state["numpy_rng"]
        torch.set_rng_state(state["torch_rng"])
        start = state["iteration"]
    val = None
    if args.val_subject is not None:
        val = subject_windows(dataset_dir, args.val_subject, stats, args.window)
    log(f"classifier {json.dumps({k: v for k, v in config.items() if k != 'dims_used'})}; train subjects {subjects}")
    t0 = time.time()
    running = []
    for it in range(start, args.iterations):
        model.train()
        frames, labels = train_set.sample_batch(rng, args.batch, window=args.window)
        x = torch.as_tensor(frames, device=args.device)
        if args.noise > 0:
            x = x + args.noise * torch.randn_like(x)
        y = torch.as_tensor(labels, device=args.device)
        for g in opt.param_groups:
            g["lr"] = lr_at(it, args.lr, args.iterations)
        if args.offset_noise > 0:
            x = x + args.offset_noise * torch.randn(x.shape[0], 1, x.shape[2], device=x.device)
        logits = model.logits_from_features(model.features_from_normalized(x))
        loss = F.cross_entropy(logits, y)
        opt.zero_grad()
        loss.backward()
        torch.nn.utils.clip_grad_norm_(model.parameters(), 1.0)
        opt.step()
        running.append((loss.item(), (logits.argmax(1) == y).float().mean().item()))
        done = it + 1
        if done % args.log_every == 0 or done == args.iterations:
            l, a = np.mean(running, axis=0)
            running = []
            msg = f"it {done} loss {l:.4f} train-acc {a:.3f} lr {lr_at(it, args.lr, args.iterations):.2e} {(time.time() - t0) / max(1, done - start):.3f} s/it"
            if val is not None and (done % (args.log_every * 10) == 0 or done == args.iterations):
                model.eval()
                rep = accuracy_report(predict_windows(model, val[0], args.device), val[1], h36m.ACTIONS)
                msg += f" | S{args.val_subject} mean-acc {rep['mean_accuracy']:.3f} overall {rep['overall_accuracy']:.3f}"
                with open(run / "metrics.jsonl", "a") as f:
                    f.write(json.dumps({"iteration": done, "val": rep}) + "\n")
            log(msg)
        if done % args.checkpoint_every == 0 or done == args.iterations:
            atomic_save(
                {
                    "config": config,
                    "args": {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items()},
                    "model": {k: v.detach().cpu() for k, v in model.state_dict().items()},
                    "optimizer": opt.state_dict(),
                    "iteration": done,
                    "numpy_rng": rng.bit_generator.state,
                    "torch_rng": torch.get_rng_state(),
                    "command": "python -m training.train_classifier " + shlex.join(sys.argv[1:]),
                },
                ckpt_path,
            )
    log(f"done: {args.iterations} iterations in {time.time() - t0:.0f} s; checkpoint {ckpt_path}")


def evaluate(args) -> dict:
    state = load_checkpoint(args.evaluate)
    model = model_from_checkpoint(state)
    dataset_dir = args.data_dir or h36m.default_dataset_dir()
    stats = h36m.NormStats(
        mean=model.norm.mean.double().numpy(),
        std=model.norm.std.double().numpy(),
        dims_used=np.asarray(state["config"]["dims_used"]),
    )
    frames, labels = subject_windows(dataset_dir, h36m.VALIDATION_SUBJECT, stats, state["config"]["window"])
    report = accuracy_report(predict_windows(model, frames), labels, state["config"]["actions"])
    report["checkpoint"] = str(args.evaluate)
    report["iteration"] = state["iteration"]
    print(markdown(report))
    out = Path(args.evaluate).with_name("s5_accuracy.json")
    out.write_text(json.dumps(report, indent=1))
    print(f"\nwritten {out}")
    return report


def export(args) -> None:
    if args.from_ is None:
        raise SystemExit("error: --export needs --from CKPT")
    state = load_checkpoint(args.from_)
    model = model_from_checkpoint(state)
    s5 = args.from_.with_name("s5_accuracy.json")
    provenance = {
        "data": "H3.6M " + ",".join(f"S{s}" for s in h36m.TRAIN_SUBJECTS if s != state["args"].get("val_subject")),
        "iterations": state["iteration"],
        "date": datetime.date.today().isoformat(),
        "command": state.get("command", ""),
        "export_command": "python -m training.train_classifier " + shlex.join(sys.argv[1:]),
        "checkpoint": str(args.from_),
        "seed": state["args"]["seed"],
        "selection": "last iteration (no selection on S5)",
    }
    if s5.is_file():
        rep = json.loads(s5.read_text())
        provenance["s5_mean_accuracy"] = round(rep["mean_accuracy"], 4)
    out = Path(args.export)
    save_weights(model, out, provenance)
    print(f"written {out} ({out.stat().st_size} bytes)")


def main(argv=None) -> None:
    args = build_parser().parse_args(argv)
    try:
        if args.export:
            export(args)
        elif args.evaluate:
            evaluate(args)
        else:
            train(args)
    except (ValueError, FileNotFoundError) as e:
        raise SystemExit(f"error: {e}") from e


if __name__ == "__main__":
    main()
