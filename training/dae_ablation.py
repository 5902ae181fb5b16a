"""The DAE-LSTM ablation (Ghosh et al. 2017, Table 1 and section 3): which part of the recipe keeps the closed loop
moving, at the shipped size (LSTM 3 x 256, autoencoder 3 x 512), scored on the S5 validation windows only.

    MOTION_DATA_DIR=../shared/data training/.venv/bin/python -m training.dae_ablation run     # train what is missing
    MOTION_DATA_DIR=../shared/data training/.venv/bin/python -m training.dae_ablation score   # eval + table

``run`` trains every stage the variants need under ``--root`` (default ``training/runs/dae_ablation``), each one
resumable (a stage whose ``last.pt`` is complete is skipped; one cut short is resumed), one stage at a time with
one thread. ``score`` exports each row (``train_dae --export``, the bare LSTM rows with ``--raw``), runs
``motion-cli eval --windows validation --horizon 300 --json`` on it and prints the table: per row, the speed ratio
in each time window (0-2, 2-4, 4-8, 8-12 s; the mean over the 15 actions and the smallest) and the classifier's
probability of the seed's action at 8-12 s (walking, eating, and the mean over actions) beside real motion and
zero-velocity, plus the Euler error at 80 ms. Below it, each autoencoder's reconstruction error of clean S5
validation poses (what its filter moves a pose that needs no filtering), RMS over the used dims in the scaled
space and in radians.

The recipe common to every variant (fixed before any variant was scored): autoencoder 3,000 iterations, LSTM
1,500 iterations (batch 32, 100-frame windows), the paper's fine-tune (eq. 1 + eq. 2 with the reversed schedules
annealed to 0, no closed-loop term) 300 iterations at batch 16; seed 1. Each variant changes one thing:

- ``base``: min-max scaling, the action one-hot input, Gaussian noise on the LSTM's inputs;
- ``zscore``: z-score scaling instead (autoencoder and LSTM retrained);
- ``input_drop``: the LSTM's inputs also lose whole joints with the autoencoder's dropout schedule;
- ``no_onehot``: no action input;
- ``drop_x3``: the autoencoder's joint dropout schedule tripled (0.03 .. 0.3);
- ``dae_long``: the autoencoder trained 5x longer (15,000 iterations);
- ``ft_long``: the base fine-tune continued to 1,200 iterations;
- ``low_noise``: the Gaussian noise schedule of every stage a tenth (std 0.001 .. 0.01 of the scaled range).

Rows: ``lstm`` (the pre-trained LSTM-3LR alone), ``raw`` (the fine-tuned LSTM without its filter: the paper's
"Ours without filtering") and ``filtered`` (the DAE-LSTM as it runs).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import torch

from . import data as h36m
from . import train_dae
from .checkpoint_io import CHECKPOINT
from .long_horizon_targets import classifier_mean

ROOT = Path("training/runs/dae_ablation")
COMMON = ["--threads", "1", "--seed", "1", "--checkpoint-every", "100", "--log-every", "100"]
DAE = ["--stage", "dae", "--iterations", "3000", "--dae-hidden", "512", "--dae-layers", "3"]
LSTM = ["--stage", "lstm", "--iterations", "1500", "--hidden", "256", "--layers", "3", "--val-every", "1500"]
FINETUNE = ["--stage", "finetune", "--iterations", "300", "--batch", "16", "--window", "100", "--val-every", "300"]

# stage name -> (run arguments, the stages it starts from)
STAGES: dict[str, tuple[list[str], tuple[str, ...]]] = {
    "dae_base": (DAE, ()),
    "dae_zscore": (DAE + ["--scaling", "standard"], ()),
    "dae_drop_x3": (DAE + ["--drop-scale", "3"], ()),
    "dae_long": (DAE[:3] + ["15000"] + DAE[4:], ()),
    "lstm_base": (LSTM, ()),
    "lstm_zscore": (LSTM + ["--scaling", "standard"], ()),
    "lstm_input_drop": (LSTM + ["--input-drop"], ()),
    "lstm_no_onehot": (LSTM + ["--no-action-input"], ()),
    "ft_base": (FINETUNE, ("dae_base", "lstm_base")),
    "ft_zscore": (FINETUNE, ("dae_zscore", "lstm_zscore")),
    "ft_input_drop": (FINETUNE, ("dae_base", "lstm_input_drop")),
    "ft_no_onehot": (FINETUNE, ("dae_base", "lstm_no_onehot")),
    "ft_drop_x3": (FINETUNE, ("dae_drop_x3", "lstm_base")),
    "ft_dae_long": (FINETUNE, ("dae_long", "lstm_base")),
    "ft_long": (FINETUNE[:3] + ["1200"] + FINETUNE[4:], ("dae_base", "lstm_base")),
    "dae_low_noise": (DAE + ["--noise-scale", "0.1"], ()),
    "lstm_low_noise": (LSTM + ["--noise-scale", "0.1"], ()),
    "ft_low_noise": (FINETUNE + ["--noise-scale", "0.1"], ("dae_low_noise", "lstm_low_noise")),
}
# variant -> (its lstm stage, its finetune stage)
VARIANTS = {
    "base": ("lstm_base", "ft_base"),
    "zscore": ("lstm_zscore", "ft_zscore"),
    "input_drop": ("lstm_input_drop", "ft_input_drop"),
    "no_onehot": ("lstm_no_onehot", "ft_no_onehot"),
    "drop_x3": ("lstm_base", "ft_drop_x3"),
    "dae_long": ("lstm_base", "ft_dae_long"),
    "ft_long": ("lstm_base", "ft_long"),
    "low_noise": ("lstm_low_noise", "ft_low_noise"),
}
WINDOWS = ("0-2 s", "2-4 s", "4-8 s", "8-12 s")


# The order stages are trained in: the base pair and the cheap autoencoder variants first, then each LSTM
# followed by the fine-tunes it enables (every stage after those it starts from).
ORDER = ("dae_base", "dae_drop_x3", "dae_low_noise", "dae_zscore", "lstm_base", "ft_base", "ft_drop_x3",
         "lstm_low_noise", "ft_low_noise", "lstm_zscore", "ft_zscore", "lstm_input_drop", "ft_input_drop",
         "lstm_no_onehot", "ft_no_onehot", "ft_long", "dae_long", "ft_dae_long")


def stage_order() -> list[str]:
    """Every stage, in the training order (``ORDER``)."""
    assert sorted(ORDER) == sorted(STAGES), "ORDER must list every stage once"
    return list(ORDER)


def target_iterations(args: list[str]) -> int:
    return int(args[args.index("--iterations") + 1])


def done_iterations(run_dir: Path) -> int:
    path = run_dir / CHECKPOINT
    return torch.load(path, weights_only=False, map_location="cpu")["iteration"] if path.is_file() else 0


def run_stages(root: Path, only: list[str] | None) -> None:
    for name in stage_order():
        if only and name not in only:
            continue
        argv, parents = STAGES[name]
        run_dir = root / name
        have, want = done_iterations(run_dir), target_iterations(argv)
        if have >= want:
            print(f"{name}: complete ({have} iterations)", flush=True)
            continue
        missing = [p for p in parents if done_iterations(root / p) < target_iterations(STAGES[p][0])]
        if missing:
            print(f"{name}: waits for {', '.join(missing)}", flush=True)
            continue
        init = []
        for p in parents:
            init += ["--init-dae" if p.startswith("dae") else "--init-lstm", str(root / p / CHECKPOINT)]
        if have:
            full = ["--stage", argv[1], "--run-dir", str(run_dir), "--resume", "--iterations", str(want), "--threads", "1"]
        else:
            full = argv + ["--run-dir", str(run_dir)] + COMMON + init
        print(f"{name}: python -m training.train_dae {' '.join(full)}", flush=True)
        train_dae.main(full)


def motion_cli() -> str:
    return os.environ.get("MOTION_CLI", "target/release/motion-cli")


def evaluate(weights: Path, out: Path) -> dict:
    """``motion-cli eval`` of one weights file on the validation windows to 12 s (cached in ``out``)."""
    if not out.is_file():
        cmd = [motion_cli(), "eval", "--model", str(weights), "--windows", "validation", "--horizon", "300", "--json"]
        result = subprocess.run(cmd, capture_output=True, text=True)
        if result.returncode != 0:
            raise SystemExit(f"error: {' '.join(cmd)} failed: {result.stderr.strip()}")
        tmp = out.with_suffix(".tmp")
        tmp.write_text(result.stdout)
        tmp.replace(out)
    return json.loads(out.read_text())


def summarise(report: dict, which: str = "model") -> dict:
    """Speed ratio per time window (mean and smallest over actions), classifier at 8-12 s, Euler error at 80 ms."""
    speed = {w: [] for w in WINDOWS}
    prob, euler = {}, []
    for a in report["actions"]:
        block = a[which]
        for w in block["speed_ratio"]["windows"]:
            key = f"{w['start_s']:g}-{w['end_s']:g} s"
            if key in speed:
                speed[key].append(w["ratio"])
        if "classifier" in block:
            prob[a["action"]] = classifier_mean(block["classifier"])
        if "euler_error_ms" in block:
            euler.append(block["euler_error_ms"]["80"])
    return {
        "speed_mean": {w: float(np.mean(v)) for w, v in speed.items()},
        "speed_min": {w: float(np.min(v)) for w, v in speed.items()},
        "classifier": prob,
        "euler_80": float(np.mean(euler)) if euler else None,
    }


def rows(root: Path) -> list[tuple[str, dict]]:
    out, seen = [], set()
    for variant, (lstm, ft) in VARIANTS.items():
        for row, stage, raw in (("lstm", lstm, True), ("raw", ft, True), ("filtered", ft, False)):
            ckpt = root / stage / CHECKPOINT
            if not ckpt.is_file() or done_iterations(root / stage) < target_iterations(STAGES[stage][0]):
                continue
            tag = f"{stage}{'_raw' if raw else ''}"
            if tag in seen:
                continue
            seen.add(tag)
            weights = root / f"{tag}.safetensors"
            if not weights.is_file():
                train_dae.main(["--export", str(weights), "--from", str(ckpt)] + (["--raw"] if raw else []))
            out.append((f"{variant}: {row}", evaluate(weights, root / f"{tag}.eval.json")))
    return out


@torch.no_grad()
def reconstruction_errors(root: Path) -> list[str]:
    """Per autoencoder stage: the RMS change its filter makes to clean S5 validation poses (scaled, radians)."""
    lines = ["| autoencoder | clean-pose reconstruction RMS, scaled | radians |", "|---|---|---|"]
    frames = torch.from_numpy(np.concatenate([w.frames for w in h36m.validation_windows(None, h36m.ACTIONS)]))
    for name in stage_order():
        if not name.startswith("dae") or done_iterations(root / name) < target_iterations(STAGES[name][0]):
            continue
        model = train_dae.model_from_checkpoint(train_dae.load_checkpoint(root / name / CHECKPOINT)).eval()
        poses = model.norm.normalize(frames.to(model.norm.mean.dtype))
        change = model.filter(poses) - poses
        radians = change * model.norm.std[model.norm.dims_used]
        lines.append(f"| {name} | {change.pow(2).mean().sqrt():.4f} | {radians.pow(2).mean().sqrt():.3f} |")
    return lines


def fmt_row(label: str, s: dict) -> str:
    speed = " / ".join(f"{s['speed_mean'][w]:.2f}" for w in WINDOWS)
    smallest = " / ".join(f"{s['speed_min'][w]:.2f}" for w in WINDOWS)
    p = s["classifier"]
    mean_p = np.mean(list(p.values())) if p else float("nan")
    euler = "-" if s["euler_80"] is None else f"{s['euler_80']:.2f}"
    return (f"| {label} | {speed} | {smallest} | {p.get('walking', float('nan')):.2f} | {p.get('eating', float('nan')):.2f} "
            f"| {mean_p:.2f} | {euler} |")


def table(results: list[tuple[str, dict]]) -> str:
    lines = [
        "| row | speed ratio 0-2 / 2-4 / 4-8 / 8-12 s (mean over actions) | smallest over actions | classifier "
        "8-12 s walking | eating | mean over actions | Euler 80 ms (mean) |",
        "|---|---|---|---|---|---|---|",
    ]
    if results:
        first = results[0][1]
        lines.append(fmt_row("real motion", summarise(first, "ground_truth")))
        lines.append(fmt_row("zero-velocity", summarise(first, "zero_velocity")))
    for label, report in results:
        lines.append(fmt_row(label, summarise(report)))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m training.dae_ablation", description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("command", choices=["run", "score", "list"])
    p.add_argument("--root", type=Path, default=ROOT, help="where the stages' run directories go")
    p.add_argument("--only", nargs="*", help="run: these stages only (names as `list` prints)")
    args = p.parse_args(argv)
    if args.command == "list":
        for name in stage_order():
            print(name, "<-", ", ".join(STAGES[name][1]) or "-")
    elif args.command == "run":
        run_stages(args.root, args.only)
    else:
        print(table(rows(args.root)))
        print()
        print("\n".join(reconstruction_errors(args.root)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
