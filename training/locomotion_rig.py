"""``training/locomotion.py --takes``: the goal-conditioned model trained on a folder of takes on their own rig (the
module docs of ``training/locomotion.py`` state the windows, the validation rule and the export)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import torch

from . import data as h36m
from .export import save_weights
from .goal_loss import new_goal_model, train_goal
from .models import GoalGRU, make_config
from .takes import TakeSet, controls_of, load_takes, validation_names

SHORT_HORIZONS = (15, 30)  # closed-loop lengths drawn beside --horizon
VALIDATION_SECONDS = 10.0
LATE_FROM_SECONDS = 5.0


class RigSet:
    """Normalized frames and controls of some takes of a take set."""

    def __init__(self, takes: TakeSet, names: list[str], stats: h36m.NormStats, k: int):
        self.items = []
        for take in takes.takes:
            if take.name not in names or take.frames.shape[0] < 2:
                continue
            controls = controls_of(take.frames, k, takes.fps, takes.rest_forward).astype(np.float32)
            self.items.append((take.name, stats.normalize(take.frames).astype(np.float32), controls, take.frames))

    def sample(self, rng: np.random.Generator, batch: int, window: int):
        """``batch`` windows of ``window`` frames: a take uniformly among those long enough, a start uniformly."""
        long_enough = [it for it in self.items if it[1].shape[0] >= window]
        out_f = np.empty((batch, window, self.items[0][1].shape[1]), np.float32)
        out_c = np.empty((batch, window, 3), np.float32)
        for b in range(batch):
            _, frames, controls, _ = long_enough[int(rng.integers(len(long_enough)))]
            start = int(rng.integers(0, frames.shape[0] - window + 1))
            out_f[b] = frames[start : start + window]
            out_c[b] = controls[start : start + window]
        return out_f, out_c

    def longest(self) -> int:
        return max(it[1].shape[0] for it in self.items)


def speed(frames: np.ndarray) -> float:
    """Mean absolute frame-to-frame change of normalized frames."""
    return float(np.abs(np.diff(frames, axis=0)).mean()) if frames.shape[0] > 1 else 0.0


@torch.no_grad()
def validate_rig(model: GoalGRU, val: RigSet, seed: int, stats: h36m.NormStats, k: int, fps: float,
                 rest_forward: np.ndarray) -> dict:
    """The validation rule of ``training/locomotion.py --takes`` (see its module docs)."""
    model.eval()
    steps = int(round(VALIDATION_SECONDS * fps))
    late_from = int(round(LATE_FROM_SECONDS * fps))
    errors, early, late = [], [], []
    for _, frames, controls, _ in val.items:
        s = min(seed, frames.shape[0] - 2)
        real = frames.shape[0] - s
        wanted = np.concatenate([controls, np.repeat(controls[-1:], steps + s, axis=0)])[: s + steps]
        wanted[:s] = controls[s - 1]
        gen = model.closed_loop(torch.from_numpy(frames[None, :s]), steps,
                                action=torch.from_numpy(wanted[None].astype(np.float32)))[0].numpy().astype(np.float64)
        whole = np.concatenate([frames[:s].astype(np.float64), gen])
        achieved = controls_of(stats.unnormalize(whole), k, fps, rest_forward)[s : s + real]
        errors.append(np.abs(achieved - controls[s : s + real]).mean(axis=0))
        real_speed = max(speed(frames.astype(np.float64)), 1e-9)
        early.append(speed(gen[:real]) / real_speed)
        late.append(speed(gen[late_from:]) / real_speed)
    model.train()
    forward, side, turn = np.mean(errors, axis=0)
    e, l_ = float(np.mean(early)), float(np.mean(late))
    score = forward + side + turn / 2 + 2 * max(0.0, 0.6 - e) + 2 * max(0.0, 0.6 - l_) + 2 * max(0.0, l_ - 1.6)
    return {"score": float(score), "forward": float(forward), "side": float(side), "turn": float(turn),
            "speed_ratio": e, "late_speed_ratio": l_}


def train_rig(args, argv: list[str], log) -> int:
    takes = load_takes(args.takes, args.run_dir / "takes", args.joint_map,
                       [n for n in (args.exclude or "").split(",") if n.strip()], args.fps, log)
    names = [t.name for t in takes.takes]
    val_names = validation_names(names)
    train_names = [n for n in names if n not in val_names]
    k = max(1, int(round(args.control_seconds * takes.fps)))
    train_frames = [t.frames for t in takes.takes if t.name in train_names]
    stats = h36m.normalization_stats(train_frames)
    train_set = RigSet(takes, train_names, stats, k)
    val = RigSet(takes, val_names, stats, k)
    log(f"{len(train_set.items)} training takes ({sum(f.shape[0] for f in train_frames)} frames), "
        f"validation takes {', '.join(val_names)}; {takes.frame_dims} values per frame, {len(stats.dims_used)} used")
    config = make_config("goal-gru", [int(d) for d in stats.dims_used], hidden=args.hidden, layers=args.layers,
                         seed_frames=args.seed_frames, horizon=args.horizon, frame_dims=takes.frame_dims,
                         fps=takes.fps, skeleton="rig", control_frames=k, rig_bvh=takes.rig_bvh,
                         mm_per_unit=takes.mm_per_unit)
    model, opt = new_goal_model(config, stats.mean, stats.std, args.lr)
    horizons = [h for h in (*SHORT_HORIZONS, args.horizon) if args.seed_frames + h + 1 <= train_set.longest()]
    if not horizons:
        raise SystemExit(f"no training take has {args.seed_frames + SHORT_HORIZONS[0] + 1} frames")
    provenance_data = {
        "data": f"{args.takes}: takes {', '.join(train_names)} (validation {', '.join(val_names)})",
        "excluded": args.exclude or "none",
        "rest_forward": [float(v) for v in takes.rest_forward],
    }

    def sample(rng: np.random.Generator):
        horizon = horizons[int(rng.integers(len(horizons)))]
        return train_set.sample(rng, args.batch, args.seed_frames + horizon + 1)

    return train_goal(args, argv, model, opt, config, sample,
                      lambda: validate_rig(model, val, args.seed_frames, stats, k, takes.fps, takes.rest_forward),
                      log, {"data": provenance_data})


def export_rig(out: Path, state: dict, licence: str) -> None:
    model = GoalGRU(state["config"])
    model.load_state_dict(state["model"])
    provenance = dict(state["data"])
    provenance.update({
        "iterations": state["iteration"],
        "best_validation": state["validation"],
        "command": "python -m training.locomotion " + " ".join(state["argv"]),
        "checkpoint_rule": "lowest validation score (training/locomotion.py --takes: control tracking, liveliness "
                           "over the real frames and at 5-10 s)",
        "date": time.strftime("%Y-%m-%d"),
        "licence": licence,
    })
    save_weights(model, out, provenance)
    print(f"wrote {out} (iteration {state['iteration']}, validation {state['validation']})")
