"""Stage two of steering: train ``goal-gru``, a locomotion model told where its root goes over the next second.

The control of 25 Hz frame ``t`` (``control_of``) is what the root does from frame ``t`` to frame ``t + K``
(``K = control_frames``, 25: one second), in the floor frame of the pelvis heading at ``t``:

- ``forward``, ``side``: the root's floor displacement over those ``K`` frames divided by their duration (m/s),
  along the heading and across it (``side`` is +x when facing +z);
- ``turn``: the heading change over them (radians, wrapped to ``[-pi, pi]``).

The heading is that of ``motion_core::steering``: the rest pose faces +z (H3.6M's hips lie along x), turned by
the integrated root rotation and laid on the floor (y up), ``atan2(x, z)``. The root is integrated as
``motion_core::root`` does (deltas in the previous root frame, each 25 Hz delta applied twice); ``K`` frames of
it are invariant to where the integration starts. At run time the engine feeds the control its goal asks for
(``Character::set_goal``), or without a goal the control of the last second it moved.

Training (closed loop, as the engine runs it): a window of ``--seed`` teacher-forced frames, all read with the
control of the last seed frame (the engine starts a character with one control), then ``--horizon`` frames fed
back with each frame's true control; loss = mean squared error in normalized units over both parts. Data:
H3.6M training subjects (S1, S6-S9, S11), walking, walkingdog and walkingtogether, plus waiting and directions
(people standing, so that a control of zero means stand). Checkpoint rule, fixed before scoring: the lowest
``validate`` score (4 s closed loops on S5 windows of those actions reading the true controls: how closely the
generated root follows them, and a penalty when the body moves less than 0.6 of the real one) among the
checkpoints written every ``--val-every`` iterations; ``--export`` writes that one.

    python -m training.locomotion --run-dir runs/goal --iterations 20000
    python -m training.locomotion --run-dir runs/goal --resume
    python -m training.locomotion --export weights/goal_gru_h36m.safetensors --from runs/goal/best.pt

**Any rig's takes** (``--takes DIR``): a folder of BVH takes on any rig (read by the project's take reader,
``motion-cli takes export``: one rig, ``--fps``, ``--joint-map`` and ``--exclude`` as ``matching build`` takes them;
``training/takes.py``) or a folder that command wrote. The model works on the rig's own exp-map frames (``3 + 3 *
joints`` values, the root as per-frame deltas) at the takes' rate; its file holds the rig (``config.rig_bvh``,
``skeleton: "rig"``), so engines play it on that rig. Controls are measured over ``--control-seconds`` with the rig's
rest forward (``training/takes.py`` ``controls_of``). Training windows are ``--seed`` teacher-forced frames and a
closed loop of 15, 30 or ``--horizon`` frames (drawn per iteration among those the takes are long enough for), each
window in a take drawn uniformly. Validation (the rule fixed before any run was scored): the takes
``training/takes.py validation_names`` picks (every 6th by name) are left out of training; each is seeded with its
first ``--seed`` frames and run closed loop for 10 s reading its true controls, then its last control held. ``score``
= forward + side + turn / 2 control errors over the take's real frames + 2 * max(0, 0.6 - speed ratio) over the real
frames + 2 * max(0, 0.6 - late speed ratio) + 2 * max(0, late speed ratio - 1.6), the late ratio over seconds 5-10
against the take's real speed; the lowest is kept as ``best.pt``.

    python -m training.locomotion --takes ../shared/data/cmu_locomotion \\
        --exclude 16_16,16_18,16_24,16_30,16_38,16_43,131_01,131_02 --run-dir runs/goal_cmu --iterations 6000
    python -m training.locomotion --export weights/goal_gru_cmu.safetensors --from runs/goal_cmu/best.pt
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import torch

from . import data as h36m
from . import takes
from .export import save_weights
from .goal_loss import new_goal_model, seed_controls, train_goal, window_loss  # noqa: F401
from .models import GoalGRU, make_config

ACTIONS = ("walking", "walkingdog", "walkingtogether", "waiting", "directions")
CONTROL_FRAMES = 25
FPS = 25.0
ROOT_STEP = 2  # 50 Hz source deltas per 25 Hz frame (motion_core::root)


def root_trajectory(frames: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Absolute root rotations ``[n, 3, 3]`` (row vectors) and translations ``[n, 3]`` (mm) of 25 Hz H3.6M frames
    (dims 0..5: deltas), every delta applied ``ROOT_STEP`` times, from the identity."""
    return takes.root_trajectory(frames, ROOT_STEP)


def headings(rots: np.ndarray) -> np.ndarray:
    """Pelvis heading (radians, 0 facing +z, pi/2 facing +x) of absolute root rotations ``[n, 3, 3]``: the rest
    forward +z as a row vector times ``R``, on the floor."""
    return takes.headings(rots, np.array([0.0, 0.0, 1.0]))


wrap = takes.wrap


