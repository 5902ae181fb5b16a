"""The training of ``goal-gru`` (``training/locomotion.py``, on H3.6M or on any rig's takes): the loss (a window's
seed teacher-forced with one control, then a closed loop reading each frame's own control) and the loop (learning
rate halving every third of the run, checkpoints every ``--val-every`` iterations, the best by the validation score
kept as ``best.pt``, resumable from ``last.pt``)."""

from __future__ import annotations

import json
import time
from typing import Callable

import numpy as np
import torch

from .checkpoint_io import atomic_save
from .models import GoalGRU


def seed_controls(controls: torch.Tensor, seed: int) -> torch.Tensor:
    """The controls a run reads: the last seed frame's over the whole seed, then each frame's own."""
    out = controls.clone()
    out[:, :seed] = controls[:, seed - 1 : seed]
    return out


def window_loss(model: GoalGRU, frames: torch.Tensor, controls: torch.Tensor, seed: int, feed_noise: float):
    """Mean squared error of the teacher-forced seed outputs and of the closed loop after them."""
    horizon = frames.shape[1] - seed - 1
    seed_out, generated = model.closed_loop(
        frames[:, :seed], horizon + 1, action=seed_controls(controls, seed), return_seed_outputs=True,
        feed_noise=feed_noise,
    )
    truth_seed = frames[:, 1 : seed + 1]
    truth_gen = frames[:, seed : seed + horizon + 1]
    return ((seed_out - truth_seed) ** 2).mean(), ((generated - truth_gen) ** 2).mean()


def new_goal_model(config: dict, mean: np.ndarray, std: np.ndarray, lr: float) -> tuple[GoalGRU, torch.optim.Adam]:
    """A model that starts as zero-velocity (the residual decoder outputs the input) and its optimizer."""
    model = GoalGRU(config)
    model.norm.set_stats(torch.from_numpy(mean).float(), torch.from_numpy(std).float())
    with torch.no_grad():
        model.decoder.weight.mul_(0.01)
        model.decoder.bias.zero_()
    return model, torch.optim.Adam(model.parameters(), lr=lr)


def train_goal(args, argv: list[str], model: GoalGRU, opt, config: dict,
               sample: Callable[[np.random.Generator], tuple[np.ndarray, np.ndarray]],
               validate: Callable[[], dict], log, extra_state: dict | None = None) -> int:
    """The loop (module docs): ``sample(rng)`` gives a batch of windows (frames, controls), ``validate()`` the
    validation report (its ``score``: lower is better); ``extra_state`` goes into every checkpoint."""
    last = args.run_dir / "last.pt"
    rng = np.random.default_rng(args.rng_seed)
    start_it, best = 0, None
    if args.resume and last.exists():
        state = torch.load(last, map_location="cpu", weights_only=False)
        model.load_state_dict(state["model"])
        opt.load_state_dict(state["optimizer"])
        start_it, best = state["iteration"], state.get("best")
        rng = np.random.default_rng(args.rng_seed + start_it)
        log(f"resumed at iteration {start_it}, best validation {best}")
    log(f"{sum(p.numel() for p in model.parameters())} parameters")
    t0 = time.time()
    running = None
    for it in range(start_it, args.iterations):
        lr = args.lr * (0.5 ** (it / max(args.iterations / 3, 1)))
        for group in opt.param_groups:
            group["lr"] = lr
        f, c = sample(rng)
        seed_loss, closed_loss = window_loss(model, torch.from_numpy(f), torch.from_numpy(c), args.seed_frames,
                                             args.feed_noise)
        loss = seed_loss + closed_loss
        opt.zero_grad()
        loss.backward()
        torch.nn.utils.clip_grad_norm_(model.parameters(), 1.0)
        opt.step()
        value = float(loss.detach())
        running = value if running is None else 0.98 * running + 0.02 * value
        done = it + 1
        if done % 100 == 0:
            log(f"it {done} loss {running:.4f} (seed {float(seed_loss.detach()):.4f}, closed {float(closed_loss.detach()):.4f}) "
                f"lr {lr:.2e} {(time.time() - t0) / (done - start_it):.3f} s/it")
        if done % args.val_every == 0 or done == args.iterations:
            report = validate()
            v = report["score"]
            state = {"model": model.state_dict(), "optimizer": opt.state_dict(), "config": config,
                     "iteration": done, "validation": report, "argv": argv, **(extra_state or {})}
            if best is None or v < best:
                best = v
                atomic_save(state, args.run_dir / "best.pt")
            state["best"] = best
            atomic_save(state, last)
            log(f"it {done} validation " + " ".join(f"{k} {x:.3f}" for k, x in report.items()) + f" (best {best:.3f})")
    (args.run_dir / "done.json").write_text(json.dumps({"iterations": args.iterations, "best": best}))
    return 0