def control_of(frames: np.ndarray, k: int = CONTROL_FRAMES, fps: float = FPS) -> np.ndarray:
    """Controls ``[n - k, 3]`` (forward m/s, side m/s, turn rad) of 25 Hz full frames ``[n, 99]`` (see the module
    doc): row ``t`` is what the root does from frame ``t`` to frame ``t + k``."""
    rots, trans = root_trajectory(frames)
    h = headings(rots)
    n = frames.shape[0] - k
    d = (trans[k:] - trans[:n]) / 1000.0 / (k / fps)
    s, c = np.sin(h[:n]), np.cos(h[:n])
    forward = d[:, 0] * s + d[:, 2] * c
    side = d[:, 0] * c - d[:, 2] * s
    turn = wrap(h[k:] - h[:n])
    return np.stack([forward, side, turn], axis=1)


class LocomotionSet:
    """Normalized 25 Hz sequences of the locomotion actions with their controls."""

    def __init__(self, subjects, stats: h36m.NormStats, dataset_dir: Path | None = None, log=print):
        dataset_dir = Path(dataset_dir) if dataset_dir else h36m.default_dataset_dir()
        raw = h36m.load_sequences(dataset_dir, subjects, ACTIONS, log=log)
        self.items = []
        for key in sorted(raw):
            s25 = h36m.downsample(raw[key])
            if s25.shape[0] < 200:
                continue
            controls = control_of(s25).astype(np.float32)
            frames = stats.normalize(s25[: controls.shape[0]]).astype(np.float32)
            self.items.append((key, frames, controls))
        if not self.items:
            raise FileNotFoundError(f"no H3.6M locomotion sequences under {dataset_dir} (set MOTION_DATA_DIR)")

    def sample(self, rng: np.random.Generator, batch: int, window: int):
        """``batch`` windows of ``window`` frames: a sequence uniformly (each action equally often), a start
        uniformly. Returns (frames [B, window, O], controls [B, window, 3])."""
        by_action = {}
        for item in self.items:
            by_action.setdefault(item[0][1], []).append(item)
        actions = sorted(by_action)
        out_f = np.empty((batch, window, self.items[0][1].shape[1]), np.float32)
        out_c = np.empty((batch, window, 3), np.float32)
        for b in range(batch):
            seqs = by_action[actions[int(rng.integers(len(actions)))]]
            _, frames, controls = seqs[int(rng.integers(len(seqs)))]
            start = int(rng.integers(h36m.MIN_START, frames.shape[0] - window))
            out_f[b] = frames[start : start + window]
            out_c[b] = controls[start : start + window]
        return out_f, out_c


VALIDATION_HORIZON = 100  # closed-loop frames of a validation window (4 s)


@torch.no_grad()
def validate(model: GoalGRU, windows: list[tuple[np.ndarray, np.ndarray]], seed: int, stats: h36m.NormStats) -> dict:
    """Closed loops of ``VALIDATION_HORIZON`` frames on the validation windows, each step reading the true
    control: how well the generated root follows it (mean absolute error of the control the generated frames
    achieve: forward and side in m/s, turn in radians) and how alive the body is (mean frame-to-frame change of
    the generated used dims over the real one's). ``score`` (lower is better, the checkpoint rule) =
    forward + side + turn / 2 errors + 2 * max(0, 0.6 - speed ratio)."""
    model.eval()
    frames = torch.from_numpy(np.stack([w[0] for w in windows]))
    controls = torch.from_numpy(np.stack([w[1] for w in windows]))
    generated = model.closed_loop(frames[:, :seed], VALIDATION_HORIZON, action=seed_controls(controls, seed))
    model.train()
    gen = generated.numpy().astype(np.float64)
    truth = frames[:, seed : seed + VALIDATION_HORIZON].numpy().astype(np.float64)
    errors = []
    for b in range(gen.shape[0]):
        achieved = control_of(stats.unnormalize(gen[b]))
        wanted = controls[b, seed : seed + achieved.shape[0]].numpy()
        errors.append(np.abs(achieved - wanted).mean(axis=0))
    forward, side, turn = np.mean(errors, axis=0)
    speed = np.abs(np.diff(gen, axis=1)).mean() / max(np.abs(np.diff(truth, axis=1)).mean(), 1e-9)
    score = forward + side + turn / 2 + 2 * max(0.0, 0.6 - speed)
    return {"score": float(score), "forward": float(forward), "side": float(side), "turn": float(turn),
            "speed_ratio": float(speed)}


def validation_set(stats: h36m.NormStats, window: int, dataset_dir=None, per_sequence: int = 4, log=print):
    """Windows of the S5 sequences of the locomotion actions: ``per_sequence`` evenly spread starts each."""
    val = LocomotionSet([h36m.VALIDATION_SUBJECT], stats, dataset_dir, log=log)
    out = []
    for _, frames, controls in val.items:
        last = frames.shape[0] - window
        for start in np.linspace(h36m.MIN_START, last, per_sequence).astype(int):
            out.append((frames[start : start + window], controls[start : start + window]))
    return out


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--run-dir", type=Path)
    p.add_argument("--iterations", type=int, default=20000)
    p.add_argument("--batch", type=int, default=32)
    p.add_argument("--seed-frames", type=int, default=25)
    p.add_argument("--horizon", type=int, default=50, help="closed-loop frames per training window")
    p.add_argument("--hidden", type=int, default=256)
    p.add_argument("--layers", type=int, default=2)
    p.add_argument("--lr", type=float, default=1e-3)
    p.add_argument("--feed-noise", type=float, default=0.05)
    p.add_argument("--val-every", type=int, default=500)
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--rng-seed", type=int, default=0)
    p.add_argument("--resume", action="store_true")
    p.add_argument("--data-dir", type=Path, default=None)
    p.add_argument("--takes", type=Path, metavar="DIR",
                   help="train on a folder of BVH takes on any rig (or one motion-cli takes export wrote)")
    p.add_argument("--joint-map", type=Path, metavar="F", help="with --takes: a JSON joint map for the takes' rigs")
    p.add_argument("--exclude", metavar="NAME,...", help="with --takes: takes to leave out (e.g. test takes)")
    p.add_argument("--fps", type=float, default=30.0, help="with --takes: the rate the takes are brought to")
    p.add_argument("--control-seconds", type=float, default=1.0, help="with --takes: the control's horizon")
    p.add_argument("--licence", help="with --export of a --takes run: the takes' licence, stored in the file")
    p.add_argument("--export", type=Path, metavar="OUT")
    p.add_argument("--from", dest="from_", type=Path, metavar="CKPT")
    return p


def export(out: Path, ckpt: Path, licence: str | None = None) -> None:
    state = torch.load(ckpt, map_location="cpu", weights_only=False)
    if state["config"].get("skeleton") == "rig":
        from .locomotion_rig import export_rig

        if not licence:
            raise SystemExit("--export of a --takes run needs --licence TEXT: the takes' licence")
        export_rig(out, state, licence)
        return
    model = GoalGRU(state["config"])
    model.load_state_dict(state["model"])
    provenance = {
        "data": "H3.6M S1, S6-S9, S11: " + ", ".join(ACTIONS),
        "iterations": state["iteration"],
        "best_validation": state["validation"],
        "command": "python -m training.locomotion " + " ".join(state["argv"]),
        "checkpoint_rule": "lowest validation score (control tracking + liveliness, training/locomotion.py validate)",
        "date": time.strftime("%Y-%m-%d"),
        "licence": "Human3.6M licence: research use only",
    }
    save_weights(model, out, provenance)
    print(f"wrote {out} (iteration {state['iteration']}, validation {state['validation']})")


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser().parse_args(argv)
    if args.export:
        if not args.from_:
            raise SystemExit("--export needs --from CKPT")
        export(args.export, args.from_, args.licence)
        return 0
    if not args.run_dir:
        raise SystemExit("--run-dir is required to train")
    torch.set_num_threads(args.threads)
    args.run_dir.mkdir(parents=True, exist_ok=True)
    last = args.run_dir / "last.pt"
    if last.exists() and not args.resume:
        raise SystemExit(f"{last} exists: pass --resume to continue that run")
    log_file = open(args.run_dir / "log.txt", "a")

    def log(msg: str) -> None:
        line = f"{time.strftime('%H:%M:%S')} {msg}"
        print(line, flush=True)
        log_file.write(line + "\n")
        log_file.flush()

    if args.takes:
        from .locomotion_rig import train_rig

        return train_rig(args, argv, log)
    dataset_dir = args.data_dir
    all_seqs = h36m.load_sequences(
        Path(dataset_dir) if dataset_dir else h36m.default_dataset_dir(), h36m.TRAIN_SUBJECTS, h36m.ACTIONS, log=log
    )
    stats = h36m.normalization_stats(all_seqs.values())
    del all_seqs
    train_set = LocomotionSet(h36m.TRAIN_SUBJECTS, stats, dataset_dir, log=log)
    window = args.seed_frames + args.horizon + 1
    val = validation_set(stats, args.seed_frames + VALIDATION_HORIZON, dataset_dir, log=log)
    config = make_config("goal-gru", [int(d) for d in stats.dims_used], hidden=args.hidden, layers=args.layers,
                         seed_frames=args.seed_frames, horizon=args.horizon)
    model, opt = new_goal_model(config, stats.mean, stats.std, args.lr)
    log(f"{len(train_set.items)} training sequences, {len(val)} validation windows")
    return train_goal(args, argv, model, opt, config, lambda rng: train_set.sample(rng, args.batch, window),
                      lambda: validate(model, val, args.seed_frames, stats), log)


if __name__ == "__main__":
    raise SystemExit(main())
